"""PX4's mission feasibility check for a multicopter: whether the stored mission may be flown.

Source: PX4 src/modules/navigator/MissionFeasibility/FeasibilityChecker.cpp (the 2022-2023 code
of PX4 1.15: ``processNextItem`` stops at the first invalid item; the takeoff altitude only has to
be above home; the first waypoint is measured from the vehicle's position; MIS_DIST_WPS is no
longer read), mission_feasibility_checker.cpp (``checkMissionFeasible``: the items one by one, then
every positional item against the geofence) and mission_base.cpp (``check_mission_valid``: run
again when the mission, the geofence or home changes; ``canRunMissionFeasibility``: only once
home is set). Its unit tests (FeasibilityCheckerTest.cpp) are reproduced in
tests/unit/test_mission_feasibility.py.

Rules:
- ``FeasibilityChecker`` is PX4's class: ``process_next_item`` for each item in order (the first
  resets it and reads home, the landed state, the vehicle's position and MIS_DIST_1WP /
  MIS_TKO_LAND_REQ), then ``some_check_failed``. Each failing check sends PX4's critical text
  (with its tab) and event once.
- A mission is infeasible when an item's command is not one PX4 flies (e.g. CONDITION_DELAY),
  a positional item uses a relative altitude without home, it starts with a landing while
  landed, a takeoff is not above home or comes after a positional item, it holds VTOL items,
  its first positional item is MIS_DIST_1WP or farther from the vehicle, a gate sits on a
  waypoint, MIS_TKO_LAND_REQ is not met, or a positional item is outside the geofence.
- ``MissionCheck`` caches the verdict: it runs the check once home is set (the mission is not
  valid until then), then again when the mission or the fence changed (MissionBase's
  onMissionUpdate / _mission_checked) and on each Mission activation (``force``:
  Mission::on_activation). A new home alone, or a parameter change, does not run it in PX4
  1.15 (check_mission_valid compares the home counter only when one of those calls it). Each
  run resets the reached item (check_mission_valid: seq_reached = -1), reported to ``on_run``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

from vehicles import events as ev
from vehicles.cnum import c_int
from vehicles.events import Log
from vehicles.geodesy import distance_m
from vehicles.plan_types import PlanItem, PlanType
from vehicles.plans import RELATIVE_FRAMES, item_ned
from vehicles.status_log import StatusLog
from vehicles.types import GeoPoint, HomePosition

FLT_EPSILON = 1.1920929e-07
GATE_MIN_DIST_M = 0.05
# PX4's NAV_CMD numbers (navigation.h) that appear below
WAYPOINT, LOITER_UNLIMITED, LOITER_TIME, RTL, LAND, TAKEOFF, LOITER_TO_ALT = 16, 17, 19, 20, 21, 22, 31
FOLLOW_REPOSITION, VTOL_TAKEOFF, VTOL_LAND, CONDITION_GATE, VTOL_TRANSITION = 33, 84, 85, 4501, 3000
NAV_ROI, DO_SET_ROI = 80, 201
# checkMissionItemValidity: the commands PX4 flies
SUPPORTED = frozenset({
    0, WAYPOINT, LOITER_UNLIMITED, LOITER_TIME, RTL, LAND, TAKEOFF, LOITER_TO_ALT, VTOL_TAKEOFF,
    VTOL_LAND, 93, CONDITION_GATE, 42600, 211, 177, 178, 179, 189, 2003, 203, 2000, 2001, 2500, 2501,
    200, 204, 205, 1000, 1001, 187, DO_SET_ROI, 195, 196, 197, 206, 260, 214, 530, 531, 532,
    VTOL_TRANSITION})
# checkTakeoff: the items that may come before a takeoff (they have no position)
NO_POSITION = frozenset({
    0, 93, 177, 178, 179, 189, 2003, 203, 2000, 2001, 2500, 2501, 200, 204, 205, 1000, 1001,
    DO_SET_ROI, 195, 196, 197, 206, 260, 214, 530, 531, 532, VTOL_TRANSITION})
# MissionBlock::item_contains_position
POSITIONAL = frozenset({WAYPOINT, LOITER_UNLIMITED, LOITER_TIME, LAND, TAKEOFF, LOITER_TO_ALT,
                        VTOL_TAKEOFF, VTOL_LAND, FOLLOW_REPOSITION, CONDITION_GATE})


class Item(NamedTuple):
    """The fields of PX4's mission_item_s the check reads."""

    nav_cmd: int
    lat_deg: float = 0.0
    lon_deg: float = 0.0
    altitude_m: float = 0.0
    relative: bool = False

    @classmethod
    def of(cls, item: PlanItem) -> Item:
        # mavlink_mission.cpp stores a NAV_ROI as a DO_SET_ROI
        cmd = DO_SET_ROI if item.command == NAV_ROI else item.command
        return cls(cmd, item.lat_deg, item.lon_deg, item.z, item.frame in RELATIVE_FRAMES)


