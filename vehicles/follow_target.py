"""Follow Me: follow a moving target (FOLLOW_TARGET from MAVSDK's follow_me or QGC's Follow Me,
the GCS's own position), after PX4 ``flight_mode_manager/tasks/AutoFollowTarget``.

Rules:
- The target's latest report (local NED position and velocity) is extrapolated with its
  velocity and smoothed by a second-order reference model (1 rad/s, damping 0.707); a report
  older than TARGET_TIMEOUT_S, or none, means "no target": the vehicle brakes and holds.
- The vehicle keeps FLW_TGT_DST from the target at FLW_TGT_FA degrees from the target's course
  (its direction of motion, frozen below 1 m/s; 180 = behind), moving round the target at most
  at FLW_TGT_MAX_VEL; altitude FLW_TGT_HT above home (FLW_TGT_ALT_M 0 and 1 — the ground is
  flat) or above the target (2), never below 1 m above home. Horizontal following waits until
  the altitude is within 3 m.
- The nose points at the target once it is more than 1 m away.
- The setpoints are targets for the autopilot's smoothed trajectory (auto_trajectory.py: speed
  MPC_XY_VEL_MAX, acceleration MPC_ACC_HOR), the target's velocity fed forward.
- Pure: time and dt are arguments.
"""

from __future__ import annotations

import math

from vehicles.control.position_control import PositionSetpoint
from vehicles.types import Vec3

TARGET_TIMEOUT_S = 3.0
FILTER_OMEGA = 1.0  # rad/s
FILTER_ZETA = 0.7071
COURSE_MIN_SPEED_MPS = 1.0
ALT_ACCEPTANCE_M = 3.0
YAW_MIN_DISTANCE_M = 1.0
ALT_MODE_TRACK_TARGET = 2
MINIMUM_SAFETY_ALTITUDE_M = 1.0


class FollowTarget:
    def __init__(self, params) -> None:
        self.params = params
        self._report: tuple[float, Vec3, Vec3] | None = None  # (time, position, velocity)
        self._pos: Vec3 | None = None  # the filtered target
        self._vel: Vec3 = (0.0, 0.0, 0.0)
        self._course = math.nan
        self._orbit_angle = math.nan
        self._down_sp = math.nan
        self.yaw_sp = math.nan

    def set_target(self, now_s: float, position_ned_m: Vec3, velocity_ned_mps: Vec3) -> None:
        if all(math.isfinite(x) for x in (*position_ned_m, *velocity_ned_mps)):
            self._report = (now_s, position_ned_m, velocity_ned_mps)

    def activate(self, pos: Vec3, yaw: float) -> None:
        self._pos = None
        self._orbit_angle = math.nan
        self._down_sp = pos[2]
        self.yaw_sp = yaw

    def target(self, now_s: float) -> tuple[Vec3, Vec3] | None:
        """The target's report extrapolated to ``now_s``, or None when there is none."""
        if self._report is None or now_s - self._report[0] > TARGET_TIMEOUT_S:
            return None
        t, p, v = self._report
        dt = now_s - t
        return (p[0] + v[0] * dt, p[1] + v[1] * dt, p[2] + v[2] * dt), v

    def update(self, now_s: float, dt: float, pos: Vec3, yaw: float) -> PositionSetpoint | None:
        """Where to fly (position target, target velocity, yaw); None without a target (the
        autopilot then brakes and holds)."""
        p = self.params
        step = math.radians(float(p["MPC_YAWRAUTO_MAX"])) * dt
        measured = self.target(now_s)
        if measured is None:
            self._pos = None
            self._slew(self.yaw_sp, step, yaw)
            return None
        tp, tv = measured
        fp, fv = self._pos, self._vel
        if fp is None:
            fp, fv = tp, tv
        else:  # second-order reference model towards the measurement
            w2, k = FILTER_OMEGA ** 2, 2.0 * FILTER_ZETA * FILTER_OMEGA
            an, ae, ad = (w2 * (tp[i] - fp[i]) + k * (tv[i] - fv[i]) for i in range(3))
            fv = (fv[0] + an * dt, fv[1] + ae * dt, fv[2] + ad * dt)
            fp = (fp[0] + fv[0] * dt, fp[1] + fv[1] * dt, fp[2] + fv[2] * dt)
        self._pos, self._vel = fp, fv
        if math.hypot(fv[0], fv[1]) >= COURSE_MIN_SPEED_MPS:
            self._course = math.atan2(fv[1], fv[0])
        dist = max(float(p["FLW_TGT_DST"]), 1.0)
        if math.isnan(self._orbit_angle):  # start from where the vehicle is
            self._orbit_angle = math.atan2(pos[1] - fp[1], pos[0] - fp[0])
        course = self._course if math.isfinite(self._course) else 0.0
        wanted = math.remainder(course + math.radians(float(p["FLW_TGT_FA"])), math.tau)
        err = math.remainder(wanted - self._orbit_angle, math.tau)
        max_step = float(p["FLW_TGT_MAX_VEL"]) / dist * dt
        self._orbit_angle = math.remainder(self._orbit_angle + min(max(err, -max_step), max_step),
                                           math.tau)
        height = float(p["FLW_TGT_HT"])
        if int(p["FLW_TGT_ALT_M"]) == ALT_MODE_TRACK_TARGET:
            self._down_sp = fp[2] - height
        else:
            self._down_sp = min(self._down_sp, -height)
        # Never lower than MINIMUM_SAFETY_ALTITUDE above home (PX4 climbs out from there).
        self._down_sp = min(self._down_sp, -MINIMUM_SAFETY_ALTITUDE_M)
        dn = fp[0] + math.cos(self._orbit_angle) * dist
        de = fp[1] + math.sin(self._orbit_angle) * dist
        to_n, to_e = fp[0] - pos[0], fp[1] - pos[1]
        if math.hypot(to_n, to_e) > YAW_MIN_DISTANCE_M:
            self._slew(math.atan2(to_e, to_n), step, yaw)
        if abs(self._down_sp - pos[2]) < ALT_ACCEPTANCE_M:
            return PositionSetpoint((dn, de, self._down_sp), (fv[0], fv[1], 0.0), self.yaw_sp)
        # Reach the altitude first, holding the horizontal position.
        return PositionSetpoint((pos[0], pos[1], self._down_sp), (0.0, 0.0, 0.0), self.yaw_sp)

    def _slew(self, target: float, step: float, yaw: float) -> float:
        if math.isnan(self.yaw_sp):
            self.yaw_sp = yaw
        if not math.isnan(target):
            err = math.remainder(target - self.yaw_sp, math.tau)
            self.yaw_sp = math.remainder(self.yaw_sp + min(max(err, -step), step), math.tau)
        return self.yaw_sp
