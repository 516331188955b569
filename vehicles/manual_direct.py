"""Altitude and Position modes with MPC_POS_MODE 0: PX4 v1.15's FlightTaskManualAltitude and
FlightTaskManualPosition, the sticks straight to velocity setpoints, no smoothing.

- Vertical (both): the throttle stick's velocity (MPC_Z_VEL_MAX_UP/DN, expo and deadzone), slowed
  near the ground as in the other variants (MPC_LAND_ALT1/2, MPC_LAND_SPEED, MPC_TKO_SPEED). The
  altitude locks where the vehicle is once the stick is centred and the vehicle climbs or sinks
  slower than MPC_HOLD_MAX_Z (0: at once), and unlocks when the stick moves
  (_updateAltitudeLock; no distance sensor here, so no terrain hold). No vertical acceleration
  setpoint.
- Altitude mode's horizontal: the tilt from the sticks, as the smooth variant's (StickTiltXY).
- Position mode's horizontal: the sticks' velocity (manual_position_smooth.stick_velocity_xy) as
  the setpoint, no acceleration setpoint; the position locks where the vehicle is once the sticks
  are centred and it moves slower than MPC_HOLD_MAX_XY (_updateXYlock).
- Entering: the altitude (and in Position mode the position) locked where the vehicle is, the
  velocity setpoints zero.

Sticks as in manual_control.py. Pure: time and dt are arguments.
"""

from __future__ import annotations

import math

from vehicles.control.position_control import PositionSetpoint
from vehicles.manual_control import EPS, ManualAltitude, Sticks, _clamp, expo_deadzone, gradual
from vehicles.manual_position_smooth import stick_velocity_xy
from vehicles.types import EstimatorReset, Vec3


class ManualAltitudeDirect(ManualAltitude):
    """FlightTaskManualAltitude."""

    def __init__(self, params) -> None:
        super().__init__(params)
        self._vz_meas = 0.0

    def _activate(self, pos: Vec3, vel: Vec3, yaw: float, last: PositionSetpoint | None) -> None:
        self.yaw_sp = yaw
        self._vz_sp = 0.0
        self.z_sp = pos[2]

    def estimator_reset(self, pos: Vec3, vel: Vec3, r: EstimatorReset) -> None:
        """FlightTaskManualAltitude (and ManualPosition) handle only heading resets."""

    def _vertical(self, dt: float, sticks: Sticks, pos: Vec3, vel_sp_feedback_z: float,
                  home_z: float) -> tuple[float, float]:
        (z_expo_e, dz, up_max, dn_max, alt1, alt2, land_speed, tko_speed, *_) = self._limits()
        stick_z = -sticks.throttle  # down +
        e = expo_deadzone(stick_z, z_expo_e, dz)
        target = (min(dn_max, self.velocity_constraint_down) if stick_z > 0.0
                  else min(up_max, self.velocity_constraint_up)) * e
        hold = float(self.params["MPC_HOLD_MAX_Z"])
        brake = abs(e) <= EPS
        stopped = hold < EPS or abs(self._vz_meas) < hold
        if brake and stopped and not math.isfinite(self.z_sp):
            self.z_sp = pos[2]
        elif not (math.isfinite(self.z_sp) and brake):
            self.z_sp = math.nan
        # _respectGroundSlowdown: the height above home (the local origin without one)
        dist = -(pos[2] - home_z) if math.isfinite(home_z) else -pos[2]
        target = _clamp(target, -gradual(dist, alt2, alt1, tko_speed, up_max),
                        gradual(dist, alt2, alt1, land_speed, dn_max))
        self._vz_sp = target
        return target, math.nan

    def update(self, dt: float, sticks: Sticks, pos: Vec3, vel: Vec3, yaw: float,
               vel_sp_feedback: Vec3, home_z: float = math.nan) -> PositionSetpoint:
        self._vz_meas = vel[2]
        return super().update(dt, sticks, pos, vel, yaw, vel_sp_feedback, home_z)


class ManualPositionDirect(ManualAltitudeDirect):
    """FlightTaskManualPosition."""

    def __init__(self, params) -> None:
        super().__init__(params)
        self._pos_xy = (math.nan, math.nan)

    def _activate(self, pos: Vec3, vel: Vec3, yaw: float, last: PositionSetpoint | None) -> None:
        super()._activate(pos, vel, yaw, last)
        self._pos_xy = (pos[0], pos[1])

    def update(self, dt: float, sticks: Sticks, pos: Vec3, vel: Vec3, yaw: float,
               vel_sp_feedback: Vec3, home_z: float = math.nan) -> PositionSetpoint:
        self._vz_meas = vel[2]
        self._yaw(sticks, yaw, dt)
        vz, _ = self._vertical(dt, sticks, pos, vel_sp_feedback[2], home_z)
        vx, vy = stick_velocity_xy(self.params, sticks,
                                   self.yaw_sp if not math.isnan(self.yaw_sp) else yaw)
        hold = float(self.params["MPC_HOLD_MAX_XY"])
        brake = math.hypot(vx, vy) < EPS
        stopped = hold < EPS or math.hypot(vel[0], vel[1]) < hold
        locked = math.isfinite(self._pos_xy[0]) and math.isfinite(self._pos_xy[1])
        if brake and stopped and not locked:
            self._pos_xy = (pos[0], pos[1])
        elif not (locked and brake):
            self._pos_xy = (math.nan, math.nan)
        return PositionSetpoint((self._pos_xy[0], self._pos_xy[1], self.z_sp), (vx, vy, vz),
                                self.yaw_sp, (math.nan, math.nan, math.nan))
