"""Pure library: thrust vector + yaw -> attitude setpoint; attitude P -> body rate setpoint.

Follows PX4:
- ``src/modules/mc_pos_control/PositionControl/ControlMath.cpp`` ``thrustToAttitude`` /
  ``bodyzToAttitude`` (desired body z = -thrust direction, body x from the yaw setpoint).
- ``src/modules/mc_att_control/AttitudeControl/AttitudeControl.cpp`` ``update``: quaternion
  controller that first aligns the thrust axis (reduced attitude) and mixes yaw in with weight
  MC_YAW_WEIGHT, rate setpoint = MC_*_P times the sin(half-angle) error, limited to MC_*RATE_MAX.

Rules: quaternions (w, x, y, z), FRD -> NED; gains are PX4's (1/s), used unscaled; pure functions
and one stateless class, no physics engine and no clock. ``attitude_rates`` is the one source of
the controller: the class calls it in Python, the compiled inner loop (vehicles/inner_loop.py)
inlines it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from numba.extending import register_jitable

from vehicles.control.quat import (
    Quat,
    Vec3,
    cross,
    norm,
    q_canonical,
    q_conj,
    q_dcm_z,
    q_from_dcm_columns,
    q_from_two_vectors,
    q_mul,
)


class AttitudeSetpoint(NamedTuple):
    """An attitude and collective thrust setpoint (a NamedTuple: one is built every 50 Hz tick)."""

    attitude_q: Quat
    thrust_body_norm: float  # collective thrust, 0..1 (body -z)
    yawspeed_radps: float = 0.0  # heading rate feed-forward (sticks, offboard yaw rate)


@dataclass(frozen=True)
class AttitudeControlGains:
    p_roll: float
    p_pitch: float
    p_yaw: float
    yaw_weight: float
    rate_max_frd_radps: Vec3

    @staticmethod
    def from_params(params) -> AttitudeControlGains:
        p = params
        return AttitudeControlGains(
            p_roll=float(p["MC_ROLL_P"]),
            p_pitch=float(p["MC_PITCH_P"]),
            p_yaw=float(p["MC_YAW_P"]),
            yaw_weight=float(p["MC_YAW_WEIGHT"]),
            rate_max_frd_radps=(
                math.radians(float(p["MC_ROLLRATE_MAX"])),
                math.radians(float(p["MC_PITCHRATE_MAX"])),
                math.radians(float(p["MC_YAWRATE_MAX"])),
            ),
        )

    def coefficients(self) -> tuple[float, float, float, float, float, float, float]:
        """``attitude_rates``' gain arguments: (p_roll, p_pitch, p_yaw / weight, limits…, weight)."""
        yaw_w = min(max(self.yaw_weight, 0.0), 1.0)
        p_yaw = self.p_yaw / yaw_w if yaw_w > 1e-4 else self.p_yaw
        r = self.rate_max_frd_radps
        return (self.p_roll, self.p_pitch, p_yaw, r[0], r[1], r[2], yaw_w)


def thrust_to_attitude(thrust_ned: Vec3, yaw_rad: float) -> AttitudeSetpoint:
    """ControlMath::thrustToAttitude: body z opposite to the thrust vector, nose towards yaw."""
    q, thrust_norm = thrust_to_attitude_q(thrust_ned, yaw_rad)
    return AttitudeSetpoint(q, thrust_norm)


@register_jitable
def thrust_to_attitude_q(thrust_ned: Vec3, yaw_rad: float) -> tuple[Quat, float]:
    """``thrust_to_attitude`` as (attitude, collective thrust): plain Python from Python,
    compiled into position control's kernel (position_control.py)."""
    bz = (-thrust_ned[0], -thrust_ned[1], -thrust_ned[2])
    n = norm(bz)
    if n * n < 1.2e-7:
        bz, n = (0.0, 0.0, 1.0), 1.0
    bz = (bz[0] / n, bz[1] / n, bz[2] / n)
    y_c = (-math.sin(yaw_rad), math.cos(yaw_rad), 0.0)
    bx = cross(y_c, bz)
    if bz[2] < 0.0:
        bx = (-bx[0], -bx[1], -bx[2])
    if abs(bz[2]) < 1e-6:
        bx = (0.0, 0.0, 1.0)
    nx = norm(bx)
    bx = (bx[0] / nx, bx[1] / nx, bx[2] / nx)
    by = cross(bz, bx)
    return q_from_dcm_columns(bx, by, bz), norm(thrust_ned)


