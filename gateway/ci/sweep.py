"""``cornet sweep PLAN``: fly a plan over a grid of conditions, in parallel, and tabulate it.

    cornet sweep square.plan --latency-ms 0,100,300 --loss 0,0.2 --seeds 3 --out sweep/

The grid is the product of the swept axes (``--latency-ms``, ``--jitter-ms``, ``--loss``, each
``--scenario``, each ``--param NAME=V1,V2``); every cell is flown once per seed (0..N-1: the
network's random streams, the sensor noise and the wind), each flight in lockstep
(gateway/ci/fly.py) in a process of a pool (spawned, ``--jobs`` at a time, default the core
count). Flights are deterministic, so the table does not depend on the order they finish in.

Writes into ``--out``: ``sweep.csv`` (one row per flight), ``cells.csv`` (one row per cell:
success rate, mean completion time of the passing flights, mean drift — the largest deviation
from the planned path — of the flights that finished the mission) and the PNGs of
gateway/ci/regress_plot.py (against the first swept axis, the first value at which a cell stops
passing every seed highlighted).

The control is the sweep's own question. By default (``--control ground``) a ground-side
controller (gateway/ci/ground.py) flies the waypoints: it sees the vehicle only through telemetry
and sends offboard velocity setpoints, both across the swept network, so the drift grows with the
latency — the paper's Fig. 8. ``--control mission`` uploads the plan and PX4 flies it onboard, as
``cornet fly`` does: the network then only delays the upload and the commands. Progress: a bar
on a terminal, a line per finished flight elsewhere. Exit 0 every flight passed, 1 some failed, 2 bad input.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import itertools
import math
import multiprocessing
import os
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gateway.ci import report
from gateway.ci.spec import FlightSpec

FLIGHT_COLUMNS = ("cell", "seed", "conditions", "control", "passed", "reasons", "items_reached",
                  "items_total", "mission_finished", "landed", "completion_s", "drift_m",
                  "sim_s", "wall_s")
CELL_COLUMNS = ("cell", "conditions", "flights", "passed", "success_rate", "completion_s",
                "drift_m")
AXIS_LABELS = {"latency_ms": "one-way latency (ms)", "jitter_ms": "jitter (ms)",
               "loss": "loss probability", "scenario": "scenario"}


class SweepError(ValueError):
    """The grid cannot be flown: bad input (exit 2)."""


@dataclass(frozen=True)
class Axis:
    name: str  # latency_ms, jitter_ms, loss, scenario, or a PX4 parameter name
    values: tuple[Any, ...]

    @property
    def label(self) -> str:
        return AXIS_LABELS.get(self.name, self.name)


def grid(base: FlightSpec, axes: list[Axis], seeds: int) -> list[tuple[int, FlightSpec]]:
    """(cell index, spec) for every cell and seed, cells in the order of the axes' product."""
    if not axes or any(not a.values for a in axes) or seeds < 1:
        raise SweepError("the grid is empty: give at least one value on each swept axis")
    out = []
    for cell, values in enumerate(itertools.product(*(a.values for a in axes))):
        fields: dict[str, Any] = {}
        params = dict(base.params)
        for axis, v in zip(axes, values):
            if axis.name in AXIS_LABELS:
                fields[axis.name] = v
            else:
                params[axis.name] = v
        for seed in range(seeds):
            out.append((cell, FlightSpec(**{**base.as_dict(), **fields, "params": params,
                                            "seed": seed})))
    return out


def _fly_one(spec: FlightSpec) -> dict[str, Any]:
    """One flight, in a worker process: its row of sweep.csv and its report."""
    from gateway.ci.regress import fly_spec

    try:
        res = fly_spec(spec)
    except Exception as exc:  # one broken flight is a failed cell, not a lost sweep
        return {"seed": spec.seed, "conditions": spec.conditions(control=False),
                "control": spec.control, "passed": False,
                "reasons": f"error: {exc!r}", "items_reached": 0, "items_total": 0,
                "mission_finished": False, "landed": False, "completion_s": math.nan,
                "drift_m": math.nan, "sim_s": 0.0, "wall_s": 0.0, "summary": repr(exc)}
    times = list(res.item_times.values())
    return {"seed": spec.seed, "conditions": spec.conditions(control=False),
            "control": spec.control, "passed": res.passed,
            "reasons": "; ".join(res.reasons), "items_reached": res.items_reached,
            "items_total": res.items_total, "mission_finished": res.mission_finished,
            "landed": res.landed,
            "completion_s": round(max(times), 3) if res.mission_finished and times else math.nan,
            "drift_m": round(res.max_deviation_m, 3), "sim_s": round(res.sim_s, 3),
            "wall_s": round(res.wall_s, 3), "summary": res.summary()}


