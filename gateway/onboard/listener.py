"""What PX4's ``listener <topic>`` prints of one message: uORB's orb_print_message_internal
(platforms/common/uORB/uORB.cpp), over the fields CORNET logs of the topic (topic.py).

Rules, as orb_print_message_internal has them:
- ``_padding*`` fields are not printed;
- each field ``    name: value``; an array ``[a, b, …]``; floats ``%.5f``, doubles ``%.6f``,
  bools True/False, integers as they are;
- ``timestamp`` (a uint64_t) is followed by `` (S seconds ago)`` unless it is 0, and
  ``timestamp_sample`` by `` (N us before timestamp)``; a non-zero
  integer whose name contains "flags" by its bits, `` (0b1010'0001)``; a float[4] named ``q`` or
  ``q_*`` by its Euler angles, `` (Roll: 1.0 deg, Pitch: 2.0 deg, Yaw: 3.0 deg)``;
- a nested message (a field of a nested format's type) ``  name (type):`` and its fields below,
  an array of them ``  name[i] (type):`` per element.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, NamedTuple

from gateway.onboard.topic import Fields
from vehicles.types import q_euler_rad

_INT_BITS = {"uint8_t": 8, "uint16_t": 16, "uint32_t": 32, "uint64_t": 64}


def print_message(fields: Fields, values: Iterator[Any], now_us: int,
                  nested: Mapping[str, Fields]) -> str:
    """The lines of one message whose ``fields`` take ``values`` in order (an array's
    elements one by one, a nested message's fields in its place)."""
    out: list[str] = []
    stamp = 0  # this message's timestamp, once printed
    for ftype, name in fields:
        base, _, size = ftype.partition("[")
        count = int(size[:-1]) if size else 1
        if base in nested:
            for i in range(count):
                out.append(f"  {name}[{i}] ({base}):\n" if size else f"  {name} ({base}):\n")
                out.append(print_message(nested[base], values, now_us, nested))
            continue
        if name.startswith("_padding"):  # never printed; a record carries no trailing one
            for _ in range(count):
                next(values, None)
            continue
        items = [next(values) for _ in range(count)]
        text = "[" + ", ".join(_scalar(base, v) for v in items) + "]" if size \
            else _scalar(base, items[0])
        if name == "timestamp" and base == "uint64_t" and not size:
            stamp = int(items[0])
        out.append(f"    {name}: {text}{_note(base, name, items, now_us, stamp)}\n")
    return "".join(out)


def _scalar(ctype: str, v: Any) -> str:
    if ctype == "bool":
        return "True" if v else "False"
    if ctype in ("float", "double"):
        v = float(v)
        if not math.isfinite(v):
            return str(v).lower()
        return f"{v:.6f}" if ctype == "double" else f"{v:.5f}"
    return str(int(v))


def _note(ctype: str, name: str, items: Sequence[Any], now_us: int, stamp: int) -> str:
    if len(items) == 1:
        v = items[0]
        if ctype == "uint64_t" and name == "timestamp":
            return f" ({(now_us - int(v)) / 1e6:.6f} seconds ago)" if v else ""
        if ctype == "uint64_t" and name == "timestamp_sample":
            return f" ({stamp - int(v)} us before timestamp)" if stamp and v else ""
        if "flags" in name and ctype in _INT_BITS and int(v):
            bits = format(int(v), "b")
            # a ' between nibbles, counted from the low bit
            return " (0b" + "".join(b + ("'" if (len(bits) - 1 - k) % 4 == 0 and
                                           k < len(bits) - 1 else "")
                                     for k, b in enumerate(bits)) + ")"
    elif len(items) == 4 and ctype == "float" and (name == "q" or name.startswith("q_")):
        roll, pitch, yaw = (math.degrees(a) for a in q_euler_rad(tuple(items)))
        return f" (Roll: {roll:.1f} deg, Pitch: {pitch:.1f} deg, Yaw: {yaw:.1f} deg)"
    return ""


# --- listener -n / -r / -i: listening over time (listener_main.cpp's listener()) ----------------
MESSAGE_TIMEOUT_S = 2.0  # listener_main.cpp: poll()'s timeout before it gives up
POLL_S = 0.02  # how often a running listener looks for publications (the links' 50 Hz wake-ups)
_U32 = 1 << 32


class Options(NamedTuple):
    instance: int  # -i (-1: not given)
    rate: int  # -r: the subscription's rate limit (0: unlimited)
    messages: int  # -n (0: not given)


def listener_options(args: Sequence[str]) -> Options | None:
    """px4_getopt(argc, argv, "i:r:n:") over the arguments after the topic name (options and
    other words in any order; an option's value attached or the next word), each value read by
    strtol(…, 0) (0x… hex, 0… octal, junk 0; the unsigned ones wrap). None: an unknown option
    or one without its value (usage, then -1)."""
    got = {"i": -1, "r": 0, "n": 0}
    k = 0
    while k < len(args):
        word = args[k]
        if word.startswith("-") and len(word) > 1:
            opt = word[1]
            if opt not in got:
                return None
            if len(word) > 2:
                value = word[2:]
            elif k + 1 < len(args):
                k += 1
                value = args[k]
            else:
                return None
            got[opt] = _strtol(value)
        k += 1
    return Options(got["i"], got["r"] % _U32, got["n"] % _U32)


def _strtol(text: str) -> int:
    """C's strtol(text, nullptr, 0): the leading number, 0 if none."""
    m = re.match(r"\s*([+-]?)(0[xX][0-9a-fA-F]+|0[0-7]*|[1-9][0-9]*)", text)
    if m is None:
        return 0
    sign, digits = m.groups()
    if digits[:2].lower() == "0x":
        value = int(digits, 16)
    elif digits.startswith("0"):
        value = int(digits, 8)
    else:
        value = int(digits)
    return -value if sign == "-" else value


class Listening:
    """``listener <topic> -n N [-r R] [-i I]``: up to N messages of one instance, each as it is
    published, at most R per second (orb_set_interval 1000 / R ms), headed "TOPIC: <name>
    instance <I> #<k>"; the first at once (a new subscription has the latest). It gives up
    after MESSAGE_TIMEOUT_S without a publication. When a topic publishes: at each physics step
    for the sensors' topics (seen at each POLL_S look), on change (and at its republication
    period) for an on-change topic, at its publisher's period for a fixed-rate one, and at each
    look for the others (PX4's modules publish them at 50 Hz or more). ``poll`` returns what it
    printed and whether it is done."""

    def __init__(self, name: str, instance: int, rate: int, count: int,
                 read: Callable[[int], Sequence[Any] | None],
                 render: Callable[[Sequence[Any], int], str], on_change: bool,
                 republish_s: float, period_s: float, now_s: float) -> None:
        self.name, self.instance, self.count = name, instance, count
        self.interval_s = (1000 // rate) / 1000.0 if rate else 0.0
        self.read, self.render = read, render
        self.on_change, self.republish_s, self.period_s = on_change, republish_s, period_s
        self.received = 0
        self.last_s = now_s  # the last message printed (or the start): the timeout's clock
        self.last_values: Sequence[Any] | None = None
        self.due_s = now_s

    def _published(self, values: Sequence[Any], now_s: float) -> bool:
        if self.received == 0:
            return True
        since = now_s - self.last_s
        if since < self.interval_s - 1e-9:
            return False
        if self.on_change:
            return values != self.last_values or \
                (self.republish_s > 0 and since >= self.republish_s - 1e-9)
        return since >= self.period_s - 1e-9

    def poll(self, now_s: float) -> tuple[str, bool]:
        us = int(now_s * 1e6)
        values = self.read(us)
        if values is not None and self._published(values, now_s):
            self.received += 1
            self.last_s, self.last_values = now_s, values
            text = f"\nTOPIC: {self.name} instance {self.instance} #{self.received}\n" + \
                self.render(values, us)
            self.due_s = now_s + POLL_S
            return text, self.received >= self.count
        if now_s - self.last_s >= MESSAGE_TIMEOUT_S - 1e-9:
            return (f"Waited for {MESSAGE_TIMEOUT_S:.1f} seconds without a message. "
                    "Giving up.\n"), True
        self.due_s = now_s + POLL_S
        return "", False
