"""The autopilot wrapper: owns params, timestamps, commander, navigator and the control libraries.

After PX4's split between libraries (PositionControl, AttitudeControl, RateControl) and module
wrappers (MulticopterPositionControl, mc_att_control, mc_rate_control, control_allocator).

Rules and invariants:
- ``update(now_s, measurement)`` is called once per physics step (250 Hz). Commander, land
  detector, navigator, trajectory and position control run every POSITION_CONTROL_DIVIDER-th step
  (50 Hz, like PX4's EKF-driven position loop); attitude, rate control and the mixer every step.
- Disarmed -> no motor output (None) and every controller is reset.
- On the ground (landed) the motors idle unless the navigator's target is clearly above the
  vehicle (PX4 takeoff handling); while the land detector reports ground contact the thrust is cut
  (PX4 ``limit_thrust_during_landing``).
- Gains come from PX4 parameter names, re-read when a parameter changes. No scale factors are
  applied: the mixer's normalization (airframe.py) makes PX4's rate gains fit this plant.
- Time is an argument; nothing here calls a clock or a physics engine.
"""

from __future__ import annotations

import math

from vehicles.airframe import Airframe
from vehicles.battery import BatterySim
from vehicles.commander import Commander
from vehicles.control.attitude_control import (
    AttitudeControl,
    AttitudeControlGains,
    AttitudeSetpoint,
    thrust_to_attitude,
)
from vehicles.control.mixer import Mixer
from vehicles.control.position_control import PositionControl, PositionControlGains, PositionSetpoint
from vehicles.control.quat import q_yaw
from vehicles.control.rate_control import RateControl, RateControlGains
from vehicles.control.trajectory import TrajectoryLimiter
from vehicles.land_detector import LandDetector
from vehicles.navigator import NavContext, Navigator, NavSetpoint, auto_limits
from vehicles.status_log import StatusLog
from vehicles.types import CommandResult, GeoPoint, HomePosition, LandedState, NavState

POSITION_CONTROL_DIVIDER = 5  # 250 Hz / 5 = 50 Hz
# Motors spin at this normalized thrust when armed and idle (PX4 idle PWM / CA idle).
IDLE_THRUST_NORM = 0.02
# The navigator must ask for this much climb before a landed vehicle spools up.
TAKEOFF_TRIGGER_M = 0.2


