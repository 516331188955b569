"""Assertions on a run's flight logs: what the pytest plugin and users' tests judge a flight by.

The logs are a run directory of ``meta.json`` and ``state.csv`` (gateway/sim/flightlog.py).
Positions come from ``state.csv`` (10 Hz): the vehicle's local NED position from its EKF origin
(meta.json), projected to latitude/longitude as the simulator does (PX4's azimuthal equidistant
map projection, vehicles/geodesy.py); the relative altitude is the height above that origin
(where the vehicle spawned: its home). ``reached`` and ``landed_within`` return a :class:`Check`,
true or false, whose repr says what was measured, so a failing ``assert`` explains itself.
"""

from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vehicles.geodesy import distance_m, reproject

__all__ = ["Check", "FlightLogView", "StateSample", "distance_m", "landed_within",
           "max_deviation_m", "reached"]

META_FILE = "meta.json"
STATE_FILE = "state.csv"


# --- flight logs ---------------------------------------------------------------------------------
def _float(s: str) -> float:
    return float(s) if s else math.nan


@dataclass(frozen=True)
class StateSample:
    """One row of state.csv for one vehicle, with its position as latitude/longitude."""

    t_s: float
    lat_deg: float
    lon_deg: float
    rel_alt_m: float  # height above the vehicle's EKF origin (its spawn point)
    n_m: float  # local NED from the EKF origin
    e_m: float
    d_m: float
    vn_mps: float
    ve_mps: float
    vd_mps: float
    mode: str  # NavState name: AUTO_MISSION, AUTO_RTL, POSCTL ...
    armed: bool
    landed_state: str  # ON_GROUND, TAKEOFF, IN_AIR, LANDING
    battery_remaining: float
    mission_seq: int | None

    @property
    def in_air(self) -> bool:
        return self.landed_state != "ON_GROUND"

    @property
    def ground_speed_mps(self) -> float:
        return math.hypot(self.vn_mps, self.ve_mps)


class FlightLogView:
    """A run's flight logs, read-only: meta.json and state.csv, by vehicle index (0-based, as
    ``mavsdk_url(i)`` and ``Sim.api(i)``); paths of the tlogs and the packet trace."""

    def __init__(self, run_dir: str | Path) -> None:
        from gateway.sim.flightlog import resolve_run_dir

        self.run_dir = resolve_run_dir(run_dir)
        self.meta: dict = json.loads((self.run_dir / META_FILE).read_text())
        self._by_sysid: dict[int, list[StateSample]] = {}
        origins = {int(v["sysid"]): v["origin"] for v in self.meta["vehicles"]}
        state = self.run_dir / STATE_FILE
        if state.is_file():
            with open(state, newline="") as f:
                for r in csv.DictReader(f):
                    sysid = int(r["sysid"])
                    origin = origins.get(sysid)
                    if origin is None:
                        continue
                    n, e, d = _float(r["n_m"]), _float(r["e_m"]), _float(r["d_m"])
                    lat, lon = reproject(origin[0], origin[1], n, e)
                    seq = r.get("mission_seq") or ""
                    self._by_sysid.setdefault(sysid, []).append(StateSample(
                        float(r["t_s"]), lat, lon, -d, n, e, d, _float(r["vn_mps"]),
                        _float(r["ve_mps"]), _float(r["vd_mps"]), r["mode"], r["armed"] == "1",
                        r["landed_state"], _float(r["battery_remaining"]),
                        int(seq) if seq else None))

    @classmethod
    def load(cls, source: Any) -> FlightLogView:
        """From a run directory, a base directory of runs (the newest), a CornetDaemon, a
        ``gateway.ci.lockstep.Sim`` (flushed first) or a FlightLogView."""
        if isinstance(source, FlightLogView):
            return source
        run_dir = getattr(source, "run_dir", None)
        if isinstance(run_dir, Path):  # a CornetDaemon
            return cls(run_dir)
        flightlog = getattr(source, "flightlog", None)
        if flightlog is not None:  # a Sim
            flightlog.flush()
            return cls(flightlog.dir)
        if isinstance(source, (str, os.PathLike)):
            return cls(os.fspath(source))
        raise TypeError(f"not a flight log: {source!r}")

    @property
    def vehicles(self) -> int:
        return len(self.meta["vehicles"])

    def sysid(self, vehicle: int = 0) -> int:
        return int(self.meta["vehicles"][vehicle]["sysid"])

    def home(self, vehicle: int = 0) -> tuple[float, float, float]:
        """The vehicle's home: its EKF origin (lat, lon, alt AMSL), where it spawned."""
        lat, lon, alt = self.meta["vehicles"][vehicle]["origin"]
        return (lat, lon, alt)

    def states(self, vehicle: int = 0) -> list[StateSample]:
        return self._by_sysid.get(self.sysid(vehicle), [])

    def __iter__(self) -> Iterator[StateSample]:
        return iter(self.states(0))

    def modes(self, vehicle: int = 0) -> list[tuple[float, str]]:
        """(time, mode) at every mode change."""
        out: list[tuple[float, str]] = []
        for s in self.states(vehicle):
            if not out or out[-1][1] != s.mode:
                out.append((s.t_s, s.mode))
        return out

    def tlog(self, vehicle: int = 0, link: str = "api") -> Path:
        return self.run_dir / f"v{vehicle + 1}-{link}.tlog"

    @property
    def packet_trace(self) -> Path:
        return self.run_dir / "packets.trace"

    @property
    def duration_s(self) -> float:
        rows = self.states(0)
        return rows[-1].t_s - rows[0].t_s if rows else 0.0

    def __repr__(self) -> str:
        return (f"<FlightLogView {self.run_dir}: {self.vehicles} vehicle(s), "
                f"{self.duration_s:.1f} s>")


