"""Manual control: stick input (QGC's virtual joystick or a joystick through QGC, MAVSDK's
manual_control plugin, pymavlink's MANUAL_CONTROL) and the stick-driven flight modes.

After PX4:
- ``modules/manual_control`` (ManualControl.cpp, lib MovingDiff): the input is valid for
  COM_RC_LOSS_T after the last message; "sticks moving" is any stick's rate of change (low-passed
  over 0.1 s) above COM_RC_STICK_OV percent of full travel per second; that is what lets a pilot
  take over an auto mode or Offboard (COM_RC_OVERRIDE, autopilot.py); the arm and disarm gestures
  (stick_gestures.py).
- ``flight_mode_manager/tasks/Utility/Sticks.cpp``: expo + deadzone (MPC_*_EXPO, MPC_HOLD_DZ);
  lost input reads as centred sticks.
- ``tasks/ManualAltitudeSmoothVel`` (Altitude mode, and the vertical of Position mode with the
  default MPC_POS_MODE 4): vertical velocity from the throttle stick (MPC_Z_VEL_MAX_UP/DN),
  slower near the ground (MPC_LAND_ALT1/2, MPC_LAND_SPEED, MPC_TKO_SPEED), jerk-limited
  (ManualVelocitySmoothingZ: MPC_JERK_MAX, MPC_ACC_UP_MAX/MPC_ACC_DOWN_MAX), the altitude locked
  where the smoothed trajectory stops once the stick is centred; tilt from roll/pitch
  (StickTiltXY: MPC_MAN_TILT_MAX, as at most 3 g sideways, Altitude mode), yaw rate from the
  yaw stick (MPC_MAN_Y_MAX, MPC_MAN_Y_TAU); take-off wanted above 65 % throttle.
- ``tasks/Utility/StickAccelerationXY.cpp`` (Position mode, MPC_POS_MODE 4, PX4's default since
  v1.13; older values run the same): sticks command horizontal acceleration (2 × MPC_ACC_HOR)
  less a drag that caps the speed at MPC_VEL_MANUAL and brakes harder with centred sticks, the
  sum jerk-limited (MPC_JERK_MAX); the position is locked once the velocity setpoint is zero.
- Stabilized, Manual and Acro: manual_attitude.py.

Sticks are PX4's ``manual_control_setpoint``: pitch forward +, roll right +, yaw right +, all in
[-1, 1]; throttle in [-1, 1] (−1 = stick down). Pure: time and dt are arguments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vehicles.control.manual_velocity_smoothing_z import ManualVelocitySmoothingZ
from vehicles.control.position_control import PositionSetpoint
from vehicles.manual_setpoint import SetpointPublications
from vehicles.mode_table import ArmEvent
from vehicles.stick_gestures import StickGestures
from vehicles.types import GRAVITY_MPS2, EstimatorReset, Vec3

EPS = 1.1920929e-07  # FLT_EPSILON
UNIT_EPS = 1e-5  # matrix::Vector::unit_or_zero's
TAKEOFF_THROTTLE = 0.3  # FlightTaskManualAltitude::_checkTakeoff: above 65 % of the stick
STICK_RATE_TAU_S = 0.1  # MovingDiff's filter
BRAKE_BOOST_TAU_S = 0.8


@dataclass(frozen=True)
class Sticks:
    pitch: float = 0.0
    roll: float = 0.0
    throttle: float = 0.0
    yaw: float = 0.0
    buttons: int = 0


CENTRED = Sticks()


# --- PX4 mathlib -----------------------------------------------------------------------------
def _clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v


def deadzone(value: float, dz: float) -> float:
    value = _clamp(value, -1.0, 1.0)
    dz = _clamp(dz, 0.0, 0.99)
    if abs(value) <= dz:
        return 0.0
    return (value - math.copysign(dz, value)) / (1.0 - dz)


def expo(value: float, e: float) -> float:
    value = _clamp(value, -1.0, 1.0)
    e = _clamp(e, 0.0, 1.0)
    return (1.0 - e) * value + e * value * value * value


def expo_deadzone(value: float, e: float, dz: float) -> float:
    return expo(deadzone(value, dz), e)


def superexpo(value: float, e: float, g: float) -> float:
    value = _clamp(value, -1.0, 1.0)
    g = _clamp(g, 0.0, 0.99)
    return expo(value, e) * (1.0 - g) / (1.0 - abs(value) * g)


def gradual(value: float, x_low: float, x_high: float, y_low: float, y_high: float) -> float:
    if value <= x_low:
        return y_low
    if value >= x_high:
        return y_high
    return y_low + (y_high - y_low) * (value - x_low) / (x_high - x_low)


def _sign(value: float) -> float:
    """matrix::sign: 0 at 0."""
    return 1.0 if value > 0.0 else -1.0 if value < 0.0 else 0.0


def _sqrt_linear(value: float) -> float:
    if value < 0.0:
        return 0.0
    return math.sqrt(value) if value < 1.0 else value


def _lowpass(state: float, target: float, dt: float, tau: float) -> float:
    """AlphaFilter with time constant ``tau`` (0: no filtering)."""
    alpha = dt / max(tau + dt, 1e-3)
    return (1.0 - alpha) * state + alpha * target


def _rotate(x: float, y: float, yaw: float) -> tuple[float, float]:
    c, s = math.cos(yaw), math.sin(yaw)
    return c * x - s * y, s * x + c * y


def _max_tilt_acceleration(tilt_max_deg: float) -> float:
    """StickTiltXY::updateParams: full stick's sideways acceleration, the tilt taken as at most
    89° and the result kept within [0.02, 3] g (about 1° to 71°), so a MPC_MAN_TILT_MAX near or
    at 90° cannot ask for a near-infinite (or, past 90°, reversed) acceleration."""
    tilt = math.radians(_clamp(tilt_max_deg, 0.0, 89.0))
    return _clamp(math.tan(tilt), 0.02, 3.0) * GRAVITY_MPS2


# --- the input -------------------------------------------------------------------------------
class _MovingDiff:
    """PX4 MovingDiff: the stick's rate of change (per second), low-passed (0.1 s)."""

    def __init__(self) -> None:
        self.rate = 0.0
        self._last = math.nan

    def update(self, value: float, dt: float) -> float:
        if dt < EPS:
            return self.rate
        if not math.isnan(self._last):
            self.rate = _lowpass(self.rate, (value - self._last) / dt, dt, STICK_RATE_TAU_S)
        self._last = value
        return self.rate

    def reset(self) -> None:
        self.rate = 0.0
        self._last = math.nan


