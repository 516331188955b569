"""Navigator core: setpoint/context types, the NavMode hooks and the basic modes Hold, Takeoff, Land.

After PX4 ``src/modules/navigator`` (NavigatorMode hooks ``on_activation`` / ``on_active`` /
``on_inactive``; loiter.cpp, takeoff.cpp, land.cpp). Mission and Return live in nav_mission.py and
nav_rtl.py; navigator.py wires them together.

Rules and invariants:
- Targets are local NED; a NaN target z means vertical velocity control at ``vz_cmd_mps``.
- A mode asks for a mode change (takeoff done -> Hold) through ``ctx.switch_to``; the commander
  applies it.
- Horizontal auto speed is ``ctx.cruise_mps`` (MPC_XY_CRUISE unless DO_CHANGE_SPEED /
  DO_REPOSITION / a mission DO_CHANGE_SPEED set another, navigator.cpp ``get_cruising_speed``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

from vehicles.control.trajectory import TrajectoryLimits
from vehicles.events import TAKEOFF_ALREADY_HIGHER, TAKEOFF_DEFAULT_ALT, Log
from vehicles.params import ParamStore
from vehicles.status_log import StatusLog
from vehicles.types import GeoPoint, HomePosition, NavState, Vec3

if TYPE_CHECKING:
    from vehicles.auto_trajectory import AutoTrajectory


class NavSetpoint(NamedTuple):
    """What a mode asks of the trajectory this tick (a NamedTuple: one is made every 50 Hz tick
    and a frozen dataclass takes several times as long to build)."""

    target_ned_m: Vec3
    yaw_rad: float
    limits: TrajectoryLimits
    vz_cmd_mps: float = 0.0
    idle: bool = False  # stay on the ground with motors at idle
    landing: bool = False  # LandedState.LANDING while in the air
    taking_off: bool = False  # LandedState.TAKEOFF (mission takeoff)
    # PX4's position setpoint triplet: the waypoint before the target and the one after it (a
    # fly-through corner is planned towards it), and the target's acceptance radius.
    previous_ned_m: Vec3 | None = None
    next_ned_m: Vec3 | None = None
    acceptance_radius_m: float = math.nan
    loiter: bool = False  # a loiter setpoint (SETPOINT_TYPE_LOITER: Hold's, a loiter item's)
    # its loiter radius (position_setpoint_s loiter_radius: a loiter item's own; NaN:
    # NAV_LOITER_RAD, mission_item_to_position_setpoint's default)
    loiter_radius_m: float = math.nan


def braking_stop(position_ned_m: Vec3, velocity_ned_mps: Vec3, params) -> Vec3:
    """Navigator::calculate_breaking_stop: ``position_ned_m`` moved along the horizontal course
    by computeBrakingDistanceFromVelocity(speed, MPC_JERK_AUTO, MPC_ACC_HOR, 0.6 x
    MPC_JERK_AUTO), its altitude kept."""
    x, y, z = position_ned_m
    vx, vy = velocity_ned_mps[0], velocity_ned_mps[1]
    speed = math.hypot(vx, vy)
    acc = float(params["MPC_ACC_HOR"])
    if not speed > 0.0 or not acc > 0.0:
        return (x, y, z)
    # v (v / 2a + accel_delay_max / jerk), accel_delay_max = 0.6 x MPC_JERK_AUTO
    distance = speed * (speed / (2.0 * acc) + 0.6)
    return (x + vx / speed * distance, y + vy / speed * distance, z)


@dataclass
class NavContext:
    """What a mode may look at and do during one tick (built by the autopilot)."""

    now_s: float
    params: ParamStore
    log: StatusLog
    armed: bool
    landed: bool
    position_ned_m: Vec3
    velocity_ned_mps: Vec3
    yaw_rad: float
    home: HomePosition | None
    # The trajectory carrot: where it is now (``setpoint_ned_m``), read when a mode asks, which
    # few ticks do.
    trajectory: AutoTrajectory
    origin: GeoPoint  # EKF origin: lat/lon of plan items -> local NED
    switch_to: Callable[[NavState, Vec3 | None], None] = field(default=lambda s, p: None)
    cruise_mps: float = math.nan  # NaN = MPC_XY_CRUISE
    set_cruise_mps: Callable[[float], None] = field(default=lambda v: None)
    # the navigator's Precision Land block (nav_precland.PrecLand), which a mission's land item
    # or Return's landing may run (MissionBlock::startPrecLand)
    precland: Any = None

    @property
    def setpoint_ned_m(self) -> Vec3:
        return self.trajectory.position_ned_m

    @functools.cached_property
    def braking_stop_ned_m(self) -> Vec3:
        """Navigator::calculate_breaking_stop, where Loiter holds a multicopter: the vehicle's
        position moved along its course by computeBrakingDistanceFromVelocity (MPC_JERK_AUTO,
        MPC_ACC_HOR, an acceleration delay of 0.6 x MPC_JERK_AUTO) on its horizontal speed, at
        its present altitude (setLoiterItemFromCurrentPositionWithBreaking). The vehicle's state,
        not the setpoint's: a vehicle lagging its setpoint overshoots and flies back."""
        return braking_stop(self.position_ned_m, self.velocity_ned_mps, self.params)

    @property
    def speed_xy_mps(self) -> float:
        if math.isnan(self.cruise_mps):
            return float(self.params["MPC_XY_CRUISE"])
        return min(self.cruise_mps, float(self.params["MPC_XY_VEL_MAX"]))

    def limits_at(self, cruise_mps: float) -> TrajectoryLimits:
        """Auto-mode limits at a setpoint's own cruising speed (NaN: MPC_XY_CRUISE), at most
        MPC_XY_VEL_MAX (FlightTaskAuto)."""
        p = self.params
        if math.isnan(cruise_mps):
            return self.limits(float(p["MPC_XY_CRUISE"]))
        return self.limits(min(cruise_mps, float(p["MPC_XY_VEL_MAX"])))

    def limits(self, speed_xy_mps: float | None = None, speed_up_mps: float | None = None,
               speed_down_mps: float | None = None) -> TrajectoryLimits:
        """Auto-mode limits at the current cruise speed."""
        return auto_limits(self.params, self.speed_xy_mps if speed_xy_mps is None else speed_xy_mps,
                           speed_up_mps, speed_down_mps)

    @property
    def home_alt_amsl_m(self) -> float:
        if self.home is not None:
            return self.home.geo.alt_amsl_m
        return self.origin.alt_amsl_m


