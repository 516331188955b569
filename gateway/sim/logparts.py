"""The shards' parts of a log that holds every vehicle, merged into the one file one process writes.

A sharded daemon (gateway/daemon/shard/) simulates each vehicle in exactly one shard; a file
that mixes vehicles — the packet trace, the flight log's state.csv and meta.json — is written by
every shard as its part (``NAME.shard<k>``, gateway/sim/flightlog.py ``part_name``), and merged
here once every shard has closed it.

Order: lines by simulated time (each line's first field), lines of the same instant in shard
order, and each shard's lines of one instant in the order it wrote them. Shards hold contiguous
blocks of vehicles, so this is the order one process writes: its rows of one instant come vehicle
by vehicle (state.csv), and a vehicle's events are ordered as in one process because vehicles do
not schedule each other's events (each shard's kernel runs the one-process order restricted to
its vehicles).
"""

from __future__ import annotations

import contextlib
import heapq
import json
import os
from collections.abc import Iterator
from pathlib import Path

from gateway.sim.files import write_atomic
from gateway.sim.flightlog import META_FILE, STATE_FILE, TRACE_FILE, part_name


def _lines(path: Path, skip: int, sep: str) -> Iterator[tuple[float, str]]:
    with open(path, encoding="ascii", newline="") as f:
        for n, line in enumerate(f):
            if n >= skip:
                yield float(line.split(sep, 1)[0]), line


def merge_lines(target: Path, parts: list[Path], header: int = 0, sep: str = " ") -> None:
    """Write ``target`` from ``parts`` (in shard order) merged by the time in each line's first
    field (separated by ``sep``), keeping the first part's ``header`` lines; remove the parts.
    A missing part (its shard never started) counts as empty."""
    parts = [p for p in parts if p.exists()]
    tmp = target.with_name(target.name + ".tmp")
    with open(tmp, "w", encoding="ascii", newline="") as out:
        if parts and header:
            with open(parts[0], encoding="ascii", newline="") as first:
                for _ in range(header):
                    out.write(first.readline())
        for _, line in heapq.merge(*(_lines(p, header, sep) for p in parts), key=lambda x: x[0]):
            out.write(line)
    os.replace(tmp, target)
    for p in parts:
        with contextlib.suppress(FileNotFoundError):
            p.unlink()


def merge_meta(run_dir: Path, shards: int) -> None:
    """meta.json from the shards' parts: the first part's fields, every shard's vehicles."""
    metas = []
    for k in range(shards):
        path = run_dir / part_name(META_FILE, k)
        if path.exists():
            metas.append(json.loads(path.read_text()))
    if not metas:
        return
    meta = {**metas[0], "vehicles": [v for m in metas for v in m["vehicles"]]}
    write_atomic(run_dir / META_FILE, json.dumps(meta, indent=1, sort_keys=True) + "\n")
    for k in range(shards):
        with contextlib.suppress(FileNotFoundError):
            (run_dir / part_name(META_FILE, k)).unlink()


def merge_run_dir(run_dir: Path, shards: int) -> None:
    """A sharded flight log directory made the one one process writes (tlogs are per vehicle:
    each shard wrote its own)."""
    merge_meta(run_dir, shards)
    merge_lines(run_dir / STATE_FILE, [run_dir / part_name(STATE_FILE, k)
                                       for k in range(shards)], header=1, sep=",")
    merge_trace(run_dir / TRACE_FILE, shards)


def merge_trace(path: Path, shards: int) -> None:
    """A packet trace (``--packet-trace FILE`` or a run directory's) from its shards' parts."""
    merge_lines(path, [path.with_name(part_name(path.name, k)) for k in range(shards)])
