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
- Phases advance on the vehicle's measured position (NAV_MC_ALT_RAD vertically).
"""

from __future__ import annotations

import enum
import math

from vehicles.cnum import c_ceil
from vehicles.events import RTL_COMPLETED_LOITER, RTL_LAND, RTL_RETURN_AT, Log
from vehicles.nav_core import Land, NavContext, NavMode, NavSetpoint
from vehicles.plan_types import MavCmd, PlanType
from vehicles.plans import PlanStore, item_ned
from vehicles.types import Vec3


class RtlPhase(enum.Enum):
    CLIMB = "climb"
    RETURN = "return"
    DESCEND = "descend"
    LOITER = "loiter"
    LAND = "land"


def rtl_destination(ctx: NavContext, plans: PlanStore | None) -> Vec3:
    """Home or the horizontally closest rally point (rtl.cpp findRtlDestination, RTL_TYPE 0)."""
    assert ctx.home is not None  # the autopilot refuses RTL without home
    best = ctx.home.position_ned_m
    if plans is None or ctx.origin is None:
        return best
    x, y = ctx.position_ned_m[0], ctx.position_ned_m[1]
    best_d = math.hypot(best[0] - x, best[1] - y)
    for item in plans.get(PlanType.RALLY):
        if item.command != MavCmd.NAV_RALLY_POINT:
            continue
        p = item_ned(item, ctx.origin, ctx.home_alt_amsl_m)
        d = math.hypot(p[0] - x, p[1] - y)
        if d < best_d:
            best, best_d = p, d
    return best


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


class Return(NavMode):
    def __init__(self, plans: PlanStore | None = None) -> None:
        self.plans = plans
        self.phase = RtlPhase.CLIMB
        self.dest: Vec3 = (0.0, 0.0, 0.0)
        self.return_z = 0.0
        self.yaw = 0.0
        self._loiter_since = 0.0
        self._land = Land()

    def on_activation(self, ctx: NavContext) -> None:
        p = ctx.params
        self.yaw = ctx.yaw_rad
        self.dest = rtl_destination(ctx, self.plans)
        x, y, z = ctx.position_ned_m
        dz = self.dest[2]
        above = return_height_m(math.hypot(x - self.dest[0], y - self.dest[1]),
                                float(p["RTL_RETURN_ALT"]), float(p["RTL_CONE_ANG"]),
                                float(p["RTL_MIN_DIST"]), float(p["NAV_ACC_RAD"]))
        self.return_z = min(dz - above, z)  # never descend to return
        self.phase = RtlPhase.LAND if ctx.landed else RtlPhase.CLIMB
        if not ctx.landed:
            # rtl_direct.cpp: the return altitude AMSL, and above the destination
            home = ctx.home
            amsl = c_ceil((home.geo.alt_amsl_m + home.position_ned_m[2] if home else 0.0)
                          - self.return_z - 1e-6)
            above = c_ceil(dz - self.return_z - 1e-6)
            ctx.log.info(ctx.now_s, f"RTL: start return at {amsl} m ({above} m above destination)\t")
            ctx.log.event(ctx.now_s, RTL_RETURN_AT, Log.INFO, None, "ii", amsl, above)

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        p = ctx.params
        hx, hy, hz = self.dest
        x, y, z = ctx.position_ned_m
        alt_rad = float(p["NAV_MC_ALT_RAD"])
        if self.phase is RtlPhase.CLIMB:
            if abs(z - self.return_z) < alt_rad or z < self.return_z:
                self.phase = RtlPhase.RETURN
            else:
                return NavSetpoint((x, y, self.return_z), self.yaw, ctx.limits())
        if self.phase is RtlPhase.RETURN:
            if math.hypot(x - hx, y - hy) < 0.5 and math.hypot(*ctx.velocity_ned_mps[:2]) < 0.5:
                self.phase = RtlPhase.DESCEND
            else:
                if math.hypot(x - hx, y - hy) > 2.0:
                    self.yaw = math.atan2(hy - y, hx - x)  # MPC_YAW_MODE 0: face the way home
                return NavSetpoint((hx, hy, self.return_z), self.yaw, ctx.limits())
        descend_z = max(hz - float(p["RTL_DESCEND_ALT"]), self.return_z)
        if self.phase is RtlPhase.DESCEND:
            if abs(z - descend_z) < alt_rad or z > descend_z:
                self.phase = RtlPhase.LOITER
                self._loiter_since = ctx.now_s
                if float(p["RTL_LAND_DELAY"]) < 0:
                    ctx.log.info(ctx.now_s, "RTL: completed, loitering\t")
                    ctx.log.event(ctx.now_s, RTL_COMPLETED_LOITER)
            else:
                return NavSetpoint((hx, hy, descend_z), self.yaw, ctx.limits())
        if self.phase is RtlPhase.LOITER:
            delay = float(p["RTL_LAND_DELAY"])
            if delay < 0 or ctx.now_s - self._loiter_since < delay:
                return NavSetpoint((hx, hy, descend_z), self.yaw, ctx.limits())
            self.phase = RtlPhase.LAND
            ctx.log.info(ctx.now_s, "RTL: land at destination\t")
            ctx.log.event(ctx.now_s, RTL_LAND)
            self._land.on_activation(ctx)
            self._land.target_xy = (hx, hy)
        return self._land.on_active(ctx)
