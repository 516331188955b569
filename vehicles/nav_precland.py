"""Precision Land: land on a landing target, search for it, or land where the vehicle is.

After PX4 v1.15 ``navigator/precland.cpp`` (NAVIGATION_STATE_AUTO_PRECLAND runs it in its
Required mode, navigator_main.cpp; mission_base.cpp and rtl_direct.cpp run it for a landing)
and mavlink_receiver's LANDING_TARGET:
- The target is ``landing_target_pose``: a LANDING_TARGET with ``position_valid`` in
  MAV_FRAME_LOCAL_NED gives its x, y, z (the vehicle's local frame), stamped with its
  time_usec on our clock once the link's timesync has converged, on arrival before
  (``LandingTarget``; gateway/mavlink/timesync.py). It is valid from its first report until
  PLD_BTOUT passes without one: by hrt_elapsed_time, 0 for a stamp in the future (a client
  clock ahead never times out), whereas the final approach's 0.5 s check subtracts unsigned (a
  stamp in the future is never fresh there).
  Other frames are refused with PX4's critical message; reports without a position (IR-LOCK
  angles) feed the landing target estimator, which PX4 SITL does not start (LTEST_EN 0).
- Start: the mode flies to the position setpoint it found (the previous mode's; none: where the
  vehicle is). A target seen goes to the horizontal approach; 2 s after arriving within
  NAV_ACC_RAD without one it climbs to PLD_SRCH_ALT above the local origin and searches for
  PLD_SRCH_TOUT s (0: no search, fall back at once); a search that times out falls back.
  Each Start counts a search: more than PLD_MAX_SRCH and Start is refused (fallback).
- Horizontal approach: at the altitude it began at, towards the target through PX4's setpoint
  slew rate (MPC_XY_CRUISE, MPC_ACC_HOR, stopping distance). Above the target within
  PLD_HACC_RAD for 2 s it descends; having reached where it last saw the target without a
  fresh report, it starts again (or falls back).
- Descend above target: a landing setpoint (PX4's land descent speeds) at the target; without
  a valid target it goes to the final approach when within PLD_FAPPR_ALT of the target's
  height, else starts again. The final approach and the fallback land where they are.
- On the ground: done (the commander disarms after COM_DISARM_LAND).
- A mission's land item with param2 1 (opportunistic) or 2 (required), and Return's landing with
  RTL_PLD_MD 1 or 2, run this block from their landing's start (``land``): Opportunistic lands
  normally when no target is seen at once; Required behaves as the mode does, but from the
  landing's LAND setpoint (it descends at the landing point until its 2 s there have passed).
State changes are PX4_INFO/PX4_WARN lines on PX4's console, here the daemon's log.
"""

from __future__ import annotations

import enum
import logging
import math

from vehicles.events import LANDING_TARGET_UNSUPPORTED_FRAME, Log
from vehicles.nav_core import NavContext, NavMode, NavSetpoint, land_speed_mps
from vehicles.status_log import StatusLog
from vehicles.types import Vec3

log = logging.getLogger(__name__)

SETTLE_S = 2.0  # at the start point, and above the target, before the next state
ACQUIRED_SETTLE_S = 1.0  # a target found while searching: climb stopped, then approach
FINAL_TIMEOUT_S = 0.5  # near the ground a report older than this is lost
FIRST_DT_S = 0.05  # slewrate's guess of the navigator period on its first call
MAV_FRAME_LOCAL_NED = 1
_U64 = (1 << 64) - 1


class PrecLandState(enum.Enum):
    START = 0
    HORIZONTAL_APPROACH = 1
    DESCEND_ABOVE_TARGET = 2
    FINAL_APPROACH = 3
    SEARCH = 4
    FALLBACK = 5
    DONE = 6


OPPORTUNISTIC, REQUIRED = 1, 2  # PrecLandMode (land_precision, RTL_PLD_MD)
OWNER_GAP_S = 0.1  # a landing not run for longer than this has ended: the next one activates


