"""Position Slow: Position mode under lower speed and yaw-rate limits.

After PX4 v1.15 ``flight_mode_manager/tasks/ManualAccelerationSlow`` (FlightModeManager runs it in
NAVIGATION_STATE_POSITION_SLOW, custom main mode POSCTL, sub mode POSCTL_SLOW):
- it is Position mode (FlightTaskManualAcceleration, manual_control.ManualPosition) whose
  horizontal speed (StickAccelerationXY's velocity constraint, the acceleration scaled with it),
  vertical stick speeds (FlightTaskManualAltitude's up and down constraints) and yaw rate
  (StickYaw's yawspeed constraint) are limited below MPC_VEL_MANUAL, MPC_Z_VEL_MAX_UP/DN and
  MPC_MAN_Y_MAX;
- the limits come from the last SET_VELOCITY_LIMITS (the ``velocity_limits`` topic, as
  mavlink_receiver publishes it: every such message on any link, whatever its target; a new
  subscriber reads the last one published, so a limit sent before the mode is entered applies):
  each finite field, raised to its MC_SLOW_MIN_* floor;
- a knob mapped by MC_SLOW_MAP_HVEL/VVEL/YAWR (1..6: AUX1..AUX6) scales its limit between the
  floor (knob at -1) and the limit (+1). This simulation has no RC input, and PX4's MANUAL_CONTROL
  handler fills no aux channel, so a mapped knob reads 0: half-way;
- a limit set by neither is MC_SLOW_DEF_HVEL, MC_SLOW_DEF_VVEL (up and down) or MC_SLOW_DEF_YAWR.

Pure: the constraints are computed at each update from the parameters and the last limits.
"""

from __future__ import annotations

import math

from vehicles.control.position_control import PositionSetpoint
from vehicles.manual_control import EPS, ManualPosition, Sticks, gradual
from vehicles.types import Vec3

AUX_INPUT = 0.0  # every aux channel of manual_control_setpoint here (module rules)


class VelocityLimits:
    """The ``velocity_limits`` topic: the last SET_VELOCITY_LIMITS' horizontal speed (m/s),
    vertical speed (m/s) and yaw rate (rad/s), NaN where it sets none; None before any."""

    __slots__ = ("last",)

    def __init__(self) -> None:
        self.last: tuple[float, float, float] | None = None

    def publish(self, horizontal_mps: float, vertical_mps: float, yaw_rate_rps: float) -> None:
        self.last = (float(horizontal_mps), float(vertical_mps), float(yaw_rate_rps))


def _knob_scale(floor: float, limit: float) -> float:
    """The knob's scale of ``limit``: from floor / limit (knob -1) to 1 (knob +1)."""
    return gradual(AUX_INPUT, -1.0, 1.0, floor / max(limit, EPS), 1.0)


class ManualPositionSlow(ManualPosition):
    """FlightTaskManualAccelerationSlow: sets the constraints, then runs Position mode."""

    def __init__(self, params, limits: VelocityLimits) -> None:
        super().__init__(params)
        self.limits = limits

    def constrain(self) -> None:
        """FlightTaskManualAccelerationSlow::update's limits, onto the constraints."""
        p = self.params
        horizontal = float(p["MPC_VEL_MANUAL"])
        up, down = float(p["MPC_Z_VEL_MAX_UP"]), float(p["MPC_Z_VEL_MAX_DN"])
        yaw_rate = math.radians(float(p["MPC_MAN_Y_MAX"]))
        min_h, min_v = float(p["MC_SLOW_MIN_HVEL"]), float(p["MC_SLOW_MIN_VVEL"])
        min_yaw = math.radians(float(p["MC_SLOW_MIN_YAWR"]))
        h_set = v_set = yaw_set = False
        last = self.limits.last
        if last is not None:
            h, v, yr = last
            if math.isfinite(h):
                horizontal, h_set = max(h, min_h), True
            if math.isfinite(v):
                up = down = max(v, min_v)
                v_set = True
            if math.isfinite(yr):
                yaw_rate, yaw_set = max(yr, min_yaw), True
        if int(p["MC_SLOW_MAP_HVEL"]) != 0:
            horizontal *= _knob_scale(min_h, horizontal)
            h_set = True
        if int(p["MC_SLOW_MAP_VVEL"]) != 0:
            up, down = up * _knob_scale(min_v, up), down * _knob_scale(min_v, down)
            v_set = True
        if int(p["MC_SLOW_MAP_YAWR"]) != 0:
            yaw_rate *= _knob_scale(min_yaw, yaw_rate)
            yaw_set = True
        if not h_set:
            horizontal = float(p["MC_SLOW_DEF_HVEL"])
        if not v_set:
            up = down = float(p["MC_SLOW_DEF_VVEL"])
        if not yaw_set:
            yaw_rate = math.radians(float(p["MC_SLOW_DEF_YAWR"]))
        self.velocity_constraint = max(horizontal, EPS)  # setVelocityConstraint
        self.velocity_constraint_up, self.velocity_constraint_down = up, down
        self.yawspeed_constraint = yaw_rate

    def update(self, dt: float, sticks: Sticks, pos: Vec3, vel: Vec3, yaw: float,
               vel_sp_feedback: Vec3, home_z: float = math.nan) -> PositionSetpoint:
        self.constrain()
        return super().update(dt, sticks, pos, vel, yaw, vel_sp_feedback, home_z)
