"""DO_REPOSITION and DO_CHANGE_ALTITUDE, split as PX4 v1.15 splits them.

Source: PX4 v1.15.2 Commander::handle_command (the switch to Hold, which alone decides the
answer), navigator_main.cpp (the target), loiter.cpp ``reposition()``.
Rules:
- The answer is the switch to Hold's: ACCEPTED, or TEMPORARILY_REJECTED when Hold cannot run.
- The navigator takes the target only while armed (disarmed, the vehicle just switches). A target
  outside the geofence, while GF_ACTION is neither None nor Warning, is dropped with the
  navigator's critical text and event: the command stays ACCEPTED and the vehicle holds.
- Without a position: the current setpoint's (a mission's waypoint, Hold's target) when only
  the altitude or the yaw is given; the braking point (Navigator::calculate_breaking_stop: the
  position moved along the course by the braking distance) when nothing is (QGC's Pause) or
  for an altitude change, where the vehicle is while the setpoint is a takeoff's.
- The target's horizontal speed is the command's when above 0; else MPC_XY_CRUISE when the
  vehicle enters Hold with it, the navigator's cruising speed when it holds already. It is the
  reposition setpoint's own: the cruising speed DO_CHANGE_SPEED or a mission set is unchanged.
"""

from __future__ import annotations

import math
from typing import Protocol

from vehicles.commander import Commander
from vehicles.events import CHANGE_ALT_OUTSIDE_FENCE, REPOSITION_OUTSIDE_FENCE, Log
from vehicles.flight_tasks import Tasks
from vehicles.geofence import Geofence
from vehicles.nav_core import braking_stop
from vehicles.navigator import Navigator
from vehicles.params import ParamStore
from vehicles.status_log import StatusLog
from vehicles.types import CommandResult, GeoPoint, HomePosition, Measurement, NavState


class Autopilot(Protocol):
    """What of vehicles/autopilot.py's Autopilot a reposition uses."""

    @property
    def commander(self) -> Commander: ...
    @property
    def navigator(self) -> Navigator: ...
    @property
    def geofence(self) -> Geofence: ...
    @property
    def params(self) -> ParamStore: ...
    @property
    def origin(self) -> GeoPoint: ...
    @property
    def home(self) -> HomePosition | None: ...
    @property
    def log(self) -> StatusLog: ...
    @property
    def tasks(self) -> Tasks: ...
    def set_nav_state(self, now_s: float, nav_state: NavState) -> CommandResult: ...

GF_ACTION_NONE = 0
GF_ACTION_WARN = 1
OUTSIDE_EVENTS = {"Reposition": REPOSITION_OUTSIDE_FENCE,
                  "Altitude change": CHANGE_ALT_OUTSIDE_FENCE}


def goto(ap: Autopilot, now_s: float, here: Measurement, lat_deg: float, lon_deg: float,
         alt_amsl_m: float, yaw_rad: float, speed_mps: float, what: str) -> CommandResult:
    """``what``: "Reposition" (DO_REPOSITION) or "Altitude change" (DO_CHANGE_ALTITUDE), as the
    geofence refusal says it. NaN keeps the present position (``here``) on that axis."""
    if not ap.commander.position_valid:
        return CommandResult.TEMPORARILY_REJECTED
    holding = ap.commander.nav_state is NavState.AUTO_LOITER
    sp = ap.tasks.auto.setpoint
    taking_off = ap.commander.nav_state is NavState.AUTO_TAKEOFF or (
        sp is not None and sp.taking_off)  # the triplet's current is a takeoff setpoint
    result = ap.set_nav_state(now_s, NavState.AUTO_LOITER)
    if result is not CommandResult.ACCEPTED or not ap.commander.armed:
        return result
    n, e, d = here.position_ned_m
    if not (math.isnan(lat_deg) or math.isnan(lon_deg)):
        n, e, _ = ap.origin.ned_of(GeoPoint(lat_deg, lon_deg, ap.origin.alt_amsl_m))
    elif what == "Reposition" and not (math.isnan(alt_amsl_m) and math.isnan(yaw_rad)):
        # "Position is not changing, thus we keep the setpoint": the current setpoint's (a
        # mission's waypoint, Hold's target), else where the vehicle is
        if sp is not None and math.isfinite(sp.target_ned_m[0]) and math.isfinite(sp.target_ned_m[1]):
            n, e = sp.target_ned_m[0], sp.target_ned_m[1]
    elif not taking_off:
        # a pause (all NaN) or an altitude change: a multicopter stops where it can brake to
        # (calculate_breaking_stop), not where it was, unless the setpoint is a takeoff's
        n, e, _ = braking_stop(here.position_ned_m, here.velocity_ned_mps, ap.params)
    if not math.isnan(alt_amsl_m):
        d = ap.origin.alt_amsl_m - alt_amsl_m
    gf_action = int(ap.params["GF_ACTION"])
    if (gf_action not in (GF_ACTION_NONE, GF_ACTION_WARN) and ap.geofence.enabled
            and ap.geofence.check((n, e, d), ap.home.position_ned_m if ap.home else None)
            is not None):
        ap.log.critical(now_s, f"{what} is outside geofence\t")
        ap.log.event(now_s, OUTSIDE_EVENTS[what], Log.ERROR, Log.INFO)
        return result
    hold = ap.navigator.hold
    hold.reposition = (n, e, d)
    hold.hint_yaw = yaw_rad
    if speed_mps > 0:
        hold.reposition_speed_mps = speed_mps
    else:  # -1 (the default) entering Hold, else the navigator's cruising speed
        hold.reposition_speed_mps = ap.navigator.cruise_mps if holding else math.nan
    ap.navigator.reactivate()
    return result