# How many auto_limits a parameter store keeps (a landing asks for a new descent speed every
# tick between MPC_LAND_ALT1 and MPC_LAND_ALT2; the rest are a handful).
_LIMITS_KEPT = 64


def auto_limits(params, speed_xy_mps: float | None = None, speed_up_mps: float | None = None,
                speed_down_mps: float | None = None,
                acc_up_mps2: float | None = None) -> TrajectoryLimits:
    """The auto modes' limits from the parameters, with the speeds given (not None) in place of
    MPC_XY_CRUISE, MPC_Z_V_AUTO_UP and MPC_Z_V_AUTO_DN (and the climb acceleration in place of
    MPC_ACC_UP_MAX). Kept in ``params.derived`` (emptied on any parameter change): the navigator
    asks every 50 Hz tick, and the trajectory (auto_trajectory.py) skips its set-up while the
    same limits come back."""
    key = ("auto_limits", speed_xy_mps, speed_up_mps, speed_down_mps, acc_up_mps2)
    derived = params.derived
    limits = derived.get(key)
    if limits is None:
        p = params
        limits = TrajectoryLimits(
            speed_xy_mps=float(p["MPC_XY_CRUISE"]) if speed_xy_mps is None else speed_xy_mps,
            speed_up_mps=float(p["MPC_Z_V_AUTO_UP"]) if speed_up_mps is None else speed_up_mps,
            speed_down_mps=(float(p["MPC_Z_V_AUTO_DN"]) if speed_down_mps is None
                            else speed_down_mps),
            acc_xy_mps2=float(p["MPC_ACC_HOR"]),
            acc_up_mps2=float(p["MPC_ACC_UP_MAX"]) if acc_up_mps2 is None else acc_up_mps2,
            acc_down_mps2=float(p["MPC_ACC_DOWN_MAX"]),
        )
        if len(derived) >= _LIMITS_KEPT:
            derived.clear()
        derived[key] = limits
    return limits


