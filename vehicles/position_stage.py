"""Between the flight tasks and the inner loop: what PX4's MulticopterPositionControl module does
with a task's trajectory setpoint (position control, thrust → attitude, landing thrust limits).

Rules and invariants:
- One per autopilot. The flight task of the present navigation state (flight_tasks.py) drives it
  once per 50 Hz tick through ``set_idle``, ``start_flying``, ``apply`` (``apply_auto``: the
  auto tasks' trajectory and position control in one compiled call) or ``direct``; the
  autopilot turns what it holds (``attitude``, ``rates``, ``reset_rates``) into the inner loop's
  command.
- ``trajectory`` (the jerk-limited setpoint generator the auto tasks share) restarts from the
  measured state whenever the vehicle is not flying under it; the auto task restarts it from
  ``task_setpoint`` when it takes over from another task (FlightTaskAuto::activate).
- ``task_setpoint``: the trajectory setpoint the running task published last (PX4's
  FlightTask::getTrajectorySetpoint), what FlightModeManager::switchTask hands the next task's
  ``activate`` (the auto task's, Altitude's and Position's); None (PX4's empty setpoint) where
  PX4 runs no flight task (Offboard, Stabilized, Acro, Manual, Termination) and while the
  motors idle.
- Takeoff as PX4's mc_pos_control does it (control/takeoff.py): after arming the motors idle for
  COM_SPOOLUP_TIME; until a task wants to take off and the ramp starts the controller gets no
  setpoint (zero thrust, integrators held); then the upward speed limit ramps over MPC_TKO_RAMP_T;
  until the flight state the tilt limit is MPC_TILTMAX_LND (slewed at 0.2 rad/s) and the minimum
  thrust 0. Flying with ground contact (landing) the setpoint is dropped for a downward one, so
  the thrust sits at MPC_THR_MIN and the land detector can see the landing.
- Idle: thrust 0, integrators reset, the attitude setpoint is the measured attitude, and the
  inner loop is asked to restart its rate controller (``reset_rates``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from vehicles.auto_trajectory import AutoTrajectory
from vehicles.control.attitude_control import AttitudeSetpoint
from vehicles.control.position_control import (
    NO_THRUST_ACC,
    REACTIVATE_VEL,
    PositionControl,
    PositionControlGains,
    PositionSetpoint,
)
from vehicles.control.takeoff import FLIGHT, RAMPUP, TakeoffHandling, TakeoffState
from vehicles.control.trajectory import TrajectoryLimits
from vehicles.inner_loop import MODE_FLY, MODE_IDLE, MODE_OFF
from vehicles.land_detector import LandDetector
from vehicles.params import ParamStore
from vehicles.types import Measurement, Quat, Vec3

_NAN3: Vec3 = (math.nan, math.nan, math.nan)
# AttitudeSetpoint and PositionSetpoint made as tuples at every tick (a NamedTuple's ``__new__``
# is a Python function)
_new_tuple = tuple.__new__
TILT_LIMIT_SLEW_RADPS = 0.2  # mc_pos_control _tilt_limit_slew_rate


class PositionStage:
    def __init__(self, land_detector: LandDetector, gains: PositionControlGains,
                 params: ParamStore) -> None:
        self.land_detector = land_detector
        self.params = params
        self.takeoff = TakeoffHandling()
        self._tilt_limit = math.radians(float(params["MPC_TILTMAX_LND"]))
        self._params_version = -1  # the tilt limits below are read at the first ``apply``
        self._tilt_air_rad = self._tilt_land_rad = 0.0
        self._now_s = 0.0
        self._armed = False
        self.trajectory = AutoTrajectory(params)
        self.position_control = PositionControl(gains)
        self.attitude = AttitudeSetpoint((1.0, 0.0, 0.0, 0.0), 0.0)
        self.rates: Vec3 | None = None  # a body-rate setpoint that replaces attitude control
        self.reset_rates = False  # the inner loop restarts its rate controller (then clears it)
        self.idle = True  # motors at idle (on the ground, or nothing to fly)
        self.motors_stopped = False  # a non-finite attitude setpoint: motor commands NaN, stopped
        self.flying = False  # the trajectory and the position controller are live
        self.thrust = 0.0  # the collective thrust asked for (battery model, land detector)
        self.vel_sp_z = 0.0  # the task's vertical velocity setpoint (the land detector's input)
        self.vel_sp: Vec3 = _NAN3  # the last velocity setpoint (Orbit's and the sticks' feedback)
        self.acc_sp: Vec3 = _NAN3  # the last acceleration setpoint (PX4's _acc_sp)
        # The position controller's last thrust setpoint's z (NED; PX4's
        # vehicle_local_position_setpoint thrust[2]); NaN when it did not run this tick.
        self.thrust_z_ned = math.nan
        self.yaw_sp = math.nan  # the auto tasks' slewed heading setpoint
        # The running task's last trajectory setpoint (None: PX4's empty one), see the rules.
        self.task_setpoint: PositionSetpoint | None = None

    def set_gains(self, gains: PositionControlGains) -> None:
        """New parameters: PX4 rebuilds the controller (its integrator starts at zero)."""
        self.position_control = PositionControl(gains)
        p, tk = self.params, self.takeoff
        tk.spoolup_time_s = float(p["COM_SPOOLUP_TIME"])
        tk.ramp_time_s = float(p["MPC_TKO_RAMP_T"])
        tk.set_velocity_p_gain(float(p["MPC_Z_VEL_P_ACC"]))

    def begin_tick(self, now_s: float, armed: bool) -> None:
        """Called by the autopilot before the flight task of this 50 Hz tick."""
        self._now_s = now_s
        self.thrust_z_ned = math.nan
        self._armed = armed
        self.rates = None

    @property
    def tick_s(self) -> float:
        """When the present tick began (the setpoints' time)."""
        return self._now_s

    def _takeoff_state(self, want_takeoff: bool, skip: bool = False) -> TakeoffState:
        return self.takeoff.update_state(self._armed, self.land_detector.landed, want_takeoff,
                                         self._now_s, skip)

    @property
    def tilt_limit_rad(self) -> float:
        """mc_pos_control's slewed tilt limit (takeoff_status.tilt_limit)."""
        return self._tilt_limit

    @property
    def taking_off(self) -> bool:
        """The takeoff ramp runs (PX4 stays in rampup until the ramp ends, whatever the task
        asks: a task on the ground keeps flying its setpoint meanwhile)."""
        return self.takeoff.state is RAMPUP

    def motor_mode(self) -> int:
        """The inner loop's mode while armed: OFF for a non-finite attitude setpoint (PX4's
        mixer sends a NaN motor command as the disarmed value), IDLE or FLY."""
        return MODE_OFF if self.motors_stopped else MODE_IDLE if self.idle else MODE_FLY

    def set_idle(self, meas: Measurement) -> None:
        self._takeoff_state(False)
        self.idle = True
        self.motors_stopped = False
        self.flying = False
        self.thrust = 0.0
        self.vel_sp_z = 0.0
        self.yaw_sp = math.nan
        # On the ground FlightModeManager re-activates the task every tick (reActivate), which
        # leaves the setpoints at the state or NaN but for a zero vertical velocity: as good as
        # none for the next task (the vehicle is at rest).
        self.task_setpoint = None
        self.position_control.reset_integral()
        self.reset_rates = True
        self.attitude = _new_tuple(AttitudeSetpoint, (meas.attitude_q, 0.0, 0.0))

    def start_flying(self, meas: Measurement, reset_trajectory: bool = True) -> None:
        """The position controller takes over (the trajectory starts from the state if it was
        not running, unless ``reset_trajectory`` is False)."""
        if not self.flying and reset_trajectory:
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

    def _limits(self, dt: float, speed_up_mps: float, speed_down_mps: float = math.nan
                ) -> tuple[bool, bool]:
        """The takeoff state, tilt limit and climb-speed ramp of this tick, set on the position
        controller: (no setpoint, restart the trajectory) for ``apply``. ``speed_up_mps``: the
        task's climb speed (the takeoff ramp's end; MPC_Z_VEL_MAX_UP when NaN or above it);
        ``speed_down_mps``: its descent speed (MPC_Z_VEL_MAX_DN when NaN)."""
        pc = self.position_control
        # FlightModeManager re-activates the task on the takeoff state mc_pos_control last
        # published, the one before this tick's update
        tk = self.takeoff
        reactivate = tk.state < RAMPUP
        state = tk.update_state(self._armed, self.land_detector.landed, True, self._now_s)
        flying = state >= FLIGHT
        no_setpoint = state < RAMPUP or (flying and self.land_detector.ground_contact)
        g, p = pc.gains, self.params
        if p.version != self._params_version:
            self._params_version = p.version
            self._tilt_air_rad = math.radians(float(p["MPC_TILTMAX_AIR"]))
            self._tilt_land_rad = math.radians(float(p["MPC_TILTMAX_LND"]))
        tilt = self._tilt_air_rad if flying else self._tilt_land_rad
        step = TILT_LIMIT_SLEW_RADPS * dt
        # min(max(·, -step), step) and min(·, up_max) as comparisons (the same values, NaN
        # included)
        d = tilt - self._tilt_limit
        d = -step if -step > d else d
        self._tilt_limit += step if step < d else d
        up_max = g.vel_max_up_mps
        # updateRamp ramps towards the task's constraint, the result is clipped at
        # MPC_Z_VEL_MAX_UP afterwards (mc_pos_control setVelocityLimits)
        wanted_up = speed_up_mps if math.isfinite(speed_up_mps) else up_max
        up = tk.update_ramp(dt, wanted_up)
        up = up_max if up_max < up else up
        pc.set_limits(up, g.thrust_min if flying else 0.0, self._tilt_limit, speed_down_mps)
        # PX4 re-activates the flight task (FlightTaskAuto::reActivate) after its update until
        # the ramp starts: the smoothing restarts at the vehicle at rest but for a 0.7 m/s
        # descent, so that once the ramp starts the climb setpoint first has to turn round
        # instead of running far ahead.
        return no_setpoint, reactivate

    def apply(self, dt: float, meas: Measurement, sp: PositionSetpoint, yaw: float,
              yawspeed: float = 0.0, speed_up_mps: float = math.nan) -> None:
        """Position control on ``sp`` (the task wants to fly: a takeoff when landed), then
        thrust vector → attitude (PX4 thrustToAttitude). ``speed_up_mps``: the task's climb
        speed (the takeoff ramp's end; MPC_Z_VEL_MAX_UP when NaN or above it)."""
        pc = self.position_control
        self.task_setpoint = sp
        task_vz = sp.velocity_ned_mps[2]  # the land detector judges the task's setpoint (PX4)
        no_setpoint, reactivate = self._limits(dt, speed_up_mps)
        if reactivate:
            self.trajectory.reset(meas.position_ned_m, REACTIVATE_VEL)
        if no_setpoint:
            sp = PositionSetpoint(_NAN3, _NAN3, sp.yaw_rad, NO_THRUST_ACC)
            pc.reset_integral()
        yaw_sp = yaw if no_setpoint or math.isnan(sp.yaw_rad) else sp.yaw_rad
        q, thrust, vel_sp, acc_sp = pc.update_attitude(
            dt, meas.position_ned_m, meas.velocity_ned_mps, meas.accel_ned_mps2, sp, yaw_sp)
        if no_setpoint:
            pc.reset_integral()
        self._output(task_vz, q, thrust, vel_sp, acc_sp,
                     yawspeed if yawspeed != 0.0 and not no_setpoint else 0.0)

    def apply_auto(self, dt: float, meas: Measurement, target_ned_m: Vec3,
                   lim: TrajectoryLimits, vz_cmd_mps: float, previous_ned_m: Vec3 | None,
                   next_ned_m: Vec3 | None, acceptance_radius_m: float, yaw: float,
                   yawspeed: float = 0.0, hold: bool = False,
                   heading_of: Callable[[Vec3], tuple[float, float]] | None = None) -> None:
        """The auto tasks' ``trajectory.update`` towards the navigator's triplet (the vehicle's
        position for the lag stretch and the vertical-speed altitude) and then ``apply`` on its
        setpoint at the heading ``yaw_sp`` and the limits' climb speed, in one compiled call
        (position_control.auto_position_attitude_step). ``hold``: a zero velocity setpoint
        (force_zero_velocity_setpoint: MPC_YAW_MODE 4 waiting for the heading). ``heading_of``:
        the heading comes from this tick's trajectory (FlightTaskAuto::update computes
        _generateHeadingAlongTraj after the smoothing): given the velocity setpoint it returns
        (``yaw_sp``, ``yawspeed``), between the trajectory and position control (two calls)."""
        traj, pc = self.trajectory, self.position_control
        traj.set_up(lim)
        # FlightTaskAuto::_updateTrajConstraints: the controller's climb constraint is at least
        # MPC_Z_VEL_MAX_UP (the default) and 1.2 x MPC_Z_V_AUTO_UP, whatever the trajectory's
        # own climb speed (MPC_TKO_SPEED in a takeoff): the takeoff ramp runs towards it; the
        # descent's at least MPC_Z_VEL_MAX_DN and 1.2 x MPC_Z_V_AUTO_DN; both raised to the
        # smoothing's vertical speed while it brakes in an emergency.
        speed_up, speed_down = traj.controller_speed_limits()
        no_setpoint, reactivate = self._limits(dt, speed_up, speed_down)
        braking = traj.emergency_braking
        s = traj.smoothing
        s.set_auto_input(meas.position_ned_m, previous_ned_m, target_ned_m, next_ned_m, None)
        if heading_of is not None:
            smoothed = pc.trajectory_auto(s, dt, previous_ned_m is not None,
                                          next_ned_m is not None,
                                          traj.acceptance_radius(acceptance_radius_m),
                                          vz_cmd_mps, braking or hold)
            p_sp, v_sp, a_sp = smoothed
            self.yaw_sp, yawspeed = heading_of(v_sp)
            yaw_sp = yaw if no_setpoint or math.isnan(self.yaw_sp) else self.yaw_sp
            q, thrust, vel_sp, acc_sp = pc.attitude_auto(
                s, dt, smoothed, meas.velocity_ned_mps, meas.accel_ned_mps2, yaw_sp,
                no_setpoint, reactivate)
        else:
            yaw_sp = yaw if no_setpoint or math.isnan(self.yaw_sp) else self.yaw_sp
            p_sp, v_sp, a_sp, q, thrust, vel_sp, acc_sp = pc.update_attitude_auto(
                s, dt, previous_ned_m is not None, next_ned_m is not None,
                traj.acceptance_radius(acceptance_radius_m), vz_cmd_mps, meas.velocity_ned_mps,
                meas.accel_ned_mps2, yaw_sp, no_setpoint, reactivate, braking or hold)
        self.task_setpoint = _new_tuple(PositionSetpoint, (p_sp, v_sp, self.yaw_sp, a_sp))
        if reactivate:
            # FlightTaskAuto::reActivate → activate with no last setpoint: no emergency braking,
            # the setpoints are the state's and the heading slews on from the vehicle's
            # (_yaw_sp_prev = _yaw), not from this tick's slewed setpoint
            traj.emergency_braking = False
            self.yaw_sp = yaw
            self.task_setpoint = None
        # the heading rate feed-forward (FlightTaskAuto::_limitYawRate), none on the ground
        self._output(v_sp[2], q, thrust, vel_sp, acc_sp, 0.0 if no_setpoint else yawspeed)

    def _output(self, task_vz: float, q: Quat, thrust: float, vel_sp: Vec3, acc_sp: Vec3,
                yawspeed: float) -> None:
        # The land detector judges the task's vertical velocity setpoint (PX4), else the
        # controller's.
        self.vel_sp_z = task_vz if math.isfinite(task_vz) else vel_sp[2]
        self.vel_sp = vel_sp
        self.acc_sp = acc_sp
        qw, qx, qy, qz = q
        self.thrust_z_ned = -thrust * (1.0 - 2.0 * (qx * qx + qy * qy))  # along body z
        self.attitude = _new_tuple(AttitudeSetpoint, (q, thrust, yawspeed))
        self.thrust = thrust

    def direct(self, attitude: AttitudeSetpoint, rates: Vec3 | None = None,
               flying: bool = False) -> None:
        """An attitude (or body-rate) and thrust setpoint straight to the inner loop, no position
        control (Stabilized, Acro, Offboard attitude/rates/acceleration); ``flying``: the
        position controller's state stays live (Offboard acceleration). Without climb-rate
        control there is no takeoff ramp (PX4 skip_takeoff)."""
        self._takeoff_state(False, skip=True)
        self.idle = False
        self.motors_stopped = False
        self.flying = flying
        self.task_setpoint = None  # PX4 runs no flight task in these modes
        self.vel_sp_z = math.nan
        self.attitude = attitude
        self.rates = rates
        self.thrust = attitude.thrust_body_norm

    def setpoint_ned_m(self) -> Vec3 | None:
        """The trajectory's position setpoint while flying under it (flight logs)."""
        return self.trajectory.position_ned_m if self.flying else None