class FeasibilityChecker:
    """PX4's FeasibilityChecker for a multicopter (module rules)."""

    def __init__(self, log: StatusLog, now_s: float, params: Any, home: GeoPoint | None,
                 landed: bool, position: tuple[float, float] | None) -> None:
        """``home``: None while PX4 has no home position; ``position``: the vehicle's (lat, lon)
        estimate, None while it has none."""
        self._log, self._now_s = log, now_s
        self._params = params
        self._home = home
        self._landed = landed
        self._position = position
        self.reset()

    def reset(self) -> None:
        self.validity_failed = self.takeoff_failed = self.vtol_items_failed = False
        self.first_waypoint_failed = self.gate_failed = self.takeoff_land_failed = False
        self._found_item_with_position = self._first_waypoint_found = False
        self._has_takeoff = self._landing_valid = False
        self._last: Item | None = None  # the last positional item

    def some_check_failed(self) -> bool:
        return (self.validity_failed or self.takeoff_failed or self.vtol_items_failed
                or self.first_waypoint_failed or self.gate_failed or self.takeoff_land_failed)

    def process_next_item(self, item: Item, index: int, total: int) -> bool:
        """False once an item is invalid (the other checks are not run then)."""
        if index == 0:
            self.reset()
            p = self._params
            self._dist_1wp_m = float(p["MIS_DIST_1WP"])
            self._takeoff_land_req = int(p["MIS_TKO_LAND_REQ"])
        if not self.validity_failed:
            self.validity_failed = not self._item_valid(item, index)
        if self.validity_failed:
            return False
        if not self.gate_failed:
            self.gate_failed = not self._gate_apart(item)
        if not self.first_waypoint_failed:
            self.first_waypoint_failed = not self._first_waypoint_near(item)
        if not self.takeoff_failed:
            self.takeoff_failed = not self._takeoff_ok(item)
        if not self.vtol_items_failed:
            self.vtol_items_failed = not self._fits_vehicle(item)
        self._landing_valid |= item.nav_cmd == LAND
        if index == total - 1:
            self.takeoff_land_failed = not self._takeoff_land_available()
        return True

    def _reject(self, text: str, event: ev.EventDef, internal: Log = Log.INFO, fmt: str = "",
                *args: float) -> bool:
        self._log.critical(self._now_s, text)
        self._log.event(self._now_s, event, Log.ERROR, internal, fmt, *args)
        return False

    def _item_valid(self, item: Item, index: int) -> bool:
        n = index + 1
        if item.relative and self._home is None and item.nav_cmd in POSITIONAL:
            return self._reject(f"Mission rejected: No home pos, WP {n} uses rel alt\t",
                                ev.MIS_NO_HOME_REL_ALT, Log.INFO, "h", n)
        if item.nav_cmd not in SUPPORTED:
            return self._reject(f"Mission rejected: item {n}: unsupported cmd: {item.nav_cmd}\t",
                                ev.MIS_UNSUPPORTED_CMD, Log.WARNING, "HH", n,
                                item.nav_cmd & 0xFFFF)
        if index == 0 and item.nav_cmd == LAND and self._landed:
            return self._reject("Mission rejected: starts with landing\t",
                                ev.MIS_STARTS_WITH_LANDING)
        return True

    def _takeoff_ok(self, item: Item) -> bool:
        if item.nav_cmd in (TAKEOFF, VTOL_TAKEOFF):
            home_alt = self._home.alt_amsl_m if self._home is not None else math.nan
            above_home = item.altitude_m if item.relative else item.altitude_m - home_alt
            if not above_home >= FLT_EPSILON:  # (NaN without home: PX4's comparison is false)
                return self._reject("Mission rejected: Takeoff altitude below home altitude!\t",
                                    ev.MIS_TAKEOFF_TOO_LOW, Log.INFO, "f",
                                    0.0 if item.relative else home_alt)
            self._has_takeoff = True
            if self._found_item_with_position:
                return self._reject("Mission rejected: takeoff not first waypoint item\t",
                                    ev.MIS_TAKEOFF_NOT_FIRST)
        if not self._found_item_with_position:
            self._found_item_with_position = item.nav_cmd not in NO_POSITION
        return True

    def _fits_vehicle(self, item: Item) -> bool:
        if item.nav_cmd in (VTOL_TAKEOFF, VTOL_LAND, VTOL_TRANSITION):
            return self._reject(
                "Mission rejected: Mission contains VTOL items but vehicle is not a VTOL\t",
                ev.MIS_VTOL_ITEMS)
        return True

    def _first_waypoint_near(self, item: Item) -> bool:
        """checkHorizontalDistanceToFirstWaypoint, from the vehicle's position."""
        limit = self._dist_1wp_m
        if (limit <= FLT_EPSILON or self._position is None or self._first_waypoint_found
                or item.nav_cmd not in POSITIONAL):
            return True
        self._first_waypoint_found = True
        dist = distance_m(item.lat_deg, item.lon_deg, *self._position)
        if dist < limit:
            return True
        return self._reject(f"First waypoint too far away: {c_int(dist)}m, {c_int(limit)} max\t",
                            ev.MIS_FIRST_WP_TOO_FAR, Log.INFO, "II", c_int(dist),
                            c_int(limit, 0, 2**32 - 1))

    def _gate_apart(self, item: Item) -> bool:
        """checkDistancesBetweenWaypoints: a gate on top of its neighbouring waypoint."""
        if item.nav_cmd not in POSITIONAL:
            return True
        last = self._last
        if last is not None:
            dist = distance_m(item.lat_deg, item.lon_deg, last.lat_deg, last.lon_deg)
            if dist < GATE_MIN_DIST_M and CONDITION_GATE in (item.nav_cmd, last.nav_cmd):
                return self._reject(
                    f"Distance between waypoint and gate too close: {int(dist)} meters\t",
                    ev.MIS_WP_GATE_TOO_CLOSE, Log.INFO, "ff", dist, GATE_MIN_DIST_M)
        self._last = item
        return True

    def _takeoff_land_available(self) -> bool:
        req = self._takeoff_land_req
        if req == 1 and not self._has_takeoff:
            return self._reject("Mission rejected: Takeoff waypoint required.\t",
                                ev.MIS_TAKEOFF_MISSING)
        if req == 2 and not self._landing_valid:
            return self._reject("Mission rejected: Landing waypoint/pattern required.\t",
                                ev.MIS_LAND_MISSING)
        if req == 3 and not (self._has_takeoff and self._landing_valid):
            return self._reject("Mission rejected: Takeoff or Landing item missing.\t",
                                ev.MIS_TAKEOFF_OR_LAND_MISSING)
        if req == 5 and not self._landed:  # (a multicopter has no VTOL approach)
            if not self._landing_valid:
                return self._reject("Mission rejected: Landing waypoint/pattern required.",
                                    ev.MIS_IN_AIR_LANDING_REQ)
            return True
        if req in (4, 5) and self._has_takeoff != self._landing_valid:
            if self._has_takeoff:
                return self._reject("Mission rejected: Add Landing item or remove Takeoff.\t",
                                    ev.MIS_ADD_LAND_OR_RM_TAKEOFF)
            return self._reject("Mission rejected: Add Takeoff item or remove Landing.\t",
                                ev.MIS_ADD_TAKEOFF_OR_RM_LAND)
        return True


