#!/usr/bin/env python3
"""What does a simulated second through ns-3 cost, and where does it go?

For 5, 10, 20 and 30 vehicles (plus the GCS, and the AP in the `ap` topology), every vehicle sends
MAVLink-like telemetry to the GCS (``--telemetry-hz`` datagrams/s of 50 bytes: PX4 SITL's GCS and
API links together send ~790 messages/s, each in a datagram of its own, 50 bytes on average) and
the GCS sends each vehicle a few commands (5 datagrams/s of 40 bytes); vehicles sit on a 60 m
circle around the GCS/AP and drift along it. The kernel runs the backend at exact time
(netsim/ns3/README.md "Timing") in lockstep, with the GCS's deliveries not stopping ns-3's steps
(as the daemon runs it: its ground clients are outside the simulation), for ``--sim-seconds``.
Printed per point: wall seconds per simulated second (above 1: that many vehicles cannot run in
real time through ns-3 on this machine), the engine's CPU and this process's CPU per simulated
second (the exchanges alternate: the two add up to the wall time), engine round trips per simulated
second, and the share delivered.

    .venv/bin/python bench/ns3_cycle.py [--sim-seconds 2] [--telemetry-hz 790] [--engine ns3]
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from netsim.kernel import PRIORITY_PHYSICS, Kernel, Ticker  # noqa: E402
from netsim.ns3 import Ns3Backend  # noqa: E402

TELEMETRY_BYTES = 50
COMMAND_HZ, COMMAND_BYTES = 5.0, 40
RADIUS_M = 60.0


def cpu_s(who: int) -> float:
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def measure(vehicles: int, topology: str, sim_s: float, sync_s: float, engine: str,
            data_mode: str, telemetry_hz: float) -> dict:
    kernel = Kernel()
    config = {"engine": engine, "topology": topology, "timeout_s": 120.0,
              "nodes": {"gcs": {"position": [0.0, 0.0, 0.0]}}}
    if engine == "ns3":
        config["wifi"] = {"standard": "80211g", "data_mode": data_mode}
    if topology == "ap":
        config["nodes"]["ap"] = {"position": [0.0, 0.0, -3.0]}
    backend = Ns3Backend(kernel, config, seed=1, sync_period_s=sync_s)
    backend.passive_ground = True
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

        backend.start(positions(0.0))
        Ticker(kernel, sync_s, lambda now: backend.update_mobility(now, positions(now)),
               priority=PRIORITY_PHYSICS)
        # Spread each vehicle's sends over the period, as independent autopilots would.
        for i, (down, up) in enumerate(zip(downs, ups)):
            phase = (i / vehicles) / telemetry_hz + 1e-4
            Ticker(kernel, 1 / telemetry_hz, lambda now, d=down: d.send(bytes(TELEMETRY_BYTES)),
                   start_s=phase)
            Ticker(kernel, 1 / COMMAND_HZ, lambda now, u=up: u.send(bytes(COMMAND_BYTES)),
                   start_s=phase + 0.003)
        wall0, own0 = time.perf_counter(), cpu_s(resource.RUSAGE_SELF)
        kernel.run(until=sim_s)
        wall, own = time.perf_counter() - wall0, cpu_s(resource.RUSAGE_SELF) - own0
        sent = sum(link.stats.sent for link in downs + ups)
        delivered = sum(link.stats.delivered for link in downs + ups)
        in_flight = sum(link.stats.in_flight for link in downs + ups)
        exchanges = backend.exchanges
    finally:
        engine0 = cpu_s(resource.RUSAGE_CHILDREN)
        backend.close()
    # The engine's CPU is known once it has exited (its init and warm-up included: a second).
    engine_cpu = cpu_s(resource.RUSAGE_CHILDREN) - engine0
    return {"wall": wall / sim_s, "engine": engine_cpu / sim_s, "own": own / sim_s,
            "exchanges": exchanges / sim_s, "pkts": sent / sim_s,
            "delivered": delivered / max(1, sent - in_flight)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sim-seconds", type=float, default=2.0)
    parser.add_argument("--sync-ms", type=float, default=20.0)
    parser.add_argument("--engine", choices=["ns3", "reference"], default="ns3")
    parser.add_argument("--data-mode", default="ErpOfdmRate6Mbps")
    parser.add_argument("--telemetry-hz", type=float, default=790.0)
    parser.add_argument("--topology", choices=["ap", "adhoc"], default="ap")
    parser.add_argument("--vehicles", type=int, nargs="+", default=[5, 10, 20, 30])
    args = parser.parse_args()
    sync_s = args.sync_ms / 1e3
    print(f"engine {args.engine}, {args.topology}, 802.11g {args.data_mode}, "
          f"{args.sim_seconds:g} s simulated; per vehicle {args.telemetry_hz:g} telemetry + "
          f"{COMMAND_HZ:g} command datagrams/s")
    print(f"{'vehicles':>8} {'pkts/s':>7} {'wall/sim':>9} {'engine CPU/sim':>15} "
          f"{'python CPU/sim':>15} {'exchanges/s':>12} {'delivered':>9}")
    for n in args.vehicles:
        r = measure(n, args.topology, args.sim_seconds, sync_s, args.engine, args.data_mode,
                    args.telemetry_hz)
        print(f"{n:>8} {r['pkts']:>7.0f} {r['wall']:>9.2f} {r['engine']:>15.2f} "
              f"{r['own']:>15.2f} {r['exchanges']:>12.0f} {r['delivered']:>9.1%}", flush=True)


if __name__ == "__main__":
    main()
