#!/usr/bin/env python3
"""A long run of the hostile-message property test (tests/unit/test_fuzz.py): well-formed MAVLink
2 frames of every message type a vehicle's session routes (and a few it does not), with extreme
field values (NaN, ±inf, ±3e38, integer limits, empty and oversized strings, wrong targets),
through one simulated vehicle in lockstep on both of its links.

Counted, never stopping at the first: exceptions that escaped a handler (the simulation's
``internal_errors``), telemetry fields that came out non-finite, vehicle states that went
non-finite. At the end the vehicle must still stream HEARTBEAT and answer a land command.

    python bench/fuzz_campaign.py --messages 100000 [--seed 1]
"""

from __future__ import annotations

import argparse
import collections
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests" / "unit")]

import test_fuzz as fuzz  # noqa: E402
from hypothesis import HealthCheck, given, seed, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from pymavlink.dialects.v20 import common as M  # noqa: E402

from gateway.mavlink.session import LinkKind  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--messages", type=int, default=100_000,
                        help="stop after this many generated frames (default 100000)")
    parser.add_argument("--seed", type=int, default=1, help="Hypothesis seed (default 1)")
    args = parser.parse_args()
    if args.messages < 1:
        parser.error("--messages must be at least 1")

    sim = fuzz._sim()
    tried: collections.Counter[str] = collections.Counter()
    failures = {"escaped": 0, "telemetry": 0, "state": 0}
    bad_fields: collections.Counter[str] = collections.Counter()  # TYPE.field: times non-finite
    examples = [0]
    t0 = time.perf_counter()

    @seed(args.seed)
    @settings(max_examples=args.messages, deadline=None, database=None, derandomize=False,
              suppress_health_check=list(HealthCheck))
    @given(st.lists(fuzz.hostile_frame(), min_size=1, max_size=3), st.sampled_from(list(LinkKind)))
    def campaign(frames: list[bytes], kind: LinkKind) -> None:
        if sum(tried.values()) >= args.messages:
            return
        examples[0] += 1
        before = sim.internal_errors
        rx = M.MAVLink(None, 0, 0)
        rx.robust_parsing = True
        for f in frames:
            tried[rx.decode(bytearray(f)).get_type()] += 1
            sim.inject(0, kind, f, ("fuzz", 1))
        sim.run(until=sim.now + 0.05)
        failures["escaped"] += sim.internal_errors - before
        bad = fuzz.non_finite_telemetry()
        failures["telemetry"] += len(bad)
        bad_fields.update(bad)
        k = sim.vehicles[0].kinematics
        if not all(math.isfinite(x) for x in k.position_ned_m + k.attitude_q):
            failures["state"] += 1

    while sum(tried.values()) < args.messages:
        campaign()
    wall = time.perf_counter() - t0
    health_ok = True
    try:
        fuzz.test_after_the_fuzzing_the_vehicle_still_answers_and_lands()
    except AssertionError as exc:
        health_ok = False
        print(f"health check failed: {exc}")
    total = sum(tried.values())
    print(f"{total} generated messages in {examples[0]} examples ({len(tried)} message types), "
          f"{sim.now:.0f} s simulated in {wall:.0f} s wall")
    print("per type: " + ", ".join(f"{name} {n}" for name, n in sorted(tried.items())))
    print(f"escaped exceptions: {failures['escaped']}; non-finite telemetry fields: "
          f"{failures['telemetry']}; non-finite vehicle states: {failures['state']}; "
          f"afterwards HEARTBEAT and land ACK: {'yes' if health_ok else 'NO'}")
    if bad_fields:
        print("non-finite fields: " + ", ".join(f"{name} {n}" for name, n in
                                                 bad_fields.most_common()))
    for s in fuzz._SIM:
        s.close()
    return 0 if health_ok and not any(failures.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
