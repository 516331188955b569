"""Navigator: the auto modes, each producing a target for the smoothed trajectory (auto_trajectory.py).

After PX4 ``src/modules/navigator`` (navigator_main.cpp: one NavigatorMode per nav_state, hooks
``on_activation`` / ``on_active`` / ``on_inactive``; the cruising speed set by DO_CHANGE_SPEED /
DO_REPOSITION and the region of interest set by the ROI commands, ``_vroi``, are navigator state
shared by all modes; only Mission reads the ROI, nav_roi.py).

Rules and invariants:
- One ``NavMode`` object per NavState it serves, registered in ``Navigator.modes`` (Hold, Takeoff,
  Land in nav_core.py, Return in nav_rtl.py, Mission in nav_mission.py, Precision Land in
  nav_precland.py). Offboard and Termination
  have no navigator part: the autopilot bypasses the navigator for them.
- The navigator follows the commander's nav_state: when it differs from the active mode, the old
  mode's ``on_inactive`` and the new mode's ``on_activation`` run, then ``on_active`` every tick.
  Disarmed, no mode runs (the active one's ``on_inactive`` runs once); arming starts the mode.
- A mode asks for a mode change (takeoff done -> Hold) through ``ctx.switch_to``; the commander
  applies it.
- Targets are local NED; a NaN target z means vertical velocity control at ``vz_cmd_mps``.
"""

from __future__ import annotations

import math

from vehicles.nav_core import (  # noqa: F401  (re-exported: the autopilot and tests use them)
    Hold,
    Land,
    NavContext,
    NavMode,
    NavSetpoint,
    Takeoff,
    auto_limits,
    land_speed_mps,
)
from vehicles.nav_mission import Mission
from vehicles.nav_precland import LandingTarget, PrecLand
from vehicles.nav_roi import Params7, Roi
from vehicles.nav_rtl import (  # noqa: F401
    NO_ESTIMATE,
    Return,
    RtlPhase,
    RtlTimeEstimate,
    activation_phase,
    return_height_m,
    return_z_m,
    rtl_destination,
    rtl_time_estimate,
)
from vehicles.plans import PlanStore
from vehicles.status_log import StatusLog
from vehicles.types import Changes, NavState

# Read at every 50 Hz tick, by a module name: in Python 3.11 a member read off its class
# (``NavState.AUTO_LOITER``) goes through EnumType.__getattr__ (~0.2 us).
_HOLD = NavState.AUTO_LOITER


