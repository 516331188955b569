"""Stabilized (and Manual, which is Stabilized on a multicopter) and Acro: the sticks straight to
attitude or body rates and thrust.

After PX4:
- ``mc_att_control`` (Stabilized): roll/pitch sticks → tilt up to MPC_MAN_TILT_MAX, yaw stick →
  heading rate (MPC_MAN_Y_MAX), throttle → thrust through MPC_THR_CURVE (0: the centred stick is
  hover thrust).
- ``mc_rate_control`` (Acro): sticks → body rates (MC_ACRO_*_MAX, superexpo MC_ACRO_EXPO*,
  MC_ACRO_SUPEXPO*), throttle → thrust.

Sticks as in manual_control.py. Pure: time and dt are arguments.
"""

from __future__ import annotations

import math

from vehicles.manual_control import Sticks, _clamp, superexpo
from vehicles.types import Vec3


def throttle_to_thrust(throttle: float, params, hover_thrust: float) -> float:
    """mc_att_control throttle_curve: MPC_THR_CURVE 1 linear, otherwise centred = hover."""
    lo, hi = float(params["MPC_MANTHR_MIN"]), float(params["MPC_THR_MAX"])
    t = _clamp(throttle, -1.0, 1.0)
    if int(params["MPC_THR_CURVE"]) == 1:
        return lo + (hi - lo) * (t + 1.0) * 0.5
    if t < 0.0:
        return hover_thrust + (hover_thrust - lo) * t
    return hover_thrust + (hi - hover_thrust) * t


class Stabilized:
    """mc_att_control's manual attitude: tilt from roll/pitch, heading from the yaw stick."""

    def __init__(self, params) -> None:
        self.params = params
        self.yaw_sp = math.nan
        self.yawspeed = 0.0

    def activate(self, yaw: float) -> None:
        self.yaw_sp = yaw
        self.yawspeed = 0.0

    def update(self, dt: float, sticks: Sticks, yaw: float, landed: bool
               ) -> tuple[float, float, float, float]:
        """The attitude setpoint quaternion (w, x, y, z), FRD → NED."""
        p = self.params
        self.yawspeed = 0.0
        if landed or math.isnan(self.yaw_sp):
            self.yaw_sp = yaw
        else:
            self.yawspeed = sticks.yaw * math.radians(float(p["MPC_MAN_Y_MAX"]))
            self.yaw_sp = math.remainder(self.yaw_sp + self.yawspeed * dt, math.tau)
        tilt_max = math.radians(float(p["MPC_MAN_TILT_MAX"]))
        vx, vy = sticks.roll * tilt_max, -sticks.pitch * tilt_max
        n = math.hypot(vx, vy)
        if n > tilt_max:
            vx, vy, n = vx * tilt_max / n, vy * tilt_max / n, tilt_max
        # AxisAngle(vx, vy, 0) then the heading: q = q_yaw * q_rp.
        if n > 0.0:
            s = math.sin(n / 2.0) / n
            rw, rx, ry = math.cos(n / 2.0), vx * s, vy * s
        else:
            rw, rx, ry = 1.0, 0.0, 0.0
        cw, cz = math.cos(self.yaw_sp / 2.0), math.sin(self.yaw_sp / 2.0)
        return (cw * rw, cw * rx - cz * ry, cw * ry + cz * rx, cz * rw)


def acro_rates(sticks: Sticks, params) -> Vec3:
    """mc_rate_control's Acro body-rate setpoint (FRD, rad/s)."""
    p = params
    e, g = float(p["MC_ACRO_EXPO"]), float(p["MC_ACRO_SUPEXPO"])
    ey, gy = float(p["MC_ACRO_EXPO_Y"]), float(p["MC_ACRO_SUPEXPOY"])
    return (superexpo(sticks.roll, e, g) * math.radians(float(p["MC_ACRO_R_MAX"])),
            superexpo(-sticks.pitch, e, g) * math.radians(float(p["MC_ACRO_P_MAX"])),
            superexpo(sticks.yaw, ey, gy) * math.radians(float(p["MC_ACRO_Y_MAX"])))


def acro_thrust(sticks: Sticks) -> float:
    return _clamp((sticks.throttle + 1.0) * 0.5, 0.0, 1.0)
