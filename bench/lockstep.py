"""Lockstep speed (issue 19, acceptance 3: >= 200x for one vehicle): the 4-waypoint square
(~60 s simulated) flown in-process through gateway.ci.lockstep.Sim, best of 3; prints simulated
seconds per wall second, with and without flight logs, where the time goes (one profiled run),
and the ceiling PyBullet alone sets: the same number of steps of one body with the four calls per
step a vehicle makes (two forces, two reads), nothing else."""

import cProfile
import pstats
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.floor import bare_pybullet_cpu_per_body_sim_s  # noqa: E402
from gateway.ci.lockstep import Sim  # noqa: E402
from tests.unit.test_testing_sim import fly_square  # noqa: E402


def once(log_dir=None) -> tuple[float, float]:
    with Sim(1, log_dir=log_dir) as sim:
        t0 = time.perf_counter()
        fly_square(sim)
        return sim.now, time.perf_counter() - t0


def main() -> None:
    for label in ("no logs", "flight logs"):
        best = None
        for _ in range(3):
            with tempfile.TemporaryDirectory() as d:
                sim_s, wall_s = once(d if label == "flight logs" else None)
            best = wall_s if best is None else min(best, wall_s)
        print(f"{label:12}: {sim_s:.1f} s simulated in {best:.3f} s wall = {sim_s / best:.0f}x "
              f"real time (goal >= 200x)")
        if label == "no logs":
            no_logs_s = best / sim_s
    floor = min(bare_pybullet_cpu_per_body_sim_s(1, 60.0, reads=True) for _ in range(3))
    print(f"PyBullet's calls alone: {floor * 1e3:.2f} ms per simulated second, a ceiling of "
          f"{1 / floor:.0f}x; they are {100 * floor / no_logs_s:.0f} % of the run without logs")
    prof = cProfile.Profile()
    prof.enable()
    once()
    prof.disable()
    # (file, function) of the profile entries, whatever line they start on.
    groups = {"physics+autopilot (World.step)": ("physics.py", "step"),
              "sessions: telemetry/timers (VehicleWake._fire)": ("wake.py", "_fire"),
              "uplink delivery → session": ("simulation.py", "_on_uplink_delivered"),
              "downlink delivery → client": ("lockstep.py", "_on_downlink")}
    stats = pstats.Stats(prof)
    total = stats.total_tt
    for name, key in groups.items():
        cum = sum(v[3] for k, v in stats.stats.items() if (Path(k[0]).name, k[2]) == key)
        print(f"  {name:52} {100 * cum / total:5.1f} %")


if __name__ == "__main__":
    main()
