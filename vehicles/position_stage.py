"""Between the flight tasks and the inner loop: what PX4's MulticopterPositionControl module does
with a task's trajectory setpoint (position control, thrust → attitude, landing thrust limits).

Rules and invariants:
- One per autopilot. The flight task of the present navigation state (flight_tasks.py) drives it
  once per 50 Hz tick through ``set_idle``, ``start_flying``, ``apply`` or ``direct``; the
  autopilot turns what it holds (``attitude``, ``rates``, ``reset_rates``) into the inner loop's
  command.
- ``trajectory`` (the jerk-limited setpoint generator the auto tasks share) restarts from the
  measured state whenever the vehicle is not flying under it, so a switch brakes from the real
  state.
- While the land detector reports ground contact (or maybe landed) the thrust is cut and the
  position integrator held at zero (PX4 ``limit_thrust_during_landing``).
- Idle: thrust 0, integrators reset, the attitude setpoint is the measured attitude, and the
  inner loop is asked to restart its rate controller (``reset_rates``).
"""

from __future__ import annotations

import math

from vehicles.control.attitude_control import AttitudeSetpoint, thrust_to_attitude
from vehicles.control.position_control import (
    PositionControl,
    PositionControlGains,
    PositionSetpoint,
)
from vehicles.control.trajectory import TrajectoryLimiter
from vehicles.land_detector import LandDetector
from vehicles.types import Measurement, Vec3

_NAN3: Vec3 = (math.nan, math.nan, math.nan)


class PositionStage:
    def __init__(self, land_detector: LandDetector, gains: PositionControlGains) -> None:
        self.land_detector = land_detector
        self.trajectory = TrajectoryLimiter()
        self.position_control = PositionControl(gains)
        self.attitude = AttitudeSetpoint((1.0, 0.0, 0.0, 0.0), 0.0)
        self.rates: Vec3 | None = None  # a body-rate setpoint that replaces attitude control
        self.reset_rates = False  # the inner loop restarts its rate controller (then clears it)
        self.idle = True  # motors at idle (on the ground, or nothing to fly)
        self.flying = False  # the trajectory and the position controller are live
        self.thrust = 0.0  # the collective thrust asked for (battery model, land detector)
        self.vel_sp_z = 0.0  # the vertical velocity setpoint (land detector)
        self.vel_sp: Vec3 = _NAN3  # the last velocity setpoint (Orbit's and the sticks' feedback)
        self.yaw_sp = math.nan  # the auto tasks' slewed heading setpoint

    def set_gains(self, gains: PositionControlGains) -> None:
        """New parameters: PX4 rebuilds the controller (its integrator starts at zero)."""
        self.position_control = PositionControl(gains)

    def set_idle(self, meas: Measurement) -> None:
        self.idle = True
        self.flying = False
        self.thrust = 0.0
        self.vel_sp_z = 0.0
        self.yaw_sp = math.nan
        self.position_control.reset_integral()
        self.reset_rates = True
        self.attitude = AttitudeSetpoint(meas.attitude_q, 0.0)

    def start_flying(self, meas: Measurement) -> None:
        """The position controller takes over (the trajectory starts from the state if it was
        not running)."""
        if not self.flying:
            self.trajectory.reset(meas.position_ned_m, meas.velocity_ned_mps)
        self.idle = False
        self.flying = True

    def take_off_or_idle(self, meas: Measurement, armed: bool) -> bool:
        """For the tasks that do not take off (Orbit, Follow Me): False, motors idle, when
        disarmed or on the ground; else flying."""
        if not armed or self.land_detector.landed:
            self.trajectory.reset(meas.position_ned_m, meas.velocity_ned_mps)
            self.set_idle(meas)
            return False
        self.start_flying(meas)
        return True

    def apply(self, dt: float, meas: Measurement, sp: PositionSetpoint, yaw: float,
              yawspeed: float = 0.0) -> None:
        """Position control on ``sp``, then thrust vector → attitude (PX4 thrustToAttitude)."""
        ld = self.land_detector
        out = self.position_control.update(dt, meas.position_ned_m, meas.velocity_ned_mps,
                                           meas.accel_ned_mps2, sp)
        thrust = out.thrust_ned
        yaw_sp = out.yaw_rad if not math.isnan(out.yaw_rad) else yaw
        self.vel_sp_z = out.velocity_sp_ned_mps[2]
        self.vel_sp = out.velocity_sp_ned_mps
        on_ground = ld.ground_contact or ld.maybe_landed
        if on_ground:
            thrust = (0.0, 0.0, 0.0)
            yaw_sp = yaw
            self.position_control.reset_integral()
        att_sp = thrust_to_attitude(thrust, yaw_sp)
        if yawspeed != 0.0 and not on_ground:
            att_sp = AttitudeSetpoint(att_sp.attitude_q, att_sp.thrust_body_norm, yawspeed)
        self.attitude = att_sp
        self.thrust = att_sp.thrust_body_norm

    def direct(self, attitude: AttitudeSetpoint, rates: Vec3 | None = None,
               flying: bool = False) -> None:
        """An attitude (or body-rate) and thrust setpoint straight to the inner loop, no position
        control (Stabilized, Acro, Offboard attitude/rates/acceleration); ``flying``: the
        position controller's state stays live (Offboard acceleration)."""
        self.idle = False
        self.flying = flying
        self.vel_sp_z = math.nan
        self.attitude = attitude
        self.rates = rates
        self.thrust = attitude.thrust_body_norm

    def setpoint_ned_m(self) -> Vec3 | None:
        """The trajectory's position setpoint while flying under it (flight logs)."""
        return self.trajectory.position_ned_m if self.flying else None