class Autopilot:
    def __init__(self, params, airframe: Airframe, origin: GeoPoint, dt_s: float,
                 boot_time_s: float = 0.0, name: str = "") -> None:
        self.params = params
        self.airframe = airframe
        self.origin = origin
        self.dt_s = dt_s
        self.log = StatusLog(name)
        self.commander = Commander(params, self.log, boot_time_s)
        self.navigator = Navigator()
        self.land_detector = LandDetector(params)
        self.battery = BatterySim(params, airframe.hover_thrust_norm)
        self.trajectory = TrajectoryLimiter()
        self.mixer = Mixer(airframe.mixer_rows(), IDLE_THRUST_NORM)
        self.home: HomePosition | None = None
        self._hover = airframe.hover_thrust_norm
        self._load_gains()
        params.on_change(lambda name, value: self._load_gains())
        self._tick = 0
        self._att_sp = AttitudeSetpoint((1.0, 0.0, 0.0, 0.0), 0.0)
        self._idle = True
        self._flying = False  # trajectory/controllers are live (not idling on the ground)
        self._nav_sp: NavSetpoint | None = None
        self._vel_sp_z = 0.0
        self._thrust = 0.0
        self._meas = None
        self._sat_pos = (False, False, False)
        self._sat_neg = (False, False, False)
        self.time_s = boot_time_s

    def _load_gains(self) -> None:
        self.position_control = PositionControl(
            PositionControlGains.from_params(self.params, hover_thrust=self._hover))
        self.attitude_control = AttitudeControl(AttitudeControlGains.from_params(self.params))
        self.rate_control = RateControl(RateControlGains.from_params(self.params))

    # --- commands (the Vehicle API delegates here) -----------------------------------------------
    def arm(self, now_s: float, forced: bool = False) -> CommandResult:
        was_armed = self.commander.armed
        result = self.commander.arm(now_s, forced)
        if result is CommandResult.ACCEPTED and not was_armed:
            self._set_home()
        return result

    def disarm(self, now_s: float, forced: bool = False) -> CommandResult:
        return self.commander.disarm(now_s, forced)

    def takeoff(self, now_s: float, alt_amsl_m: float = math.nan) -> CommandResult:
        if not self.commander.position_valid:
            return CommandResult.TEMPORARILY_REJECTED
        result = self.commander.request_nav_state(now_s, NavState.AUTO_TAKEOFF)
        if result is CommandResult.ACCEPTED:
            self.navigator.takeoff.requested_alt_amsl_m = alt_amsl_m
            self.navigator.takeoff.origin_alt_amsl_m = self.origin.alt_amsl_m
            self.navigator.reactivate()
        return result

    def land(self, now_s: float) -> CommandResult:
        return self.commander.request_nav_state(now_s, NavState.AUTO_LAND)

    def return_to_launch(self, now_s: float) -> CommandResult:
        if self.home is None:
            return CommandResult.TEMPORARILY_REJECTED
        return self.commander.request_nav_state(now_s, NavState.AUTO_RTL)

    def reposition(self, now_s: float, target_ned_m: tuple[float, float, float]) -> CommandResult:
        """Fly to a local NED point and hold there (what DO_REPOSITION does in PX4: Hold + target)."""
        result = self.commander.request_nav_state(now_s, NavState.AUTO_LOITER)
        if result is CommandResult.ACCEPTED:
            self.navigator.hold.hint = target_ned_m
            self.navigator.reactivate()
        return result

    def set_nav_state(self, now_s: float, nav_state: NavState) -> CommandResult:
        if nav_state is NavState.AUTO_RTL and self.home is None:
            return CommandResult.TEMPORARILY_REJECTED
        if nav_state is NavState.AUTO_TAKEOFF:
            return self.takeoff(now_s)
        return self.commander.request_nav_state(now_s, nav_state)

    # --- status ------------------------------------------------------------------------------
    @property
    def landed_state(self) -> LandedState:
        if self.land_detector.landed:
            return LandedState.ON_GROUND
        if self.commander.nav_state is NavState.AUTO_TAKEOFF:
            return LandedState.TAKEOFF
        if self._nav_sp is not None and self._nav_sp.landing:
            return LandedState.LANDING
        return LandedState.IN_AIR

    @property
    def thrust_norm(self) -> float:
        return self._thrust

    def _set_home(self) -> None:
        m = self._meas
        if m is None:
            return
        n, e, d = m.position_ned_m
        self.home = HomePosition(self.origin.offset_ned(n, e, d), (n, e, d), q_yaw(m.attitude_q))

    # --- the loop ----------------------------------------------------------------------------
    def update(self, now_s: float, meas, accel_ned_mps2) -> tuple[float, ...] | None:
        self._meas = meas
        self.time_s = now_s
        cmd = self.commander
        if self._tick % POSITION_CONTROL_DIVIDER == 0:
            self._update_slow(now_s, meas, accel_ned_mps2)
        self._tick += 1
        if not cmd.armed:
            return None
        if self._idle:
            self.rate_control.reset()
            return self.mixer.mix(0.0, (0.0, 0.0, 0.0)).motor_u
        rates_sp = self.attitude_control.update(meas.attitude_q, self._att_sp.attitude_q)
        torque = self.rate_control.update(self.dt_s, meas.rates_frd_radps, rates_sp,
                                          landed=self.land_detector.landed,
                                          saturation_positive=self._sat_pos,
                                          saturation_negative=self._sat_neg)
        out = self.mixer.mix(self._att_sp.thrust_body_norm, torque)
        self._sat_pos, self._sat_neg = out.saturation_positive, out.saturation_negative
        return out.motor_u

    def _update_slow(self, now_s: float, meas, accel) -> None:
        cmd = self.commander
        dt = self.dt_s * POSITION_CONTROL_DIVIDER
        ld = self.land_detector
        ld.update(now_s, cmd.armed, meas.velocity_ned_mps, self._vel_sp_z, self._thrust, self._hover)
        was_armed = cmd.armed
        if cmd.update(now_s, ld.landed):
            self._set_home()
        self.battery.update(now_s, cmd.armed, self._thrust if cmd.armed else 0.0)
        if was_armed and not cmd.armed:
            ld.update(now_s, False, meas.velocity_ned_mps, 0.0, 0.0, self._hover)
        yaw = q_yaw(meas.attitude_q)
        pos, vel = meas.position_ned_m, meas.velocity_ned_mps
        if not self._flying:
            self.trajectory.reset(pos, vel)
        ctx = NavContext(now_s, self.params, self.log, cmd.armed, ld.landed, pos, vel, yaw,
                         self.home, self.trajectory.position_ned_m, self.trajectory.stopping_point(
                             self._nav_sp.limits if self._nav_sp else auto_limits(self.params)),
                         self._switch_by_vehicle)
        nav_sp = self.navigator.update(cmd.nav_state, ctx)
        self._nav_sp = nav_sp
        wants_climb = (nav_sp.target_ned_m[2] < pos[2] - TAKEOFF_TRIGGER_M
                       if not math.isnan(nav_sp.target_ned_m[2]) else nav_sp.vz_cmd_mps < -0.1)
        if not cmd.armed or nav_sp.idle or (ld.landed and not wants_climb):
            self._idle = True
            self._flying = False
            self._thrust = 0.0
            self._vel_sp_z = 0.0
            self.position_control.reset_integral()
            self.rate_control.reset()
            self._att_sp = AttitudeSetpoint(meas.attitude_q, 0.0)
            return
        self._idle = False
        self._flying = True
        p_sp, v_sp, a_sp = self.trajectory.update(dt, nav_sp.target_ned_m, nav_sp.limits,
                                                  nav_sp.vz_cmd_mps, pos[2])
        out = self.position_control.update(dt, pos, vel, accel,
                                           PositionSetpoint(p_sp, v_sp, nav_sp.yaw_rad, a_sp))
        thrust = out.thrust_ned
        yaw_sp = out.yaw_rad if not math.isnan(out.yaw_rad) else yaw
        self._vel_sp_z = out.velocity_sp_ned_mps[2]
        if ld.ground_contact or ld.maybe_landed:
            thrust = (0.0, 0.0, 0.0)
            yaw_sp = yaw
            self.position_control.reset_integral()
        self._att_sp = thrust_to_attitude(thrust, yaw_sp)
        self._thrust = self._att_sp.thrust_body_norm

    def _switch_by_vehicle(self, nav_state: NavState, hold_at: tuple[float, float, float] | None
                           ) -> None:
        if nav_state is NavState.AUTO_LOITER:
            self.navigator.hold.hint = hold_at
        self.commander.switch_by_vehicle(nav_state)

