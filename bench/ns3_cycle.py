#!/usr/bin/env python3
"""How long does one ns-3 sync cycle take, against the sync period it must fit in?

For 5, 30 and 100 vehicles (plus the GCS, and the AP in the `ap` topology), every vehicle sends
MAVLink-like telemetry to the GCS (50 datagrams/s of 60 bytes) and the GCS sends each vehicle a
few commands (5 datagrams/s of 40 bytes); vehicles sit on a 60 m circle around the GCS/AP and
drift along it. The backend runs in lockstep; a cycle's wall time is the time `update_mobility`
takes (JSON out, ns-3 simulates one sync period, JSON back). A ratio above 1 means ns-3 cannot
keep up in real time with that many nodes: late packets (see the late policy).

    .venv/bin/python bench/ns3_cycle.py [--sim-seconds 2] [--sync-ms 20] [--engine ns3]
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from netsim.kernel import PRIORITY_PHYSICS, Kernel, Ticker  # noqa: E402
from netsim.ns3 import Ns3Backend  # noqa: E402

TELEMETRY_HZ, TELEMETRY_BYTES = 50.0, 60
COMMAND_HZ, COMMAND_BYTES = 5.0, 40
RADIUS_M = 60.0


def measure(vehicles: int, topology: str, sim_s: float, sync_s: float, engine: str,
            data_mode: str) -> dict:
    kernel = Kernel()
    config = {"engine": engine, "topology": topology, "timeout_s": 60.0,
              "nodes": {"gcs": {"position": [0.0, 0.0, 0.0]}}}
    if engine == "ns3":
        config["wifi"] = {"standard": "80211g", "data_mode": data_mode}
    if topology == "ap":
        config["nodes"]["ap"] = {"position": [0.0, 0.0, -3.0]}
    backend = Ns3Backend(kernel, config, seed=1, sync_period_s=sync_s)
    cycle_s: list[float] = []
    try:
        downs, ups = [], []
        for i in range(1, vehicles + 1):
            downs.append(backend.make_link(f"v{i}/down", f"v{i}", "gcs", lambda p, m: None))
            ups.append(backend.make_link(f"v{i}/up", "gcs", f"v{i}", lambda p, m: None))

        def positions(now: float) -> dict:
            out = {}
            for i in range(vehicles):
                a = 2 * math.pi * i / vehicles + 0.05 * now
                out[f"v{i + 1}"] = (RADIUS_M * math.cos(a), RADIUS_M * math.sin(a), -20.0)
            return out

        def sync(now: float) -> None:
            t = time.perf_counter()
            backend.update_mobility(now, positions(now))
            if now > 0:  # the first call is init + warm-up
                cycle_s.append(time.perf_counter() - t)

        Ticker(kernel, sync_s, sync, priority=PRIORITY_PHYSICS)
        # Spread each vehicle's sends over the period, as independent autopilots would.
        for i, (down, up) in enumerate(zip(downs, ups)):
            phase = (i / vehicles) / TELEMETRY_HZ + 1e-4
            Ticker(kernel, 1 / TELEMETRY_HZ, lambda now, d=down: d.send(bytes(TELEMETRY_BYTES)),
                   start_s=phase)
            Ticker(kernel, 1 / COMMAND_HZ, lambda now, u=up: u.send(bytes(COMMAND_BYTES)),
                   start_s=phase + 0.003)
        kernel.run(until=sim_s)
        sent = sum(link.stats.sent for link in downs + ups)
        delivered = sum(link.stats.delivered for link in downs + ups)
        in_flight = sum(link.stats.in_flight for link in downs + ups)
    finally:
        backend.close()
    mean = statistics.fmean(cycle_s)
    p95 = sorted(cycle_s)[int(0.95 * (len(cycle_s) - 1))]
    return {"vehicles": vehicles, "topology": topology, "mean_ms": mean * 1e3,
            "p95_ms": p95 * 1e3, "ratio": mean / sync_s, "ratio_p95": p95 / sync_s,
            "pkts_per_cycle": sent / (sim_s / sync_s),
            "delivered": delivered / max(1, sent - in_flight)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sim-seconds", type=float, default=2.0)
    parser.add_argument("--sync-ms", type=float, default=20.0)
    parser.add_argument("--engine", choices=["ns3", "reference"], default="ns3")
    parser.add_argument("--data-mode", default="ErpOfdmRate24Mbps")
    parser.add_argument("--vehicles", type=int, nargs="+", default=[5, 30, 100])
    args = parser.parse_args()
    sync_s = args.sync_ms / 1e3
    print(f"engine {args.engine}, 802.11g {args.data_mode}, sync period {args.sync_ms:g} ms, "
          f"{args.sim_seconds:g} s simulated; per vehicle {TELEMETRY_HZ:g} telemetry + "
          f"{COMMAND_HZ:g} command datagrams/s")
    print(f"{'topology':>8} {'vehicles':>8} {'pkts/cycle':>10} {'cycle ms':>9} {'p95 ms':>8} "
          f"{'ratio':>6} {'p95 ratio':>9} {'delivered':>9}")
    for topology in ("adhoc", "ap"):
        for n in args.vehicles:
            r = measure(n, topology, args.sim_seconds, sync_s, args.engine, args.data_mode)
            print(f"{topology:>8} {n:>8} {r['pkts_per_cycle']:>10.1f} {r['mean_ms']:>9.2f} "
                  f"{r['p95_ms']:>8.2f} {r['ratio']:>6.2f} {r['ratio_p95']:>9.2f} "
                  f"{r['delivered']:>9.1%}", flush=True)


if __name__ == "__main__":
    main()