def run_grid(flights: list[tuple[int, FlightSpec]], jobs: int,
             on_done: Callable[[dict[str, Any]], None] | None = None) -> list[dict[str, Any]]:
    """Fly every (cell, spec), ``jobs`` at a time (1: in this process). Rows in grid order."""
    rows: list[dict[str, Any] | None] = [None] * len(flights)

    def done(k: int, row: dict[str, Any]) -> None:
        row["cell"] = flights[k][0]
        rows[k] = row
        if on_done is not None:
            on_done(row)

    if jobs <= 1:
        for k, (_, spec) in enumerate(flights):
            done(k, _fly_one(spec))
    else:
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
            futures = {pool.submit(_fly_one, spec): k for k, (_, spec) in enumerate(flights)}
            try:
                for fut in as_completed(futures):
                    done(futures[fut], fut.result())
            except BaseException:  # Ctrl-C, SIGTERM: no more flights
                pool.shutdown(wait=False, cancel_futures=True)
                raise
    return [r for r in rows if r is not None]


def _mean(values: list[float]) -> float:
    values = [v for v in values if v == v]
    return round(sum(values) / len(values), 3) if values else math.nan


def cells(rows: list[dict[str, Any]], specs: dict[int, FlightSpec]) -> list[dict[str, Any]]:
    out = []
    for cell in sorted({r["cell"] for r in rows}):
        mine = [r for r in rows if r["cell"] == cell]
        ok = [r for r in mine if r["passed"]]
        conditions = dataclasses.replace(specs[cell], seed=None).conditions(control=False)
        out.append({"cell": cell, "conditions": conditions, "flights": len(mine),
                    "passed": len(ok), "success_rate": round(len(ok) / len(mine), 4),
                    "completion_s": _mean([r["completion_s"] for r in ok]),
                    "drift_m": _mean([r["drift_m"] for r in mine if r["mission_finished"]])})
    return out


def _write_csv(path: Path, columns: tuple[str, ...], rows: list[dict[str, Any]]) -> Path:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, columns, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    return path


def _x_axis(axes: list[Axis]) -> Axis:
    """The axis the plots draw along: the first numeric one with several values."""
    for a in axes:
        if len(a.values) > 1 and a.name != "scenario":
            return a
    return next((a for a in axes if a.name != "scenario"), axes[0])


def plot_cells(table: list[dict[str, Any]], axes: list[Axis], out: Path) -> list[Path]:
    from gateway.ci.regress_plot import plot_sweep

    x = _x_axis(axes)
    others = [a for a in axes if a is not x and len(a.values) > 1]
    shape = [len(a.values) for a in axes]
    points = []
    for c in table:
        idx = _unravel(c["cell"], shape)
        value = dict(zip([a.name for a in axes], (a.values[i] for a, i in zip(axes, idx))))
        xv = value[x.name]
        group = ", ".join(f"{a.label.split(' (')[0]} {_show(value[a.name])}" for a in others)
        points.append({**c, "axis": xv if x.name != "scenario" else idx[axes.index(x)],
                       "group": group})
    return plot_sweep(points, x.name, x.label, out)