class LandingTarget:
    """``landing_target_pose``: the last report (local NED, m) and its timestamp (µs, uint64 on
    our clock); ``seq`` counts reports, so that a mode sees whether one came since it last
    looked."""

    __slots__ = ("position_ned_m", "stamp_us", "seq", "log")

    def __init__(self, log: StatusLog | None = None) -> None:
        self.position_ned_m: Vec3 = (math.nan, math.nan, math.nan)
        self.stamp_us: int | None = None  # None: never published
        self.seq = 0
        self.log = log  # the vehicle's (a refused frame's message)

    def publish(self, stamp_us: int, position_ned_m: Vec3) -> None:
        self.position_ned_m, self.stamp_us = position_ned_m, stamp_us & _U64
        self.seq += 1

    def elapsed_s(self, now_s: float) -> float:
        """hrt_elapsed_time(&timestamp) in s: 0 for a stamp in the future; inf before any."""
        if self.stamp_us is None:
            return math.inf
        return max(0, round(now_s * 1e6) - self.stamp_us) * 1e-6

    def since_s(self, now_s: float) -> float:
        """hrt_absolute_time() - timestamp in s, unsigned: a stamp in the future is ~5.8e5
        years old; inf before any."""
        if self.stamp_us is None:
            return math.inf
        return ((round(now_s * 1e6) - self.stamp_us) & _U64) * 1e-6

    def report(self, now_s: float, position_valid: bool, frame: int,
               position_ned_m: Vec3, stamp_us: int | None = None) -> None:
        """A LANDING_TARGET (mavlink_receiver handle_message_landing_target): published with a
        position in MAV_FRAME_LOCAL_NED, refused with a critical message in another frame; one
        without a position is the IR-LOCK estimator's, not running (module rules).
        ``stamp_us``: its time_usec through the link's timesync (None: now)."""
        if position_valid and frame == MAV_FRAME_LOCAL_NED:
            self.publish(round(now_s * 1e6) if stamp_us is None else stamp_us, position_ned_m)
        elif position_valid and self.log is not None:
            log = self.log
            log.critical(now_s, f"Landing target: coordinate frame {frame} unsupported\t")
            log.event(now_s, LANDING_TARGET_UNSUPPORTED_FRAME, Log.ERROR, None, "B", frame & 0xFF)


