#!/usr/bin/env python3
"""What the MAVLink links cost per vehicle-second, with the physics taken out.

``Simulation(N)`` (both links per vehicle, as the daemon runs them; embedded ideal network; a
no-op downlink sink) runs ``--warmup`` simulated seconds, then the world's step becomes a no-op:
the vehicles hold their last state and what is left is the links' wake-ups (sessions, telemetry
framing, downlinks, the kernel). Two figures per vehicle-second:

- Python bytecodes executed (``sys.settrace`` opcode events over ``--trace-seconds``): a count
  that does not depend on the machine's load, so trees can be compared exactly; with ``--top K``
  the K functions that execute most of them;
- process CPU time, best of ``--repeats`` runs of ``--seconds`` each (noisy on a shared machine:
  compare trees alternately).

Compare two trees by running it with each one on PYTHONPATH:

    PYTHONPATH=<tree> .venv/bin/python bench/session_path.py [--vehicles 2] [--top 20]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.append(str(Path(__file__).resolve().parents[1]))  # PYTHONPATH picks the tree

from gateway.sim.simulation import Simulation  # noqa: E402


def frozen(vehicles: int, warmup_s: float) -> Simulation:
    sim = Simulation(vehicles)
    sim.on_downlink = lambda index, tag, datagram, peer: None
    sim.run(until=warmup_s)
    sim._physics._callback = lambda now: None  # the vehicles keep their last state
    return sim


def bytecodes(sim: Simulation, seconds: float) -> Counter:
    counts: Counter = Counter()

    def local(frame, event, arg):
        if event == "opcode":
            code = frame.f_code
            counts[(Path(code.co_filename).name, code.co_name)] += 1
        return local

    def start(frame, event, arg):
        frame.f_trace_opcodes = True
        frame.f_trace_lines = False
        return local

    sys.settrace(start)
    try:
        sim.run(until=sim.now + seconds)
    finally:
        sys.settrace(None)
    return counts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vehicles", type=int, default=2)
    ap.add_argument("--warmup", type=float, default=5.0, help="simulated s with physics")
    ap.add_argument("--trace-seconds", type=float, default=2.0)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--top", type=int, default=0)
    args = ap.parse_args()
    n = args.vehicles
    sim = frozen(n, args.warmup)
    counts = bytecodes(sim, args.trace_seconds)
    per = 1.0 / (n * args.trace_seconds)
    print(f"bytecodes per vehicle-second: {sum(counts.values()) * per:.0f}")
    for (file, fn), c in counts.most_common(args.top):
        print(f"  {c * per:9.0f}  {file}:{fn}")
    best = min(_cpu(sim, args.seconds) for _ in range(args.repeats))
    print(f"CPU per vehicle-second: {best / (n * args.seconds) * 1e6:.0f} us "
          f"(best of {args.repeats})")
    sim.close()


def _cpu(sim: Simulation, seconds: float) -> float:
    t0 = time.process_time()
    sim.run(until=sim.now + seconds)
    return time.process_time() - t0


if __name__ == "__main__":
    main()
