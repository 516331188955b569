"""Return mode (RTL_TYPE 0): to the closest of home and the rally points, then land there.

After PX4 ``src/modules/navigator/rtl.cpp`` (``findRtlDestination``: home or the closest safe
point from the RALLY plan) and ``rtl_direct.cpp`` (climb to the return altitude, fly over the
destination, descend to RTL_DESCEND_ALT, wait RTL_LAND_DELAY, land).

Rules:
- Return altitude (rtl.cpp ``calculate_return_alt_from_cone_half_angle``, multicopter): with
  RTL_CONE_ANG 0, destination + RTL_RETURN_ALT; with a cone (PX4's default 45°), closer than
  RTL_MIN_DIST the vehicle climbs only into the cone over the destination (distance /
  tan(angle) above it, at least 2 × NAV_ACC_RAD), and within NAV_ACC_RAD to twice its distance.
  It never descends to return: at least the current altitude.
- RTL_LAND_DELAY < 0 loiters over the destination for ever ("RTL: completed, loitering").
- Phases advance as rtl_direct.cpp's mission items are reached (mission_block.cpp
  ``is_mission_item_reached_or_completed``, multicopter): within NAV_ACC_RAD horizontally and
  NAV_MC_ALT_RAD vertically (the climb and the descent, loiter-to-altitude items, only
  vertically), and, where the item has a heading, within MIS_YAW_ERR of it. The heading is the
  current one while climbing, none on the way (the auto task's MPC_YAW_MODE heading: towards the
  destination with mode 0; the destination's, home's yaw, when the return starts closer than
  RTL_MIN_DIST), home's yaw from the descent on.
- Activated on the ground (armed and landed) Return stays idle there (rtl_direct.cpp
  ``getActivationLandState``: IDLE "for safety reasons"), but still says where it would return.
- Rally points count only farther than 10 m from home, and only when more than 2 m closer than
  the best destination so far (rtl.cpp MAX_DIST_FROM_HOME_FOR_LAND_APPROACHES,
  MIN_DIST_THRESHOLD); only those in frame 0 or 3 give a position (``rtl_destination``).
"""

from __future__ import annotations

import enum
import math
from typing import NamedTuple

from vehicles.cnum import c_ceil, f32
from vehicles.events import (
    RTL_COMPLETED_LOITER,
    RTL_LAND,
    RTL_RETURN_AT,
    RTL_UNSUPPORTED_FRAME,
    Log,
)
from vehicles.nav_core import Land, NavContext, NavMode, NavSetpoint
from vehicles.plan_types import MavCmd, MavFrame, PlanType
from vehicles.plans import PlanStore, item_ned
from vehicles.types import Vec3

# rtl.cpp: rally points this close to home are not destinations; a destination has to be this
# much closer than the best one so far.
RALLY_MIN_DIST_FROM_HOME_M = 10.0
MIN_DIST_THRESHOLD_M = 2.0
# setSafepointAsDestination: the rally point frames RTL can use (MAV_FRAME_GLOBAL,
# MAV_FRAME_GLOBAL_RELATIVE_ALT)
SAFE_POINT_FRAMES = frozenset({MavFrame.GLOBAL, MavFrame.GLOBAL_RELATIVE_ALT})


class RtlTimeEstimate(NamedTuple):
    """rtl_time_estimate: RtlTimeEstimator::getEstimate (safe = RTL_TIME_FACTOR × time +
    RTL_TIME_MARGIN, both 0 while not ``valid``)."""

    valid: bool
    time_estimate_s: float
    safe_time_estimate_s: float


NO_ESTIMATE = RtlTimeEstimate(False, 0.0, 0.0)


class RtlPhase(enum.Enum):
    IDLE = "idle"
    CLIMB = "climb"
    RETURN = "return"
    DESCEND = "descend"
    LOITER = "loiter"
    LAND = "land"