@register_jitable
def attitude_rates(q: Quat, qd: Quat, p0: float, p1: float, p2: float, l0: float, l1: float,
                   l2: float, yaw_w: float, yawspeed: float) -> Vec3:
    """AttitudeControl::update: body rate setpoint for attitude ``q`` and setpoint ``qd``, plus
    the heading rate ``yawspeed`` (rad/s about NED down) fed forward in the body frame.

    ``p2`` is the yaw gain already divided by the yaw weight ``yaw_w`` (clamped to 0..1), ``l*``
    the rate limits. Plain Python from Python, compiled into vehicles/inner_loop.py's kernel."""
    w, x, y, z = q
    ax, ay, az = 2.0 * (x * z + w * y), 2.0 * (y * z - w * x), w * w - x * x - y * y + z * z
    bx, by, bz = q_dcm_z(qd)
    cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    d = ax * bx + ay * by + az * bz
    if math.sqrt(cx * cx + cy * cy + cz * cz) < 1e-5 and d < 0.0:
        qd_red = q_from_two_vectors((ax, ay, az), (bx, by, bz))  # antiparallel: rare
    else:
        rw = d + math.sqrt((ax * ax + ay * ay + az * az) * (bx * bx + by * by + bz * bz))
        n = math.sqrt(rw * rw + cx * cx + cy * cy + cz * cz)
        qd_red = (rw / n, cx / n, cy / n, cz / n)
    if abs(qd_red[1]) > 1.0 - 1e-5 or abs(qd_red[2]) > 1.0 - 1e-5:
        qd_red = qd  # roll or pitch near 180 deg: use the full attitude
    else:
        qd_red = q_mul(qd_red, q)
    q_mix = q_canonical(q_mul(q_conj(qd_red), qd))
    mw = q_mix[0]
    mw = -1.0 if mw < -1.0 else (1.0 if mw > 1.0 else mw)
    mz = q_mix[3]
    mz = -1.0 if mz < -1.0 else (1.0 if mz > 1.0 else mz)
    qd = q_mul(qd_red, (math.cos(yaw_w * math.acos(mw)), 0.0, 0.0, math.sin(yaw_w * math.asin(mz))))
    _, ex, ey, ez = q_canonical(q_mul((w, -x, -y, -z), qd))
    r0, r1, r2 = 2.0 * ex * p0, 2.0 * ey * p1, 2.0 * ez * p2
    if yawspeed != 0.0:  # + q⁻¹ · e_z · yawspeed: NED down in the body frame
        r0 += 2.0 * (x * z - w * y) * yawspeed
        r1 += 2.0 * (y * z + w * x) * yawspeed
        r2 += (w * w - x * x - y * y + z * z) * yawspeed
    return (-l0 if r0 < -l0 else (l0 if r0 > l0 else r0),
            -l1 if r1 < -l1 else (l1 if r1 > l1 else r1),
            -l2 if r2 < -l2 else (l2 if r2 > l2 else r2))


class AttitudeControl:
    """Stateless apart from its gains (PX4's AttitudeControl has no integrator either)."""

    def __init__(self, gains: AttitudeControlGains) -> None:
        self.gains = gains
        self.coefficients = gains.coefficients()

    def update(self, attitude_q: Quat, attitude_sp_q: Quat, yawspeed: float = 0.0) -> Vec3:
        return attitude_rates(attitude_q, attitude_sp_q, *self.coefficients, yawspeed)