class ManualControl:
    """The latest stick input and when it came."""

    def __init__(self, params) -> None:
        self._params = params
        self.sticks: Sticks | None = None
        self.received_s = -math.inf
        self.source: object = None
        self._diffs = (_MovingDiff(), _MovingDiff(), _MovingDiff(), _MovingDiff())
        self.moving = False  # a stick moved faster than COM_RC_STICK_OV with the last input
        self._gestures = StickGestures(params)
        self.gesture: ArmEvent | None = None  # what the last input's gesture asks for
        self._first_source: object = None  # COM_RC_IN_MODE 3 keeps it until reboot
        # manual_control_setpoint, as ManualControl publishes it (MANUAL_CONTROL echoes it)
        self.setpoint: SetpointPublications[Sticks] = SetpointPublications(CENTRED)

    def set(self, now_s: float, sticks: Sticks, source: object = None) -> bool:
        """``source``: where it came from (the gateway: the link). As PX4's
        ManualControlSelector, the first source keeps control while its input is fresh; another
        one is ignored until then, and COM_RC_IN_MODE 0 (RC only) and 4 (disabled) ignore all,
        3 all but the first source since boot (returns False when ignored)."""
        mode = int(self._params["COM_RC_IN_MODE"])
        fresh = self.fresh(now_s, float(self._params["COM_RC_LOSS_T"]))
        if (fresh and source != self.source) or mode in (0, 4) or (
                mode == 3 and self._first_source not in (None, source)):
            return False
        if self._first_source is None:
            self._first_source = source
        self.source = source
        if not fresh:
            for d in self._diffs:
                d.reset()
            self._gestures.reset(now_s)
        self.gesture = self._gestures.update(now_s, sticks.pitch, sticks.roll, sticks.throttle,
                                             sticks.yaw)
        dt = 0.0 if self.sticks is None else now_s - self.received_s
        threshold = 0.01 * float(self._params["COM_RC_STICK_OV"])
        self.moving = False
        for d, v in zip(self._diffs, (sticks.roll, sticks.pitch, sticks.yaw, sticks.throttle)):
            if abs(d.update(v, dt)) > threshold:
                self.moving = True
        self.sticks = sticks
        self.received_s = now_s
        self.setpoint.on_input(now_s, sticks, float(self._params["COM_RC_LOSS_T"]))
        return True

    def published(self, now_s: float) -> tuple[int, Sticks]:
        """manual_control_setpoint by ``now_s``: how many publications, the last one's sticks."""
        loss_s = float(self._params["COM_RC_LOSS_T"])
        return self.setpoint.count(now_s, loss_s), self.setpoint.sticks

    def fresh(self, now_s: float, timeout_s: float) -> bool:
        return self.sticks is not None and now_s - self.received_s <= timeout_s

    def current(self, now_s: float) -> Sticks:
        """The sticks now: centred once the input is lost (Sticks::checkAndUpdateStickInputs)."""
        sticks = self.sticks
        if sticks is not None and self.fresh(now_s, float(self._params["COM_RC_LOSS_T"])):
            return sticks
        return CENTRED