def rtl_destination(ctx: NavContext, plans: PlanStore | None, warn: bool = True) -> Vec3:
    """Home or the horizontally closest rally point (rtl.cpp findRtlDestination, RTL_TYPE 0).

    setSafepointAsDestination knows only MAV_FRAME_GLOBAL (0) and GLOBAL_RELATIVE_ALT (3): for
    each rally point of another frame (a MISSION_ITEM_INT client's 5 or 6: the upload keeps
    the frame as sent) that counts, PX4 sends "RTL: unsupported MAV_FRAME" every time it picks
    a destination (here too: on activation and with each 2 s estimate) and leaves the point's
    position unset; the point still competes on its distance. Where such a point wins, PX4
    flies to whatever that unset position holds (undefined): here the destination found so far
    stays (home, or an earlier rally point) and no later point can beat the winner's distance.
    Without home PX4's home is at latitude/longitude 0, far from every point: only the texts
    matter then (the result is the vehicle's position). ``warn`` False: no texts (PX4 runs no
    mode while disarmed)."""
    if plans is None or ctx.origin is None:
        return ctx.home.position_ned_m if ctx.home is not None else ctx.position_ned_m
    if ctx.home is None:
        for item in plans.get(PlanType.RALLY):
            if warn and item.command == MavCmd.NAV_RALLY_POINT:
                _unsupported_frame(ctx, item.frame)
        return ctx.position_ned_m
    best = ctx.home.position_ned_m
    x, y = ctx.position_ned_m[0], ctx.position_ned_m[1]
    best_d = math.hypot(best[0] - x, best[1] - y)
    hx, hy = best[0], best[1]
    for item in plans.get(PlanType.RALLY):
        if item.command != MavCmd.NAV_RALLY_POINT:
            continue
        p = item_ned(item, ctx.origin, ctx.home_alt_amsl_m)
        if math.hypot(p[0] - hx, p[1] - hy) <= RALLY_MIN_DIST_FROM_HOME_M:
            continue
        usable = item.frame in SAFE_POINT_FRAMES
        if warn:
            _unsupported_frame(ctx, item.frame)
        d = math.hypot(p[0] - x, p[1] - y)
        if d + MIN_DIST_THRESHOLD_M < best_d:
            best_d = d
            if usable:
                best = p
    return best


def _unsupported_frame(ctx: NavContext, frame: int) -> None:
    if frame not in SAFE_POINT_FRAMES:
        ctx.log.critical(ctx.now_s, "RTL: unsupported MAV_FRAME\t")
        ctx.log.event(ctx.now_s, RTL_UNSUPPORTED_FRAME, Log.ERROR, None, "B", frame & 0xFF)


def return_height_m(distance_m: float, return_alt_m: float, cone_deg: float, min_dist_m: float,
                    acc_rad_m: float) -> float:
    """Height above the destination to return at, ``distance_m`` away from it (rtl.cpp; the
    current altitude is the caller's floor)."""
    if cone_deg <= 0.0:
        return return_alt_m
    if distance_m <= acc_rad_m:
        return 2.0 * distance_m
    height = return_alt_m
    if distance_m <= min_dist_m:
        cone = math.radians(min(max(cone_deg, 1.0), 89.0))
        height = min(distance_m / math.tan(cone), height)
    return max(height, 2.0 * acc_rad_m)


def return_z_m(ctx: NavContext, dest: Vec3) -> float:
    """_rtl_alt as NED z: ``return_height_m`` above ``dest`` from where the vehicle is, never
    below it (rtl.cpp: never descend to return)."""
    x, y, z = ctx.position_ned_m
    p = ctx.params
    above = return_height_m(math.hypot(x - dest[0], y - dest[1]), float(p["RTL_RETURN_ALT"]),
                            float(p["RTL_CONE_ANG"]), float(p["RTL_MIN_DIST"]),
                            float(p["NAV_ACC_RAD"]))
    return min(dest[2] - above, z)


def activation_phase(landed: bool, z: float, return_z: float) -> RtlPhase:
    """rtl_direct.cpp getActivationLandState: landed -> idle, below the return altitude -> the
    climb, else the return leg."""
    if landed:
        return RtlPhase.IDLE
    return RtlPhase.CLIMB if z > return_z else RtlPhase.RETURN


def _yaw_error_rad(a: float, b: float) -> float:
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


