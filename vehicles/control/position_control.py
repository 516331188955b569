"""Pure library: position P + velocity PID -> normalized thrust vector (PX4 PositionControl).

Follows PX4 ``src/modules/mc_pos_control/PositionControl/PositionControl.cpp`` (v1.14+):
``_positionControl`` (P on position, velocity limits), ``_velocityControl`` (PID on velocity with
vertical-priority thrust saturation and tracking anti-windup after Rundqwist 1990),
``_accelerationControl`` (acceleration -> body z with tilt limit, collective thrust via the hover
thrust), and ``ControlMath::limitTilt``.

Rules:
- Frames: NED; thrust is normalized (1.0 = all rotors at full thrust), pointing where the body's
  -z axis must point, so hovering level gives (0, 0, -hover_thrust).
- NaN in a setpoint component means "not commanded" (PX4 convention): NaN position -> that axis is
  velocity-controlled; NaN velocity feed-forward -> 0.
- The gains are PX4's physical gains (m/s per m, m/s² per m/s): the plant is physical, so no
  scaling is needed here. The hover thrust is the airframe's true value, standing in for PX4's
  converged hover-thrust estimator (MPC_USE_HTE=1); MPC_THR_HOVER is used only if none is given.
- Pure: no physics engine, no clock; ``update`` takes ``dt_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vehicles.types import GRAVITY_MPS2

Vec3 = tuple[float, float, float]
NAN3: Vec3 = (math.nan, math.nan, math.nan)

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
    hover_thrust: float

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


@dataclass(frozen=True)
class PositionSetpoint:
    """What the navigator/trajectory asks of the position controller (NaN = not commanded)."""

    position_ned_m: Vec3 = NAN3
    velocity_ned_mps: Vec3 = NAN3
    yaw_rad: float = math.nan
    acceleration_ned_mps2: Vec3 = NAN3  # feed-forward


@dataclass(frozen=True)
class PositionControlOutput:
    thrust_ned: Vec3  # normalized thrust vector
    velocity_sp_ned_mps: Vec3  # the velocity setpoint the P loop produced
    yaw_rad: float


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


class PositionControl:
    def __init__(self, gains: PositionControlGains) -> None:
        self.gains = gains
        self._vel_int = [0.0, 0.0, 0.0]

    def reset_integral(self) -> None:
        self._vel_int = [0.0, 0.0, 0.0]

    @property
    def velocity_integral(self) -> Vec3:
        return (self._vel_int[0], self._vel_int[1], self._vel_int[2])

    def update(self, dt_s: float, position_ned_m: Vec3, velocity_ned_mps: Vec3,
               acceleration_ned_mps2: Vec3, sp: PositionSetpoint) -> PositionControlOutput:
        g = self.gains
        # --- _positionControl: P on position + feed-forward, NaN axes stay velocity-only.
        vff = sp.velocity_ned_mps
        vsp = [0.0 if math.isnan(vff[i]) else vff[i] for i in range(3)]
        for i, kp in ((0, g.pos_p_xy), (1, g.pos_p_xy), (2, g.pos_p_z)):
            if not math.isnan(sp.position_ned_m[i]):
                vsp[i] += kp * (sp.position_ned_m[i] - position_ned_m[i])
        vxy = math.hypot(vsp[0], vsp[1])
        if vxy > g.vel_max_xy_mps:
            vsp[0] *= g.vel_max_xy_mps / vxy
            vsp[1] *= g.vel_max_xy_mps / vxy
        vsp[2] = min(max(vsp[2], -g.vel_max_up_mps), g.vel_max_down_mps)

        # --- _velocityControl: PID -> acceleration setpoint.
        err = [vsp[i] - velocity_ned_mps[i] for i in range(3)]
        kp = (g.vel_p_xy, g.vel_p_xy, g.vel_p_z)
        kd = (g.vel_d_xy, g.vel_d_xy, g.vel_d_z)
        aff = sp.acceleration_ned_mps2
        acc = [err[i] * kp[i] + self._vel_int[i] - acceleration_ned_mps2[i] * kd[i]
               + (0.0 if math.isnan(aff[i]) else aff[i]) for i in range(3)]

        # --- _accelerationControl: acceleration -> body z (tilt-limited) and collective thrust.
        bz = (-acc[0], -acc[1], GRAVITY_MPS2)
        n = math.sqrt(bz[0] * bz[0] + bz[1] * bz[1] + bz[2] * bz[2])
        bz = limit_tilt((bz[0] / n, bz[1] / n, bz[2] / n), g.tilt_max_rad)
        collective = acc[2] * (g.hover_thrust / GRAVITY_MPS2) - g.hover_thrust
        collective /= bz[2]
        collective = min(collective, -g.thrust_min)
        thr = [bz[0] * collective, bz[1] * collective, bz[2] * collective]

        # Vertical anti-windup: stop integrating into the saturated direction.
        if (thr[2] >= -g.thrust_min and err[2] >= 0.0) or (thr[2] <= -g.thrust_max and err[2] <= 0.0):
            err[2] = 0.0
        # Prioritize vertical control while keeping a horizontal margin.
        thr_xy = math.hypot(thr[0], thr[1])
        thr_max_sq = g.thrust_max * g.thrust_max
        allocated_xy = min(thr_xy, THRUST_XY_MARGIN)
        thr[2] = max(thr[2], -math.sqrt(max(thr_max_sq - allocated_xy * allocated_xy, 0.0)))
        thr_max_xy_sq = thr_max_sq - thr[2] * thr[2]
        thr_max_xy = math.sqrt(thr_max_xy_sq) if thr_max_xy_sq > 0.0 else 0.0
        if thr_xy > thr_max_xy:
            thr[0] *= thr_max_xy / thr_xy
            thr[1] *= thr_max_xy / thr_xy
        # Tracking anti-windup for the horizontal integrator.
        produced = (thr[0] * GRAVITY_MPS2 / g.hover_thrust, thr[1] * GRAVITY_MPS2 / g.hover_thrust)
        if acc[0] ** 2 + acc[1] ** 2 > produced[0] ** 2 + produced[1] ** 2:
            limited = produced
        else:
            limited = (acc[0], acc[1])
        arw_gain = 2.0 / g.vel_p_xy
        err[0] -= arw_gain * (acc[0] - limited[0])
        err[1] -= arw_gain * (acc[1] - limited[1])
        ki = (g.vel_i_xy, g.vel_i_xy, g.vel_i_z)
        for i in range(3):
            if math.isfinite(err[i]):
                self._vel_int[i] += err[i] * ki[i] * dt_s
        # PX4 limits the vertical integral to one g worth of acceleration.
        self._vel_int[2] = min(max(self._vel_int[2], -GRAVITY_MPS2), GRAVITY_MPS2)
        return PositionControlOutput((thr[0], thr[1], thr[2]), (vsp[0], vsp[1], vsp[2]), sp.yaw_rad)
