"""``cornet plot LOGDIR``: three PNGs from a run's flight logs (gateway/sim/flightlog.py), headless.

- ``track.png``: top view (world frame, metres north/east of the world's home) of every vehicle's
  flown track, with the planned mission (from the MISSION_ITEM_INT/MISSION_ITEM uploads in the
  tlogs, or a ``.plan`` file) and any uploaded geofence polygons / circles.
- ``altitude_speed.png``: altitude above the home and horizontal speed vs time, mode changes marked.
- ``link.png``: per-link one-way latency and loss per second, from the packet trace.

``LOGDIR`` is a run directory (it holds meta.json) or a base directory of runs (the newest run, by
name, is plotted). Matplotlib's object API with the Agg canvas: no pyplot state, no display.
"""

from __future__ import annotations

import csv
import json
import math
from collections import defaultdict
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from pymavlink.dialects.v20 import common as mavlink2

from gateway.sim.flightlog import (
    META_FILE,
    STATE_FILE,
    TRACE_FILE,
    frame_msgid,
    frame_source,
    read_tlog,
    resolve_run_dir,
)
from vehicles.plan_types import MavCmd, PlanItem, PlanType
from vehicles.plans import GLOBAL_FRAMES, RELATIVE_FRAMES
from vehicles.types import GeoPoint

M = mavlink2
OUTPUTS = ("track.png", "altitude_speed.png", "link.png")
_ITEM_IDS = frozenset({M.MAVLINK_MSG_ID_MISSION_ITEM_INT, M.MAVLINK_MSG_ID_MISSION_ITEM})
MAX_LINKS_DRAWN = 8  # more links than this: aggregated by direction (up / down)
DPI = 100


# --- readers -----------------------------------------------------------------------------------
def read_state(run: Path) -> list[dict[str, str]]:
    with open(run / STATE_FILE, newline="") as f:
        return list(csv.DictReader(f))


def uploaded_plans(run: Path, meta: dict) -> dict[tuple[int, int], list[PlanItem]]:
    """(sysid, mission_type) → the last complete list of items a client uploaded."""
    mav = M.MAVLink(None)
    mav.robust_parsing = True
    sysids = {v["sysid"] for v in meta["vehicles"]}
    uploads: dict[tuple[int, int], dict[int, PlanItem]] = {}
    done: dict[tuple[int, int], list[PlanItem]] = {}
    for v in meta["vehicles"]:
        for name in v["tlogs"]:
            path = run / name
            if not path.is_file():
                continue
            for _, frame in read_tlog(path):
                if frame_msgid(frame) not in _ITEM_IDS or frame_source(frame)[0] in sysids:
                    continue  # telemetry, or a download answered by the vehicle
                mav.buf, mav.buf_index = bytearray(), 0
                msgs = mav.parse_buffer(frame) or []
                if not msgs or msgs[0].get_type() == "BAD_DATA":
                    continue
                m = msgs[0]
                key = (m.target_system, m.mission_type)
                if m.seq == 0:
                    uploads[key] = {}
                scale = 1e7 if m.get_type() == "MISSION_ITEM" and m.frame in GLOBAL_FRAMES else 1
                uploads.setdefault(key, {})[m.seq] = PlanItem(
                    m.seq, m.frame, m.command, m.current, m.autocontinue, m.param1, m.param2,
                    m.param3, m.param4, int(round(m.x * scale)), int(round(m.y * scale)), m.z,
                    m.mission_type)
                items = uploads[key]
                if len(items) == max(items) + 1:
                    done[key] = [items[k] for k in sorted(items)]
    return done


