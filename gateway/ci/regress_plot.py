"""PNGs of flight regression: a flight over its baseline, and a sweep's grid.

- :func:`plot_overlay`: top view (metres north/east of the vehicle's origin) of the baseline's and
  the new track, and their altitude and distance apart against progress along the track
  (the equal-progress comparison of gateway/ci/baseline.py).
- :func:`plot_sweep`: per cell of a sweep (gateway/ci/sweep.py), the success rate, the completion
  time and the drift (largest deviation from the planned path), against the first swept axis,
  one line per combination of the others; failing cells are marked, and the first value of the
  axis at which a line stops succeeding every time (its failure boundary) is highlighted.

Matplotlib's object API with the Agg canvas (as gateway/ci/plot.py): no pyplot state, no display.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from gateway.ci.baseline import Baseline, by_progress
from gateway.ci.plot import _save

SWEEP_OUTPUTS = ("success_rate.png", "completion_time.png", "drift.png")


def plot_overlay(base: Baseline, res: Any, out: str | Path) -> Path:
    """Baseline vs the flight ``res`` (a gateway.ci.fly.FlyResult)."""
    now = np.array(res.track, dtype=float).reshape(-1, 4)
    fig = Figure(figsize=(12, 5.5))
    top = fig.add_subplot(1, 2, 1)
    for track, style, label in ((base.track, "k--", "baseline"), (now, "-", "now")):
        if len(track):
            top.plot(track[:, 2], track[:, 1], style, lw=1.4, label=label)
    top.set_xlabel("east (m)")
    top.set_ylabel("north (m)")
    top.set_aspect("equal", adjustable="datalim")
    top.grid(True, alpha=0.3)
    top.legend(loc="best")
    top.set_title(f"{base.plan}: top view")
    side = fig.add_subplot(1, 2, 2)
    progress = np.linspace(0, 100, len(by_progress(base.track[:, 1:])))
    a = by_progress(base.track[:, 1:])
    b = by_progress(now[:, 1:])
    side.plot(progress, -a[:, 2], "k--", label="baseline altitude")
    side.plot(progress, -b[:, 2], "-", label="altitude now")
    side.set_xlabel("progress along the track (%)")
    side.set_ylabel("altitude above the origin (m)")
    apart = side.twinx()
    apart.plot(progress, np.linalg.norm(a - b, axis=1), color="tab:red", lw=1.0,
               label="distance apart")
    apart.set_ylabel("distance between the tracks at equal progress (m)", color="tab:red")
    side.grid(True, alpha=0.3)
    side.legend(loc="upper left")
    side.set_title("altitude and divergence vs progress")
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    return _save(fig, out)


def plot_sweep(cells: Sequence[dict[str, Any]], axis: str, axis_label: str,
               out_dir: str | Path) -> list[Path]:
    """``cells``: one dict per cell, with ``axis`` (a number), ``group`` (the other axes' values,
    a label), ``success_rate``, ``completion_s`` and ``drift_m`` (NaN: no flight finished)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    groups: dict[str, list[dict[str, Any]]] = {}
    for c in cells:
        groups.setdefault(c["group"], []).append(c)
    paths = []
    for name, key, what, ylabel in (
            ("success_rate.png", "success_rate", "success rate", "flights passed / flown"),
            ("completion_time.png", "completion_s", "completion time",
             "simulated s (mean of the passing flights)"),
            ("drift.png", "drift_m", "drift: largest deviation from the plan",
             "m (mean of the flights that finished)")):
        fig = Figure(figsize=(8, 5))
        ax = fig.add_subplot(1, 1, 1)
        for label, rows in groups.items():
            rows = sorted(rows, key=lambda c: c["axis"])
            x = [c["axis"] for c in rows]
            y = [c[key] for c in rows]
            (line,) = ax.plot(x, y, "o-", label=label or "all")
            bad = [(xi, yi) for xi, yi, c in zip(x, y, rows) if c["success_rate"] < 1.0
                   and yi == yi]
            if bad:
                ax.plot([p[0] for p in bad], [p[1] for p in bad], "x", color="tab:red", ms=10,
                        mew=2)
            edge = next((c["axis"] for c in rows if c["success_rate"] < 1.0), None)
            if edge is not None:
                ax.axvline(edge, color=line.get_color(), ls=":", lw=1.5)
                ax.annotate(f" fails from {edge:g}", (edge, 0.03), xycoords=("data", "axes fraction"),
                            fontsize=8, color=line.get_color(), ha="right", va="bottom",
                            rotation=90)
        if key == "success_rate":
            ax.set_ylim(-0.05, 1.05)
        ax.set_xlabel(axis_label)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="best")
        ax.set_title(f"{what} per cell (x: failing cells; dotted: failure boundary)",
                     fontsize=10)
        fig.tight_layout()
        paths.append(_save(fig, out_dir / name))
    return paths
