"""PX4's ``listener`` command (src/systemcmds/topic_listener/listener_main.cpp) over the
topics CORNET logs: once (every published instance), or ``-n``/``-r``/``-i`` over time
(listener.py ``Listening``, which the shell polls)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from gateway.onboard.listener import Listening, listener_options, print_message
from gateway.onboard.logged_topics import NESTED_FORMATS, TOPICS
from gateway.onboard.topic import U64, Topic

# listener_main.cpp's usage(), as PRINT_MODULE_DESCRIPTION / _USAGE_NAME / _ARG / _PARAM_INT
# print it (platforms/common/module.cpp)
LISTENER_USAGE = (
    "\nUtility to listen on uORB topics and print the data to the console.\n\nThe listener can "
    "be exited any time by pressing Ctrl+C, Esc, or Q.\n\n\n"
    "Usage: listener <command> [arguments...]\n Commands:\n"
    "     <topic_name> uORB topic name\n"
    "     [-i <val>]  Topic instance\n                 default: 0\n"
    "     [-n <val>]  Number of messages\n                 default: 1\n"
    "     [-r <val>]  Subscription rate (unlimited if 0)\n                 default: 0\n")


def listener(args: list[str], now_s: float, vehicle: Any, links: Sequence[Any],
             say: Callable[[str], None]) -> tuple[int, Listening | None]:
    """listener_main: its return code, and the listening to poll (None: done). Without a topic
    its usage; a topic it does not know: its words and -1; an unknown option: usage and -1.
    Listening once (no -n, -r or -i): each published instance; otherwise instance -i (0) from
    its latest message on, or "never published"."""
    if not args:
        say(LISTENER_USAGE)
        return 1, None
    options = listener_options(args)
    if options is None:
        say(LISTENER_USAGE)
        return -1, None
    instances = [t for t in TOPICS if t.name == args[0]]
    if not instances:
        say(f"Topic {args[0]} did not match any known topics\n")
        return -1, None
    view = _ListenerView(vehicle, links)
    us = int(now_s * 1e6)
    count = options.messages or (30 * options.rate if options.rate else 1)
    name = instances[0].name
    if options.instance == -1 and count == 1:
        published = [(t, v) for t in instances if (v := t.read(view, us)) is not None]
        if not published:
            say("never published\n")
            return 0, None
        out = [f"\nTOPIC: {name}\n" if len(published) == 1
               else f"\nTOPIC: {name} {len(published)} instances\n"]
        for topic, values in published:
            if len(published) > 1:
                out.append(f"\nInstance {topic.multi_id}:\n")
            out.append(_render(topic, values, us))
        say("".join(out))
        return 0, None
    instance = max(options.instance, 0)
    chosen = [t for t in instances if t.multi_id == instance]
    if not chosen or chosen[0].read(view, us) is None:
        say("never published\n")
        return 0, None
    topic = chosen[0]
    listening = Listening(name, instance, options.rate, count,
                          lambda now_us: topic.read(_ListenerView(vehicle, links), now_us),
                          lambda values, now_us: _render(topic, values, now_us),
                          topic.on_change, topic.republish_s,
                          topic.period_s, now_s)
    text, done = listening.poll(now_s)
    say(text)
    return 0, None if done else listening


def _render(topic: Topic, values: Sequence[Any], us: int) -> str:
    """listener_print_topic: the topic's name, then its fields (orb_print_message_internal)."""
    return f" {topic.name}\n" + print_message(
        ((U64, "timestamp"), *topic.fields),
        iter(values if topic.stamped else (us, *values)), us, NESTED_FORMATS)


class _ListenerView:
    """The vehicle as ``listener`` reads a topic: with the MAVLink instances the logger reads
    (telemetry_status, timesync_status) and a memo of its own (the logger's is the logger's)."""

    def __init__(self, vehicle: Any, links: Sequence[Any]) -> None:
        self._vehicle = vehicle
        self.mavlink_links = links
        self.memo: dict[str, Any] = {}

    def __getattr__(self, name: str) -> Any:
        return getattr(self._vehicle, name)