class PrecLand(NavMode):
    def __init__(self, target: LandingTarget) -> None:
        self.target = target
        self.state = PrecLandState.DONE
        self.current: Vec3 | None = None  # the position setpoint handed over (navigator.py)
        self.mode = REQUIRED
        self._owner: object = None  # the mission item or Return running it (``land``)
        self._owner_s = -math.inf
        self._sp: Vec3 = (0.0, 0.0, 0.0)  # the position setpoint (type POSITION or LAND)
        self._land = False  # the setpoint is a landing one
        self._yaw = 0.0
        self._seen_seq = 0
        self._updated = False
        self._valid = False
        self._search_cnt = 0
        self._state_start_s = 0.0
        self._point_reached_s: float | None = None
        self._target_acquired_s: float | None = None
        self._approach_z = 0.0
        self._last_slew_s: float | None = None
        self._sp_prev = (0.0, 0.0)
        self._sp_prev_prev = (0.0, 0.0)

    # --- NavMode ----------------------------------------------------------------------------
    def on_activation(self, ctx: NavContext) -> None:
        if self._owner is not None:  # the mode itself (navigator_main.cpp): Required
            self.mode, self._owner = REQUIRED, None
        self._activate(ctx)

    def land(self, ctx: NavContext, owner: object, target: Vec3, yaw: float, mode: int
             ) -> NavSetpoint:
        """A mission's land item or Return's landing that asks for a precision landing
        (``mode``: OPPORTUNISTIC or REQUIRED). MissionBlock::startPrecLand activates the block
        when that landing starts, from the setpoint before it; the landing's own LAND setpoint
        at ``target`` then replaces the Start's (setActiveMissionItems sets the triplet after
        it), so a Required search first descends there until its 2 s at the point have passed,
        and an Opportunistic one without a target falls back at its first tick."""
        if owner is not self._owner or ctx.now_s - self._owner_s > OWNER_GAP_S:
            self._owner, self.mode = owner, mode
            self.current = (target[0], target[1], ctx.position_ned_m[2])
            self._activate(ctx)
            self._sp, self._land, self._yaw = self.current, True, yaw
        self._owner_s = ctx.now_s
        return self.on_active(ctx)

    def _activate(self, ctx: NavContext) -> None:
        self.state = PrecLandState.START
        self._search_cnt = 0
        self._last_slew_s = None
        pos = ctx.position_ned_m
        cur = self.current
        # an invalid current setpoint: land where the vehicle is ("Reset")
        self._sp = tuple(c if math.isfinite(c) else p for c, p in zip(cur, pos)) \
            if cur is not None else pos  # type: ignore[assignment]
        self._yaw = ctx.yaw_rad
        self._sp_prev = self._sp_prev_prev = (0.0, 0.0)
        self._switch_to_start(ctx)

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        t = self.target
        self._updated = t.seq != self._seen_seq
        self._seen_seq = t.seq
        if self._updated:
            self._valid = True
        if t.elapsed_s(ctx.now_s) > float(ctx.params["PLD_BTOUT"]):
            self._valid = False
        if ctx.landed:
            self._set_state(ctx, PrecLandState.DONE)
        run = {PrecLandState.START: self._run_start,
               PrecLandState.HORIZONTAL_APPROACH: self._run_horizontal_approach,
               PrecLandState.DESCEND_ABOVE_TARGET: self._run_descend_above_target,
               PrecLandState.SEARCH: self._run_search}.get(self.state)
        if run is not None:
            run(ctx)
        return self._setpoint(ctx)

    def _setpoint(self, ctx: NavContext) -> NavSetpoint:
        if ctx.landed:
            return NavSetpoint(ctx.position_ned_m, self._yaw, ctx.limits(), idle=True)
        if self._land:
            speed = land_speed_mps(ctx.params, -ctx.position_ned_m[2])
            return NavSetpoint((self._sp[0], self._sp[1], math.nan), self._yaw,
                               ctx.limits(speed_down_mps=speed), vz_cmd_mps=speed, landing=True)
        return NavSetpoint(self._sp, self._yaw, ctx.limits(),
                           acceptance_radius_m=float(ctx.params["NAV_ACC_RAD"]))

    def _console(self, level: int, text: str, *args: object) -> None:
        """PX4_INFO / PX4_WARN on the instance's console: the daemon's log, naming the vehicle."""
        status_log = self.target.log
        name = status_log.name if status_log is not None else ""
        log.log(level, "%s " + text, name, *args)

    # --- the states -------------------------------------------------------------------------
    def _run_start(self, ctx: NavContext) -> None:
        if self._switch_to_horizontal_approach(ctx):
            return
        if self.mode == OPPORTUNISTIC:  # not seen at once: land normally
            self._switch_to_fallback(ctx)
            return
        x, y, _ = ctx.position_ned_m
        if math.hypot(self._sp[0] - x, self._sp[1] - y) < float(ctx.params["NAV_ACC_RAD"]):
            if self._point_reached_s is None:
                self._point_reached_s = ctx.now_s
            if float(ctx.params["PLD_SRCH_TOUT"]) > 0.0:
                if ctx.now_s - self._point_reached_s > SETTLE_S:
                    self._switch_to_search(ctx)
            else:
                self._switch_to_fallback(ctx)

    def _run_horizontal_approach(self, ctx: NavContext) -> None:
        if not self._conditions(ctx, PrecLandState.HORIZONTAL_APPROACH):
            self._console(logging.WARNING, "Lost landing target while landing, state: %d",
                              self.state.value)
            self._sp = ctx.position_ned_m  # stay here to search for the target
            if not self._switch_to_start(ctx):
                self._switch_to_fallback(ctx)
            return
        if self._conditions(ctx, PrecLandState.DESCEND_ABOVE_TARGET):
            if self._point_reached_s is None:
                self._point_reached_s = ctx.now_s
            if ctx.now_s - self._point_reached_s > SETTLE_S and \
                    self._switch_to_descend_above_target(ctx):
                return
        tx, ty = self._target_xy()
        x, y = self._slewrate(ctx, tx, ty)
        self._sp, self._land = (x, y, self._approach_z), False

    def _run_descend_above_target(self, ctx: NavContext) -> None:
        if not self._conditions(ctx, PrecLandState.DESCEND_ABOVE_TARGET):
            if not self._switch_to_final_approach(ctx):
                self._console(logging.WARNING, "Lost landing target while landing, state: %d",
                              self.state.value)
                self._sp = ctx.position_ned_m
                if not self._switch_to_start(ctx):
                    self._switch_to_fallback(ctx)
            return
        tx, ty = self._target_xy()
        self._sp, self._land = (tx, ty, self._sp[2]), True

    def _run_search(self, ctx: NavContext) -> None:
        if self._conditions(ctx, PrecLandState.HORIZONTAL_APPROACH) and \
                self._target_acquired_s is None:
            # seen: stop climbing, with a metre of margin
            self._target_acquired_s = ctx.now_s
            self._sp = (self._sp[0], self._sp[1], max(ctx.position_ned_m[2] - 1.0, self._sp[2]))
        if self._target_acquired_s is not None and \
                ctx.now_s - self._target_acquired_s > ACQUIRED_SETTLE_S:
            if self._switch_to_horizontal_approach(ctx):
                return
        if ctx.now_s - self._state_start_s > float(ctx.params["PLD_SRCH_TOUT"]):
            self._console(logging.WARNING, "Search timed out")
            self._switch_to_fallback(ctx)

    def _target_xy(self) -> tuple[float, float]:
        """The target's horizontal position; a report without one (NaN) leaves the setpoint
        where it is, as FlightTaskAuto locks the position of a setpoint without lat/lon."""
        tx, ty, _ = self.target.position_ned_m
        if math.isfinite(tx) and math.isfinite(ty):
            return tx, ty
        return self._sp[0], self._sp[1]

    # --- switches ---------------------------------------------------------------------------
    def _set_state(self, ctx: NavContext, state: PrecLandState) -> None:
        self.state, self._state_start_s = state, ctx.now_s

    def _switch_to_start(self, ctx: NavContext) -> bool:
        if not self._conditions(ctx, PrecLandState.START):
            return False
        self._land = False
        self._search_cnt += 1
        self._point_reached_s = None
        self._set_state(ctx, PrecLandState.START)
        return True

    def _switch_if(self, ctx: NavContext, state: PrecLandState, name: str) -> bool:
        """switch_to_state_*: to ``state`` if its conditions hold."""
        if not self._conditions(ctx, state):
            return False
        self._console(logging.INFO, "Precland: switching to %s", name)
        self._set_state(ctx, state)
        return True

    def _switch_to_horizontal_approach(self, ctx: NavContext) -> bool:
        if not self._switch_if(ctx, PrecLandState.HORIZONTAL_APPROACH, "horizontal approach"):
            return False
        self._approach_z = ctx.position_ned_m[2]
        self._point_reached_s = None
        return True

    def _switch_to_descend_above_target(self, ctx: NavContext) -> bool:
        return self._switch_if(ctx, PrecLandState.DESCEND_ABOVE_TARGET, "descend")

    def _switch_to_final_approach(self, ctx: NavContext) -> bool:
        return self._switch_if(ctx, PrecLandState.FINAL_APPROACH, "final approach")

    def _switch_to_search(self, ctx: NavContext) -> None:
        self._console(logging.INFO, "Climbing to search altitude.")
        self._sp = (self._sp[0], self._sp[1], -float(ctx.params["PLD_SRCH_ALT"]))
        self._land = False
        self._target_acquired_s = None
        self._set_state(ctx, PrecLandState.SEARCH)

    def _switch_to_fallback(self, ctx: NavContext) -> None:
        self._console(logging.INFO, "Precland: switching to fallback")
        self._sp, self._land = ctx.position_ned_m, True
        self._set_state(ctx, PrecLandState.FALLBACK)

    def _conditions(self, ctx: NavContext, state: PrecLandState) -> bool:
        """check_state_conditions."""
        p = ctx.params
        tx, ty, tz = self.target.position_ned_m
        x, y, z = ctx.position_ned_m
        hacc = float(p["PLD_HACC_RAD"])
        above = abs(tx - x) < hacc and abs(ty - y) < hacc
        if state is PrecLandState.START:
            return self._search_cnt <= int(p["PLD_MAX_SRCH"])
        if state is PrecLandState.HORIZONTAL_APPROACH:
            if self.state is PrecLandState.HORIZONTAL_APPROACH:
                # reached where it was last seen: only a valid target will do; on the way there
                # the approach goes on
                return self._valid if above else True
            return self._updated and self._valid
        if state is PrecLandState.DESCEND_ABOVE_TARGET:
            if self.state is PrecLandState.DESCEND_ABOVE_TARGET:
                if self._conditions(ctx, PrecLandState.FINAL_APPROACH):
                    return self.target.since_s(ctx.now_s) < FINAL_TIMEOUT_S
                return self._valid
            return self._updated and above
        if state is PrecLandState.FINAL_APPROACH:
            return self._valid and (tz - z) < float(p["PLD_FAPPR_ALT"])
        return True

    def _slewrate(self, ctx: NavContext, sp_x: float, sp_y: float) -> tuple[float, float]:
        """PrecLand::slewrate: the setpoint's speed at most MPC_XY_CRUISE, its acceleration at
        most MPC_ACC_HOR, and its speed no more than stops it at the target."""
        now = ctx.now_s
        if self._last_slew_s is not None:
            dt = now - self._last_slew_s
            if dt <= 0.0:
                return sp_x, sp_y
        else:
            # the first call: a guess of the period, and of the setpoints before, from the
            # current setpoint and the vehicle's velocity
            dt = FIRST_DT_S
            vx, vy = ctx.velocity_ned_mps[0], ctx.velocity_ned_mps[1]
            self._sp_prev = (self._sp[0], self._sp[1])
            self._sp_prev_prev = (self._sp[0] - vx * dt, self._sp[1] - vy * dt)
        self._last_slew_s = now
        cruise, acc = float(ctx.params["MPC_XY_CRUISE"]), float(ctx.params["MPC_ACC_HOR"])
        (px, py), (qx, qy) = self._sp_prev, self._sp_prev_prev
        cx, cy = sp_x, sp_y
        vx, vy = (cx - px) / dt, (cy - py) / dt
        v = math.hypot(vx, vy)
        if v > cruise:
            cx, cy = px + vx / v * cruise * dt, py + vy / v * cruise * dt
        ax, ay = (cx - 2.0 * px + qx) / (dt * dt), (cy - 2.0 * py + qy) / (dt * dt)
        a = math.hypot(ax, ay)
        if a > acc:
            cx = 2.0 * px - qx + ax / a * acc * dt * dt
            cy = 2.0 * py - qy + ay / a * acc * dt * dt
        max_speed = math.sqrt(acc * math.hypot(px - sp_x, py - sp_y))
        vx, vy = (cx - px) / dt, (cy - py) / dt
        v = math.hypot(vx, vy)
        if v > max_speed:
            cx, cy = px + vx / v * max_speed * dt, py + vy / v * max_speed * dt
        self._sp_prev_prev, self._sp_prev = self._sp_prev, (cx, cy)
        return cx, cy
