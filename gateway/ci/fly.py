"""``cornet fly PLAN``: fly a QGroundControl ``.plan`` headless, in lockstep, and judge the flight.

The plan goes up through the MAVLink mission protocol (mission, then geofence, then rally, as QGC
uploads them) from an in-process client (gateway/ci/lockstep.py); the client arms and switches to
Mission mode as MAVSDK does; the run ends when the vehicle has landed and disarmed, when a pass
criterion is already lost (a geofence breach), or at the time limit. As fast as the CPU allows.

Pass criteria (every one must hold):
- the mission finished: every item was reported reached (but a last Return-to-launch item, which
  PX4 hands over to Return mode instead);
- the vehicle landed and disarmed;
- no geofence breach: every position sampled at GEOFENCE_SAMPLE_S is checked against the plan's
  own fence (vehicles.geofence geometry) as PX4 checks it: every area must allow it (inside each
  inclusion area, outside each exclusion area), whatever GF_ACTION the vehicle has;
- optional: the largest distance from the planned path while in Mission mode is below a limit.

The planned path is the polyline start → takeoff altitude above it → each positional item (a
land item descends at its position); Return-to-launch legs are not judged (they depend on RTL_*).

QGC's plan format (JSON, "fileType": "Plan"): ``mission.items`` of ``SimpleItem`` (command,
frame, params[7] with null for NaN, autoContinue) or ``ComplexItem`` (survey, corridor: the
generated SimpleItems are in ``TransectStyleComplexItem.Items``); ``geoFence.polygons`` (inclusion
flag, [[lat, lon], ...]) and ``geoFence.circles`` (center, radius); ``rallyPoints.points``
([lat, lon, rel_alt]); ``mission.plannedHomePosition`` [lat, lon, alt AMSL].
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gateway.ci.lockstep import Sim, mission_item
from gateway.daemon.progress import ProgressLine
from gateway.data import plan_path
from gateway.sim.scenario import NetworkConfig, Scenario
from vehicles.geodesy import reproject
from vehicles.geofence import build_areas
from vehicles.plan_types import MavCmd, MavFrame, PlanItem, PlanResult, PlanType
from vehicles.plans import GLOBAL_FRAMES, item_ned
from vehicles.types import GeoPoint, NavState, Vec3

DEFAULT_TIME_LIMIT_S = 900.0
GEOFENCE_SAMPLE_S = 0.02  # the position-control rate
TRACK_SAMPLE_S = 0.1  # the flown track kept in FlyResult.track (baselines compare it)
POSITION_VALID_TIMEOUT_S = 10.0
PROGRESS_PERIOD_S = 0.5  # simulated time between progress reports (ProgressLine throttles)
POSITION_COMMANDS = frozenset({MavCmd.NAV_WAYPOINT, MavCmd.NAV_LOITER_UNLIM,
                               MavCmd.NAV_LOITER_TURNS, MavCmd.NAV_LOITER_TIME,
                               MavCmd.NAV_LOITER_TO_ALT})
LAND_COMMANDS = frozenset({MavCmd.NAV_LAND, 85})
TAKEOFF_COMMANDS = frozenset({MavCmd.NAV_TAKEOFF, 84})
# Modes in which the flown path is compared with the plan (offboard: ground control).
JUDGED_MODES = frozenset({NavState.AUTO_MISSION, NavState.OFFBOARD})



class PlanFileError(ValueError):
    """The .plan file cannot be read or uses something we cannot fly."""


@dataclass(frozen=True)
class QgcPlan:
    source: str
    mission: tuple[PlanItem, ...]
    fence: tuple[PlanItem, ...]
    rally: tuple[PlanItem, ...]
    planned_home: GeoPoint | None = None
    polygons: int = 0
    circles: int = 0


def _num(v: Any) -> float:
    return math.nan if v is None else float(v)


def _simple_item(d: dict, where: str) -> PlanItem:
    try:
        command, frame = int(d["command"]), int(d["frame"])
        params = [_num(p) for p in d["params"]]
    except (KeyError, TypeError, ValueError) as exc:
        raise PlanFileError(f"{where}: not a valid SimpleItem ({exc!r})") from None
    if len(params) != 7:
        raise PlanFileError(f"{where}: params must have 7 values, got {len(params)}")
    p5, p6 = params[4], params[5]
    if frame in GLOBAL_FRAMES:
        x, y = (0 if math.isnan(p5) else int(round(p5 * 1e7)),
                0 if math.isnan(p6) else int(round(p6 * 1e7)))
    else:
        x, y = (0 if math.isnan(p5) else int(p5), 0 if math.isnan(p6) else int(p6))
    z = 0.0 if math.isnan(params[6]) else params[6]
    return PlanItem(seq=0, frame=frame, command=command, current=0,
                    autocontinue=int(bool(d.get("autoContinue", True))),
                    param1=params[0], param2=params[1], param3=params[2], param4=params[3],
                    x=x, y=y, z=z, mission_type=int(PlanType.MISSION))


def _mission_items(items: list, where: str) -> list[PlanItem]:
    out: list[PlanItem] = []
    for k, d in enumerate(items):
        here = f"{where}[{k}]"
        if not isinstance(d, dict):
            raise PlanFileError(f"{here}: expected an object")
        kind = d.get("type")
        if kind == "SimpleItem":
            out.append(_simple_item(d, here))
        elif kind == "ComplexItem":
            inner = (d.get("TransectStyleComplexItem") or {}).get("Items")
            if not isinstance(inner, list):
                raise PlanFileError(f"{here}: complex item {d.get('complexItemType')!r} without "
                                    "generated items (save it with QGroundControl ≥ 3.5)")
            out += _mission_items(inner, f"{here}.TransectStyleComplexItem.Items")
        else:
            raise PlanFileError(f"{here}: unknown item type {kind!r}")
    return out


def parse_plan(doc: dict, source: str = "<plan>") -> QgcPlan:
    if not isinstance(doc, dict) or doc.get("fileType") != "Plan":
        raise PlanFileError(f"{source}: not a QGroundControl plan (fileType must be \"Plan\")")
    mission = doc.get("mission") or {}
    items = _mission_items(mission.get("items") or [], "mission.items")
    if not items:
        raise PlanFileError(f"{source}: the mission has no items")
    home = None
    ph = mission.get("plannedHomePosition")
    if isinstance(ph, list) and len(ph) >= 2 and all(v is not None for v in ph[:2]):
        alt = ph[2] if len(ph) > 2 and ph[2] is not None else 0.0
        home = GeoPoint(float(ph[0]), float(ph[1]), float(alt))
    fence: list[PlanItem] = []
    geofence = doc.get("geoFence") or {}
    polygons = geofence.get("polygons") or []
    for k, poly in enumerate(polygons):
        pts = poly.get("polygon") if isinstance(poly, dict) else None
        if not isinstance(pts, list) or len(pts) < 3:
            raise PlanFileError(f"{source}: geoFence.polygons[{k}]: needs at least 3 vertices")
        cmd = (MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION if poly.get("inclusion", True)
               else MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION)
        for lat, lon in pts:
            fence.append(mission_item(cmd, lat, lon, 0.0, params=(len(pts), 0, 0, 0),
                                      frame=MavFrame.GLOBAL, mission_type=PlanType.FENCE))
    circles = geofence.get("circles") or []
    for k, c in enumerate(circles):
        try:
            (lat, lon), radius = c["circle"]["center"], float(c["circle"]["radius"])
        except (KeyError, TypeError, ValueError):
            raise PlanFileError(f"{source}: geoFence.circles[{k}]: needs circle.center and "
                                "circle.radius") from None
        cmd = (MavCmd.NAV_FENCE_CIRCLE_INCLUSION if c.get("inclusion", True)
               else MavCmd.NAV_FENCE_CIRCLE_EXCLUSION)
        fence.append(mission_item(cmd, lat, lon, 0.0, params=(radius, 0, 0, 0),
                                  frame=MavFrame.GLOBAL, mission_type=PlanType.FENCE))
    rally = []
    for k, p in enumerate((doc.get("rallyPoints") or {}).get("points") or []):
        if not isinstance(p, list) or len(p) < 3:
            raise PlanFileError(f"{source}: rallyPoints.points[{k}]: expected [lat, lon, alt]")
        rally.append(mission_item(MavCmd.NAV_RALLY_POINT, p[0], p[1], float(p[2]),
                                  params=(0, 0, 0, 0), frame=MavFrame.GLOBAL_RELATIVE_ALT,
                                  mission_type=PlanType.RALLY))
    return QgcPlan(source, tuple(items), tuple(fence), tuple(rally), home, len(polygons),
                   len(circles))


def load_plan(path: str | Path) -> QgcPlan:
    """A .plan file, or a shipped plan by name (``square``; gateway/data/)."""
    path = plan_path(path)
    try:
        doc = json.loads(path.read_text())
    except OSError as exc:
        raise PlanFileError(f"{path}: cannot read ({exc.strerror})") from None
    except json.JSONDecodeError as exc:
        raise PlanFileError(f"{path}: not valid JSON: {exc}") from None
    except UnicodeDecodeError as exc:
        raise PlanFileError(f"{path}: not UTF-8 text (byte {exc.start}); a .plan is JSON "
                            "text") from None
    try:
        return parse_plan(doc, str(path))
    except PlanFileError as exc:
        msg = str(exc)
        raise PlanFileError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None


# --- the planned path --------------------------------------------------------------------------
def planned_targets(items: Sequence[PlanItem], origin: GeoPoint,
                    start_ned_m: Vec3) -> list[tuple[int | None, Vec3]]:
    """The points of :func:`planned_path`, each with the seq of the item that asks for it (None
    for the start)."""
    pts: list[tuple[int | None, Vec3]] = [(None, start_ned_m)]
    home_alt = origin.alt_amsl_m
    for seq, it in enumerate(items):
        prev = pts[-1][1]
        has_xy = it.frame in GLOBAL_FRAMES and (it.x != 0 or it.y != 0)
        n, e, d = item_ned(it, origin, home_alt) if it.frame in GLOBAL_FRAMES else (*prev[:2], 0.0)
        if not has_xy:
            n, e = prev[0], prev[1]
        if it.command in TAKEOFF_COMMANDS:
            pts.append((seq, (prev[0], prev[1], d)))
            pts.append((seq, (n, e, d)))
        elif it.command in POSITION_COMMANDS:
            pts.append((seq, (n, e, d)))
        elif it.command in LAND_COMMANDS:
            pts.append((seq, (n, e, prev[2])))
            pts.append((seq, (n, e, start_ned_m[2])))
        elif it.command == MavCmd.NAV_RETURN_TO_LAUNCH:
            break
    return pts


def planned_path(items: Sequence[PlanItem], origin: GeoPoint, start_ned_m: Vec3) -> list[Vec3]:
    """The polyline the mission asks for, in the local NED frame of ``origin``."""
    return [p for _, p in planned_targets(items, origin, start_ned_m)]


def distance_to_path(p: Vec3, path: Sequence[Vec3]) -> float:
    if len(path) == 1:
        return math.dist(p, path[0])
    best = math.inf
    for a, b in zip(path, path[1:]):
        ab = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
        ap = (p[0] - a[0], p[1] - a[1], p[2] - a[2])
        L2 = ab[0] ** 2 + ab[1] ** 2 + ab[2] ** 2
        t = 0.0 if L2 == 0 else max(0.0, min(1.0, (ap[0] * ab[0] + ap[1] * ab[1]
                                                   + ap[2] * ab[2]) / L2))
        q = (a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2])
        best = min(best, math.dist(p, q))
    return best


# --- the run -----------------------------------------------------------------------------------
@dataclass
class FlyResult:
    plan: str
    passed: bool = False
    reasons: list[str] = field(default_factory=list)
    items_total: int = 0
    items_reached: int = 0
    mission_finished: bool = False
    landed: bool = False
    disarmed: bool = False
    max_deviation_m: float = 0.0
    max_deviation_limit_m: float | None = None
    geofence_breach: str | None = None
    fence_areas: int = 0
    sim_s: float = 0.0
    wall_s: float = 0.0
    vehicle_texts: list[str] = field(default_factory=list)
    faults: list[str] = field(default_factory=list)  # the scenario's faults, as they fired
    failsafes: list[str] = field(default_factory=list)  # what the vehicle said of failsafes
    refused_plan: bool = False  # the vehicle refused the plan: bad input, not a failed flight
    # What a baseline keeps (gateway/ci/baseline.py): (t, n, e, d) every TRACK_SAMPLE_S from
    # arming on, (t, mode) at each mode change while armed, first MISSION_ITEM_REACHED time by seq, and the
    # links' counters at the end.
    track: list[tuple[float, float, float, float]] = field(default_factory=list)
    mode_changes: list[tuple[float, str]] = field(default_factory=list)
    item_times: dict[int, float] = field(default_factory=dict)
    link_stats: dict[str, dict] = field(default_factory=dict)

    @property
    def exit_code(self) -> int:
        """0 pass, 1 the flight failed its checks, 2 the plan was bad input."""
        if self.refused_plan:
            return 2
        return 0 if self.passed else 1

    @property
    def rtf(self) -> float:
        return self.sim_s / self.wall_s if self.wall_s > 0 else math.inf

    def summary(self) -> str:
        verdict = "PASS" if self.passed else "FAIL: " + "; ".join(self.reasons)
        limit = ("" if self.max_deviation_limit_m is None
                 else f" (limit {self.max_deviation_limit_m:g} m)")
        lines = [f"cornet fly {self.plan}: {verdict}",
                 f"  mission: {self.items_reached}/{self.items_total} items reached, "
                 f"{'finished' if self.mission_finished else 'not finished'}",
                 f"  landed: {'yes' if self.landed else 'no'}, "
                 f"disarmed: {'yes' if self.disarmed else 'no'}",
                 f"  max deviation from the planned path: {self.max_deviation_m:.1f} m{limit}",
                 "  geofence: " + ("no fence in the plan" if not self.fence_areas else
                                   f"breached: {self.geofence_breach}" if self.geofence_breach
                                   else f"never breached ({self.fence_areas} area(s))"),
                 f"  duration: {self.sim_s:.1f} s simulated in {self.wall_s:.2f} s wall "
                 f"(RTF {self.rtf:.0f}x)"]
        if self.faults:
            lines.append("  faults: " + "; ".join(self.faults))
        if self.failsafes:
            lines.append("  failsafes: " + "; ".join(self.failsafes))
        if not self.passed and self.vehicle_texts:
            lines.append("  vehicle said: " + " | ".join(self.vehicle_texts[-5:]))
        return "\n".join(lines)


def fly(plan: QgcPlan | str | Path, *, network: NetworkConfig | None = None,
        scenario: str | Path | Scenario | None = None, params: dict[str, float] | None = None,
        time_limit_s: float = DEFAULT_TIME_LIMIT_S, max_deviation_m: float | None = None,
        log_dir: str | Path | None = None, use_plan_home: bool = True,
        progress: ProgressLine | None = None, control: str = "mission",
        clock: Callable[[], float] = time.perf_counter) -> FlyResult:
    """Fly ``plan`` on vehicle 1 in lockstep and judge it (see the module doc).

    ``use_plan_home``: spawn at the plan's plannedHomePosition (else the scenario's / PX4 SITL
    home). ``progress`` shows sim time, real-time factor, mode and mission item (a bar on a
    terminal, plain periodic lines elsewhere). ``control``: ``mission`` (PX4 flies the plan in
    Mission mode) or ``ground`` (a ground-side controller flies its waypoints with offboard
    velocity setpoints over the network, gateway/ci/ground.py). Raises PlanFileError for an
    unreadable plan."""
    if control not in ("mission", "ground"):
        raise ValueError(f"control must be 'mission' or 'ground', not {control!r}")
    if not isinstance(plan, QgcPlan):
        plan = load_plan(plan)
    wall0 = clock()
    home = plan.planned_home if use_plan_home else None
    res = FlyResult(plan=plan.source, items_total=len(plan.mission),
                    max_deviation_limit_m=max_deviation_m)
    sim = Sim(1 if scenario is None else None, network, scenario=scenario, params=params,
              home=home, log_dir=log_dir, extra_meta={"plan": plan.source})
    try:
        _fly(sim, plan, res, time_limit_s, progress, clock, wall0, control)
    finally:
        if progress is not None:
            progress.close()
        res.sim_s = sim.now
        res.wall_s = clock() - wall0
        res.faults = [f"t={t:.1f} s {f.describe()}" for t, f in sim.simulation.faults_fired]
        res.link_stats = sim.link_stats()
        sim.close()
    if max_deviation_m is not None and res.max_deviation_m >= max_deviation_m:
        res.reasons.append(f"max deviation {res.max_deviation_m:.1f} m >= {max_deviation_m:g} m")
    if not res.reasons:
        if not res.mission_finished:
            res.reasons.append(f"mission not finished ({res.items_reached}/{res.items_total} "
                               "items reached)")
        if not (res.landed and res.disarmed):
            res.reasons.append("did not land and disarm")
    res.passed = not res.reasons
    return res


def _fly(sim: Sim, plan: QgcPlan, res: FlyResult, time_limit_s: float,
         progress: ProgressLine | None, clock: Callable[[], float],
         wall0: float, control: str = "mission") -> None:
    api = sim.api(0)
    vehicle = sim.vehicles[0]
    if not sim.run_until(lambda: sim.status(0).position_valid, POSITION_VALID_TIMEOUT_S):
        res.reasons.append("no valid position estimate")
        return
    for name, items, ptype in (("mission", plan.mission, PlanType.MISSION),
                               ("geofence", plan.fence, PlanType.FENCE),
                               ("rally points", plan.rally, PlanType.RALLY)):
        if not items and ptype is not PlanType.MISSION:
            continue
        result = api.upload_mission(items, ptype)
        if result != PlanResult.ACCEPTED:
            why = "timed out" if result is None else f"rejected ({_result_name(result)})"
            res.reasons.append(f"{name} upload {why}")
            res.refused_plan = result is not None
            return
    origin = vehicle.origin
    n0, e0, d0 = (float(x) for x in sim.state(0).position_ned_m)
    start = (n0, e0, d0)
    path = planned_path(plan.mission, origin, start)
    areas = [area for _, area in build_areas(plan.fence, origin)]
    res.fence_areas = len(areas)

    tick = [0]

    def watch(now: float) -> None:
        st = vehicle.state
        n, e, d = (float(x) for x in st.position_ned_m)
        status = vehicle.status
        mode = status.nav_state.name
        if status.armed and (not res.mode_changes or res.mode_changes[-1][1] != mode):
            res.mode_changes.append((round(now, 3), mode))
        if status.armed and tick[0] % round(TRACK_SAMPLE_S / GEOFENCE_SAMPLE_S) == 0:
            res.track.append((round(now, 3), n, e, d))
        tick[0] += 1
        if areas and status.armed and res.geofence_breach is None:
            lat, lon = reproject(origin.lat_deg, origin.lon_deg, n, e)
            # geofence.cpp isInsidePolygonOrCircle: every area must allow the point (inside
            # each inclusion, outside each exclusion)
            if not all(a.allows(n, e, lat, lon) for a in areas):
                res.geofence_breach = (f"at t={now:.1f} s, {round(n, 1) + 0.0:.1f} m N "
                                       f"{round(e, 1) + 0.0:.1f} m E of the vehicle's origin")
        if status.nav_state in JUDGED_MODES and status.armed and \
                status.landed_state.name != "ON_GROUND":
            dev = distance_to_path((n, e, d), path)
            if dev > res.max_deviation_m:
                res.max_deviation_m = dev

    sim.every(GEOFENCE_SAMPLE_S, watch)
    if progress is not None:
        started = sim.now
        reached: set[int] = set()
        cursor = [0]  # frames of the API client already looked at

        def report(now: float) -> None:
            if now == started:
                return  # the ticker's first call, at start
            wall = clock() - wall0
            cur = api.last("MISSION_CURRENT")
            total = len(plan.mission)
            item = f"{min(cur.seq + 1, total)}/{total}" if cur is not None and total else "-"
            for m in api.messages("MISSION_ITEM_REACHED", since=cursor[0]):
                reached.add(m.seq)
            cursor[0] = len(api.frames)
            done = len(reached & set(range(total)))
            progress.update(now, f"t={now:.0f} s rtf={now / wall if wall > 0 else 0:.0f}x "
                            f"mode={vehicle.status.nav_state.name} item={item}",
                            fraction=done / total if total else None)
        sim.every(PROGRESS_PERIOD_S, report)

    result = api.arm()
    if result != 0:
        res.reasons.append(f"arming {'timed out' if result is None else 'denied'}"
                           + ("" if result is None else f" (MAV_RESULT {result})"))
        _collect(api, res, plan)
        return
    if control == "ground":
        from gateway.ci.ground import fly_ground

        failed = fly_ground(sim, planned_targets(plan.mission, origin, start), res, time_limit_s)
    else:
        result = api.start_mission()
        failed = None if result == 0 else "mission start " + (
            "timed out" if result is None else f"denied (MAV_RESULT {result})")
    if failed is not None:
        res.reasons.append(failed)
        _collect(api, res, plan)
        return
    deadline = time_limit_s
    sim.run_until(lambda: not vehicle.status.armed or res.geofence_breach is not None,
                  max(0.0, deadline - sim.now))
    if res.geofence_breach is not None:
        res.reasons.append(f"geofence breached {res.geofence_breach}")
    elif vehicle.status.armed:
        res.reasons.append(f"still flying at the time limit ({time_limit_s:g} s simulated)")
    status = vehicle.status
    res.disarmed = not status.armed
    res.landed = status.landed_state.name == "ON_GROUND"
    _collect(api, res, plan)


def _collect(api, res: FlyResult, plan: QgcPlan) -> None:
    """What the GCS heard: items reached, mission state, the vehicle's warnings."""
    for t, m in api.timed_messages("MISSION_ITEM_REACHED"):
        res.item_times.setdefault(int(m.seq), round(t, 3))
    reached = set(res.item_times)
    res.items_reached = len(reached & set(range(len(plan.mission))))
    # A last Return-to-launch item is never reported reached: PX4 hands over to Return on it
    # (MAVSDK's is_mission_finished makes the same allowance).
    rtl_last = bool(plan.mission) and plan.mission[-1].command == MavCmd.NAV_RETURN_TO_LAUNCH
    needed = set(range(len(plan.mission) - rtl_last))
    res.mission_finished = res.mission_finished or (bool(plan.mission) and needed <= reached)
    res.vehicle_texts = [m.text for m in api.messages("STATUSTEXT") if m.severity <= 4]
    res.failsafes = [f"t={t:.1f} s {m.text}" for t, m in api.timed_messages("STATUSTEXT")
                     if "ailsafe" in m.text]


def _result_name(result: int) -> str:
    try:
        return PlanResult(result).name
    except ValueError:
        return str(result)


def main(plan: str | Path, **kwargs: Any) -> int:
    """What ``cornet fly`` runs: fly, print the summary, return the exit code (2: bad plan)."""
    import sys

    try:
        res = fly(plan, **kwargs)
    except PlanFileError as exc:
        print(f"cornet fly: {exc}", file=sys.stderr)
        return 2
    print(res.summary(), flush=True)
    return res.exit_code