class MissionCheck:
    """The navigator's verdict on the stored mission (module rules), kept until the mission,
    the fence changes or Mission mode is activated."""

    def __init__(self, on_run: Callable[[], None] | None = None) -> None:
        """``on_run``: told each time the check runs (check_mission_valid also puts the
        mission result's seq_reached back to -1)."""
        self.valid = False
        self._on_run = on_run
        self._ids: tuple[int, int] | None = None  # (mission, fence) ids checked; None: never
        self._forced = False
        # The plan store whose changes this check hears of (the first one it is given), and
        # whether a plan may have changed since the ids were last read (asked at every 50 Hz
        # tick; reading the ids is the costly part).
        self._plans: object = None
        self._plans_changed = True
        self._home: object = None  # the home last seen, and how often it changed (PX4's
        self._home_updates = 0  # home_position update_count, as far as these updates see it)
        self.home_counter = 0  # mission_result.home_position_counter: the count at the last run

    @property
    def checked_ids(self) -> tuple[int, int] | None:
        """The (mission, fence) ids the check last ran on; None before its first run."""
        return self._ids

    def force(self) -> None:
        """Mission::on_activation's check_mission_valid(true): run again at the next update."""
        self._forced = True

    def update(self, now_s: float, ap: Any) -> bool:
        """Run the check when due; returns the verdict. ``ap``: the vehicle's Autopilot (its
        log, params, plans, geofence, home, origin, land detector and last measurement)."""
        home = ap.home
        if home is not self._home:  # HomePosition is replaced at each update
            self._home = home
            self._home_updates += 1
        if home is None:  # canRunMissionFeasibility: not before home is set
            return self.valid
        plans = ap.plans
        if self._plans is None:
            self._plans = plans
            plans.on_change(self._plan_changed)
        ids = self._ids
        if self._plans_changed or plans is not self._plans:
            self._plans_changed = plans is not self._plans  # (another store: read every time)
            ids = (plans.plan_id(PlanType.MISSION), plans.plan_id(PlanType.FENCE))
        if ids != self._ids or self._forced:
            self._ids, self._forced = ids, False
            self.home_counter = self._home_updates
            last = ap.last_meas
            here = ap.origin.offset_ned(*last.position_ned_m) if last is not None else None
            self.valid = check_mission(plans.get(PlanType.MISSION), now_s, ap.log, ap.params,
                                       ap.geofence, home, ap.origin, ap.land_detector.landed,
                                       (here.lat_deg, here.lon_deg) if here else None)
            if self._on_run is not None:
                self._on_run()
        return self.valid

    def _plan_changed(self, _plan_type: PlanType) -> None:
        self._plans_changed = True

    def rejected(self, mission_id: int) -> bool:
        """The check ran on the mission with this id and found it infeasible."""
        return self._ids is not None and self._ids[0] == mission_id and not self.valid


