"""Pure library: PX4's ManualVelocitySmoothingXY (src/lib/motion_planning/ManualVelocitySmoothingXY),
the jerk-limited horizontal of Position mode with MPC_POS_MODE 3 (FlightTaskManualPositionSmoothVel).

The sticks' horizontal velocity target goes through two axes of the jerk-limited velocity
smoothing (velocity_smoothing.py), time-synchronised so that both arrive together: MPC_JERK_MAX,
MPC_ACC_HOR_MAX, MPC_VEL_MANUAL. The position locks where the smoothed trajectory is once the
target is zero and the trajectory has slowed below 0.1 m/s and 0.2 m/s² (the norms of both axes);
while not locked the trajectory's position follows the vehicle's estimate and there is no position
setpoint (NaN). Unlocking restarts the trajectory's velocity from the velocity controller's input
(``vel_sp_feedback``), as the vertical's does (manual_velocity_smoothing_z.py).

Time is an argument; no clock, no physics.
"""

from __future__ import annotations

import math

from vehicles.control.velocity_smoothing import VelocitySmoothing

EPS = 1.1920929e-07  # FLT_EPSILON
LOCK_VEL_MPS = 0.1  # checkPositionLock: the trajectory's speed below which the position locks
LOCK_ACC_MPS2 = 0.2  # … and its acceleration

Vec2 = tuple[float, float]


class ManualVelocitySmoothingXY:
    """The two horizontal axes (NED north, east)."""

    def __init__(self) -> None:
        self.trajectories = [VelocitySmoothing(), VelocitySmoothing()]
        self.j: Vec2 = (0.0, 0.0)  # the state after the last update (_state)
        self.a: Vec2 = (0.0, 0.0)
        self.v: Vec2 = (0.0, 0.0)
        self.x: Vec2 = (0.0, 0.0)
        self.lock_active = False
        self.position_locked: Vec2 = (0.0, 0.0)  # zero until the first reset, as PX4's
        self.vel_sp_feedback: Vec2 = (0.0, 0.0)  # setVelSpFeedback
        self.position_estimate: Vec2 = (0.0, 0.0)  # setCurrentPositionEstimate

    def reset(self, accel: Vec2, vel: Vec2, pos: Vec2) -> None:
        for i, t in enumerate(self.trajectories):
            t.reset(accel[i], vel[i], pos[i])
        self._reset_lock()

    def _reset_lock(self) -> None:
        self.lock_active = False
        self.position_locked = (math.nan, math.nan)

    def set_limits(self, jerk: float, accel: float, vel: float) -> None:
        """setMaxJerk, setMaxAccel, setMaxVel: the same on both axes."""
        for t in self.trajectories:
            t.max_jerk, t.max_accel, t.max_vel = jerk, accel, vel

    def set_current_velocity(self, vel: Vec2) -> None:
        self.v = vel
        for i, t in enumerate(self.trajectories):
            t.set_current_velocity(vel[i])

    def set_current_position(self, pos: Vec2) -> None:
        self.x = pos
        for i, t in enumerate(self.trajectories):
            t.set_current_position(pos[i])
        self.position_estimate = pos
        if self.lock_active:
            self.position_locked = pos

    def update(self, dt: float, velocity_target: Vec2) -> None:
        """One tick towards ``velocity_target``: the state integrates over ``dt`` on the
        durations of the last tick, then the lock, then the new, synchronised durations."""
        rows = []
        for t in self.trajectories:
            t.update_traj(dt)
            rows.append([float(v) for v in t.row[:4]])
        (jx, ax, vx, xx), (jy, ay, vy, xy) = rows
        self.j, self.a, self.v, self.x = (jx, jy), (ax, ay), (vx, vy), (xx, xy)
        # checkPositionLock
        if math.hypot(vx, vy) < LOCK_VEL_MPS and math.hypot(ax, ay) < LOCK_ACC_MPS2 \
                and math.hypot(*velocity_target) <= EPS:
            self.lock_active = True
            self.position_locked = self.x
        else:
            if self.lock_active:
                fb = self.vel_sp_feedback
                # (a feedback that is not finite, no velocity controller output yet, keeps the
                # trajectory's velocity where PX4 would take the NaN)
                if math.isfinite(fb[0]) and math.isfinite(fb[1]):
                    self.set_current_velocity(fb)
                self._reset_lock()
            for i, t in enumerate(self.trajectories):
                t.set_current_position(self.position_estimate[i])
        for i, t in enumerate(self.trajectories):
            t.update_durations(velocity_target[i])
        VelocitySmoothing.time_synchronization(self.trajectories)
