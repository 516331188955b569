"""Pure library: PX4's ManualVelocitySmoothingZ (src/lib/motion_planning/ManualVelocitySmoothingZ),
the jerk-limited vertical of Altitude and Position modes (FlightTaskManualAltitudeSmoothVel, which
FlightTaskManualAcceleration extends: PX4's tasks for MPC_POS_MODE 3 and 4).

The throttle stick's velocity target goes through one axis of the jerk-limited velocity smoothing
(velocity_smoothing.py): MPC_JERK_MAX, the acceleration and speed limits of the direction the
target points to (MPC_ACC_UP_MAX / MPC_Z_VEL_MAX_UP climbing, MPC_ACC_DOWN_MAX / MPC_Z_VEL_MAX_DN
descending; a zero target takes the descent's). The altitude locks where the smoothed trajectory
is once the target is zero and the trajectory has slowed below 0.1 m/s and 0.2 m/s²; while not
locked the trajectory's position follows the vehicle's estimate and there is no altitude setpoint
(NaN). Unlocking restarts the trajectory's velocity from the velocity controller's input
(``vel_sp_feedback``), so the velocity setpoint does not jump when the position loop's share of
it drops out.

Time is an argument; no clock, no physics.
"""

from __future__ import annotations

import math

from vehicles.control.velocity_smoothing import VelocitySmoothing

EPS = 1.1920929e-07  # FLT_EPSILON
LOCK_VEL_MPS = 0.1  # checkPositionLock: the trajectory's speed below which the altitude locks
LOCK_ACC_MPS2 = 0.2  # … and its acceleration


class ManualVelocitySmoothingZ:
    """One vertical axis (NED, down +)."""

    def __init__(self) -> None:
        self.trajectory = VelocitySmoothing()
        self.j = self.a = self.v = self.x = 0.0  # the state after the last update (_state)
        self.lock_active = False
        self.position_locked = math.nan
        self.vel_sp_feedback = 0.0  # the velocity controller's last input (setVelSpFeedback)
        self.position_estimate = 0.0  # setCurrentPositionEstimate
        self.max_accel_up = self.max_accel_down = 0.0
        self.max_vel_up = self.max_vel_down = 0.0

    def reset(self, accel: float, vel: float, pos: float) -> None:
        """The trajectory restarts from this state, unlocked (the task's activate)."""
        self.trajectory.reset(accel, vel, pos)
        self._reset_lock()

    def _reset_lock(self) -> None:
        self.lock_active = False
        self.position_locked = math.nan

    def set_limits(self, jerk: float, accel_up: float, accel_down: float, vel_up: float,
                   vel_down: float) -> None:
        """FlightTaskManualAltitudeSmoothVel::_updateTrajConstraints."""
        self.trajectory.max_jerk = jerk
        self.max_accel_up, self.max_accel_down = accel_up, accel_down
        self.max_vel_up, self.max_vel_down = vel_up, vel_down

    def set_current_position(self, pos: float) -> None:
        """setCurrentPosition (an estimator reset, the end of a terrain hold): the trajectory and
        a held lock move there."""
        self.x = pos
        self.trajectory.set_current_position(pos)
        self.position_estimate = pos
        if self.lock_active:
            self.position_locked = pos

    def set_current_velocity(self, vel: float) -> None:
        self.v = vel
        self.trajectory.set_current_velocity(vel)

    def update(self, dt: float, velocity_target: float) -> None:
        """One tick towards ``velocity_target`` (down +): the state integrates over ``dt`` on
        the durations of the last tick, then the limits, the lock and the new durations."""
        traj = self.trajectory
        traj.update_traj(dt)
        self.j, self.a, self.v, self.x = (float(v) for v in traj.row[:4])
        # updateTrajConstraints: the limits of the direction asked for
        if velocity_target < 0.0:
            traj.max_accel, traj.max_vel = self.max_accel_up, self.max_vel_up
        else:
            traj.max_accel, traj.max_vel = self.max_accel_down, self.max_vel_down
        # checkPositionLock
        if abs(self.v) < LOCK_VEL_MPS and abs(self.a) < LOCK_ACC_MPS2 \
                and abs(velocity_target) <= EPS:
            self.lock_active = True
            self.position_locked = self.x
        else:
            if self.lock_active:
                # (a feedback that is not finite, no velocity controller output yet, keeps
                # the trajectory's velocity where PX4 would take the NaN)
                if math.isfinite(self.vel_sp_feedback):
                    traj.set_current_velocity(self.vel_sp_feedback)
                    self.v = self.vel_sp_feedback
                self._reset_lock()
            traj.set_current_position(self.position_estimate)
        traj.update_durations(velocity_target)
