#!/usr/bin/env python3
"""What the ns-3 coupling adds to a round trip: PING from the API client to the vehicle of
scenarios/ns3-wifi.toml (802.11g, 30 m from its access point) at sync periods 1, 5 and 20 ms,
in lockstep and in real time, beside ns-3's own latency up and down that link.

Each run builds the simulation in-process from the scenario (its sync period replaced), arms
nothing, and sends a MAVLink PING on the API link every 0.2 simulated seconds after a 1 s
settle; the vehicle's PING answer closes the round trip, in simulated time. Lockstep: the
bridge's exact-time exchange (the sync period only paces position updates). Real time: the
kernel is paced to the wall clock in 1 ms slices, so the ns-3 bridge runs as in the daemon
(its real-time pipeline of two sync periods; replies it reads too late are dropped and counted
"late").
ns-3's latency is the links' own share (``net_latency_mean_ms``: injection into ns-3 to ns-3's
delivery, the mean over every datagram of the link, telemetry included) on the API link's two
directions, added; the coupling adds the rest of the round trip.

    .venv/bin/python bench/ns3_coupling.py [--seconds 10] [--sync-ms 1,5,20]

Prints one row per (sync period, mode): pings answered, round trip p50 / p99, ns-3's latency
up + down, what the coupling adds at p50, late drops. Needs the ns-3 engine (`make ns3`).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pymavlink.dialects.v20 import common as M  # noqa: E402

from gateway.mavlink.session import LinkKind  # noqa: E402
from gateway.sim import scenario as scenario_mod  # noqa: E402
from gateway.sim.simulation import Simulation  # noqa: E402
from netsim.ns3.bridge import BINARY, build_missing_message  # noqa: E402

SCENARIO = ROOT / "scenarios" / "ns3-wifi.toml"
PING_PERIOD_S = 0.2
SETTLE_S = 1.0
SLICE_S = 0.001
PEER = ("api-client", 14540)


def measure(sync_s: float, realtime: bool, seconds: float) -> dict:
    sc = scenario_mod.load(SCENARIO)
    network = dataclasses.replace(sc.network, sync_period_s=sync_s)
    sim = Simulation(sc.vehicles, network, home=sc.home, realtime=realtime)
    mav = M.MAVLink(None, 255, 190)
    rx = M.MAVLink(None, 0, 0)
    rx.robust_parsing = True
    sent: dict[int, float] = {}
    rtts: list[float] = []

    def on_downlink(index: int, kind: LinkKind, datagram: bytes, peer: object) -> None:
        if kind is not LinkKind.API:
            return
        for msg in rx.parse_buffer(datagram) or []:
            if msg.get_type() == "PING" and msg.target_system == 255 and msg.seq in sent:
                rtts.append(sim.kernel.now - sent.pop(msg.seq))

    sim.on_downlink = on_downlink
    start = getattr(sim.backend, "start", None)
    if start is not None:
        start()
    seq = 0
    next_ping = SETTLE_S
    t0 = time.perf_counter()
    end = SETTLE_S + seconds
    now = 0.0
    try:
        while now < end:
            now = min(now + SLICE_S, end)
            if realtime:
                wait = t0 + now - time.perf_counter()
                if wait > 0:
                    time.sleep(wait)
            sim.run(until=now)
            if now + 1e-9 >= next_ping:
                seq += 1
                ping = M.MAVLink_ping_message(int(now * 1e6), seq, 0, 0)
                sent[seq] = sim.kernel.now
                sim.inject(0, LinkKind.API, ping.pack(mav), PEER)
                next_ping += PING_PERIOD_S
        stats = sim.link_stats()
    finally:
        sim.close()
    up, down = stats["v1/api/up"], stats["v1/api/down"]
    late = up["dropped"].get("late", 0) + down["dropped"].get("late", 0)
    return {"pings": seq, "answered": len(rtts), "rtts_ms": [r * 1e3 for r in rtts],
            "ns3_ms": up.get("net_latency_mean_ms", 0.0) + down.get("net_latency_mean_ms", 0.0),
            "late": late}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0,
                        help="simulated seconds of pings per run (default 10)")
    parser.add_argument("--sync-ms", default="1,5,20",
                        help="sync periods in ms, comma-separated (default 1,5,20)")
    args = parser.parse_args()
    try:
        syncs = [float(x) / 1e3 for x in args.sync_ms.split(",")]
    except ValueError:
        parser.error(f"--sync-ms: expected numbers like 1,5,20, got {args.sync_ms!r}")
    if not all(0.001 <= s <= 1.0 for s in syncs) or not args.seconds > 0:
        parser.error("--sync-ms must be 1..1000 ms each and --seconds > 0")
    if not BINARY.is_file():
        print(build_missing_message(), file=sys.stderr)
        return 2
    print(f"{SCENARIO.name}: PING every {PING_PERIOD_S:g} s on the API link for "
          f"{args.seconds:g} simulated s per run")
    print("| sync | mode | answered | round trip p50 / p99 | ns-3 up + down | coupling adds "
          "(p50) | late |")
    print("|---|---|---|---|---|---|---|")
    for sync in syncs:
        for realtime in (False, True):
            r = measure(sync, realtime, args.seconds)
            rtts = sorted(r["rtts_ms"])
            if rtts:
                p50 = statistics.median(rtts)
                p99 = rtts[min(len(rtts) - 1, int(0.99 * len(rtts)))]
                trip = f"{p50:.2f} / {p99:.2f} ms"
                adds = f"{p50 - r['ns3_ms']:.2f} ms"
            else:
                trip = adds = "-"
            print(f"| {sync * 1e3:g} ms | {'real time' if realtime else 'lockstep'} | "
                  f"{r['answered']}/{r['pings']} | {trip} | {r['ns3_ms']:.2f} ms | {adds} | "
                  f"{r['late']} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