def read_trace(run: Path, bin_s: float = 1.0):
    """Per link: {bin: [latency sum, latency count, sent, dropped]}."""
    bins: dict[str, dict[int, list[float]]] = defaultdict(lambda: defaultdict(lambda: [0.0, 0, 0, 0]))
    path = run / TRACE_FILE
    if not path.is_file():
        return bins
    with open(path) as f:
        for line in f:
            parts = line.split()
            if len(parts) < 4:
                continue
            t, event, link = float(parts[0]), parts[1], parts[2]
            b = bins[link][int(t // bin_s)]
            if event == "send":
                b[2] += 1
                if len(parts) > 4:
                    b[0] += float(parts[4])
                    b[1] += 1
            elif event == "drop":
                b[2] += 1
                b[3] += 1
    return bins


# --- figures -----------------------------------------------------------------------------------
def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=DPI)
    return path


def _world_ne(home: GeoPoint, it: PlanItem) -> tuple[float, float, float]:
    alt = it.z + home.alt_amsl_m if it.frame in RELATIVE_FRAMES else it.z
    n, e, _ = home.ned_of(GeoPoint(it.x * 1e-7, it.y * 1e-7, alt))
    return n, e, alt - home.alt_amsl_m


def plot_track(run: Path, meta: dict, rows: list[dict], plans: dict, out: Path) -> Path:
    home = GeoPoint(*meta["home"])
    fig = Figure(figsize=(7, 7))
    ax = fig.add_subplot()
    by_sysid: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for r in rows:
        by_sysid[r["sysid"]].append((float(r["n_world_m"]), float(r["e_world_m"])))
    for sysid, pts in sorted(by_sysid.items(), key=lambda kv: int(kv[0])):
        ax.plot([p[1] for p in pts], [p[0] for p in pts], lw=1.5, label=f"vehicle {sysid} flown")
    for (sysid, mtype), items in sorted(plans.items()):
        if mtype == PlanType.MISSION:
            pos = [(k, _world_ne(home, it)) for k, it in enumerate(items)
                   if it.frame in GLOBAL_FRAMES and (it.x or it.y)]
            if pos:
                ax.plot([p[1] for _, p in pos], [p[0] for _, p in pos], "k--", marker="o", ms=5,
                        lw=1, label=f"vehicle {sysid} planned")
                for k, p in pos:
                    ax.annotate(str(k), (p[1], p[0]), textcoords="offset points", xytext=(4, 4),
                                fontsize=8)
        elif mtype == PlanType.FENCE:
            _draw_fence(ax, home, items)
    ax.set_xlabel("east of home (m)")
    ax.set_ylabel("north of home (m)")
    ax.set_title("Top view: flown track vs planned mission")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    return _save(fig, out)


def _draw_fence(ax, home: GeoPoint, items: list[PlanItem]) -> None:
    k = 0
    while k < len(items):
        it = items[k]
        if it.command in (MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                          MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION):
            n = max(1, int(it.param1))
            pts = [_world_ne(home, v) for v in items[k:k + n]] + [_world_ne(home, it)]
            color = "g" if it.command == MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION else "r"
            ax.plot([p[1] for p in pts], [p[0] for p in pts], color=color, lw=1, alpha=0.7)
            k += n
            continue
        if it.command in (MavCmd.NAV_FENCE_CIRCLE_INCLUSION, MavCmd.NAV_FENCE_CIRCLE_EXCLUSION):
            n0, e0, _ = _world_ne(home, it)
            r = float(it.param1)
            th = [2 * math.pi * i / 64 for i in range(65)]
            color = "g" if it.command == MavCmd.NAV_FENCE_CIRCLE_INCLUSION else "r"
            ax.plot([e0 + r * math.sin(t) for t in th], [n0 + r * math.cos(t) for t in th],
                    color=color, lw=1, alpha=0.7)
        k += 1


def plot_altitude_speed(rows: list[dict], out: Path) -> Path:
    fig = Figure(figsize=(10, 6))
    ax_alt, ax_spd = fig.subplots(2, 1, sharex=True)
    by_sysid: dict[str, list[dict]] = defaultdict(list)
    for r in rows:
        by_sysid[r["sysid"]].append(r)
    for sysid, rs in sorted(by_sysid.items(), key=lambda kv: int(kv[0])):
        t = [float(r["t_s"]) for r in rs]
        line, = ax_alt.plot(t, [-float(r["d_world_m"]) for r in rs], label=f"vehicle {sysid}")
        ax_spd.plot(t, [math.hypot(float(r["vn_mps"]), float(r["ve_mps"])) for r in rs],
                    color=line.get_color())
        prev = None
        for r in rs:
            if r["mode"] != prev:
                x = float(r["t_s"])
                for ax in (ax_alt, ax_spd):
                    ax.axvline(x, color=line.get_color(), ls=":", lw=0.8)
                ax_alt.annotate(r["mode"], (x, 1.0), xycoords=("data", "axes fraction"),
                                rotation=90, va="top", ha="right", fontsize=7)
                prev = r["mode"]
    ax_alt.set_ylabel("altitude above home (m)")
    ax_spd.set_ylabel("horizontal speed (m/s)")
    ax_spd.set_xlabel("simulated time (s)")
    ax_alt.set_title("Altitude and speed (dotted: mode changes)")
    for ax in (ax_alt, ax_spd):
        ax.grid(True, alpha=0.3)
    ax_alt.legend(loc="upper right", fontsize=8)
    return _save(fig, out)


def plot_link(run: Path, out: Path) -> Path:
    bins = read_trace(run)
    if len(bins) > MAX_LINKS_DRAWN:
        merged: dict[str, dict[int, list[float]]] = defaultdict(lambda: defaultdict(
            lambda: [0.0, 0, 0, 0]))
        for link, per in bins.items():
            key = "all " + link.rsplit("/", 1)[-1]
            for b, v in per.items():
                acc = merged[key][b]
                for i in range(4):
                    acc[i] += v[i]
        bins = merged
    fig = Figure(figsize=(10, 6))
    ax_lat, ax_loss = fig.subplots(2, 1, sharex=True)
    for link, per in sorted(bins.items()):
        ks = sorted(per)
        lat = [(k, per[k][0] / per[k][1] * 1e3) for k in ks if per[k][1]]
        loss = [(k, 100.0 * per[k][3] / per[k][2]) for k in ks if per[k][2]]
        line, = ax_lat.plot([k for k, _ in lat], [v for _, v in lat], label=link, lw=1)
        ax_loss.plot([k for k, _ in loss], [v for _, v in loss], color=line.get_color(), lw=1)
    if not bins:
        ax_lat.text(0.5, 0.5, "no packet trace", transform=ax_lat.transAxes, ha="center")
    ax_lat.set_ylabel("one-way latency (ms, mean/s)")
    ax_loss.set_ylabel("loss (% of datagrams/s)")
    ax_loss.set_xlabel("simulated time (s)")
    ax_lat.set_title("Network: latency and loss per link")
    for ax in (ax_lat, ax_loss):
        ax.grid(True, alpha=0.3)
    if bins:
        ax_lat.legend(loc="upper right", fontsize=7, ncol=2)
    return _save(fig, out)


def plot(log_dir: str | Path, plan_file: str | Path | None = None,
         out_dir: str | Path | None = None) -> list[Path]:
    """Write the three PNGs (into the run directory unless ``out_dir``); returns their paths.
    ``plan_file``: a QGC .plan whose mission is drawn instead of the uploaded one."""
    run = resolve_run_dir(log_dir)
    out = Path(out_dir) if out_dir is not None else run
    out.mkdir(parents=True, exist_ok=True)
    meta = json.loads((run / META_FILE).read_text())
    rows = read_state(run)
    plans = uploaded_plans(run, meta)
    if plan_file is not None:
        from gateway.ci.fly import load_plan

        qp = load_plan(plan_file)
        sysid = meta["vehicles"][0]["sysid"]
        plans[(sysid, PlanType.MISSION)] = list(qp.mission)
        if qp.fence:
            plans[(sysid, PlanType.FENCE)] = list(qp.fence)
    return [plot_track(run, meta, rows, plans, out / OUTPUTS[0]),
            plot_altitude_speed(rows, out / OUTPUTS[1]),
            plot_link(run, out / OUTPUTS[2])]


def main(log_dir: str | Path, plan_file: str | Path | None = None) -> int:
    """What ``cornet plot`` runs: print the PNG paths; exit 2 if there is no log there."""
    import sys

    try:
        paths = plot(log_dir, plan_file)
    except (FileNotFoundError, ValueError) as exc:
        print(f"cornet plot: {exc}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    return 0