# --- assertion helpers ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Check:
    """The outcome of a check on a log: true or false, and what was measured."""

    ok: bool
    detail: str
    value: float = math.nan

    def __bool__(self) -> bool:
        return self.ok

    def __repr__(self) -> str:
        return f"<{'PASS' if self.ok else 'FAIL'}: {self.detail}>"


def _samples(log: Any, vehicle: int) -> tuple[FlightLogView, list[StateSample]]:
    view = FlightLogView.load(log)
    rows = view.states(vehicle)
    if not rows:
        raise AssertionError(f"{view.run_dir}: no state samples of vehicle {vehicle}")
    return view, rows


def reached(log: Any, lat: float, lon: float, rel_alt_m: float | None = None, *,
            within_m: float = 2.0, vehicle: int = 0) -> Check:
    """Whether the vehicle came within ``within_m`` of (lat, lon) — and, if ``rel_alt_m`` is
    given, of that height above its home (3-D distance)."""
    _, rows = _samples(log, vehicle)
    best, when = math.inf, math.nan
    for s in rows:
        h = distance_m(lat, lon, s.lat_deg, s.lon_deg)
        dist = h if rel_alt_m is None else math.hypot(h, s.rel_alt_m - rel_alt_m)
        if dist < best:
            best, when = dist, s.t_s
    where = f"({lat:.7f}, {lon:.7f}" + ("" if rel_alt_m is None else f", {rel_alt_m:g} m") + ")"
    return Check(best <= within_m, f"vehicle {vehicle} came within {best:.2f} m of {where} at "
                 f"t={when:.1f} s (limit {within_m:g} m)", best)


def _target(view: FlightLogView, where: Sequence[Any], vehicle: int) -> tuple[float, float, str]:
    if len(where) == 1 and isinstance(where[0], str) and where[0] == "home":
        lat, lon, _ = view.home(vehicle)
        return lat, lon, "home"
    if len(where) == 1 and hasattr(where[0], "lat_deg"):
        return where[0].lat_deg, where[0].lon_deg, f"({where[0].lat_deg:.7f}, {where[0].lon_deg:.7f})"
    if len(where) == 1 and isinstance(where[0], (tuple, list)) and len(where[0]) >= 2:
        where = where[0][:2]
    if len(where) == 2:
        lat, lon = float(where[0]), float(where[1])
        return lat, lon, f"({lat:.7f}, {lon:.7f})"
    raise TypeError("landed_within(log, lat, lon, m), landed_within(log, (lat, lon), m) or "
                    "landed_within(log, 'home', m)")


def landed_within(log: Any, *where_and_m: Any, vehicle: int = 0) -> Check:
    """Whether the vehicle flew, and its last sample is on the ground within ``m`` (horizontal)
    of the target: ``landed_within(log, lat, lon, m)``, ``landed_within(log, (lat, lon), m)``
    or ``landed_within(log, "home", m)`` (its spawn point)."""
    if len(where_and_m) < 2:
        raise TypeError("landed_within needs a target and a distance in metres")
    view, rows = _samples(log, vehicle)
    lat, lon, name = _target(view, where_and_m[:-1], vehicle)
    limit = float(where_and_m[-1])
    last = rows[-1]
    dist = distance_m(lat, lon, last.lat_deg, last.lon_deg)
    if not any(s.in_air for s in rows):
        return Check(False, f"vehicle {vehicle} never left the ground", dist)
    if last.in_air:
        return Check(False, f"vehicle {vehicle} had not landed at the end of the log "
                     f"(t={last.t_s:.1f} s, {last.landed_state}, {last.rel_alt_m:.1f} m up)", dist)
    return Check(dist <= limit, f"vehicle {vehicle} landed {dist:.2f} m from {name} "
                 f"(limit {limit:g} m)", dist)


def max_deviation_m(log: Any, plan: Any, *, vehicle: int = 0,
                    modes: Sequence[str] = ("AUTO_MISSION",)) -> float:
    """The largest distance (3-D, m) of the flown track, while in one of ``modes``, from the
    planned path: ``cornet fly``'s polyline (start → takeoff altitude → each positional item; a
    land item descends; return-to-launch legs are not judged). ``plan``: a QGroundControl
    ``.plan`` path, a ``gateway.ci.fly.QgcPlan`` or a sequence of mission PlanItems. The path
    starts where the vehicle was when the first judged sample was taken."""
    from gateway.ci.fly import QgcPlan, distance_to_path, load_plan, planned_path
    from vehicles.types import GeoPoint

    if isinstance(plan, (str, os.PathLike)):
        plan = load_plan(os.fspath(plan))
    items = plan.mission if isinstance(plan, QgcPlan) else list(plan)
    view, rows = _samples(log, vehicle)
    judged = [s for s in rows if s.mode in modes]
    if not judged:
        raise AssertionError(f"vehicle {vehicle} was never in {'/'.join(modes)}: no flight "
                             "to compare with the plan")
    origin = GeoPoint(*view.home(vehicle))
    path = planned_path(items, origin, (judged[0].n_m, judged[0].e_m, judged[0].d_m))
    return max(distance_to_path((s.n_m, s.e_m, s.d_m), path) for s in judged)