def check_mission(items: Sequence[PlanItem], now_s: float, log: StatusLog, params: Any,
                  geofence: Any, home: HomePosition, origin: GeoPoint, landed: bool,
                  position: tuple[float, float] | None) -> bool:
    """MissionFeasibilityChecker::checkMissionFeasible: the items, then the geofence."""
    if not items:
        return False
    checker = FeasibilityChecker(log, now_s, params, home.geo, landed, position)
    failed = False
    for i, plan_item in enumerate(items):
        if not checker.process_next_item(Item.of(plan_item), i, len(items)):
            failed = True
            break
    failed |= checker.some_check_failed()
    return not (_outside_geofence(items, now_s, log, geofence, home, origin) or failed)


def _outside_geofence(items: Sequence[PlanItem], now_s: float, log: StatusLog, geofence: Any,
                      home: HomePosition, origin: GeoPoint) -> bool:
    """checkGeofence (run whatever the items' verdict): the first positional item the fence
    does not allow."""
    if not geofence.enabled:
        return False
    for i, plan_item in enumerate(items):
        if Item.of(plan_item).nav_cmd not in POSITIONAL:
            continue
        ned = item_ned(plan_item, origin, home.geo.alt_amsl_m)
        if geofence.check(ned, home.position_ned_m) is not None:
            log.critical(now_s, f"Geofence violation for waypoint {i + 1}\t")
            log.event(now_s, ev.MIS_GEOFENCE_VIOLATION, Log.ERROR, Log.INFO, "h", i + 1)
            return True
    return False
