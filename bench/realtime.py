#!/usr/bin/env python3
"""How fast is one vehicle? Prints ratios measured in this one run.

1. bare PyBullet: CPU seconds to step one rigid body 250 times (one simulated second) with the
   two external-force calls a quadrotor needs per step — the physics floor.
2. as fast as possible: the whole simulation (physics, autopilot, telemetry on both links
   through netsim) with no client, simulated seconds per wall second.
3. real time: the daemon as `cornet run` starts it (UDP sockets, pacer), no client, for a few
   wall seconds: achieved real-time factor and CPU seconds per vehicle-second.

In 2 and 3 the vehicle is flying (armed and hovering at the takeoff altitude, commanded through
the vehicle API since there is no client), so the whole autopilot runs.

The CPU cost per vehicle-second is then given as a multiple of the bare PyBullet cost.

    .venv/bin/python bench/realtime.py [--sim-seconds 60] [--wall-seconds 10]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import platform
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import pybullet  # noqa: E402

from bench.floor import bare_pybullet_cpu_per_body_sim_s  # noqa: E402
from gateway.ci.ports import free_port_offset  # noqa: E402
from gateway.daemon.app import Daemon, RunConfig  # noqa: E402
from gateway.sim.simulation import Simulation  # noqa: E402

TAKEOFF_AT_S = 1.5  # position estimate valid after ~1 s
HOVERING_AT_S = 6.0


def take_off(sim: Simulation) -> None:
    sim.run(until=TAKEOFF_AT_S)
    vehicle = sim.vehicles[0]
    vehicle.arm(sim.now)
    vehicle.takeoff(sim.now)
    sim.run(until=HOVERING_AT_S)
    assert vehicle.status.armed and vehicle.state.position_ned_m[2] < -2.0, "bench vehicle not flying"


def as_fast_as_possible(sim_s: float) -> tuple[float, float]:
    sim = Simulation(1)
    try:
        take_off(sim)
        sim_s += sim.now
        w0, c0 = time.perf_counter(), time.process_time()
        start = sim.now
        sim.run(until=sim_s)
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        assert sim.vehicles[0].status.armed
    finally:
        sim.close()
    return (sim_s - start) / wall, cpu / (sim_s - start)


async def _real_time(wall_s: float) -> tuple[float, float]:
    daemon = Daemon(RunConfig(vehicles=1, port_offset=free_port_offset(1)))
    await daemon.open()
    task = asyncio.create_task(daemon.pacer.run())
    try:
        await asyncio.sleep(TAKEOFF_AT_S)
        vehicle = daemon.sim.vehicles[0]
        vehicle.arm(daemon.sim.now)
        vehicle.takeoff(daemon.sim.now)
        await asyncio.sleep(HOVERING_AT_S - TAKEOFF_AT_S)
        s0, w0, c0 = daemon.sim.now, time.perf_counter(), time.process_time()
        await asyncio.sleep(wall_s)
        sim = daemon.sim.now - s0
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        assert vehicle.status.armed
    finally:
        task.cancel()
        try:
            await task
        except asyncio.CancelledError:
            pass
        daemon.close()
    return sim / wall, cpu / sim


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim-seconds", type=float, default=60.0)
    parser.add_argument("--wall-seconds", type=float, default=10.0)
    args = parser.parse_args()

    bare = bare_pybullet_cpu_per_body_sim_s(1, args.sim_seconds)
    afap_rtf, afap_cpu = as_fast_as_possible(args.sim_seconds)
    rt_rtf, rt_cpu = asyncio.run(_real_time(args.wall_seconds))

    print(f"machine: {platform.machine()} {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, pybullet {pybullet.getAPIVersion()}")
    print(f"{'measure (vehicle hovering, no client)':<52}{'value':>12}")
    print(f"{'bare PyBullet CPU per simulated second (1 body)':<52}{bare * 1e3:>10.2f}ms")
    print(f"{'as fast as possible: sim s per wall s (1 vehicle)':<52}{afap_rtf:>12.1f}")
    print(f"{'as fast as possible: CPU per vehicle-second':<52}{afap_cpu * 1e3:>10.1f}ms")
    print(f"{'real time: sim s per wall s (1 vehicle, daemon)':<52}{rt_rtf:>12.3f}")
    print(f"{'real time: CPU per vehicle-second':<52}{rt_cpu * 1e3:>10.1f}ms")
    print(f"{'real time: CPU per vehicle-second / bare PyBullet':<52}{rt_cpu / bare:>12.1f}")
    print(f"{'as fast as possible: CPU per vehicle-s / bare':<52}{afap_cpu / bare:>12.1f}")


if __name__ == "__main__":
    main()