def land_speed_mps(params, height_m: float) -> float:
    """PX4 FlightTaskAuto: MPC_Z_V_AUTO_DN above MPC_LAND_ALT1, MPC_LAND_SPEED below MPC_LAND_ALT2."""
    fast, slow = float(params["MPC_Z_V_AUTO_DN"]), float(params["MPC_LAND_SPEED"])
    alt1, alt2 = float(params["MPC_LAND_ALT1"]), float(params["MPC_LAND_ALT2"])
    if height_m >= alt1 or alt1 <= alt2:
        return fast if height_m >= alt2 else slow
    if height_m <= alt2:
        return slow
    return slow + (fast - slow) * (height_m - alt2) / (alt1 - alt2)


def takeoff_limits(params, ctx: NavContext) -> TrajectoryLimits:
    """FlightTaskAuto::_updateTrajConstraints for a takeoff setpoint: closer to the ground than
    MPC_LAND_ALT1 (height above home) it climbs at MPC_TKO_SPEED, accelerating at most at
    MPC_TKO_SPEED / MPC_TKO_RAMP_T (emulating the motor ramp); above, as any climb. Horizontally
    at the navigator's cruising speed (mission_item_to_position_setpoint's cruising_speed)."""
    home_z = ctx.home.position_ned_m[2] if ctx.home is not None else 0.0
    if home_z - ctx.position_ned_m[2] >= float(params["MPC_LAND_ALT1"]):
        return ctx.limits()
    tko = float(params["MPC_TKO_SPEED"])
    ramp_s = float(params["MPC_TKO_RAMP_T"])
    acc = float(params["MPC_ACC_UP_MAX"])
    return auto_limits(params, ctx.speed_xy_mps, speed_up_mps=tko,
                       acc_up_mps2=min(acc, tko / ramp_s) if ramp_s > 0.0 else acc)


def takeoff_reached(ctx: NavContext, target_z: float) -> bool:
    """mission_block.cpp is_mission_item_reached_or_completed for a multicopter NAV_CMD_TAKEOFF
    (Takeoff mode and a mission's takeoff alike; the caller asks that it be in the air): above
    the takeoff altitude less NAV_MC_ALT_RAD, or less half the takeoff altitude above home when
    that is below NAV_MC_ALT_RAD. Altitude only, and without a yaw setpoint no heading test."""
    rad = float(ctx.params["NAV_MC_ALT_RAD"])
    above_home = (ctx.home.position_ned_m[2] if ctx.home is not None else 0.0) - target_z
    if 0.0 < above_home < rad:
        rad = above_home / 2.0
    return ctx.position_ned_m[2] < target_z + rad


class NavMode:
    def on_activation(self, ctx: NavContext) -> None:
        pass

    def on_inactive(self, ctx: NavContext) -> None:
        pass

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        raise NotImplementedError