# --- Altitude and Position -------------------------------------------------------------------
def stick_xy(params, sticks: Sticks, heading: float) -> tuple[float, float]:
    """The horizontal sticks as Position mode's tasks take them (StickAccelerationXY,
    FlightTaskManualPosition::_scaleSticks): expo and deadzone (MPC_XY_MAN_EXPO, MPC_HOLD_DZ),
    limited to unit length, sideways and backwards scaled by MPC_VEL_MAN_SIDE/BACK over
    MPC_VEL_MANUAL (negative: not), turned into the heading frame."""
    p = params
    dz, e = float(p["MPC_HOLD_DZ"]), float(p["MPC_XY_MAN_EXPO"])
    sx, sy = expo_deadzone(sticks.pitch, e, dz), expo_deadzone(sticks.roll, e, dz)
    n = math.hypot(sx, sy)
    if n > 1.0:
        sx, sy = sx / n, sy / n
    vel_manual = float(p["MPC_VEL_MANUAL"])
    side, back = float(p["MPC_VEL_MAN_SIDE"]), float(p["MPC_VEL_MAN_BACK"])
    if side >= 0.0:
        sy *= side / vel_manual
    if back >= 0.0 and sx < 0.0:
        sx *= back / vel_manual
    return _rotate(sx, sy, heading)


