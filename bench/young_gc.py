"""The cyclic collector's young-generation passes at scale: N vehicles flown in one process
(gateway.ci.lockstep.Sim, one link each), the heap frozen as the daemon freezes it
(gateway.daemon.heap.settle_heap), then the same flight continued with CPython's default
young-generation threshold (700) and with the daemon's (YOUNG_GC_THRESHOLD), alternately; prints
for each the passes, their time as a share of the process's CPU, and the CPU per vehicle-second.

Every vehicle's latest state (measurement, setpoints, inner-loop command) is always young, so a
pass walks ~35 objects per vehicle, and with a threshold of 700 one comes at every burst of a
step's allocations: the collector's share grows with N.

    python bench/young_gc.py --vehicles 240 --seconds 3
"""

from __future__ import annotations

import argparse
import gc
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gateway.ci.lockstep import Sim  # noqa: E402
from gateway.daemon.heap import YOUNG_GC_THRESHOLD  # noqa: E402


class PassClock:
    """gc.callbacks: the passes of the young generation and the time they take."""

    def __init__(self) -> None:
        self.passes = 0
        self.seconds = 0.0
        self._t0 = 0.0

    def __call__(self, phase: str, info: dict) -> None:
        if phase == "start":
            self._t0 = time.process_time()
        else:
            self.passes += 1
            self.seconds += time.process_time() - self._t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicles", type=int, default=240)
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated, per measurement")
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    n = args.vehicles
    defaults = gc.get_threshold()
    with Sim(n) as sim:
        sim.run_until(lambda: all(sim.status(i).position_valid for i in range(n)), timeout_s=10)
        for i in range(n):
            sim.api(i).arm()
            sim.api(i).takeoff()
        sim.advance(5.0)
        gc.collect()
        gc.freeze()
        results: dict[int, list[tuple[int, float, float]]] = {}
        try:
            for _ in range(args.rounds):
                for threshold in (defaults[0], YOUNG_GC_THRESHOLD):
                    gc.set_threshold(threshold, *defaults[1:])
                    clock = PassClock()
                    gc.callbacks.append(clock)
                    cpu0, sim0 = time.process_time(), sim.now
                    sim.advance(args.seconds)
                    cpu = time.process_time() - cpu0
                    gc.callbacks.remove(clock)
                    results.setdefault(threshold, []).append(
                        (clock.passes, clock.seconds, cpu / (n * (sim.now - sim0))))
        finally:
            gc.set_threshold(*defaults)
            gc.unfreeze()
    print(f"{n} vehicles, {args.rounds} x {args.seconds:.0f} simulated s per threshold:")
    for threshold, rows in results.items():
        passes = sum(r[0] for r in rows)
        share = sum(r[1] for r in rows) / sum(r[2] * n * args.seconds for r in rows)
        per_vs = sum(r[2] for r in rows) / len(rows)
        print(f"  young threshold {threshold:>6}: {passes:4} passes, {100 * share:4.1f} % of the CPU "
              f"in them; mean {per_vs * 1e3:.2f} ms CPU per vehicle-s")
    low, high = results[defaults[0]], results[YOUNG_GC_THRESHOLD]
    ratios = " ".join(f"{h[2] / d[2]:.2f}" for d, h in zip(low, high))
    print(f"  CPU per vehicle-s at {YOUNG_GC_THRESHOLD} / at {defaults[0]}, round by round: {ratios}")


if __name__ == "__main__":
    main()