class Navigator:
    def __init__(self, plans: PlanStore | None = None, changes: Changes | None = None,
                 log: StatusLog | None = None) -> None:
        self.plans = plans if plans is not None else PlanStore()
        self.hold = Hold()
        self.takeoff = Takeoff()
        self.roi = Roi()
        self.mission = Mission(self.plans, changes, self.roi)
        self.rtl = Return(self.plans)
        self.landing_target = LandingTarget(log)  # LANDING_TARGET's landing_target_pose
        self.precland = PrecLand(self.landing_target)
        self.modes: dict[NavState, NavMode] = {
            NavState.AUTO_LOITER: self.hold,
            NavState.AUTO_TAKEOFF: self.takeoff,
            NavState.AUTO_LAND: Land(),
            NavState.AUTO_RTL: self.rtl,
            NavState.AUTO_MISSION: self.mission,
            NavState.AUTO_PRECLAND: self.precland,
        }
        self.active_state: NavState | None = None
        self._last: NavSetpoint | None = None  # the last tick's setpoint (PX4's current one)
        self.cruise_mps = math.nan  # NaN = MPC_XY_CRUISE
        self._reactivate = False
        # rtl_time_estimate as RTL publishes it, and how many times it has (a stream sends it
        # once per publication)
        self.rtl_estimate: RtlTimeEstimate = NO_ESTIMATE
        self.rtl_estimate_seq = 0
        self._rtl_checked_s: float | None = None

    def reactivate(self) -> None:
        """Run on_activation again at the next tick (e.g. a new takeoff command while in Takeoff)."""
        self._reactivate = True

    def set_cruise_mps(self, speed_mps: float) -> None:
        self.cruise_mps = speed_mps if speed_mps > 0 else math.nan

    def set_roi(self, command: int, params: Params7, now_s: float) -> None:
        """DO_SET_ROI, NAV_ROI, DO_SET_ROI_LOCATION, DO_SET_ROI_WPNEXT_OFFSET, DO_SET_ROI_NONE
        (navigator_main.cpp): the command replaces the ROI, in any mode."""
        self.roi.command(command, params, now_s)

    def deactivate(self, ctx: NavContext) -> None:
        """The vehicle left the navigator's modes (Offboard, Termination)."""
        if not ctx.armed:
            self.mission.disarmed_while_inactive = True
        if self.active_state is not None:
            self.modes[self.active_state].on_inactive(ctx)
        self.active_state = None
        self._last = None  # reset_triplets: nothing is running
        self.hold.hint = self.hold.reposition = None  # a hand-over target is stale now
        self.hold.hint_yaw = math.nan

    def update(self, nav_state: NavState, ctx: NavContext) -> NavSetpoint:
        if nav_state not in self.modes:
            nav_state = NavState.AUTO_LOITER  # modes without a navigator part behave as Hold
        if not ctx.armed:
            # navigator_main.cpp: "Do not execute any state machine while we are disarmed" (the
            # mission notes it in on_inactive); the mode starts once armed.
            if self.active_state is not None:
                self.deactivate(ctx)  # (on_inactive; hand-over targets dropped)
            self.mission.disarmed_while_inactive = True
            self._last = None
            return NavSetpoint(ctx.position_ned_m, ctx.yaw_rad, ctx.limits(), idle=True)
        if nav_state is not _HOLD:
            self.hold.hint = self.hold.reposition = None  # a hand-over target is stale now
            self.hold.hint_yaw = math.nan
        if nav_state != self.active_state or self._reactivate:
            if self.active_state is not None:
                self.modes[self.active_state].on_inactive(ctx)
                if nav_state is _HOLD:
                    self._loiter_on(ctx)
            self.active_state = nav_state
            self._reactivate = False
            # Precision Land starts from the position setpoint it finds (the last mode's)
            last = self._last
            self.precland.current = last.target_ned_m if last is not None and not last.idle \
                else None
            self.modes[nav_state].on_activation(ctx)
        sp = self._last = self.modes[nav_state].on_active(ctx)
        return sp

    def _loiter_on(self, ctx: NavContext) -> None:
        """Loiter::set_loiter_position: a vehicle on a loiter setpoint (a loiter item's, the end
        of a mission, Hold's own) within NAV_ACC_RAD (get_acceptance_radius) plus that
        setpoint's own loiter radius (a loiter item's param, else NAV_LOITER_RAD) holds that
        setpoint, its heading too (setLoiterItemFromCurrentPositionSetpoint), instead of braking
        where it is."""
        hold, last = self.hold, self._last
        if hold.reposition is not None or hold.hint is not None or last is None \
                or not last.loiter or last.idle or ctx.landed:
            return
        (tx, ty, _), (x, y, _) = last.target_ned_m, ctx.position_ned_m
        p = ctx.params
        radius = last.loiter_radius_m
        if not math.isfinite(radius):
            radius = float(p["NAV_LOITER_RAD"])
        if math.hypot(tx - x, ty - y) <= float(p["NAV_ACC_RAD"]) + radius:
            hold.hint, hold.hint_yaw = last.target_ned_m, last.yaw_rad

    def publish_rtl_estimate(self, ctx: NavContext, position_valid: bool) -> None:
        """RTL::on_inactive / on_active: more than 2 s after the last time (the first, 2 s after
        boot), the destination is chosen again (on_inactive only: with its "RTL: unsupported
        MAV_FRAME" texts, with or without home) and the time a return would take from here is
        published (RTL::publishRemainingTimeEstimate: none without home or a global position).
        While returning, from the return's own phase, destination and altitude; else from
        getActivationLandState's phase (landed: idle, below the return altitude: the climb,
        else the return leg). (PX4's navigator runs at 20 Hz, so its period is ~2.05 s; here
        the first 50 Hz tick after 2 s.)"""
        if self._rtl_checked_s is None:
            self._rtl_checked_s = ctx.now_s
        if ctx.now_s - self._rtl_checked_s <= 2.0:
            return
        self._rtl_checked_s = ctx.now_s
        self.rtl_estimate_seq += 1
        returning = self.active_state is NavState.AUTO_RTL and ctx.armed
        if not returning:  # on_inactive's setRtlTypeAndDestination, whatever the estimate
            dest = rtl_destination(ctx, self.plans)
        if ctx.home is None or not position_valid:
            self.rtl_estimate = NO_ESTIMATE
            return
        rtl, pos = self.rtl, ctx.position_ned_m
        if returning:
            start, dest, return_z = rtl.phase, rtl.dest, rtl.return_z
        else:
            return_z = return_z_m(ctx, dest)
            start = activation_phase(ctx.landed, pos[2], return_z)
        self.rtl_estimate = rtl_time_estimate(ctx.params, start, pos, dest, return_z)