class ManualAltitude:
    """FlightTaskManualAltitudeSmoothVel (FlightTaskManualAltitude + ManualVelocitySmoothingZ, and
    StickYaw): one instance per vehicle. ``activate`` when the mode is entered (PX4 builds a new
    task object and activates it with the last task's setpoint), ``reactivate`` after every tick
    on the ground (FlightTask::reActivate until the takeoff ramp starts)."""

    def __init__(self, params) -> None:
        self.params = params
        self.z_sp = math.nan  # the altitude lock (ManualVelocitySmoothingZ's), NaN when not held
        self.yaw_sp = math.nan
        self._yawspeed = 0.0
        self._tilt = (0.0, 0.0)
        self.smoothing = ManualVelocitySmoothingZ()
        self._vz_sp = 0.0  # the last vertical velocity setpoint (what reActivate keeps)
        self._params_version = -1
        self._z_limits: tuple[float, ...] = (0.0,) * 11
        # takeoff_status.tilt_limit as mc_pos_control last published it (MPC_TILTMAX_LND until
        # the flight state, then slewed to MPC_TILTMAX_AIR); NaN: MPC_TILTMAX_AIR. Position
        # mode's StickAccelerationXY limits its acceleration with it.
        self.tilt_limit_rad = math.nan
        # what Position Slow sets below the parameters' limits (FlightTaskManualAltitude's
        # _velocity_constraint_up/down, StickYaw's yawspeed constraint; position_slow.py)
        self.velocity_constraint_up = self.velocity_constraint_down = math.inf
        self.yawspeed_constraint = math.inf

    def activate(self, pos: Vec3, vel: Vec3, yaw: float,
                 last: PositionSetpoint | None = None) -> None:
        """The mode is entered (FlightModeManager::switchTask: a new task object, then
        ``activate(last_setpoint)``; None: PX4's empty setpoint, the vehicle's state)."""
        self._yawspeed = 0.0
        self._tilt = (0.0, 0.0)
        self._activate(pos, vel, yaw, last)

    def reactivate(self, pos: Vec3, vel: Vec3, yaw: float) -> None:
        """FlightTask::reActivate: activate again on an empty setpoint but for the vertical
        velocity setpoint, kept so that the stick can descend on the ground (the filters run
        on)."""
        self._activate(pos, vel, yaw,
                       PositionSetpoint(velocity_ned_mps=(math.nan, math.nan, self._vz_sp)))

    def _activate(self, pos: Vec3, vel: Vec3, yaw: float, last: PositionSetpoint | None) -> None:
        self.yaw_sp = yaw
        self._vz_sp = 0.0
        self.reset_smoothing(pos, vel, last)

    def reset_smoothing(self, pos: Vec3, vel: Vec3, last: PositionSetpoint | None) -> None:
        """FlightTaskManualAltitudeSmoothVel::activate (and FlightTaskOrbit on reaching its
        circle): the vertical smoothing restarts, unlocked, from the last setpoint's altitude,
        vertical velocity and acceleration, each that is not finite from the vehicle's altitude
        and vertical velocity and a zero acceleration."""
        z = vz = az = math.nan
        if last is not None:
            z, vz, az = (last.position_ned_m[2], last.velocity_ned_mps[2],
                         last.acceleration_ned_mps2[2])
        self.smoothing.reset(az if math.isfinite(az) else 0.0,
                             vz if math.isfinite(vz) else vel[2],
                             z if math.isfinite(z) else pos[2])
        self.z_sp = math.nan

    def estimator_reset(self, pos: Vec3, vel: Vec3, r: EstimatorReset) -> None:
        """FlightTaskManualAltitudeSmoothVel::_ekfResetHandlerPositionZ, VelocityZ: the vertical
        smoothing takes the new height and velocity (setCurrentPosition, setCurrentVelocity)."""
        if r.z:
            self.smoothing.set_current_position(pos[2])
        if r.vz:
            self.smoothing.set_current_velocity(vel[2])

    @property
    def yawspeed(self) -> float:
        """The heading rate the yaw stick asks for (rad/s), fed forward to attitude control."""
        return self._yawspeed

    def want_takeoff(self, sticks: Sticks) -> bool:
        return sticks.throttle > TAKEOFF_THROTTLE

    def _yaw(self, sticks: Sticks, yaw: float, dt: float) -> None:
        """StickYaw::generateYawSetpoint (no unaided heading here: no yaw correction): the
        filtered rate (MPC_MAN_Y_TAU) of the stick's share of MPC_MAN_Y_MAX; while it is not
        zero there is no heading setpoint (NaN: the rate alone turns the vehicle), once it is
        the heading locks where the vehicle points (updateYawLock)."""
        p = self.params
        target = (expo_deadzone(sticks.yaw, float(p["MPC_YAW_EXPO"]), float(p["MPC_HOLD_DZ"]))
                  * min(math.radians(float(p["MPC_MAN_Y_MAX"])), self.yawspeed_constraint))
        self._yawspeed = _lowpass(self._yawspeed, target, dt, float(p["MPC_MAN_Y_TAU"]))
        if abs(self._yawspeed) > EPS:
            self.yaw_sp = math.nan
        elif math.isnan(self.yaw_sp):
            self.yaw_sp = yaw

    def _limits(self) -> tuple[float, ...]:
        p = self.params
        if p.version != self._params_version:
            self._params_version = p.version
            self._z_limits = tuple(float(p[n]) for n in (
                "MPC_Z_MAN_EXPO", "MPC_HOLD_DZ", "MPC_Z_VEL_MAX_UP", "MPC_Z_VEL_MAX_DN",
                "MPC_LAND_ALT1", "MPC_LAND_ALT2", "MPC_LAND_SPEED", "MPC_TKO_SPEED",
                "MPC_JERK_MAX", "MPC_ACC_UP_MAX", "MPC_ACC_DOWN_MAX"))
        return self._z_limits

    def _vertical(self, dt: float, sticks: Sticks, pos: Vec3, vel_sp_feedback_z: float,
                  home_z: float) -> tuple[float, float]:
        """The smoothed vertical velocity and acceleration setpoints; ``z_sp`` the altitude
        lock (NaN while the stick or the trajectory moves)."""
        (z_expo_e, dz, up_max, dn_max, alt1, alt2, land_speed, tko_speed, jerk, acc_up,
         acc_dn) = self._limits()
        # FlightTaskManualAltitude::_scaleSticks: the throttle stick (down +, as PX4's
        # positions(2)) scaled by the speed of its direction, within the constraints
        stick_z = -sticks.throttle
        target = (min(dn_max, self.velocity_constraint_down) if stick_z > 0.0
                  else min(up_max, self.velocity_constraint_up)) * expo_deadzone(stick_z,
                                                                                 z_expo_e, dz)
        # _respectGroundSlowdown: the height above home (the local origin without one)
        dist = -(pos[2] - home_z) if math.isfinite(home_z) else -pos[2]
        down = gradual(dist, alt2, alt1, land_speed, dn_max)
        up = gradual(dist, alt2, alt1, tko_speed, up_max)
        target = _clamp(target, -up, down)
        # FlightTaskManualAltitudeSmoothVel::_updateSetpoints: the target through
        # ManualVelocitySmoothingZ; its lock replaces FlightTaskManualAltitude's (no distance
        # sensor here, so no terrain hold: MPC_HOLD_MAX_Z plays no part)
        s = self.smoothing
        s.set_limits(jerk, acc_up, acc_dn, up_max, dn_max)
        s.vel_sp_feedback = vel_sp_feedback_z
        s.position_estimate = pos[2]
        s.update(dt, target)
        self.z_sp = s.position_locked
        self._vz_sp = s.v
        return s.v, s.a

    def update(self, dt: float, sticks: Sticks, pos: Vec3, vel: Vec3, yaw: float,
               vel_sp_feedback: Vec3, home_z: float = math.nan) -> PositionSetpoint:
        """``vel_sp_feedback``: the velocity controller's last input; ``home_z``: the home's
        altitude (NED) when there is one."""
        p = self.params
        self._yaw(sticks, yaw, dt)
        vz, az = self._vertical(dt, sticks, pos, vel_sp_feedback[2], home_z)
        # StickTiltXY: the stick limited to unit length, then filtered (MC_MAN_TILT_TAU), then
        # turned into the heading frame.
        sx, sy = sticks.pitch, sticks.roll
        n = math.hypot(sx, sy)
        if n > 1.0:
            sx, sy = sx / n, sy / n
        tau = float(p["MC_MAN_TILT_TAU"])
        self._tilt = (_lowpass(self._tilt[0], sx, dt, tau), _lowpass(self._tilt[1], sy, dt, tau))
        # (Sticks::rotateIntoHeadingFrameXY: the heading setpoint, else the vehicle's heading)
        x, y = _rotate(self._tilt[0], self._tilt[1],
                       self.yaw_sp if not math.isnan(self.yaw_sp) else yaw)
        a = _max_tilt_acceleration(float(p["MPC_MAN_TILT_MAX"]))
        # Horizontal: tilt only. The velocity setpoint is the measured velocity, so the
        # velocity loop adds nothing (PX4 leaves it NaN and skips that loop).
        return PositionSetpoint((math.nan, math.nan, self.z_sp), (vel[0], vel[1], vz),
                                self.yaw_sp, (x * a, y * a, az))


