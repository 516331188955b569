"""Pure library: a simple speed- and acceleration-limited setpoint generator for auto modes.

A stand-in for PX4's jerk-limited ``PositionSmoothing`` (src/lib/motion_planning): it moves a
"carrot" (position + velocity) towards a target with a braking profile v = min(v_max, sqrt(2·a·d))
and the acceleration limited to ``acc`` (horizontal MPC_ACC_HOR; vertical MPC_ACC_UP_MAX /
MPC_ACC_DOWN_MAX). The position controller gets the carrot as position setpoint and its velocity
and acceleration as feed-forward (PX4 feeds the smoother's acceleration forward too; without it the
velocity loop lags a ramp by acc / MPC_*_VEL_P_ACC and the integrator winds up).

Rules: NED frame; a NaN target z means "vertical velocity mode" (the caller's ``vz_cmd_mps``), and
then the position setpoint z is NaN too. Pure: ``update`` takes ``dt_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vehicles.types import Vec3


@dataclass(frozen=True)
class TrajectoryLimits:
    speed_xy_mps: float
    speed_up_mps: float
    speed_down_mps: float
    acc_xy_mps2: float
    acc_up_mps2: float
    acc_down_mps2: float


class TrajectoryLimiter:
    def __init__(self) -> None:
        self._pos = [0.0, 0.0, 0.0]
        self._vel = [0.0, 0.0, 0.0]

    def reset(self, position_ned_m: Vec3, velocity_ned_mps: Vec3) -> None:
        self._pos = list(position_ned_m)
        self._vel = list(velocity_ned_mps)

    @property
    def position_ned_m(self) -> Vec3:
        return (self._pos[0], self._pos[1], self._pos[2])

    @property
    def velocity_ned_mps(self) -> Vec3:
        return (self._vel[0], self._vel[1], self._vel[2])

    def stopping_point(self, lim: TrajectoryLimits) -> Vec3:
        """Where the carrot comes to rest if it brakes now at the acceleration limits."""
        vx, vy, vz = self._vel
        vxy = math.hypot(vx, vy)
        k = vxy / (2.0 * lim.acc_xy_mps2)
        acc_z = lim.acc_down_mps2 if vz > 0.0 else lim.acc_up_mps2
        return (self._pos[0] + vx * k, self._pos[1] + vy * k,
                self._pos[2] + vz * abs(vz) / (2.0 * acc_z))

    def update(self, dt_s: float, target_ned_m: Vec3, lim: TrajectoryLimits,
               vz_cmd_mps: float = 0.0, current_z_m: float = 0.0) -> tuple[Vec3, Vec3, Vec3]:
        """Advance the carrot by ``dt_s``; returns (position, velocity, acceleration) setpoints."""
        p, v = self._pos, self._vel
        v0 = (v[0], v[1], v[2])
        # Horizontal: braking profile towards the target.
        dx, dy = target_ned_m[0] - p[0], target_ned_m[1] - p[1]
        dist = math.hypot(dx, dy)
        if dist > 1e-6:
            # Braking profile, capped so that one step never jumps past the target.
            speed = min(lim.speed_xy_mps, math.sqrt(2.0 * lim.acc_xy_mps2 * dist), dist / dt_s)
            want = (dx / dist * speed, dy / dist * speed)
        else:
            want = (0.0, 0.0)
        ax, ay = want[0] - v[0], want[1] - v[1]
        dv = math.hypot(ax, ay)
        max_dv = lim.acc_xy_mps2 * dt_s
        if dv > max_dv:
            ax, ay = ax * max_dv / dv, ay * max_dv / dv
        v[0] += ax
        v[1] += ay
        step = math.hypot(v[0], v[1]) * dt_s
        # Snap onto the target only if stopping there is within this step's acceleration budget.
        if dist <= step + 1e-9 and math.hypot(v0[0], v0[1]) <= max_dv + 1e-9:
            p[0], p[1], v[0], v[1] = target_ned_m[0], target_ned_m[1], 0.0, 0.0
        else:
            p[0] += v[0] * dt_s
            p[1] += v[1] * dt_s
        # Vertical (down positive): position target, or velocity mode when the target z is NaN.
        tz = target_ned_m[2]
        if math.isnan(tz):
            want_z = min(max(vz_cmd_mps, -lim.speed_up_mps), lim.speed_down_mps)
        else:
            dz = tz - p[2]
            # Braking a descent needs upward acceleration and vice versa.
            acc_brake = lim.acc_up_mps2 if dz > 0.0 else lim.acc_down_mps2
            vmax = lim.speed_down_mps if dz > 0.0 else lim.speed_up_mps
            want_z = math.copysign(
                min(vmax, math.sqrt(2.0 * acc_brake * abs(dz)), abs(dz) / dt_s), dz)
        acc_z = lim.acc_down_mps2 if want_z > v[2] else lim.acc_up_mps2
        dvz = min(max(want_z - v[2], -acc_z * dt_s), acc_z * dt_s)
        v[2] += dvz
        if math.isnan(tz):
            p[2] = current_z_m
        elif (abs(tz - p[2]) <= abs(v[2]) * dt_s + 1e-9
              and abs(v0[2]) <= min(lim.acc_up_mps2, lim.acc_down_mps2) * dt_s + 1e-9):
            p[2], v[2] = tz, 0.0
        else:
            p[2] += v[2] * dt_s
        acc = ((v[0] - v0[0]) / dt_s, (v[1] - v0[1]) / dt_s, (v[2] - v0[2]) / dt_s)
        pz = math.nan if math.isnan(tz) else p[2]
        return (p[0], p[1], pz), (v[0], v[1], v[2]), acc
