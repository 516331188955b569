"""Position mode with MPC_POS_MODE 3: PX4 v1.15's FlightTaskManualPositionSmoothVel.

The sticks ask for a horizontal velocity (FlightTaskManualPosition::_scaleSticks: expo and
deadzone, limited to unit length, MPC_VEL_MAN_SIDE/BACK, times MPC_VEL_MANUAL, turned into the
heading frame), which goes through ManualVelocitySmoothingXY (MPC_JERK_MAX, MPC_ACC_HOR_MAX,
MPC_VEL_MANUAL; the position locks once it has stopped); the vertical, the heading and the ground
slowdown are Altitude mode's (manual_control.ManualAltitude, ManualVelocitySmoothingZ). Entering
the mode, both smoothings restart from the last task's setpoint (NaN parts: the vehicle's
position and velocity, a zero acceleration); on the ground before the takeoff (reActivate) from
the vehicle's position and horizontal velocity, at rest vertically.

Sticks as in manual_control.py. Pure: time and dt are arguments.
"""

from __future__ import annotations

import math

from vehicles.control.manual_velocity_smoothing_xy import ManualVelocitySmoothingXY
from vehicles.control.position_control import PositionSetpoint
from vehicles.manual_control import ManualAltitude, Sticks, stick_xy
from vehicles.types import EstimatorReset, Vec3


def stick_velocity_xy(params, sticks: Sticks, heading: float) -> tuple[float, float]:
    """FlightTaskManualPosition::_scaleSticks: the horizontal velocity the sticks ask for
    (manual_control.stick_xy times MPC_VEL_MANUAL; no estimator speed limit here)."""
    vel_manual = float(params["MPC_VEL_MANUAL"])
    sx, sy = stick_xy(params, sticks, heading)
    return sx * vel_manual, sy * vel_manual


def _finite_or(value: float, fallback: float) -> float:
    return value if math.isfinite(value) else fallback


class ManualPositionSmoothVel(ManualAltitude):
    def __init__(self, params) -> None:
        super().__init__(params)
        self.smoothing_xy = ManualVelocitySmoothingXY()

    def activate(self, pos: Vec3, vel: Vec3, yaw: float,
                 last: PositionSetpoint | None = None) -> None:
        super().activate(pos, vel, yaw, last)
        p = last.position_ned_m if last is not None else (math.nan,) * 3
        v = last.velocity_ned_mps if last is not None else (math.nan,) * 3
        a = last.acceleration_ned_mps2 if last is not None else (math.nan,) * 3
        self.smoothing_xy.reset((_finite_or(a[0], 0.0), _finite_or(a[1], 0.0)),
                                (_finite_or(v[0], vel[0]), _finite_or(v[1], vel[1])),
                                (_finite_or(p[0], pos[0]), _finite_or(p[1], pos[1])))

    def estimator_reset(self, pos: Vec3, vel: Vec3, r: EstimatorReset) -> None:
        """FlightTaskManualPositionSmoothVel's handlers: the horizontal smoothing takes the new
        position and velocity (setCurrentPosition, setCurrentVelocity), the vertical the new
        velocity."""
        super().estimator_reset(pos, vel, r)
        if r.xy:
            self.smoothing_xy.set_current_position((pos[0], pos[1]))
        if r.vxy:
            self.smoothing_xy.set_current_velocity((vel[0], vel[1]))

    def reactivate(self, pos: Vec3, vel: Vec3, yaw: float) -> None:
        super().reactivate(pos, vel, yaw)
        # reset the derivatives so that mc_pos_control detects the takeoff from the jerk
        self.smoothing_xy.reset((0.0, 0.0), (vel[0], vel[1]), (pos[0], pos[1]))
        self.smoothing.reset(0.0, 0.0, pos[2])

    def update(self, dt: float, sticks: Sticks, pos: Vec3, vel: Vec3, yaw: float,
               vel_sp_feedback: Vec3, home_z: float = math.nan) -> PositionSetpoint:
        p = self.params
        s = self.smoothing_xy
        s.set_limits(float(p["MPC_JERK_MAX"]), float(p["MPC_ACC_HOR_MAX"]),
                     float(p["MPC_VEL_MANUAL"]))
        s.vel_sp_feedback = (vel_sp_feedback[0], vel_sp_feedback[1])
        s.position_estimate = (pos[0], pos[1])
        self._yaw(sticks, yaw, dt)
        vz, az = self._vertical(dt, sticks, pos, vel_sp_feedback[2], home_z)
        s.update(dt, stick_velocity_xy(p, sticks, self.yaw_sp if not math.isnan(self.yaw_sp)
                                       else yaw))
        (x, y), (vx, vy), (ax, ay) = s.position_locked, s.v, s.a
        return PositionSetpoint((x, y, self.z_sp), (vx, vy, vz), self.yaw_sp, (ax, ay, az))