class ManualPosition(ManualAltitude):
    """FlightTaskManualAcceleration: StickAccelerationXY horizontally, Altitude vertically."""

    def __init__(self, params) -> None:
        super().__init__(params)
        self._pos_xy = (math.nan, math.nan)
        self._vel_xy = (0.0, 0.0)
        self._acc_xy = (0.0, 0.0)  # the jerk limit's slew rates
        self._acc_prev = (0.0, 0.0)  # the last acceleration setpoint
        self._brake_boost = 1.0
        # StickAccelerationXY::setVelocityConstraint (Position Slow), below MPC_VEL_MANUAL
        self.velocity_constraint = math.inf

    def activate(self, pos: Vec3, vel: Vec3, yaw: float,
                 last: PositionSetpoint | None = None) -> None:
        super().activate(pos, vel, yaw, last)
        # a new StickAccelerationXY (at rest, no brake boost), then
        # FlightTaskManualAcceleration::activate: no position lock; the velocity from the last
        # setpoint's when both components are finite, else the vehicle's; the acceleration
        # (the jerk limit's slew rates) from the last setpoint's when finite
        self._brake_boost = 1.0
        self._acc_prev = (0.0, 0.0)
        self._pos_xy = (math.nan, math.nan)
        v = last.velocity_ned_mps if last is not None else (math.nan,) * 3
        if not (math.isfinite(v[0]) and math.isfinite(v[1])):
            v = vel
        self._vel_xy = (v[0], v[1]) if math.isfinite(v[0]) and math.isfinite(v[1]) else (0.0, 0.0)
        a = last.acceleration_ned_mps2 if last is not None else (math.nan,) * 3
        self._acc_xy = (a[0], a[1]) if math.isfinite(a[0]) and math.isfinite(a[1]) else (0.0, 0.0)

    def estimator_reset(self, pos: Vec3, vel: Vec3, r: EstimatorReset) -> None:
        """FlightTaskManualAcceleration's handlers, besides the vertical one: a position reset
        drops the position lock (StickAccelerationXY::resetPosition), a velocity reset takes
        the new velocity (resetVelocity, when finite)."""
        super().estimator_reset(pos, vel, r)
        if r.xy:
            self._pos_xy = (math.nan, math.nan)
        if r.vxy and math.isfinite(vel[0]) and math.isfinite(vel[1]):
            self._vel_xy = (vel[0], vel[1])

    def reactivate(self, pos: Vec3, vel: Vec3, yaw: float) -> None:
        """FlightTask::reActivate → FlightTaskManualAcceleration::activate on an empty setpoint:
        no position lock, the vehicle's velocity; the slew rates and the brake boost run on."""
        super().reactivate(pos, vel, yaw)
        self._pos_xy = (math.nan, math.nan)
        if math.isfinite(vel[0]) and math.isfinite(vel[1]):
            self._vel_xy = (vel[0], vel[1])

    def update(self, dt: float, sticks: Sticks, pos: Vec3, vel: Vec3, yaw: float,
               vel_sp_feedback: Vec3, home_z: float = math.nan) -> PositionSetpoint:
        p = self.params
        self._yaw(sticks, yaw, dt)
        vz, az = self._vertical(dt, sticks, pos, vel_sp_feedback[2], home_z)
        vel_manual = float(p["MPC_VEL_MANUAL"])
        sx, sy = stick_xy(p, sticks, self.yaw_sp if not math.isnan(self.yaw_sp) else yaw)
        # the speed (and with it the acceleration) within the constraint; drag halves the
        # average acceleration
        vel_scale = min(vel_manual, self.velocity_constraint)
        acc_scale = 2.0 * float(p["MPC_ACC_HOR"]) * (vel_scale / vel_manual)
        ax, ay = sx * acc_scale, sy * acc_scale
        # calculateDrag: caps the speed at that scale; with centred sticks the brake boost
        # (filtered, 0.8 s) raises it and blends in a square-root drag below 1 m/s, so that
        # small speeds end (brake_scale: 0 at boost 1, 1 at boost 2).
        centred = sx * sx + sy * sy < EPS
        boost_target = max(2.0, math.sqrt(vel_manual)) if centred else 1.0
        self._brake_boost = _lowpass(self._brake_boost, boost_target, dt, BRAKE_BOOST_TAU_S)
        coeff = acc_scale / vel_scale * self._brake_boost
        vx, vy = self._vel_xy
        vn = math.hypot(vx, vy)
        brake_scale = gradual(self._brake_boost, 1.0, 2.0, 0.0, 1.0)
        k = coeff * ((brake_scale * _sqrt_linear(vn) / vn if vn > UNIT_EPS else 0.0)
                     + (1.0 - brake_scale))
        drag_x, drag_y = k * vx, k * vy
        # no drag that would turn the velocity round (oscillation about 0): without an
        # acceleration, or with one that changed sign, a velocity the drag would overshoot
        # stops
        qx, qy = self._acc_prev
        if (ax * ax + ay * ay < EPS or _sign(qx) != _sign(ax) or _sign(qy) != _sign(ay)) \
                and vn * vn < (drag_x ** 2 + drag_y ** 2) * dt * dt:
            drag_x = drag_y = 0.0
            vx = vy = 0.0
        ax, ay = ax - drag_x, ay - drag_y
        # applyJerkLimit: one slew rate per axis (its value the last jerk-limited acceleration),
        # each limited to MPC_JERK_MAX times its share of the change from the last output, so
        # that both axes arrive together
        dx, dy = ax - qx, ay - qy
        dn = math.hypot(dx, dy)
        jerk = float(p["MPC_JERK_MAX"])
        jx, jy = ((abs(dx) / dn * jerk * dt, abs(dy) / dn * jerk * dt) if dn > UNIT_EPS
                  else (0.0, 0.0))
        sx_, sy_ = self._acc_xy
        ax = sx_ + _clamp(ax - sx_, -jx, jx)
        ay = sy_ + _clamp(ay - sy_, -jy, jy)
        self._acc_xy = (ax, ay)
        # applyTiltLimit: takeoff_status.tilt_limit
        limit = self.tilt_limit_rad
        tilt = math.tan(limit if math.isfinite(limit) else math.radians(float(p["MPC_TILTMAX_AIR"]))
                        ) * GRAVITY_MPS2
        an = math.hypot(ax, ay)
        if an > tilt:
            ax, ay = ax * tilt / an, ay * tilt / an
        self._acc_prev = (ax, ay)
        vx, vy = vx + ax * dt, vy + ay * dt
        # Lock the position once stopped; release it (from the controller's own velocity
        # setpoint, so nothing jumps) when the sticks move again.
        moving = vx * vx + vy * vy > EPS
        locked = not math.isnan(self._pos_xy[0])
        if not moving and not locked:
            self._pos_xy = (pos[0], pos[1])
        elif moving and locked:
            self._pos_xy = (math.nan, math.nan)
            if math.isfinite(vel_sp_feedback[0]) and math.isfinite(vel_sp_feedback[1]):
                vx, vy = vel_sp_feedback[0], vel_sp_feedback[1]
        self._vel_xy = (vx, vy)
        return PositionSetpoint((self._pos_xy[0], self._pos_xy[1], self.z_sp), (vx, vy, vz),
                                self.yaw_sp, (ax, ay, az))
