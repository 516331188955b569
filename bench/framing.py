#!/usr/bin/env python3
"""Telemetry framing, before and after, measured in one run.

Two trees are measured side by side: this one ("new") and ``--base`` (default: where this branch
left main, ``git merge-base HEAD main``), checked out into a temporary detached git worktree that
is removed afterwards ("old"). For each tree a child
process (PYTHONPATH = that tree) measures, in-process:

- framing cost per message: ``Encoder.pack`` (the daemon's path: payload packing, MAVLink 2
  truncation, header, CRC) and ``Encoder.frame`` alone (header and CRC around a packed payload)
  for every message the daemon streams, with pymavlink's ``MAVLink_message.pack`` as the
  reference, in ns per message (best of 5 repeats);
- CPU per vehicle-second of ``Simulation(N)`` (default 100, both links per vehicle as the
  daemon has them, vehicles idle on the ground as PX4 SITL starts): process CPU time over
  ``--seconds`` simulated seconds after a 1 s warm-up, / (N x seconds), and the telemetry frames
  that went out per vehicle-second.

Children of the two trees alternate (old, new, old, new ...) ``--repeats`` times so that load
from other work on the machine hits both alike; the table shows the best run of each and the
ratio new/old.

    .venv/bin/python bench/framing.py [--vehicles 100] [--seconds 5] [--repeats 2]
                                      [--base REV]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import timeit
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def child(vehicles: int, seconds: float) -> dict:
    """Run in a tree's own interpreter (PYTHONPATH = the tree): the measurements as a dict."""
    from pymavlink.dialects.v20 import common as M

    from gateway.mavlink.codec import Encoder, packer_of
    from gateway.mavlink.snapshot import Snapshot
    from gateway.mavlink.streams import STREAMS
    from gateway.sim.simulation import Simulation

    sim = Simulation(vehicles)
    sim.run(1.0)
    vehicle = sim.vehicles[0]
    snap = Snapshot(vehicle, 1.0, 1.7e9)
    per_msg = {}
    for spec in STREAMS:
        enc = Encoder(1, 1)
        frame = spec.builder(enc, snap)
        if frame is None:
            continue
        msg = M.MAVLink(None, 0, 0).decode(bytearray(frame))
        cls = type(msg)
        args = tuple(getattr(msg, "_" + f + "_raw", getattr(msg, f)) for f in cls.fieldnames)
        p = packer_of(cls)
        payload = p.pack(args)
        mav = M.MAVLink(None, 1, 1)
        per_msg[msg.get_type()] = {
            "pack_ns": _best_ns(enc.pack, cls, *args),
            "frame_ns": _best_ns(enc.frame, p.msg_id, p.crc_extra, payload),
            "pymavlink_ns": _best_ns(msg.pack, mav),
        }
    frames0 = sum(link.session.stats.tx_frames for link in sim.links.values())
    t0 = time.process_time()
    sim.run(1.0 + seconds)
    cpu = time.process_time() - t0
    frames = sum(link.session.stats.tx_frames for link in sim.links.values()) - frames0
    return {"per_msg": per_msg,
            "cpu_ms_per_vehicle_s": cpu / (vehicles * seconds) * 1e3,
            "frames_per_vehicle_s": frames / (vehicles * seconds)}


def _best_ns(fn, *args, number: int = 2000) -> float:
    """``fn(*args)`` in ns per call, best of 5 repeats."""
    return min(timeit.repeat(lambda: fn(*args), number=number, repeat=5)) / number * 1e9


def run_child(tree: Path, vehicles: int, seconds: float) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run([sys.executable, str(ROOT / "bench" / "framing.py"), "--child",
                          "--vehicles", str(vehicles), "--seconds", str(seconds)],
                         cwd=tree, env=env, capture_output=True, text=True, timeout=600,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def best_of(runs: list[dict]) -> dict:
    out = min(runs, key=lambda r: r["cpu_ms_per_vehicle_s"])
    out = dict(out, per_msg={k: {m: min(r["per_msg"][k][m] for r in runs) for m in v}
                             for k, v in runs[0]["per_msg"].items()})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vehicles", type=int, default=100)
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--base", help="git revision of the 'old' tree (default: merge-base with main)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.vehicles, args.seconds)))
        return
    if args.base is None:
        args.base = subprocess.run(["git", "-C", str(ROOT), "merge-base", "HEAD", "main"],
                                   capture_output=True, text=True, check=True).stdout.strip()[:7]
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "--quiet",
                        str(base), args.base], check=True)
        try:
            runs: dict[str, list[dict]] = {"old": [], "new": []}
            for _ in range(args.repeats):
                runs["old"].append(run_child(base, args.vehicles, args.seconds))
                runs["new"].append(run_child(ROOT, args.vehicles, args.seconds))
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base)],
                           check=True)
    old, new = best_of(runs["old"]), best_of(runs["new"])
    print(f"old = {args.base}, new = this tree; best of {args.repeats} alternating runs each\n")
    print("| message | pymavlink pack() ns | old pack ns | new pack ns | old frame ns "
          "| new frame ns |")
    print("|---|---:|---:|---:|---:|---:|")
    for name, o in old["per_msg"].items():
        n = new["per_msg"][name]
        print(f"| {name} | {n['pymavlink_ns']:.0f} | {o['pack_ns']:.0f} | {n['pack_ns']:.0f} "
              f"| {o['frame_ns']:.0f} | {n['frame_ns']:.0f} |")
    print()
    o_cpu, n_cpu = old["cpu_ms_per_vehicle_s"], new["cpu_ms_per_vehicle_s"]
    print(f"Simulation({args.vehicles}), {args.seconds:g} simulated s, idle vehicles, both links:")
    print(f"  CPU per vehicle-second: old {o_cpu:.2f} ms, new {n_cpu:.2f} ms "
          f"(new/old {n_cpu / o_cpu:.2f})")
    print(f"  telemetry frames per vehicle-second: old {old['frames_per_vehicle_s']:.1f}, "
          f"new {new['frames_per_vehicle_s']:.1f}")


if __name__ == "__main__":
    main()
