"""Pure library: position P + velocity PID -> normalized thrust vector (PX4 PositionControl).

Follows PX4 ``src/modules/mc_pos_control/PositionControl/PositionControl.cpp`` (v1.14+):
``_positionControl`` (P on position, velocity limits, ``ControlMath::constrainXY``),
``_velocityControl`` (PID on velocity with vertical-priority thrust saturation and tracking
anti-windup after Rundqwist 1990), ``_accelerationControl`` (acceleration -> body z with tilt
limit, collective thrust via the hover thrust), and ``ControlMath::limitTilt``.

Rules:
- Frames: NED; thrust is normalized (1.0 = all rotors at full thrust), pointing where the body's
  -z axis must point, so hovering level gives (0, 0, -hover_thrust).
- NaN in a setpoint component means "not commanded" (PX4 convention, ControlMath::addIfNotNan):
  a position's P term is added to the velocity feed-forward; an axis with neither is not
  velocity-controlled (its acceleration feed-forward alone: no velocity damping, no integral).
  Every axis needs a position, velocity or acceleration and x, y come in pairs (``input_valid``,
  PositionControl::_inputValid); otherwise ``update`` fails (``valid`` False) without touching
  the integrator, and the flight path flies PX4's failsafe setpoint instead
  (``_control_or_failsafe``, MulticopterPositionControl's).
- The gains are PX4's physical gains (m/s per m, m/s² per m/s): the plant is physical, so no
  scaling is needed here. The hover thrust is MPC_THR_HOVER until PX4's hover thrust estimator
  gives one (vehicles/control/hover_thrust.py; ``update_hover_thrust``, as
  PositionControl::updateHoverThrust).
- Pure: no physics engine, no clock; ``update`` takes ``dt_s``.
- The arithmetic is ``position_control_step``, compiled with numba (cached next to this file):
  it runs at 50 Hz for every vehicle and was a large part of the 50 Hz loop in CPython.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba.extending import register_jitable

from vehicles.control.attitude_control import thrust_to_attitude_q
from vehicles.control.compiled import njit_cached
from vehicles.control.position_smoothing import PositionSmoothing, generate_auto_step
from vehicles.control.velocity_smoothing import IA, IJ, IV, IX, A, J, V, X
from vehicles.types import GRAVITY_MPS2, Quat, Vec3

NAN3: Vec3 = (math.nan, math.nan, math.nan)
# No setpoint: a strong downward acceleration, so no thrust (mc_pos_control, not taken off).
NO_THRUST_ACC: Vec3 = (0.0, 0.0, 100.0)
# Where the smoothing restarts while the takeoff has not ramped (FlightTaskAuto::reActivate).
REACTIVATE_VEL: Vec3 = (0.0, 0.0, 0.7)

# PositionControl::setThrustLimits keeps the minimum thrust at least this, so that there is
# always a thrust vector to take the attitude from (before takeoff mc_pos_control asks for 0).
THRUST_MIN_FLOOR = 10e-4

# PX4 MPC_THR_XY_MARG (v1.13+) is not in our parameter table: its default value.
THRUST_XY_MARGIN = 0.3


@dataclass(frozen=True)
class PositionControlGains:
    pos_p_xy: float
    pos_p_z: float
    vel_p_xy: float
    vel_i_xy: float
    vel_d_xy: float
    vel_p_z: float
    vel_i_z: float
    vel_d_z: float
    vel_max_xy_mps: float
    vel_max_up_mps: float
    vel_max_down_mps: float
    tilt_max_rad: float
    thrust_min: float
    thrust_max: float
    hover_thrust: float  # the controller's first; PositionControl.hover_thrust is the present one

    @staticmethod
    def from_params(params, hover_thrust: float | None = None) -> PositionControlGains:
        p = params
        return PositionControlGains(
            pos_p_xy=float(p["MPC_XY_P"]),
            pos_p_z=float(p["MPC_Z_P"]),
            vel_p_xy=float(p["MPC_XY_VEL_P_ACC"]),
            vel_i_xy=float(p["MPC_XY_VEL_I_ACC"]),
            vel_d_xy=float(p["MPC_XY_VEL_D_ACC"]),
            vel_p_z=float(p["MPC_Z_VEL_P_ACC"]),
            vel_i_z=float(p["MPC_Z_VEL_I_ACC"]),
            vel_d_z=float(p["MPC_Z_VEL_D_ACC"]),
            vel_max_xy_mps=float(p["MPC_XY_VEL_MAX"]),
            vel_max_up_mps=float(p["MPC_Z_VEL_MAX_UP"]),
            vel_max_down_mps=float(p["MPC_Z_VEL_MAX_DN"]),
            tilt_max_rad=math.radians(float(p["MPC_TILTMAX_AIR"])),
            thrust_min=float(p["MPC_THR_MIN"]),
            thrust_max=float(p["MPC_THR_MAX"]),
            hover_thrust=float(p["MPC_THR_HOVER"]) if hover_thrust is None else hover_thrust,
        )

    def vector(self) -> tuple[float, ...]:
        """The gains in field order, as ``position_control_step`` takes them."""
        return (self.pos_p_xy, self.pos_p_z, self.vel_p_xy, self.vel_i_xy, self.vel_d_xy,
                self.vel_p_z, self.vel_i_z, self.vel_d_z, self.vel_max_xy_mps, self.vel_max_up_mps,
                self.vel_max_down_mps, self.tilt_max_rad, self.thrust_min, self.thrust_max,
                self.hover_thrust)


class PositionSetpoint(NamedTuple):
    """What the navigator/trajectory asks of the position controller (NaN = not commanded). A
    NamedTuple: the flight tasks build one every 50 Hz tick, several times as fast as a frozen
    dataclass."""

    position_ned_m: Vec3 = NAN3
    velocity_ned_mps: Vec3 = NAN3
    yaw_rad: float = math.nan
    acceleration_ned_mps2: Vec3 = NAN3  # feed-forward


@dataclass(frozen=True)
class PositionControlOutput:
    thrust_ned: Vec3  # normalized thrust vector
    velocity_sp_ned_mps: Vec3  # the velocity setpoint the P loop produced
    yaw_rad: float
    acceleration_sp_ned_mps2: Vec3 = NAN3  # the velocity PID's (PX4's _acc_sp)
    valid: bool = True  # PositionControl::update's answer: the thrust can be flown


@register_jitable
def limit_tilt(body_z: Vec3, tilt_max_rad: float) -> Vec3:
    """ControlMath::limitTilt with world_unit = (0, 0, 1)."""
    d = max(-1.0, min(1.0, body_z[2]))
    angle = min(math.acos(d), tilt_max_rad)
    rx, ry = body_z[0], body_z[1]
    rn = math.hypot(rx, ry)
    if rn * rn < 1.2e-7:
        rx, ry, rn = 1.0, 0.0, 1.0
    s = math.sin(angle) / rn
    return (s * rx, s * ry, math.cos(angle))


@register_jitable
def add_if_not_nan(setpoint: float, addition: float) -> float:
    """ControlMath::addIfNotNan: the sum; a setpoint that is not finite takes the addition, an
    addition that is not finite leaves the setpoint."""
    if math.isfinite(setpoint) and math.isfinite(addition):
        return setpoint + addition
    return addition if not math.isfinite(setpoint) else setpoint


@register_jitable
def constrain_xy(v0: tuple[float, float], v1: tuple[float, float],
                 limit: float) -> tuple[float, float]:
    """ControlMath::constrainXY: ``v0 + v1`` no longer than ``limit``, ``v0`` first: if ``v0``
    alone reaches the limit it is shortened; else as much of ``v1``'s direction is added as
    fits (the positive root of |v0 + s·u1| = limit)."""
    sx, sy = v0[0] + v1[0], v0[1] + v1[1]
    if math.hypot(sx, sy) <= limit:
        return sx, sy
    n0 = math.hypot(v0[0], v0[1])
    if n0 >= limit or math.hypot(v1[0] - v0[0], v1[1] - v0[1]) < 0.001:
        if n0 == 0.0:  # PX4 normalizes the zero vector to NaN
            return math.nan, math.nan
        return v0[0] / n0 * limit, v0[1] / n0 * limit
    n1 = math.hypot(v1[0], v1[1])
    if n0 < 0.001:
        return v1[0] / n1 * limit, v1[1] / n1 * limit
    u0, u1 = v1[0] / n1, v1[1] / n1
    m = u0 * v0[0] + u1 * v0[1]
    c = v0[0] * v0[0] + v0[1] * v0[1] - limit * limit
    scale = -m + math.sqrt(m * m - c)
    return v0[0] + u0 * scale, v0[1] + u1 * scale


@register_jitable
def input_valid(pos: Vec3, vel: Vec3, acc_meas: Vec3, sp_pos: Vec3, sp_vel: Vec3,
                sp_acc: Vec3) -> bool:
    """PositionControl::_inputValid: every axis has a position, velocity or acceleration
    setpoint, x and y come in pairs, and every state a setpoint controls is finite (a velocity
    setpoint needs the velocity and the acceleration, its D term)."""
    fp0, fp1, fp2 = math.isfinite(sp_pos[0]), math.isfinite(sp_pos[1]), math.isfinite(sp_pos[2])
    fv0, fv1, fv2 = math.isfinite(sp_vel[0]), math.isfinite(sp_vel[1]), math.isfinite(sp_vel[2])
    fa0, fa1, fa2 = math.isfinite(sp_acc[0]), math.isfinite(sp_acc[1]), math.isfinite(sp_acc[2])
    if not ((fp0 or fv0 or fa0) and (fp1 or fv1 or fa1) and (fp2 or fv2 or fa2)):
        return False
    if fp0 != fp1 or fv0 != fv1 or fa0 != fa1:
        return False
    for i, fp, fv in ((0, fp0, fv0), (1, fp1, fv1), (2, fp2, fv2)):
        if fp and not math.isfinite(pos[i]):
            return False
        if fv and not (math.isfinite(vel[i]) and math.isfinite(acc_meas[i])):
            return False
    return True


@njit_cached
def position_control_step(dt_s, pos, vel, acc_meas, sp_pos, sp_vel, sp_acc, gains, integ
                          ):  # pragma: no cover - compiled
    """One PositionControl update (module docstring), compiled. ``gains``: the 15 numbers of
    ``PositionControlGains.vector()``; ``integ``: the velocity integrator, updated in place.
    Returns (normalized thrust NED, velocity setpoint NED, acceleration setpoint NED)."""
    return _position_control(dt_s, pos, vel, acc_meas, sp_pos, sp_vel, sp_acc, gains, integ)


@njit_cached
def position_attitude_step(dt_s, pos, vel, acc_meas, sp_pos, sp_vel, sp_acc, gains, integ,
                           yaw_rad):  # pragma: no cover - compiled
    """``position_control_step`` and then its thrust at heading ``yaw_rad`` as an attitude
    (PX4 PositionControl::getAttitudeSetpoint: ControlMath::thrustToAttitude). Returns
    (attitude setpoint, collective thrust, velocity setpoint NED, acceleration setpoint NED)."""
    thrust, vel_sp, acc_sp = _control_or_failsafe(dt_s, pos, vel, acc_meas, sp_pos, sp_vel,
                                                  sp_acc, gains, integ)
    q, thrust_norm = thrust_to_attitude_q(thrust, yaw_rad)
    return q, thrust_norm, vel_sp, acc_sp


@njit_cached
def auto_position_attitude_step(traj, cfg, traj_inp, traj_out, dt_s, has_previous, has_next,
                                acceptance_radius, vz_cmd, vel, acc_meas, gains, integ, yaw_rad,
                                no_setpoint, reactivate, force_zero
                                ):  # pragma: no cover - compiled
    """An auto mode's tick in one call: the smoothed trajectory (position_smoothing
    ``generate_auto_step`` on ``traj``; the vehicle's position is ``traj_inp``'s first row and
    the vertical-speed altitude follows it), then ``position_attitude_step`` on its setpoint.
    ``no_setpoint`` (the takeoff has not ramped, or ground contact): position control gets no
    setpoint and its integrator is held at zero; ``reactivate`` (the takeoff had not ramped): the
    trajectory then restarts at the vehicle at rest but for a 0.7 m/s descent
    (position_stage.py); ``force_zero``: the trajectory's velocity setpoint is zero
    (FlightTaskAuto's force_zero_velocity_setpoint: emergency braking). Returns (trajectory
    position, velocity, acceleration, attitude, collective thrust, velocity setpoint,
    acceleration setpoint)."""
    pos = (traj_inp[0], traj_inp[1], traj_inp[2])
    p_sp, v_sp, a_sp = generate_auto_step(traj, cfg, traj_inp, dt_s, True, has_previous,
                                          has_next, acceptance_radius, vz_cmd, pos[2], traj_out,
                                          force_zero)
    q, thrust_norm, vel_sp, acc_sp = _auto_attitude(traj, dt_s, pos, p_sp, v_sp, a_sp, vel,
                                                    acc_meas, gains, integ, yaw_rad, no_setpoint,
                                                    reactivate)
    return p_sp, v_sp, a_sp, q, thrust_norm, vel_sp, acc_sp


@njit_cached
def auto_attitude_step(traj, dt_s, pos, p_sp, v_sp, a_sp, vel, acc_meas, gains, integ, yaw_rad,
                       no_setpoint, reactivate):  # pragma: no cover - compiled
    """``auto_position_attitude_step``'s part after the trajectory, on the trajectory's
    setpoint (``p_sp``, ``v_sp``, ``a_sp``) the vehicle at ``pos``: (attitude, collective
    thrust, velocity setpoint, acceleration setpoint)."""
    return _auto_attitude(traj, dt_s, pos, p_sp, v_sp, a_sp, vel, acc_meas, gains, integ,
                          yaw_rad, no_setpoint, reactivate)


@register_jitable
def _auto_attitude(traj, dt_s, pos, p_sp, v_sp, a_sp, vel, acc_meas, gains, integ, yaw_rad,
                   no_setpoint, reactivate):
    sp_pos, sp_vel, sp_acc = p_sp, v_sp, a_sp
    if reactivate:  # PositionSmoothing.reset((0, 0, 0), REACTIVATE_VEL, pos)
        for i, x, v in ((0, pos[0], REACTIVATE_VEL[0]), (1, pos[1], REACTIVATE_VEL[1]),
                        (2, pos[2], REACTIVATE_VEL[2])):
            traj[i, J] = traj[i, A] = traj[i, IJ] = traj[i, IA] = 0.0
            traj[i, V] = traj[i, IV] = v
            traj[i, X] = traj[i, IX] = x
    if no_setpoint:
        sp_pos, sp_vel, sp_acc = NAN3, NAN3, NO_THRUST_ACC
        integ[:] = 0.0
    thrust, vel_sp, acc_sp = _control_or_failsafe(dt_s, pos, vel, acc_meas, sp_pos, sp_vel,
                                                  sp_acc, gains, integ)
    q, thrust_norm = thrust_to_attitude_q(thrust, yaw_rad)
    if no_setpoint:
        integ[:] = 0.0
    return q, thrust_norm, vel_sp, acc_sp


@register_jitable
def _control_or_failsafe(dt_s, pos, vel, acc_meas, sp_pos, sp_vel, sp_acc, gains, integ):
    """``_position_control`` as MulticopterPositionControl runs it: when the update fails
    (invalid setpoint or state, output not finite) it runs again on the failsafe setpoint
    (generateFailsafeSetpoint): stop, zero velocity where the velocity is known. (PX4's blind
    land and blind descent, for an unknown velocity, are not modelled: our estimate always has
    one.)"""
    thrust, vel_sp, acc_sp = _position_control(dt_s, pos, vel, acc_meas, sp_pos, sp_vel, sp_acc,
                                               gains, integ)
    if _all_finite(thrust) and _all_finite(acc_sp):
        return thrust, vel_sp, acc_sp
    fv = (0.0 if math.isfinite(vel[0]) and math.isfinite(vel[1]) else math.nan,
          0.0 if math.isfinite(vel[0]) and math.isfinite(vel[1]) else math.nan,
          0.0 if math.isfinite(vel[2]) else math.nan)
    return _position_control(dt_s, pos, vel, acc_meas, NAN3, fv, NAN3, gains, integ)


@register_jitable
def _all_finite(v: Vec3) -> bool:
    return math.isfinite(v[0]) and math.isfinite(v[1]) and math.isfinite(v[2])


@register_jitable
def _position_control(dt_s, pos, vel, acc_meas, sp_pos, sp_vel, sp_acc, gains, integ):
    (pos_p_xy, pos_p_z, vel_p_xy, vel_i_xy, vel_d_xy, vel_p_z, vel_i_z, vel_d_z, vel_max_xy,
     vel_max_up, vel_max_down, tilt_max, thrust_min, thrust_max, hover) = (
        gains[0], gains[1], gains[2], gains[3], gains[4], gains[5], gains[6], gains[7], gains[8],
        gains[9], gains[10], gains[11], gains[12], gains[13], gains[14])
    if not input_valid(pos, vel, acc_meas, sp_pos, sp_vel, sp_acc):
        return NAN3, NAN3, NAN3  # PositionControl::update: nothing runs, the integrator holds
    # --- _positionControl: P on position added to the velocity feed-forward (an axis with
    # neither stays NaN: it is not velocity-controlled).
    p0 = pos_p_xy * (sp_pos[0] - pos[0])
    p1 = pos_p_xy * (sp_pos[1] - pos[1])
    p2 = pos_p_z * (sp_pos[2] - pos[2])
    v0 = add_if_not_nan(sp_vel[0], p0)
    v1 = add_if_not_nan(sp_vel[1], p1)
    v2 = add_if_not_nan(sp_vel[2], p2)
    p0 = 0.0 if math.isnan(p0) else p0
    p1 = 0.0 if math.isnan(p1) else p1
    # The horizontal limit keeps the P term (towards the position setpoint) before the
    # feed-forward.
    v0, v1 = constrain_xy((p0, p1), (v0 - p0, v1 - p1), vel_max_xy)
    # math::constrain(v, -up, down): during the takeoff ramp ``up`` is negative (a limit that
    # asks for descent) and the lower bound wins, as in PX4.
    v2 = -vel_max_up if v2 < -vel_max_up else (vel_max_down if v2 > vel_max_down else v2)

    # --- _velocityControl: PID -> acceleration setpoint, added to the feed-forward (an axis
    # without a velocity setpoint gets the feed-forward alone).
    e0, e1, e2 = v0 - vel[0], v1 - vel[1], v2 - vel[2]
    a0 = add_if_not_nan(sp_acc[0], e0 * vel_p_xy + integ[0] - acc_meas[0] * vel_d_xy)
    a1 = add_if_not_nan(sp_acc[1], e1 * vel_p_xy + integ[1] - acc_meas[1] * vel_d_xy)
    a2 = add_if_not_nan(sp_acc[2], e2 * vel_p_z + integ[2] - acc_meas[2] * vel_d_z)

    # --- _accelerationControl: acceleration -> body z (tilt-limited) and collective thrust.
    bx, by, bz = -a0, -a1, GRAVITY_MPS2
    n = math.sqrt(bx * bx + by * by + bz * bz)
    bx, by, bz = limit_tilt((bx / n, by / n, bz / n), tilt_max)
    collective = a2 * (hover / GRAVITY_MPS2) - hover
    collective /= bz
    collective = min(collective, -thrust_min)
    t0, t1, t2 = bx * collective, by * collective, bz * collective

    # Vertical anti-windup: stop integrating into the saturated direction.
    if (t2 >= -thrust_min and e2 >= 0.0) or (t2 <= -thrust_max and e2 <= 0.0):
        e2 = 0.0
    # Prioritize vertical control while keeping a horizontal margin.
    thr_xy = math.hypot(t0, t1)
    thr_max_sq = thrust_max * thrust_max
    allocated_xy = min(thr_xy, THRUST_XY_MARGIN)
    t2 = max(t2, -math.sqrt(max(thr_max_sq - allocated_xy * allocated_xy, 0.0)))
    thr_max_xy_sq = thr_max_sq - t2 * t2
    thr_max_xy = math.sqrt(thr_max_xy_sq) if thr_max_xy_sq > 0.0 else 0.0
    if thr_xy > thr_max_xy:
        t0 *= thr_max_xy / thr_xy
        t1 *= thr_max_xy / thr_xy
    # Tracking anti-windup for the horizontal integrator.
    p0, p1 = t0 * GRAVITY_MPS2 / hover, t1 * GRAVITY_MPS2 / hover
    if a0 ** 2 + a1 ** 2 > p0 ** 2 + p1 ** 2:
        l0, l1 = p0, p1
    else:
        l0, l1 = a0, a1
    arw_gain = 2.0 / vel_p_xy
    e0 -= arw_gain * (a0 - l0)
    e1 -= arw_gain * (a1 - l1)
    if math.isfinite(e0):
        integ[0] += e0 * vel_i_xy * dt_s
    if math.isfinite(e1):
        integ[1] += e1 * vel_i_xy * dt_s
    if math.isfinite(e2):
        integ[2] += e2 * vel_i_z * dt_s
    # PX4 limits the vertical integral to one g worth of acceleration.
    integ[2] = min(max(integ[2], -GRAVITY_MPS2), GRAVITY_MPS2)
    # The acceleration setpoint is the velocity PID's (PX4's _acc_sp, which
    # vehicle_local_position_setpoint carries), before the tilt and thrust limits.
    return (t0, t1, t2), (v0, v1, v2), (a0, a1, a2)


class PositionControl:
    def __init__(self, gains: PositionControlGains) -> None:
        self.gains = gains
        self._gains = np.array(gains.vector())
        self._gains[12] = max(gains.thrust_min, THRUST_MIN_FLOOR)
        self._hover = float(self._gains[14])  # (read every 50 Hz tick: not off the array)
        self._vel_int = np.zeros(3)

    def reset_integral(self) -> None:
        self._vel_int.fill(0.0)

    def set_limits(self, speed_up_mps: float, thrust_min: float, tilt_max_rad: float,
                   speed_down_mps: float = math.nan) -> None:
        """This tick's upward speed limit, minimum thrust, tilt limit and downward speed limit
        (PX4's setVelocityLimits / setThrustLimits / setTiltLimit, which mc_pos_control calls
        every update; the takeoff ramp moves them; the down limit is the task's constraint,
        MPC_Z_VEL_MAX_DN when NaN, never below 0). The minimum thrust is never below
        THRUST_MIN_FLOOR."""
        g = self._gains
        # (max() as comparisons, the same values, NaN included: every tick)
        floor = THRUST_MIN_FLOOR
        g[9], g[12], g[11] = (speed_up_mps, floor if floor > thrust_min else thrust_min,
                              tilt_max_rad)
        down = speed_down_mps if math.isfinite(speed_down_mps) else self.gains.vel_max_down_mps
        g[10] = 0.0 if 0.0 > down else down

    @property
    def hover_thrust(self) -> float:
        """The hover thrust the controller uses now (``update_hover_thrust`` moves it; the
        frozen ``gains`` keep the one it was built with)."""
        return self._hover

    def update_hover_thrust(self, hover_thrust: float, acc_sp_z: float) -> None:
        """PositionControl::updateHoverThrust: a new hover thrust (0.05..0.9), the vertical
        integrator moved so that the thrust of the last acceleration setpoint ``acc_sp_z``
        (NED) stays the same: T = (a − g)·Th/g."""
        previous = self._hover
        new = min(max(hover_thrust, 0.05), 0.9)
        self._gains[14] = self._hover = new
        if math.isfinite(acc_sp_z):
            self._vel_int[2] += ((acc_sp_z - GRAVITY_MPS2) * previous / new + GRAVITY_MPS2
                                 - acc_sp_z)

    @property
    def velocity_integral(self) -> Vec3:
        i = self._vel_int
        return (float(i[0]), float(i[1]), float(i[2]))

    def update(self, dt_s: float, position_ned_m: Vec3, velocity_ned_mps: Vec3,
               acceleration_ned_mps2: Vec3, sp: PositionSetpoint) -> PositionControlOutput:
        """PositionControl::update: ``valid`` is False when the thrust or the acceleration
        setpoint is not finite."""
        thrust, vel_sp, acc_sp = position_control_step(
            dt_s, _vec3(position_ned_m), _vec3(velocity_ned_mps), _vec3(acceleration_ned_mps2),
            _vec3(sp.position_ned_m), _vec3(sp.velocity_ned_mps), _vec3(sp.acceleration_ned_mps2),
            self._gains, self._vel_int)
        valid = all(math.isfinite(v) for v in (*thrust, *acc_sp))
        return PositionControlOutput(thrust, vel_sp, sp.yaw_rad, acc_sp, valid)

    def update_attitude(self, dt_s: float, position_ned_m: Vec3, velocity_ned_mps: Vec3,
                        acceleration_ned_mps2: Vec3, sp: PositionSetpoint, yaw_rad: float
                        ) -> tuple[Quat, float, Vec3, Vec3]:
        """``update``, then the thrust as an attitude setpoint at heading ``yaw_rad``
        (``thrust_to_attitude``) in one compiled call: (attitude, collective thrust, velocity
        setpoint, acceleration setpoint)."""
        return position_attitude_step(
            dt_s, _vec3(position_ned_m), _vec3(velocity_ned_mps), _vec3(acceleration_ned_mps2),
            _vec3(sp.position_ned_m), _vec3(sp.velocity_ned_mps), _vec3(sp.acceleration_ned_mps2),
            self._gains, self._vel_int, float(yaw_rad))

    def update_attitude_auto(self, smoothing: PositionSmoothing, dt_s: float,
                             has_previous: bool, has_next: bool, acceptance_radius_m: float,
                             vz_cmd_mps: float, velocity_ned_mps: Vec3,
                             acceleration_ned_mps2: Vec3, yaw_rad: float, no_setpoint: bool,
                             reactivate: bool, force_zero_velocity: bool = False
                             ) -> tuple[Vec3, Vec3, Vec3, Quat, float, Vec3, Vec3]:
        """``smoothing.generate_auto`` (its input set with ``set_auto_input``, the vehicle's
        position first) and ``update_attitude`` on its setpoint in one compiled call
        (``auto_position_attitude_step``): (trajectory position, velocity, acceleration,
        attitude, collective thrust, velocity setpoint, acceleration setpoint);
        ``force_zero_velocity``: the trajectory plans a zero velocity (emergency braking)."""
        return auto_position_attitude_step(
            smoothing.axes, smoothing.cfg, smoothing.inp, smoothing.out, float(dt_s),
            has_previous, has_next, float(acceptance_radius_m), float(vz_cmd_mps),
            _vec3(velocity_ned_mps), _vec3(acceleration_ned_mps2), self._gains, self._vel_int,
            float(yaw_rad), no_setpoint, reactivate, force_zero_velocity)

    def trajectory_auto(self, smoothing: PositionSmoothing, dt_s: float, has_previous: bool,
                        has_next: bool, acceptance_radius_m: float, vz_cmd_mps: float,
                        force_zero_velocity: bool = False) -> tuple[Vec3, Vec3, Vec3]:
        """``update_attitude_auto`` in two calls, this the first: the trajectory (position,
        velocity, acceleration), the vehicle's position ``smoothing.inp``'s first row."""
        inp = smoothing.inp
        return generate_auto_step(smoothing.axes, smoothing.cfg, inp, float(dt_s), True,
                                  has_previous, has_next, float(acceptance_radius_m),
                                  float(vz_cmd_mps), float(inp[2]), smoothing.out,
                                  force_zero_velocity)

    def attitude_auto(self, smoothing: PositionSmoothing, dt_s: float,
                      trajectory: tuple[Vec3, Vec3, Vec3], velocity_ned_mps: Vec3,
                      acceleration_ned_mps2: Vec3, yaw_rad: float, no_setpoint: bool,
                      reactivate: bool) -> tuple[Quat, float, Vec3, Vec3]:
        """The second: position control on ``trajectory_auto``'s setpoint at heading
        ``yaw_rad`` (``auto_attitude_step``): (attitude, collective thrust, velocity setpoint,
        acceleration setpoint)."""
        inp = smoothing.inp
        p_sp, v_sp, a_sp = trajectory
        return auto_attitude_step(
            smoothing.axes, float(dt_s), (float(inp[0]), float(inp[1]), float(inp[2])),
            _vec3(p_sp), _vec3(v_sp), _vec3(a_sp), _vec3(velocity_ned_mps),
            _vec3(acceleration_ned_mps2), self._gains, self._vel_int, float(yaw_rad),
            no_setpoint, reactivate)


def compile_now() -> None:
    """Compile ``position_control_step`` (or load it from numba's cache) now, not in the middle
    of the first flight."""
    z = (0.0, 0.0, 0.0)
    position_control_step(0.02, z, z, z, z, z, z, np.ones(15), np.zeros(3))
    position_attitude_step(0.02, z, z, z, z, z, z, np.ones(15), np.zeros(3), 0.0)
    s = PositionSmoothing()
    pc = PositionControl(PositionControlGains(*np.ones(15).tolist()))
    pc.update_attitude_auto(s, 0.02, False, False, 1.0, 0.0, z, z, 0.0, False, False)
    pc.attitude_auto(s, 0.02, pc.trajectory_auto(s, 0.02, False, False, 1.0, 0.0), z, z, 0.0,
                     False, False)


def _vec3(v) -> Vec3:
    """A 3-tuple of floats (the compiled step is typed for exactly that)."""
    return (float(v[0]), float(v[1]), float(v[2]))