class Hold(NavMode):
    """Loiter: brake and hold the stopping point (or a point handed over by the previous mode).

    A reposition (DO_REPOSITION, ``reposition``) is flown to even from the ground: loiter.cpp
    ``reposition()`` asks only that the vehicle be armed, and the auto task takes off towards a
    target above it. Without one, on the ground Hold idles the motors and follows the vehicle;
    disarming forgets the reposition (PX4 resets its loiter position). A reposition is flown at
    its own speed (``reposition_speed_mps``, NaN: MPC_XY_CRUISE; vehicles/reposition.py), Hold
    otherwise at the navigator's cruising speed."""

    def __init__(self) -> None:
        self.target: Vec3 = (0.0, 0.0, 0.0)
        self.yaw = 0.0
        self.hint: Vec3 | None = None
        self.hint_yaw = math.nan
        self.reposition: Vec3 | None = None  # taken at the next activation
        self.reposition_speed_mps = math.nan  # taken with it
        self.speed_mps: float | None = None  # the setpoint's own; None: the navigator's
        self._repositioned = False

    def on_activation(self, ctx: NavContext) -> None:
        self._repositioned = self.reposition is not None
        self.speed_mps = None
        if self.reposition is not None:
            self.target = self.reposition
            self.speed_mps = self.reposition_speed_mps
        elif self.hint is not None and not ctx.landed:
            self.target = self.hint
        elif ctx.landed:
            self.target = ctx.position_ned_m
        else:  # Loiter::set_loiter_position, a rotary wing
            self.target = ctx.braking_stop_ned_m
        # The heading: a reposition's or a handed-over setpoint's own; none (NaN: the auto task
        # turns towards the target while it is farther than the acceptance radius,
        # auto_heading.py) without one and at the braking point (setLoiterItemCommonFields);
        # the vehicle's on the ground.
        self.yaw = ctx.yaw_rad if ctx.landed and not self._repositioned else self.hint_yaw
        self.hint = self.reposition = None
        self.hint_yaw = self.reposition_speed_mps = math.nan

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        if not ctx.armed:
            self._repositioned = False
        if ctx.landed and not self._repositioned:
            # On the ground Hold keeps the motors idle and follows the vehicle.
            self.target = ctx.position_ned_m
            return NavSetpoint(self.target, ctx.yaw_rad, ctx.limits(), idle=True)
        limits = ctx.limits() if self.speed_mps is None else ctx.limits_at(self.speed_mps)
        return NavSetpoint(self.target, self.yaw, limits, loiter=True)


class Takeoff(NavMode):
    def __init__(self) -> None:
        self.requested_alt_amsl_m = math.nan
        self.origin_alt_amsl_m = 0.0
        self.target: Vec3 = (0.0, 0.0, 0.0)
        self.yaw = 0.0

    def on_activation(self, ctx: NavContext) -> None:
        x, y, z = ctx.position_ned_m
        # PX4 navigator takeoff.cpp set_takeoff_position (v1.15): the requested altitude as
        # given, else MIS_TAKEOFF_ALT above the *current* altitude (not home: a takeoff command
        # in the air climbs on); never down.
        if math.isnan(self.requested_alt_amsl_m):
            alt = float(ctx.params["MIS_TAKEOFF_ALT"])
            ctx.log.info(ctx.now_s, f"Using default takeoff altitude: {alt:.1f} m\t")
            ctx.log.event(ctx.now_s, TAKEOFF_DEFAULT_ALT, Log.INFO, Log.INFO, "f", alt)
            target_z = z - alt
        else:
            target_z = self.origin_alt_amsl_m - self.requested_alt_amsl_m
        if target_z > z:
            ctx.log.critical(ctx.now_s, "Already higher than takeoff altitude\t")
            ctx.log.event(ctx.now_s, TAKEOFF_ALREADY_HIGHER, Log.ERROR, Log.INFO)
            target_z = z
        self.target = (x, y, target_z)
        self.yaw = ctx.yaw_rad
        self.requested_alt_amsl_m = math.nan

    def on_active(self, ctx: NavContext) -> NavSetpoint:
        limits = takeoff_limits(ctx.params, ctx)
        if not ctx.armed:
            return NavSetpoint(self.target, self.yaw, limits, idle=True)
        # takeoff.cpp: done once is_mission_item_reached_or_completed accepts the takeoff (in
        # the air); Hold then keeps the takeoff point as its target (the setpoint closes the rest).
        if not ctx.landed and takeoff_reached(ctx, self.target[2]):
            # COM_TAKEOFF_ACT 0: hold at the takeoff point (1: Mission, if valid: the autopilot)
            ctx.switch_to(NavState.AUTO_LOITER, self.target)
        return NavSetpoint(self.target, self.yaw, limits)


class Land(NavMode):
    def __init__(self) -> None:
        self.target_xy = (0.0, 0.0)
        self.yaw = 0.0

    def on_activation(self, ctx: NavContext) -> None:
        # MissionBlock::set_land_item: where the vehicle is (no braking distance: a vehicle
        # commanded to land at speed brakes and flies back there)
        sp = ctx.position_ned_m
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


