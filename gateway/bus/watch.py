"""`cornet watch` and `cornet stats`: subscribers to the daemon's ZeroMQ stream (docs/zmq.md).

watch: a live table, one row per vehicle — mode, arming, position, and the quality of its two
links over the last second (datagrams delivered / sent, loss, mean latency) — redrawn in place on
a terminal, printed as plain blocks otherwise. stats: one snapshot of every link's counters.
"""

from __future__ import annotations

import json
import sys
import time
from typing import TextIO

import zmq

from gateway.bus.zmq_pub import SCHEMA_VERSION, TOPIC_LINKS, TOPIC_STATE

DEFAULT_ENDPOINT = "tcp://127.0.0.1:5556"
CLEAR = "\x1b[H\x1b[2J"


def subscribe(endpoint: str, topics: list[bytes]) -> zmq.Socket:
    sock: zmq.Socket = zmq.Context.instance().socket(zmq.SUB)
    sock.setsockopt(zmq.LINGER, 0)
    for topic in topics:
        sock.setsockopt(zmq.SUBSCRIBE, topic)
    sock.connect(endpoint)
    return sock


def _link_quality(now: dict, before: dict | None) -> tuple[str, str, str]:
    """(delivered/sent, loss %, mean latency ms) over the interval between two snapshots."""
    if before is None:
        sent, delivered = now["sent"], now["delivered"]
        lat_sum = now["latency_mean_ms"] * delivered
    else:
        sent = now["sent"] - before["sent"]
        delivered = now["delivered"] - before["delivered"]
        lat_sum = (now["latency_mean_ms"] * now["delivered"]
                   - before["latency_mean_ms"] * before["delivered"])
    if sent <= 0:
        return "-", "-", "-"
    loss = 100.0 * max(0, sent - delivered - now.get("in_flight", 0)) / sent
    latency = lat_sum / delivered if delivered > 0 else float("nan")
    return f"{delivered}/{sent}", f"{loss:.0f}%", f"{latency:.1f}"


def render(state: dict, links: dict, previous_links: dict | None) -> str:
    rows = [f"sim t = {state.get('t', 0):.1f} s",
            f"{'veh':>3} {'mode':<12} {'armed':<5} {'north':>7} {'east':>7} {'alt':>6} "
            f"{'gcs link rx/tx':>14} {'loss':>5} {'ms':>6} {'api link rx/tx':>14} {'loss':>5} "
            f"{'ms':>6}"]
    for v in state.get("vehicles", []):
        sysid = v["sysid"]
        cells = []
        for kind in ("gcs", "api"):
            down = links.get(f"v{sysid}/{kind}/down")
            before = (previous_links or {}).get(f"v{sysid}/{kind}/down")
            cells.append(_link_quality(down, before) if down else ("-", "-", "-"))
        n, e, _ = v["world_ned_m"]
        alt = v["rel_alt_m"] if v["rel_alt_m"] is not None else float("nan")
        rows.append(f"{sysid:>3} {v['mode']:<12} {'yes' if v['armed'] else 'no':<5} "
                    f"{n:>7.1f} {e:>7.1f} {alt:>6.1f} "
                    f"{cells[0][0]:>14} {cells[0][1]:>5} {cells[0][2]:>6} "
                    f"{cells[1][0]:>14} {cells[1][1]:>5} {cells[1][2]:>6}")
    return "\n".join(rows)


def watch(endpoint: str, out: TextIO = sys.stdout, duration_s: float | None = None,
          refresh_s: float = 1.0) -> int:
    sock = subscribe(endpoint, [TOPIC_STATE, TOPIC_LINKS])
    poller = zmq.Poller()
    poller.register(sock, zmq.POLLIN)
    state: dict = {}
    links: dict = {}
    shown_links: dict | None = None
    tty = out.isatty()
    start = last = time.monotonic()
    if not tty:
        print(f"watching {endpoint}", file=out, flush=True)
    try:
        while duration_s is None or time.monotonic() - start < duration_s:
            if poller.poll(100):
                topic, body = sock.recv_multipart()
                msg = json.loads(body)
                if msg.get("v") != SCHEMA_VERSION:
                    print(f"cornet watch: schema v{msg.get('v')} not understood "
                          f"(this is v{SCHEMA_VERSION})", file=sys.stderr)
                    return 2
                if topic == TOPIC_STATE:
                    state = msg
                else:
                    links = msg["links"]
            if state and time.monotonic() - last >= refresh_s:
                last = time.monotonic()
                table = render(state, links, shown_links)
                shown_links = links
                print((CLEAR + table) if tty else table + "\n", file=out, flush=True)
    except KeyboardInterrupt:
        pass
    finally:
        sock.close(0)
    return 0


def stats(endpoint: str, out: TextIO = sys.stdout, timeout_s: float = 5.0) -> int:
    sock = subscribe(endpoint, [TOPIC_LINKS])
    try:
        if not sock.poll(int(timeout_s * 1000)):
            print(f"cornet stats: nothing from {endpoint} in {timeout_s:.0f} s; is the daemon "
                  "running with --zmq-pub?", file=sys.stderr)
            return 1
        _, body = sock.recv_multipart()
    finally:
        sock.close(0)
    msg = json.loads(body)
    print(format_link_table(msg["links"], msg["t"]), file=out)
    return 0


def format_link_table(links: dict, t: float) -> str:
    rows = [f"link statistics at sim t = {t:.1f} s",
            f"{'link':<16} {'sent':>8} {'delivered':>9} {'dropped':>20} {'late':>5} "
            f"{'mean ms':>8} {'p50 ms':>7} {'p99 ms':>7} {'max ms':>7}"]
    for name in sorted(links):
        s = links[name]
        dropped = ",".join(f"{k}={v}" for k, v in sorted(s["dropped"].items())) or "0"
        rows.append(f"{name:<16} {s['sent']:>8} {s['delivered']:>9} {dropped:>20} "
                    f"{s.get('late_delivered', 0):>5} {s['latency_mean_ms']:>8.2f} "
                    f"{s['latency_p50_ms']:>7.2f} {s['latency_p99_ms']:>7.2f} "
                    f"{s['latency_max_ms']:>7.2f}")
    return "\n".join(rows)
