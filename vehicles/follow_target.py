"""Follow Me: follow a moving target (FOLLOW_TARGET from MAVSDK's follow_me or QGC's Follow Me,
the GCS's own position), after PX4 v1.15 ``flight_mode_manager/tasks/AutoFollowTarget``:
FlightTaskAutoFollowTarget and its TargetEstimator.

Rules:
- ``TargetEstimator``: an alpha-beta-gamma filter of the FOLLOW_TARGET reports (gains from
  FLW_TGT_RS), predicted every tick; a position is fused at most every 0.5 s (and only when it
  moved, or after 1 s), a velocity every 0.1 s, each only when finite; a report whose time is
  not newer than the last one is not fused. Without a report for 3 s the estimate stops moving
  (velocity and acceleration zero) but stays valid: the vehicle follows where the target was
  last seen. Non-finite states reset it (invalid until the next report). It starts with the
  task, from the last report the vehicle had (a uORB subscription sees the last message).
- ``FollowTarget`` (the task): the estimate through a second-order reference model (1 rad/s,
  damping 0.7071, bilinear); the target's course from its velocity once both the filtered and
  the estimated speeds are at least 1 m/s; the orbit angle (where the vehicle sits around the
  target, starting north of it) follows course + FLW_TGT_FA through a jerk-limited trajectory
  (4 m/s³, 2 m/s² and FLW_TGT_MAX_VEL along the circle of FLW_TGT_DST). The setpoint is that
  point at FLW_TGT_HT above home (FLW_TGT_ALT_M 0, and 1 on this flat ground) or above the
  target (2), with the orbit's tangential velocity plus the target's and the orbit's
  acceleration, straight to position control; more than 3 m from that altitude only the
  altitude is flown. The nose points at the target once it is more than 1 m away.
- Sticks, when there are, trim the follow height (throttle, 1.5 m/s), distance (pitch, 2 m/s)
  and angle (roll, 1.5 rad/s at most), each only while the vehicle keeps up with it.
- Below 1 m above home the vehicle climbs at 0.5 m/s (emergency ascent); with no valid estimate
  it stops (velocity zero) where it is.
- Pure: time and dt are arguments.
"""

from __future__ import annotations

import math

from vehicles.control.position_control import PositionSetpoint
from vehicles.control.position_smoothing import max_speed_from_distance
from vehicles.control.velocity_smoothing import VelocitySmoothing
from vehicles.manual_control import Sticks, expo_deadzone
from vehicles.types import Vec3

_NAN3: Vec3 = (math.nan, math.nan, math.nan)
_EPS = 1.1920929e-07  # FLT_EPSILON

# TargetEstimator.hpp
GPS_MESSAGE_STALE_TIMEOUT_S = 3.0
MINIMUM_TIME_BETWEEN_POS_FUSIONS_S = 0.5
MINIMUM_TIME_BETWEEN_VEL_FUSIONS_S = 0.1
ACCELERATION_SATURATION = 20.0
# FlightTaskAutoFollowTarget.hpp
MINIMUM_SAFETY_ALTITUDE = 1.0
EMERGENCY_ASCENT_SPEED = 0.5
ALT_ACCEPTANCE_THRESHOLD = 3.0
MINIMUM_DISTANCE_TO_TARGET_FOR_YAW_CONTROL = 1.0
FILTER_NATURAL_FREQUENCY = 1.0
FILTER_DAMPING_RATIO = 0.7071
TARGET_SPEED_DEADZONE_FOR_ORIENTATION_TRACKING = 1.0
ORBIT_TRAJECTORY_MAX_JERK = 4.0
ORBIT_TRAJECTORY_MAX_ACCELERATION = 2.0
FOLLOW_DISTANCE_USER_ADJUST_SPEED = 2.0
FOLLOW_DISTANCE_MAX = 100.0
FOLLOW_HEIGHT_USER_ADJUST_SPEED = 1.5
FOLLOW_HEIGHT_MAX = 100.0
FOLLOW_ANGLE_USER_ADJUST_SPEED = 1.5
USER_ADJUSTMENT_ERROR_TIME_WINDOW = 0.5
# the errors within which the sticks trim (adjust speed x time window)
_HEIGHT_WINDOW = FOLLOW_HEIGHT_USER_ADJUST_SPEED * USER_ADJUSTMENT_ERROR_TIME_WINDOW
_DISTANCE_WINDOW = FOLLOW_DISTANCE_USER_ADJUST_SPEED * USER_ADJUSTMENT_ERROR_TIME_WINDOW
_ANGLE_WINDOW = FOLLOW_ANGLE_USER_ADJUST_SPEED * USER_ADJUSTMENT_ERROR_TIME_WINDOW
ALT_MODE_TRACK_TARGET = 2