def _show(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else Path(str(v)).name


def _unravel(k: int, shape: list[int]) -> list[int]:
    idx = []
    for n in reversed(shape):
        idx.append(k % n)
        k //= n
    return idx[::-1]


def boundaries(table: list[dict[str, Any]]) -> list[str]:
    """The cells that did not pass every seed, in grid order."""
    return [f"{c['conditions']}: {c['passed']}/{c['flights']} passed" for c in table
            if c["success_rate"] < 1.0]


def sweep(base: FlightSpec, axes: list[Axis], seeds: int, out: Path, jobs: int,
          progress: Any = None) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    flights = grid(base, axes, seeds)
    specs = {cell: spec for cell, spec in flights}
    failed = [0]
    finished = [0]

    def on_done(row: dict[str, Any]) -> None:
        failed[0] += not row["passed"]
        finished[0] += 1
        n = finished[0]
        if progress is not None:
            progress.update(n, f"{n}/{len(flights)} flights, {failed[0]} failed; last: "
                            f"{row['conditions']}: {'pass' if row['passed'] else 'FAIL'} "
                            f"(drift {row['drift_m']:.1f} m)", fraction=n / len(flights),
                            force=n == len(flights))

    rows = run_grid(flights, jobs, on_done)
    if progress is not None:
        progress.close()
    table = cells(rows, specs)
    out.mkdir(parents=True, exist_ok=True)
    _write_csv(out / "sweep.csv", FLIGHT_COLUMNS, rows)
    _write_csv(out / "cells.csv", CELL_COLUMNS, table)
    plot_cells(table, axes, out)
    return rows, table


def axes_from_args(args: argparse.Namespace,
                   parse_params: Callable[[list[str]], dict[str, float]]) -> list[Axis]:
    axes = [Axis(name, tuple(v)) for name, v in (("latency_ms", args.latency_ms),
                                                 ("jitter_ms", args.jitter_ms),
                                                 ("loss", args.loss)) if v is not None]
    if args.scenario:
        if axes:
            raise SweepError("--scenario sets the network: sweep it, or --latency-ms/"
                             "--jitter-ms/--loss, not both")
        names = [str(p) for p in args.scenario]
        if len(set(names)) != len(names):
            raise SweepError("--scenario: the same file twice")
        axes.append(Axis("scenario", tuple(names)))
    seen = set()
    for flag in args.param:
        name, sep, values = flag.partition("=")
        if not sep or not values.strip():
            raise SweepError(f"--param {flag}: expected NAME=V1,V2, e.g. MPC_XY_CRUISE=5,10")
        if name in seen:
            raise SweepError(f"--param {name}: given twice")
        seen.add(name)
        vals = [v.strip() for v in values.split(",")]
        parsed = [parse_params([f"{name}={v}"])[name] for v in vals]
        if len(set(parsed)) != len(parsed):
            raise SweepError(f"--param {flag}: repeats a value")
        axes.append(Axis(name, tuple(parsed)))
    return axes or [Axis("latency_ms", (0.0,))]


def main(args: argparse.Namespace, parse_params: Callable[[list[str]], dict[str, float]]) -> int:
    """What ``cornet sweep`` runs."""
    from gateway.ci.fly import PlanFileError, load_plan
    from gateway.daemon.progress import ProgressLine
    from gateway.sim.scenario import ScenarioError, load

    try:
        load_plan(args.plan)
        axes = axes_from_args(args, parse_params)
        for path in args.scenario:
            load(path)
        args.out.mkdir(parents=True, exist_ok=True)
    except (PlanFileError, SweepError, ScenarioError) as exc:
        print(f"cornet sweep: {exc}", file=sys.stderr)
        return report.EXIT_BAD_INPUT
    except OSError as exc:
        print(f"cornet sweep: --out {args.out}: not a writable directory ({exc.strerror})",
              file=sys.stderr)
        return report.EXIT_BAD_INPUT
    base = FlightSpec(str(args.plan), time_limit_s=args.time_limit,
                      max_deviation_m=args.max_deviation, control=args.control)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    jobs = args.jobs or cores or 1
    flights = len(grid(base, axes, args.seeds))
    how = {"ground": "waypoints flown from the ground over the network",
           "mission": "PX4 flies the plan onboard"}[args.control]
    print(f"cornet sweep {args.plan}: {flights} flights ({flights // args.seeds} cells x "
          f"{args.seeds} seeds), {min(jobs, flights)} at a time; control {args.control}: {how}",
          flush=True)
    wall0 = time.perf_counter()
    try:
        rows, table = sweep(base, axes, args.seeds, args.out, min(jobs, flights),
                            ProgressLine(sys.stderr, plain_period_s=0.0))
    except KeyboardInterrupt:
        print("\ncornet sweep: interrupted, nothing written", file=sys.stderr)
        return 130
    wall = time.perf_counter() - wall0
    print(f"{'cell':>4}  {'passed':>6}  {'completion':>10}  {'drift':>7}  conditions")
    for c in table:
        print(f"{c['cell']:>4}  {c['passed']:>2}/{c['flights']:<3}  {c['completion_s']:>8.1f} s"
              f"  {c['drift_m']:>5.2f} m  {c['conditions']}")
    failing = boundaries(table)
    print("failing cells: " + ("; ".join(failing) if failing else "none"))
    print(f"{len(rows)} flights in {wall:.0f} s wall; wrote {args.out / 'sweep.csv'}, "
          f"{args.out / 'cells.csv'} and the PNGs in {args.out}", flush=True)
    name = Path(args.plan).stem
    cases = [report.Case(r["conditions"], f"cornet.sweep.{name}", r["wall_s"],
                         None if r["passed"] else f"{r['conditions']}: {r['reasons']} "
                         f"(drift {r['drift_m']:.2f} m, {r['items_reached']}/"
                         f"{r['items_total']} items)", r["summary"]) for r in rows]
    if args.junit_xml is not None:
        report.write_junit(args.junit_xml, f"cornet sweep {name}", cases)
    if args.summary is not None:
        lines = ["| cell | passed | completion (s) | drift (m) | conditions |",
                 "|---|---|---|---|---|"]
        lines += [f"| {c['cell']} | {c['passed']}/{c['flights']} | {c['completion_s']:.1f} | "
                  f"{c['drift_m']:.2f} | {c['conditions']} |" for c in table]
        report.write_summary(args.summary, f"cornet sweep {Path(args.plan).name}", cases,
                             "\n".join(lines))
    return report.EXIT_PASS if all(r["passed"] for r in rows) else report.EXIT_FAIL