class Return(NavMode):
    def __init__(self, plans: PlanStore | None = None) -> None:
        self.plans = plans
        self.phase = RtlPhase.CLIMB
        self.dest: Vec3 = (0.0, 0.0, 0.0)
        self.return_z = 0.0
        self.yaw = 0.0
        self._fixed_yaw = math.nan  # the present item's heading (NaN: towards the destination)
        self._loiter_since: float | None = None
        self._land = Land()

    def on_activation(self, ctx: NavContext) -> None:
        self.yaw = ctx.yaw_rad
        self._fixed_yaw = ctx.yaw_rad  # the climb keeps the heading
        self._loiter_since = None
        self.dest = rtl_destination(ctx, self.plans, warn=ctx.armed)
        z = ctx.position_ned_m[2]
        dz = self.dest[2]
        self.return_z = return_z_m(ctx, self.dest)
        self.phase = activation_phase(ctx.landed, z, self.return_z)
        if self.phase is RtlPhase.RETURN:
            self._start_return(ctx)
        if ctx.armed:  # PX4 runs no navigator mode while disarmed
            # rtl_direct.cpp on_activation: the return altitude AMSL, and above the destination
            home = ctx.home
            amsl = c_ceil((home.geo.alt_amsl_m + home.position_ned_m[2] if home else 0.0)
                          - self.return_z - 1e-6)
            above = c_ceil(dz - self.return_z - 1e-6)
            ctx.log.info(ctx.now_s, f"RTL: start return at {amsl} m ({above} m above destination)\t")
            ctx.log.event(ctx.now_s, RTL_RETURN_AT, Log.INFO, None, "ii", amsl, above)

    def _home_yaw(self, ctx: NavContext) -> float:
        """The destination's heading: home's yaw, also over a rally point (rtl.cpp)."""
        return ctx.home.yaw_rad if ctx.home is not None else self.yaw

    def _start_return(self, ctx: NavContext) -> None:
        self.phase = RtlPhase.RETURN
        # rtl_direct.cpp MOVE_TO_LOITER: the destination's heading if it is closer than
        # RTL_MIN_DIST (WV_EN 0), else none (the flight task faces the destination).
        x, y, _ = ctx.position_ned_m
        close = math.hypot(x - self.dest[0], y - self.dest[1]) < float(ctx.params["RTL_MIN_DIST"])
        self._fixed_yaw = self._home_yaw(ctx) if close else math.nan

    def _yaw_reached(self, ctx: NavContext) -> bool:
        """mission_block.cpp: an item with a heading is reached only within MIS_YAW_ERR of it
        (no MIS_YAW_TMT timeout here: RTL's items do not force the heading)."""
        if math.isnan(self._fixed_yaw):
            return True
        err = _yaw_error_rad(self._fixed_yaw, ctx.yaw_rad)
        return err < math.radians(float(ctx.params["MIS_YAW_ERR"])) \
            or float(ctx.params["MIS_YAW_TMT"]) > 0.0

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        p = ctx.params
        hx, hy, hz = self.dest
        x, y, z = ctx.position_ned_m
        alt_rad = float(p["NAV_MC_ALT_RAD"])
        acc_rad = float(p["NAV_ACC_RAD"])
        dist_xy = math.hypot(x - hx, y - hy)
        if self.phase is RtlPhase.IDLE:
            return NavSetpoint(ctx.position_ned_m, ctx.yaw_rad, ctx.limits(), idle=True)
        if self.phase is RtlPhase.CLIMB:
            if abs(z - self.return_z) <= alt_rad and self._yaw_reached(ctx):
                self._start_return(ctx)
            else:
                return NavSetpoint((x, y, self.return_z), self.yaw, ctx.limits())
        if self.phase is RtlPhase.RETURN:
            if dist_xy <= acc_rad and abs(z - self.return_z) <= alt_rad and self._yaw_reached(ctx):
                self.phase = RtlPhase.DESCEND
                self._fixed_yaw = self.yaw = self._home_yaw(ctx)
            else:
                if not math.isnan(self._fixed_yaw):
                    self.yaw = self._fixed_yaw
                    return NavSetpoint((hx, hy, self.return_z), self.yaw, ctx.limits())
                # rtl_direct.cpp: no heading of its own on the way; the auto task's (MPC_YAW_MODE
                # 0: it faces the destination while farther than the acceptance radius)
                return NavSetpoint((hx, hy, self.return_z), math.nan, ctx.limits())
        descend_z = max(hz - float(p["RTL_DESCEND_ALT"]), self.return_z)
        if self.phase is RtlPhase.DESCEND:
            # a loiter-to-altitude item: reached on the altitude (and the heading) alone
            if abs(z - descend_z) <= alt_rad and self._yaw_reached(ctx):
                self.phase = RtlPhase.LOITER
                if float(p["RTL_LAND_DELAY"]) < 0:
                    ctx.log.info(ctx.now_s, "RTL: completed, loitering\t")
                    ctx.log.event(ctx.now_s, RTL_COMPLETED_LOITER)
            else:
                return NavSetpoint((hx, hy, descend_z), self.yaw, ctx.limits())
        if self.phase is RtlPhase.LOITER:
            # setLoiterHoldMissionItem: loiter unlimited for RTL_LAND_DELAY < 0, else the delay
            # counts from reaching the loiter point (no heading to reach)
            delay = float(p["RTL_LAND_DELAY"])
            if (self._loiter_since is None and dist_xy <= acc_rad
                    and abs(z - descend_z) <= alt_rad):
                self._loiter_since = ctx.now_s
            if (delay < 0 or self._loiter_since is None
                    or ctx.now_s - self._loiter_since < delay):
                return NavSetpoint((hx, hy, descend_z), self.yaw, ctx.limits())
            self.phase = RtlPhase.LAND
            ctx.log.info(ctx.now_s, "RTL: land at destination\t")
            ctx.log.event(ctx.now_s, RTL_LAND)
            self._land.on_activation(ctx)
            self._land.target_xy = (hx, hy)
            self._land.yaw = self.yaw
        mode = int(p["RTL_PLD_MD"])  # rtl_direct.cpp: the landing's land_precision
        if mode in (1, 2) and ctx.precland is not None:
            return ctx.precland.land(ctx, self, (hx, hy, z), self.yaw, mode)
        return self._land.on_active(ctx)