def _finite(v: Vec3) -> bool:
    return math.isfinite(v[0]) and math.isfinite(v[1]) and math.isfinite(v[2])


def _wrap_pi(x: float) -> float:
    """matrix::wrap_pi: into [-pi, pi)."""
    if -math.pi <= x < math.pi or not math.isfinite(x):
        return x
    return x - math.tau * math.floor((x + math.pi) / math.tau)


def _clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v


def _plus(a: Vec3, k: float, b: Vec3) -> Vec3:
    """``a + k * b``, by component."""
    return (a[0] + k * b[0], a[1] + k * b[1], a[2] + k * b[2])


def _minus(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


class TargetEstimator:
    """follow_target_estimator (TargetEstimator.cpp): alpha-beta-gamma on the reports."""

    def __init__(self, params) -> None:
        self.params = params
        self._responsiveness = math.nan
        self._gains = (0.0, 0.0, 0.0, 0.0, 0.0)  # G_p, H_p, K_p, G_v, H_v
        self._last_s = math.nan  # the last prediction
        self.reset()

    def reset(self) -> None:
        self.pos, self.vel, self.acc = _NAN3, _NAN3, _NAN3
        self._last_report_s = 0.0  # _last_follow_target_timestamp (0: none)
        self._last_pos_fusion_s = self._last_vel_fusion_s = 0.0
        self._pos_old, self._vel_old = _NAN3, _NAN3

    @property
    def valid(self) -> bool:
        return _finite(self.pos) and _finite(self.vel) and _finite(self.acc)

    @property
    def has_report(self) -> bool:
        """A report was fused since the last reset (follow_target_estimator's timestamp > 0)."""
        return self._last_report_s != 0.0

    def _update_gains(self) -> None:
        r = _clamp(float(self.params["FLW_TGT_RS"]), 0.1, 1.0)
        if abs(self._responsiveness - r) < _EPS:
            return
        self._responsiveness = r
        beta_p = r ** (1.0 / 3.0)
        beta_v = 0.9 * beta_p
        self._gains = (1.0 - beta_p ** 3, 1.5 * (1.0 - beta_p) ** 2 * (1.0 + beta_p),
                       0.5 * (1.0 - beta_p) ** 3, 1.0 - beta_v ** 2, (1.0 - beta_v) ** 2)

    def update(self, now_s: float, report: tuple[float, Vec3, Vec3] | None) -> bool:
        """One run at ``now_s``: the prediction, then the fusion of ``report`` (time, local
        position, velocity; None: no new one) unless it repeats the last one's time or is older
        than the last fused position. False: the first run, which only stamps the time and
        leaves the report unread."""
        if math.isnan(self._last_s):
            self._last_s = now_s
            return False
        dt = _clamp(now_s - self._last_s, 1e-3, 2.0)
        self._last_s = now_s
        self._update_gains()
        # prediction_update
        (px, py, pz), (vx, vy, vz), (ax, ay, az) = self.pos, self.vel, self.acc
        if _finite(self.vel):
            self.pos = (px + dt * vx + 0.5 * ax * dt * dt, py + dt * vy + 0.5 * ay * dt * dt,
                        pz + dt * vz + 0.5 * az * dt * dt)
        if _finite(self.acc):
            self.vel = (vx + dt * ax, vy + dt * ay, vz + dt * az)
        if report is not None and report[0] != self._last_report_s \
                and self._last_pos_fusion_s < report[0]:
            self._fuse(now_s, *report)
        if now_s - self._last_report_s >= GPS_MESSAGE_STALE_TIMEOUT_S:
            self.vel = self.acc = (0.0, 0.0, 0.0)
        if not self.valid:
            self.reset()
        return True

    def _can_fuse(self, now_s: float, value: Vec3, old: Vec3, last_s: float,
                  min_dt_s: float) -> bool:
        changed = not _finite(old) or math.hypot(*_minus(value, old)) > 2.0 * _EPS
        return (_finite(value) and now_s - last_s > min_dt_s
                and (changed or now_s - last_s > 2.0 * min_dt_s))

    def _fuse(self, now_s: float, t_s: float, pos: Vec3, vel: Vec3) -> None:
        """measurement_update."""
        if self._last_report_s == 0.0:
            self.pos = pos
            self.vel = vel if _finite(vel) else (0.0, 0.0, 0.0)
            self._pos_old, self._vel_old = pos, vel
            self.acc = (0.0, 0.0, 0.0)
        self._last_report_s = t_s
        g_p, h_p, k_p, g_v, h_v = self._gains
        if self._can_fuse(now_s, pos, self._pos_old, self._last_pos_fusion_s,
                          MINIMUM_TIME_BETWEEN_POS_FUSIONS_S):
            dt = _clamp(t_s - self._last_pos_fusion_s, 1e-3, 20.0)
            self._last_pos_fusion_s = t_s
            inn = _minus(pos, self.pos)
            self.pos = _plus(self.pos, g_p, inn)
            self.vel = _plus(self.vel, h_p / dt, inn)
            self.acc = _plus(self.acc, 2.0 * k_p / (dt * dt), inn)
            self._pos_old = pos
        if self._can_fuse(now_s, vel, self._vel_old, self._last_vel_fusion_s,
                          MINIMUM_TIME_BETWEEN_VEL_FUSIONS_S):
            dt = _clamp(t_s - self._last_vel_fusion_s, 1e-3, 20.0)
            self._last_vel_fusion_s = t_s
            inn = _minus(vel, self.vel)
            self.vel = _plus(self.vel, g_v, inn)
            self.acc = _plus(self.acc, h_v / dt, inn)
            self._vel_old = vel
        sat = ACCELERATION_SATURATION
        ax, ay, az = self.acc
        self.acc = (_clamp(ax, -sat, sat), _clamp(ay, -sat, sat), _clamp(az, -sat, sat))


class ReferenceModel:
    """SecondOrderReferenceModel<Vector3f> (bilinear): the state follows the samples it was
    given at the previous step (sample and hold)."""

    def __init__(self, natural_freq: float, damping_ratio: float) -> None:
        self.k_x = natural_freq * natural_freq
        self.k_v = 2.0 * damping_ratio * natural_freq
        z2 = damping_ratio * damping_ratio
        cutoff = natural_freq * math.sqrt(1.0 - 2.0 * z2 + math.sqrt(4.0 * z2 * z2 - 4.0 * z2 + 2.0))
        self.max_time_step = math.tau / (cutoff * 4.0)
        self.reset(_NAN3, (0.0, 0.0, 0.0))

    def reset(self, state: Vec3, rate: Vec3) -> None:
        self.state, self.rate = state, rate
        self._last = (state, rate)

    def update(self, dt: float, state: Vec3, rate: Vec3) -> None:
        if dt > self.max_time_step or dt < 0.0:
            self.reset(state, rate)
            return
        kx, kv = self.k_x, self.k_v
        t2 = dt * dt
        inv = 1.0 / (0.25 * kx * t2 + 0.5 * kv * dt + 1.0)
        a00, a01 = (-0.25 * kx * t2 + 0.5 * kv * dt + 1.0) * inv, dt * inv
        a10, a11 = -kx * dt * inv, (-0.25 * kx * t2 - 0.5 * kv * dt + 1.0) * inv
        b00, b01 = 0.5 * kx * t2 * inv, 0.5 * kv * t2 * inv
        b10, b11 = kx * dt * inv, kv * dt * inv
        (xs, vs), x, v = self._last, self.state, self.rate
        x0, x1, x2 = (a00 * x[i] + a01 * v[i] + b00 * xs[i] + b01 * vs[i] for i in range(3))
        v0, v1, v2 = (a10 * x[i] + a11 * v[i] + b10 * xs[i] + b11 * vs[i] for i in range(3))
        self.state, self.rate = (x0, x1, x2), (v0, v1, v2)
        self._last = (state, rate)


class FollowTarget:
    def __init__(self, params) -> None:
        self.params = params
        self._report: tuple[float, Vec3, Vec3] | None = None  # (time, position, velocity)
        self.estimator = TargetEstimator(params)
        self.filter = ReferenceModel(FILTER_NATURAL_FREQUENCY, FILTER_DAMPING_RATIO)
        self.orbit = VelocitySmoothing()
        self.yaw_sp = math.nan
        self.sp = PositionSetpoint()
        self.distance = self.height = self.angle = 0.0
        self.course = self.orbit_angle = 0.0
        self.home_z = 0.0
        self._seen: tuple[float, Vec3, Vec3] | None = None
        self._param_values: tuple[float, float, float] = (math.nan,) * 3

    def set_target(self, now_s: float, position_ned_m: Vec3, velocity_ned_mps: Vec3) -> None:
        """FOLLOW_TARGET (mavlink_receiver: stamped with its arrival)."""
        self._report = (now_s, position_ned_m, velocity_ned_mps)

    def activate(self, pos: Vec3, yaw: float, last: PositionSetpoint | None,
                 home_z: float) -> None:
        """A new task: its estimator starts, the filter and the orbit angle (north) reset."""
        self.estimator = TargetEstimator(self.params)
        self._seen = None  # a new subscription sees the last report
        self.filter.reset(_NAN3, (0.0, 0.0, 0.0))
        self.sp = PositionSetpoint(pos, _NAN3, math.nan, _NAN3)
        self.yaw_sp = last.yaw_rad if last is not None and math.isfinite(last.yaw_rad) else yaw
        self._param_values = (math.nan,) * 3
        self._update_params()
        self.orbit.reset(0.0, 0.0, 0.0)
        self.course = self.orbit_angle = 0.0
        self.home_z = home_z

    def _update_params(self) -> None:
        """updateParams: a parameter that changed replaces the trimmed value."""
        p = self.params
        values = (float(p["FLW_TGT_DST"]), float(p["FLW_TGT_HT"]), float(p["FLW_TGT_FA"]))
        old = self._param_values
        if values[0] != old[0]:
            self.distance = values[0]
        if values[1] != old[1]:
            self.height = values[1]
        if values[2] != old[2]:
            self.angle = _wrap_pi(math.radians(values[2]))
        self._param_values = values

    def update(self, now_s: float, dt: float, pos: Vec3, sticks: Sticks | None) -> PositionSetpoint:
        """The tick's setpoint (position, velocity, acceleration, heading); ``sticks``: None when
        there is no stick input."""
        self._update_params()
        report = self._report if self._report is not self._seen else None
        if self.estimator.update(now_s, report):
            self._seen = self._report
        est = self.estimator
        sp = self.sp
        p_sp, v_sp, a_sp = sp.position_ned_m, sp.velocity_ned_mps, sp.acceleration_ned_mps2
        if not est.valid or not est.has_report:
            self.sp = PositionSetpoint(_NAN3, (0.0, 0.0, 0.0), self.yaw_sp, a_sp)
            return self.sp
        f = self.filter
        if not (_finite(f.state) and _finite(f.rate)):
            f.reset(est.pos, est.vel)
        else:
            f.update(dt, est.pos, est.vel)
        tp, tv = f.state, f.rate
        to_n, to_e = tp[0] - pos[0], tp[1] - pos[1]
        heading = math.atan2(to_e, to_n)
        measured_angle = _wrap_pi(heading + math.pi)
        if sticks is not None:
            self._trim(dt, sticks, pos, p_sp, math.hypot(to_n, to_e), measured_angle)
        if math.hypot(tv[0], tv[1]) >= TARGET_SPEED_DEADZONE_FOR_ORIENTATION_TRACKING \
                and math.hypot(est.vel[0], est.vel[1]) >= TARGET_SPEED_DEADZONE_FOR_ORIENTATION_TRACKING:
            self.course = math.atan2(tv[1], tv[0])
        angle = self.orbit_angle = self._orbit_step(dt)
        rate = self.orbit.state.v
        d = self.distance
        s, c = math.sin(angle), math.cos(angle)
        tan_v = (-s * rate * d, c * rate * d)
        desired = (tp[0] + c * d, tp[1] + s * d, self._desired_z(tp, pos))
        radial = (tan_v[0] ** 2 + tan_v[1] ** 2) / d
        tang = self.orbit.state.a * d
        acc_xy = (-c * radial - s * tang, -s * radial + c * tang)
        if _finite(desired):
            if abs(desired[2] - pos[2]) < ALT_ACCEPTANCE_THRESHOLD:
                p_sp = desired
                v_sp = (tan_v[0] + tv[0], tan_v[1] + tv[1], v_sp[2])
                a_sp = (acc_xy[0], acc_xy[1], a_sp[2])
            else:  # the altitude first; the rest of the last setpoint stays
                p_sp = (pos[0], pos[1], desired[2])
        else:
            p_sp, v_sp, a_sp = pos, (0.0, 0.0, 0.0), _NAN3
        if math.hypot(to_n, to_e) > MINIMUM_DISTANCE_TO_TARGET_FOR_YAW_CONTROL:
            self.yaw_sp = heading
        # _evaluateDistanceToGround: above home (no distance sensor)
        ground = -(pos[2] - self.home_z) if math.isfinite(self.home_z) else -pos[2]
        if ground < MINIMUM_SAFETY_ALTITUDE:
            p_sp = (math.nan, math.nan, pos[2])
            v_sp = (0.0, 0.0, -EMERGENCY_ASCENT_SPEED)
        self.sp = PositionSetpoint(p_sp, v_sp, self.yaw_sp, a_sp)
        return self.sp

    def _desired_z(self, tp: Vec3, pos: Vec3) -> float:
        """calculateDesiredDronePosition's altitude (terrain: the ground is home's altitude)."""
        if int(self.params["FLW_TGT_ALT_M"]) == ALT_MODE_TRACK_TARGET:
            return tp[2] - self.height
        return self.home_z - self.height

    def _orbit_step(self, dt: float) -> float:
        """updateOrbitAngleTrajectory: towards course + follow angle, unwrapped around the last
        setpoint, at the rate that still stops there."""
        prev = self.orbit_angle
        raw = prev + _wrap_pi(self.course + self.angle - prev)
        d = self.distance
        o = self.orbit
        o.max_jerk = ORBIT_TRAJECTORY_MAX_JERK / d
        o.max_accel = ORBIT_TRAJECTORY_MAX_ACCELERATION / d
        o.max_vel = float(self.params["FLW_TGT_MAX_VEL"]) / d
        remaining = raw - prev
        sign = (remaining > 0.0) - (remaining < 0.0)
        o.update_durations(max_speed_from_distance(o.max_jerk, o.max_accel, abs(remaining), 0.0)
                           * sign)
        o.update_traj(dt)
        return o.state.x

    def _trim(self, dt: float, sticks: Sticks, pos: Vec3, last_p_sp: Vec3, distance: float,
              measured_angle: float) -> None:
        """updateRcAdjustedFollowHeight / Distance / Angle."""
        p = self.params
        dz = float(p["MPC_HOLD_DZ"])
        xy_e = float(p["MPC_XY_MAN_EXPO"])
        if abs(last_p_sp[2] - pos[2]) < _HEIGHT_WINDOW:
            throttle = expo_deadzone(sticks.throttle, float(p["MPC_Z_MAN_EXPO"]), dz)
            self.height = _clamp(self.height + FOLLOW_HEIGHT_USER_ADJUST_SPEED * throttle * dt,
                                 MINIMUM_SAFETY_ALTITUDE, FOLLOW_HEIGHT_MAX)
        if abs(distance - self.distance) < _DISTANCE_WINDOW:
            pitch = expo_deadzone(sticks.pitch, xy_e, dz)
            self.distance = _clamp(self.distance + FOLLOW_DISTANCE_USER_ADJUST_SPEED * pitch * dt,
                                   MINIMUM_DISTANCE_TO_TARGET_FOR_YAW_CONTROL, FOLLOW_DISTANCE_MAX)
        if abs(_wrap_pi(measured_angle - self.orbit_angle)) < _ANGLE_WINDOW:
            speed = min(FOLLOW_ANGLE_USER_ADJUST_SPEED, float(p["FLW_TGT_MAX_VEL"]) / self.distance)
            roll = expo_deadzone(sticks.roll, xy_e, dz)
            self.angle = _wrap_pi(self.angle + speed * roll * dt)
