"""Navigator: the auto modes, each producing a target for the trajectory limiter.

After PX4 ``src/modules/navigator`` (NavigatorMode hooks ``on_activation`` / ``on_active`` /
``on_inactive``; loiter.cpp, takeoff.cpp, land.cpp, rtl_direct.cpp).

Rules and invariants:
- One ``NavMode`` object per NavState it serves, registered in ``Navigator.modes``: adding Mission
  or Offboard later means adding a class and a row, nothing else.
- The navigator follows the commander's nav_state: when it differs from the active mode, the old
  mode's ``on_inactive`` and the new mode's ``on_activation`` run, then ``on_active`` every tick.
- A mode asks for a mode change (takeoff done -> Hold) through ``ctx.switch_to``; the commander
  applies it.
- Targets are local NED; a NaN target z means vertical velocity control at ``vz_cmd_mps``.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from dataclasses import dataclass, field

from vehicles.control.trajectory import TrajectoryLimits
from vehicles.status_log import StatusLog
from vehicles.types import HomePosition, NavState

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class NavSetpoint:
    target_ned_m: Vec3
    yaw_rad: float
    limits: TrajectoryLimits
    vz_cmd_mps: float = 0.0
    idle: bool = False  # stay on the ground with motors at idle
    landing: bool = False  # LandedState.LANDING while in the air


@dataclass
class NavContext:
    """What a mode may look at and do during one tick (built by the autopilot)."""

    now_s: float
    params: object
    log: StatusLog
    armed: bool
    landed: bool
    position_ned_m: Vec3
    velocity_ned_mps: Vec3
    yaw_rad: float
    home: HomePosition | None
    setpoint_ned_m: Vec3  # where the trajectory carrot is now
    stopping_point_ned_m: Vec3
    switch_to: Callable[[NavState, Vec3 | None], None] = field(default=lambda s, p: None)


def auto_limits(params, speed_xy_mps: float | None = None, speed_up_mps: float | None = None,
                speed_down_mps: float | None = None) -> TrajectoryLimits:
    p = params
    return TrajectoryLimits(
        speed_xy_mps=float(p["MPC_XY_CRUISE"]) if speed_xy_mps is None else speed_xy_mps,
        speed_up_mps=float(p["MPC_Z_V_AUTO_UP"]) if speed_up_mps is None else speed_up_mps,
        speed_down_mps=float(p["MPC_Z_V_AUTO_DN"]) if speed_down_mps is None else speed_down_mps,
        acc_xy_mps2=float(p["MPC_ACC_HOR"]),
        acc_up_mps2=float(p["MPC_ACC_UP_MAX"]),
        acc_down_mps2=float(p["MPC_ACC_DOWN_MAX"]),
    )


def land_speed_mps(params, height_m: float) -> float:
    """PX4 FlightTaskAuto: MPC_Z_V_AUTO_DN above MPC_LAND_ALT1, MPC_LAND_SPEED below MPC_LAND_ALT2."""
    fast, slow = float(params["MPC_Z_V_AUTO_DN"]), float(params["MPC_LAND_SPEED"])
    alt1, alt2 = float(params["MPC_LAND_ALT1"]), float(params["MPC_LAND_ALT2"])
    if height_m >= alt1 or alt1 <= alt2:
        return fast if height_m >= alt2 else slow
    if height_m <= alt2:
        return slow
    return slow + (fast - slow) * (height_m - alt2) / (alt1 - alt2)


class NavMode:
    def on_activation(self, ctx: NavContext) -> None:
        pass

    def on_inactive(self, ctx: NavContext) -> None:
        pass

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        raise NotImplementedError


class Hold(NavMode):
    """Loiter: brake and hold the stopping point (or a point handed over by the previous mode)."""

    def __init__(self) -> None:
        self.target: Vec3 = (0.0, 0.0, 0.0)
        self.yaw = 0.0
        self.hint: Vec3 | None = None

    def on_activation(self, ctx: NavContext) -> None:
        if self.hint is not None and not ctx.landed:
            self.target = self.hint
        elif ctx.landed:
            self.target = ctx.position_ned_m
        else:
            self.target = ctx.stopping_point_ned_m
        self.hint = None
        self.yaw = ctx.yaw_rad

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        if ctx.landed:
            # On the ground Hold keeps the motors idle and follows the vehicle.
            self.target = ctx.position_ned_m
            return NavSetpoint(self.target, ctx.yaw_rad, auto_limits(ctx.params), idle=True)
        return NavSetpoint(self.target, self.yaw, auto_limits(ctx.params))


class Takeoff(NavMode):
    def __init__(self) -> None:
        self.requested_alt_amsl_m = math.nan
        self.origin_alt_amsl_m = 0.0
        self.target: Vec3 = (0.0, 0.0, 0.0)
        self.yaw = 0.0

    def on_activation(self, ctx: NavContext) -> None:
        p = ctx.params
        x, y, z = ctx.position_ned_m
        if math.isnan(self.requested_alt_amsl_m):
            alt = float(p["MIS_TAKEOFF_ALT"])
            ctx.log.info(ctx.now_s, f"Using default takeoff altitude: {alt:.1f} m")
            target_z = z - alt
        else:
            target_z = self.origin_alt_amsl_m - self.requested_alt_amsl_m
        if not ctx.landed and target_z > z:
            ctx.log.info(ctx.now_s, "Already higher than takeoff altitude")
            target_z = z
        self.target = (x, y, target_z)
        self.yaw = ctx.yaw_rad
        self.requested_alt_amsl_m = math.nan

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        p = ctx.params
        limits = auto_limits(p, speed_up_mps=float(p["MPC_TKO_SPEED"]))
        if not ctx.armed:
            return NavSetpoint(self.target, self.yaw, limits, idle=True)
        reached = (abs(ctx.position_ned_m[2] - self.target[2]) < float(p["NAV_MC_ALT_RAD"])
                   and abs(ctx.setpoint_ned_m[2] - self.target[2]) < 1e-3)
        if not ctx.landed and reached:
            # COM_TAKEOFF_ACT = 0: hold at the takeoff point.
            ctx.switch_to(NavState.AUTO_LOITER, self.target)
        return NavSetpoint(self.target, self.yaw, limits)


class Land(NavMode):
    def __init__(self) -> None:
        self.target_xy = (0.0, 0.0)
        self.yaw = 0.0
        self.announce = True

    def on_activation(self, ctx: NavContext) -> None:
        if self.announce:
            ctx.log.info(ctx.now_s, "Landing at current position")
        sp = ctx.position_ned_m if ctx.landed else ctx.stopping_point_ned_m
        self.target_xy = (sp[0], sp[1])
        self.yaw = ctx.yaw_rad

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        height = -ctx.position_ned_m[2]
        speed = land_speed_mps(ctx.params, height)
        limits = auto_limits(ctx.params, speed_down_mps=speed)
        if ctx.landed:
            return NavSetpoint(ctx.position_ned_m, self.yaw, limits, idle=True)
        return NavSetpoint((self.target_xy[0], self.target_xy[1], math.nan), self.yaw, limits,
                           vz_cmd_mps=speed, landing=True)


class RtlPhase(enum.Enum):
    CLIMB = "climb"
    RETURN = "return"
    DESCEND = "descend"
    LAND = "land"


class Return(NavMode):
    """RTL_TYPE 0 (direct): climb to RTL_RETURN_ALT, fly home, descend to RTL_DESCEND_ALT, land."""

    def __init__(self) -> None:
        self.phase = RtlPhase.CLIMB
        self.return_z = 0.0
        self.yaw = 0.0
        self._land = Land()
        self._land.announce = False

    def on_activation(self, ctx: NavContext) -> None:
        ctx.log.info(ctx.now_s, "Returning to launch")
        self.yaw = ctx.yaw_rad
        home = ctx.home
        assert home is not None  # the autopilot refuses RTL without home
        home_z = home.position_ned_m[2]
        height_above_home = home_z - ctx.position_ned_m[2]
        return_alt = max(float(ctx.params["RTL_RETURN_ALT"]), height_above_home)
        self.return_z = home_z - return_alt
        self.phase = RtlPhase.LAND if ctx.landed else RtlPhase.CLIMB
        if not ctx.landed:
            ctx.log.info(ctx.now_s, f"RTL: start return at {return_alt:.0f} m "
                                    f"({return_alt:.0f} m above destination)")

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        p = ctx.params
        home = ctx.home
        assert home is not None
        hx, hy, hz = home.position_ned_m
        x, y, z = ctx.position_ned_m
        alt_rad = float(p["NAV_MC_ALT_RAD"])
        if self.phase is RtlPhase.CLIMB:
            if abs(z - self.return_z) < alt_rad:
                self.phase = RtlPhase.RETURN
                self._climb_xy = (x, y)
            else:
                return NavSetpoint((x, y, self.return_z), self.yaw, auto_limits(p))
        if self.phase is RtlPhase.RETURN:
            if math.hypot(x - hx, y - hy) < 0.5 and math.hypot(*ctx.velocity_ned_mps[:2]) < 0.5:
                self.phase = RtlPhase.DESCEND
            else:
                return NavSetpoint((hx, hy, self.return_z), self.yaw, auto_limits(p))
        if self.phase is RtlPhase.DESCEND:
            descend_z = min(hz - float(p["RTL_DESCEND_ALT"]), hz)
            if z >= descend_z - alt_rad:
                self.phase = RtlPhase.LAND
                ctx.log.info(ctx.now_s, "RTL: land at destination")
                self._land.on_activation(ctx)
                self._land.target_xy = (hx, hy)
            else:
                return NavSetpoint((hx, hy, max(descend_z, self.return_z)), self.yaw,
                                   auto_limits(p))
        return self._land.on_active(ctx)


class Navigator:
    def __init__(self) -> None:
        self.hold = Hold()
        self.takeoff = Takeoff()
        self.modes: dict[NavState, NavMode] = {
            NavState.AUTO_LOITER: self.hold,
            NavState.AUTO_TAKEOFF: self.takeoff,
            NavState.AUTO_LAND: Land(),
            NavState.AUTO_RTL: Return(),
        }
        self.active_state: NavState | None = None
        self._reactivate = False

    def reactivate(self) -> None:
        """Run on_activation again at the next tick (e.g. a new takeoff command while in Takeoff)."""
        self._reactivate = True

    def update(self, nav_state: NavState, ctx: NavContext) -> NavSetpoint:
        if nav_state not in self.modes:
            nav_state = NavState.AUTO_LOITER  # modes without a navigator part behave as Hold
        if nav_state != self.active_state or self._reactivate:
            if self.active_state is not None:
                self.modes[self.active_state].on_inactive(ctx)
            self.active_state = nav_state
            self._reactivate = False
            self.modes[nav_state].on_activation(ctx)
        return self.modes[nav_state].on_active(ctx)