FLT_EPSILON = 1.1920929e-07


def _div(a: float, b: float) -> float:
    """C's float division: by zero ±inf (0/0 NaN)."""
    if b == 0.0:
        return math.nan if a == 0.0 or math.isnan(a) else math.copysign(math.inf, a) * \
            math.copysign(1.0, b)
    return a / b


def _vert_s(p, up_m: float) -> float:
    """calcVertTimeEstimate: a climb at MPC_Z_V_AUTO_UP, a descent at MPC_Z_V_AUTO_DN."""
    rate = float(p["MPC_Z_V_AUTO_UP"] if up_m > FLT_EPSILON else p["MPC_Z_V_AUTO_DN"])
    return _div(abs(up_m), rate) if abs(up_m) > FLT_EPSILON else 0.0


def rtl_time_estimate(p, start: RtlPhase, pos: Vec3, dest: Vec3, return_z: float
                      ) -> RtlTimeEstimate:
    """RtlDirect::calc_rtl_time_estimate from the phase a return would start in (or is in):
    each phase from there on adds its time, as its switch falls through (NED here: ``return_z``
    is _rtl_alt, the loiter altitude the lower of the destination + RTL_DESCEND_ALT and it).
    The horizontal legs at MPC_XY_CRUISE, the climb at MPC_Z_V_AUTO_UP, the descent to the
    loiter altitude at MPC_Z_V_AUTO_DN, RTL_LAND_DELAY (< 0: loiter for ever, no landing), the
    landing at MPC_LAND_SPEED. Idle (landed) has no estimate."""
    if start is RtlPhase.IDLE:
        return NO_ESTIMATE
    x, y, z = pos
    hx, hy, hz = dest
    loiter_z = max(hz - float(p["RTL_DESCEND_ALT"]), return_z)
    t = 0.0
    land = True
    if start is RtlPhase.CLIMB and z > return_z:  # below the return altitude
        t += _vert_s(p, z - return_z)
    if start in (RtlPhase.CLIMB, RtlPhase.RETURN):  # MOVE_TO_LOITER: from here
        dist = math.hypot(hx - x, hy - y)
        if dist > FLT_EPSILON:
            t += _div(dist, float(p["MPC_XY_CRUISE"]))
    if start in (RtlPhase.CLIMB, RtlPhase.RETURN, RtlPhase.DESCEND):  # LOITER_DOWN
        t += _vert_s(p, (z if start is RtlPhase.DESCEND else return_z) - loiter_z)
    if start is not RtlPhase.LAND:  # LOITER_HOLD, then MOVE_TO_LAND (no approach: 0 m)
        delay = float(p["RTL_LAND_DELAY"])
        if delay > FLT_EPSILON:
            t += delay
        land = not delay < -FLT_EPSILON
    if land:  # LAND, from the loiter altitude or from here
        down = (z if start is RtlPhase.LAND else loiter_z) - hz
        if down < -FLT_EPSILON:
            t += _div(-down, float(p["MPC_LAND_SPEED"]))
    t = f32(t)
    if not math.isfinite(t):
        return NO_ESTIMATE
    return RtlTimeEstimate(True, t, f32(f32(float(p["RTL_TIME_FACTOR"])) * t
                                       + float(p["RTL_TIME_MARGIN"])))
