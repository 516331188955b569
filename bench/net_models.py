#!/usr/bin/env python3
"""How many packets per second can each link model carry? Prints ratios measured in this one run.

For each model: N packets of 100 bytes are sent through a ``netsim.link.Link`` on a kernel (one
send event and one delivery event each, as in the daemon), spaced 0.1 ms apart in simulated time,
and the wall time of ``kernel.run()`` gives packets per second. The baseline is the same bare
Link with the ``ideal`` model, measured in the same run; "ratio" is model pkt/s ÷ ideal pkt/s.
The last column is the cost of the model's ``transit`` alone (µs per packet, a tight loop).

The star path is the paper's case study I as ``netsim.topology`` builds it: wireless v1→ap
(100 m), shared channel queue, wired ap→gcs — three hops in one link.

Each case runs ``--rounds`` times, interleaved, and the best round counts (the machine is
shared). Models that drop packets skip their delivery events, so they can beat ``ideal``.

    .venv/bin/python bench/net_models.py [--packets 100000] [--rounds 3]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from netsim.backend import EmbeddedBackend, Mobility  # noqa: E402
from netsim.kernel import Kernel  # noqa: E402
from netsim.link import Link  # noqa: E402
from netsim.models import make_model  # noqa: E402
from netsim.topology import make_router  # noqa: E402

SPACING_S = 1e-4
PAYLOAD = b"x" * 100
MODELS = [
    ("ideal", {}),
    ("fixed", {"latency_s": 0.02, "jitter_s": 0.005, "loss": 0.05}),
    ("burst", {"p_good_to_bad": 0.02, "p_bad_to_good": 0.25, "latency_s": 0.02}),
    ("queue", {"rate_bps": 54e6, "queue_packets": 100, "latency_s": 0.001}),
    ("wireless", {}),  # at 100 m
    ("outage", {"windows_s": [[1.0, 2.0], [5.0, 1.0]]}),
]
STAR = {"topology": "star", "ap": {"position_ned_m": [0.0, 0.0, -10.0]},
        "channel": {"rate_bps": 54e6, "queue_packets": 100}}


def _mobility() -> Mobility:
    return Mobility({"v1": (100.0, 0.0, -10.0), "ap": (0.0, 0.0, -10.0)})


def build(name: str, params: dict):
    """(kernel, link) for a model name, or the star path."""
    kernel = Kernel()
    if name == "star path":
        route, positions = make_router(STAR)
        backend = EmbeddedBackend(kernel, route, seed=1, fixed_positions=positions)
        backend.update_mobility(0.0, {"v1": (100.0, 0.0, -10.0)})
        return kernel, backend.make_link("v1/gcs/down", "v1", "gcs", lambda p, m: None)
    model = make_model(name, params, seed=1, stream_name="bench", mobility=_mobility(),
                       src="v1", dst="ap")
    return kernel, Link(kernel, model, lambda p, m: None, name="bench")


def link_rate(name: str, params: dict, n: int) -> tuple[float, str]:
    kernel, link = build(name, params)
    for i in range(n):
        kernel.schedule(i * SPACING_S, link.send, PAYLOAD)
    t0 = time.perf_counter()
    kernel.run()
    wall = time.perf_counter() - t0
    s = link.stats
    assert s.sent == n and s.in_flight == 0
    drops = ", ".join(f"{k} {v / n:.1%}" for k, v in sorted(s.dropped.items())) or "-"
    return n / wall, drops


def transit_us(name: str, params: dict, n: int) -> float:
    _, link = build(name, params)
    transit = link.model.transit
    size = len(PAYLOAD)
    t0 = time.perf_counter()
    for i in range(n):
        transit(size, i * SPACING_S)
    return (time.perf_counter() - t0) / n * 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--packets", type=int, default=100_000)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    n = args.packets
    print(f"{platform.python_implementation()} {platform.python_version()}, "
          f"{n} packets of {len(PAYLOAD)} B per model, {SPACING_S * 1e3:g} ms apart, "
          f"best of {args.rounds}")
    cases = [*MODELS, ("star path", {})]
    best: dict[str, tuple[float, float, str]] = {}
    for _ in range(args.rounds):  # interleaved rounds, best of each: less noise from neighbours
        for name, params in cases:
            rate, drops = link_rate(name, params, n)
            us = transit_us(name, params, n)
            old = best.get(name)
            best[name] = (max(rate, old[0]) if old else rate, min(us, old[1]) if old else us,
                          drops)
    rows = [(name, *best[name]) for name, _ in cases]
    base = rows[0][1]
    print(f"{'model':<10} {'pkt/s':>10} {'ratio':>6} {'transit µs':>11}  drops")
    for name, rate, us, drops in rows:
        print(f"{name:<10} {rate:>10,.0f} {rate / base:>6.2f} {us:>11.2f}  {drops}")


if __name__ == "__main__":
    main()
