"""The autopilot wrapper: owns params, timestamps, commander, navigator and the control libraries,
after PX4's split between libraries (PositionControl, AttitudeControl, RateControl) and module
wrappers (MulticopterPositionControl, mc_att_control, mc_rate_control, control_allocator).

Rules and invariants:
- ``step(measurement, now_s)`` is the 50 Hz part, called by the Vehicle every
  POSITION_CONTROL_DIVIDER-th physics step (its ``phase`` picks which of the five): commander,
  land detector, navigator, the flight task of the present navigation state (flight_tasks.py, a
  table as PX4's FlightModeManager keeps) and position control (position_stage.py). It returns the
  ``InnerCommand`` the World's compiled inner loop (attitude, rate control, mixer; 250 Hz) applies.
  Between ticks ``poll()`` returns a new command only when one is due (an arm, a disarm, a
  termination, new gains).
- Commands that need where the vehicle is (arm sets home, DO_SET_HOME, DO_REPOSITION) take the
  vehicle's latest ``Measurement`` as an argument; nothing here reads the World.
- Disarmed or terminated -> no motor output (the inner loop's OFF mode).
- Gains come from PX4 parameter names, re-read when a parameter changes. No scale factors are
  applied: the mixer's normalization (airframe.py) makes PX4's rate gains fit this plant.
- Failsafe inputs (battery level, geofence, offboard freshness, the failure detector) are gathered
  here every 50 Hz tick and handed to the commander, which owns the failsafe state machine.
- Time is an argument; nothing here calls a clock or a physics engine.
"""

from __future__ import annotations

import math

from vehicles import reposition
from vehicles.actuator_test import ActuatorTest
from vehicles.airframe import Airframe
from vehicles.auto_trajectory import AutoTrajectory
from vehicles.battery import BatterySim
from vehicles.calibration import Calibration
from vehicles.commander import Commander
from vehicles.control.attitude_control import AttitudeControlGains
from vehicles.control.hover_thrust import HoverThrustEstimator
from vehicles.control.position_control import PositionControl, PositionControlGains
from vehicles.control.quat import q_yaw
from vehicles.control.rate_control import RateControlGains
from vehicles.events import MISSION_START_DENIED, ArmReason, Log
from vehicles.failsafe import FailsafeFlags
from vehicles.failure_detector import FailureDetector, attitude_control
from vehicles.flight_task import check_resets
from vehicles.flight_tasks import TaskInput, make_tasks
from vehicles.follow_target import FollowTarget
from vehicles.geodesy import position_fault
from vehicles.geofence import Geofence
from vehicles.inner_loop import MODE_OFF, MODE_TEST, InnerCommand
from vehicles.land_detector import LandDetector
from vehicles.manual_control import ManualControl, Sticks
from vehicles.mode_table import STICK_OVERRIDE_AUTO, ArmEvent
from vehicles.nav_roi import Params7
from vehicles.navigator import NavContext, Navigator
from vehicles.offboard import Offboard
from vehicles.orbit import Orbit, OrbitStatus
from vehicles.params import ParamStore
from vehicles.plan_types import PlanType
from vehicles.plans import PlanStore
from vehicles.position_params import constrain_params
from vehicles.position_slow import VelocityLimits
from vehicles.position_stage import PositionStage
from vehicles.status_log import StatusLog
from vehicles.types import (
    Changes,
    CommandResult,
    GeoPoint,
    HomePosition,
    LandedState,
    Measurement,
    NavState,
    Severity,
    Vec3,
)

POSITION_CONTROL_DIVIDER = 5  # 250 Hz / 5 = 50 Hz
# InnerCommand and TaskInput made as tuples at every tick (a NamedTuple's ``__new__`` is a Python
# function)
_new_tuple = tuple.__new__
BATTERY_TEXTS = {1: (Severity.CRITICAL, "Low battery\t"), 2: (Severity.CRITICAL, "Critical battery\t"),
                 3: (Severity.EMERGENCY, "Emergency battery level\t")}  # batteryCheck.cpp's


class Autopilot:
    def __init__(self, params: ParamStore, airframe: Airframe, origin: GeoPoint, dt_s: float,
                 boot_time_s: float = 0.0, name: str = "") -> None:
        """``dt_s``: the physics step (the 50 Hz part runs every POSITION_CONTROL_DIVIDER-th)."""
        self.params = params
        self.airframe = airframe
        self.origin = origin
        self.dt_s = dt_s
        self.changes = Changes()  # what the links poll (vehicles/types.py)
        self.log = StatusLog(name, changes=self.changes)
        self.commander = Commander(params, self.log, boot_time_s)
        self.plans = PlanStore()
        self.navigator = Navigator(self.plans, self.changes, self.log)
        self.geofence = Geofence(params)
        self.plans.on_change(self._plan_changed)
        self.offboard, self.failure_detector = Offboard(), FailureDetector()
        self.manual = ManualControl(params)
        self.orbit_task = Orbit(params, self.log)
        self.follow_target = FollowTarget(params)
        self.velocity_limits = VelocityLimits()  # SET_VELOCITY_LIMITS (Position Slow)
        self.land_detector = LandDetector(params)
        self.battery = BatterySim(params, airframe.hover_thrust_norm)
        self.calibration = Calibration(self.log)
        self.home: HomePosition | None = None
        self.hover_thrust = HoverThrustEstimator(params)
        self._prev_nav_state: NavState | None = None
        # the estimator's resets (set_position_aided), the counts the tasks last saw
        self._resets, self._resets_seen = [0.0] * 10, [0.0] * 4
        self._fence_breach: str | None = None
        self._battery_level = 0
        self.last_meas: Measurement | None = None  # the measurement of the last 50 Hz tick
        self.stage = PositionStage(self.land_detector, self._position_gains(), params)
        self.tasks = make_tasks(self.stage, params, self.navigator, self.offboard, self.manual,
                                self.orbit_task, self.follow_target, self.hover_thrust,
                                self.velocity_limits)
        self._new_gains = True
        self.motor_test = ActuatorTest()
        self._load_gains()
        params.on_change(lambda name, value: self._load_gains())
        self._params_version = -1  # the values below are read at the first 50 Hz tick
        self._of_loss_t_s = self._rc_loss_t_s = self._early_takeoff_s = 0.0
        self._battery_thresholds: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._gf_action = 0
        self._flags_inputs: tuple[object, ...] = ()  # what ``_flags`` was built from
        self._flags = FailsafeFlags(armed=False, user_nav_state=NavState.AUTO_LOITER)
        self._out = InnerCommand(MODE_OFF, (1.0, 0.0, 0.0, 0.0), 0.0, 0.0, None, True, None, False)
        self.time_s = boot_time_s

    @property
    def trajectory(self) -> AutoTrajectory:
        return self.stage.trajectory

    @property
    def position_control(self) -> PositionControl:
        return self.stage.position_control

    def _plan_changed(self, plan_type: PlanType) -> None:
        if plan_type is PlanType.FENCE:
            home = self.home.position_ned_m[:2] if self.home is not None else None
            here = None
            if not self.land_detector.landed and self.last_meas is not None:
                n, e, _ = self.last_meas.position_ned_m
                here = (n, e)
            self.geofence.load(self.plans.get(PlanType.FENCE), self.origin, home, here, self.log,
                               self.time_s)
        if plan_type is PlanType.MISSION:
            self.navigator.cruise_mps = math.nan  # a new mission starts at cruise speed

    def _position_gains(self) -> PositionControlGains:
        return PositionControlGains.from_params(self.params,
                                                hover_thrust=self.hover_thrust.hover_thrust)

    def _update_params(self) -> None:
        """The parameters the 50 Hz part reads, re-read when one changes."""
        p = self.params
        self._params_version = p.version
        self._of_loss_t_s, self._rc_loss_t_s = float(p["COM_OF_LOSS_T"]), float(p["COM_RC_LOSS_T"])
        self._battery_thresholds = (float(p["BAT_LOW_THR"]), float(p["BAT_CRIT_THR"]),
                                    float(p["BAT_EMERGEN_THR"]))
        self._gf_action = int(p["GF_ACTION"])
        self._early_takeoff_s = float(p["COM_SPOOLUP_TIME"]) + 3.0

    def _load_gains(self) -> None:
        self.stage.set_gains(self._position_gains())
        self.attitude_gains = AttitudeControlGains.from_params(self.params)
        self.rate_gains = RateControlGains.from_params(self.params)
        self._new_gains = True  # the inner loop takes them (and restarts its integrator)

    # --- commands (the Vehicle API delegates here) -----------------------------------------------
    def arm(self, now_s: float, here: Measurement, forced: bool = False,
            reason: ArmReason = ArmReason.COMMAND_EXTERNAL) -> CommandResult:
        """``here``: the vehicle's latest measurement (arming sets home there if positioned)."""
        was_armed = self.commander.armed
        if not was_armed and self.calibration.busy:
            self.commander.deny_arming_calibrating(now_s)
            return CommandResult.TEMPORARILY_REJECTED
        self._refresh_requirements(now_s)
        result = self.commander.arm(now_s, forced, reason)
        if result is CommandResult.ACCEPTED and not was_armed:
            self.motor_test.clear()
            if self.commander.position_valid:  # Stabilized and the like arm without a position
                self._set_home(here, now_s)
        return result

    def takeoff(self, now_s: float, alt_amsl_m: float = math.nan) -> CommandResult:
        result = self.commander.request_nav_state(now_s, NavState.AUTO_TAKEOFF)
        if result is CommandResult.ACCEPTED:
            self.navigator.takeoff.requested_alt_amsl_m = alt_amsl_m
            self.navigator.takeoff.origin_alt_amsl_m = self.origin.alt_amsl_m
            self.navigator.reactivate()
        return result

    def land(self, now_s: float) -> CommandResult:
        return self.commander.command_mode(now_s, NavState.AUTO_LAND)

    def return_to_launch(self, now_s: float) -> CommandResult:
        self._refresh_requirements(now_s)  # home_valid: Return needs a home (armed)
        return self.commander.command_mode(now_s, NavState.AUTO_RTL)

    def reposition(self, now_s: float, target_ned_m: tuple[float, float, float]) -> CommandResult:
        """Fly to a local NED point and hold there (what DO_REPOSITION does in PX4: Hold + target)."""
        result = self.commander.request_nav_state(now_s, NavState.AUTO_LOITER)
        if result is CommandResult.ACCEPTED:
            self.navigator.hold.reposition = target_ned_m
            self.navigator.reactivate()
        return result

    def set_nav_state(self, now_s: float, nav_state: NavState) -> CommandResult:
        self._refresh_requirements(now_s)
        if nav_state is NavState.AUTO_TAKEOFF:
            return self.takeoff(now_s)
        return self.commander.request_nav_state(now_s, nav_state)

    # --- missions, offboard, actions (README "the PX4 persona") ----------------------------------
    def _refresh_requirements(self, now_s: float) -> None:
        if self.params.version != self._params_version:
            constrain_params(self.params, now_s, self.log, self.commander.events)  # mc_pos_control
            self._update_params()
        c = self.commander
        c.mission_valid = self.navigator.mission.check.update(now_s, self)
        c.offboard_available = self.offboard.fresh(now_s, self._of_loss_t_s)
        c.manual_control_available = self.manual.fresh(now_s, self._rc_loss_t_s)
        c.home_valid = self.home is not None

    def manual_control(self, now_s: float, sticks: Sticks, source: object = None
                       ) -> ArmEvent | None:
        """Stick input (MANUAL_CONTROL) from ``source``. Moving the sticks in an auto mode
        (COM_RC_OVERRIDE bit 0) or in Offboard (bit 1) switches to Position, as Commander's
        stick override does. Returns the arming request a stick gesture completed."""
        if not self.manual.set(now_s, sticks, source):
            return None
        c = self.commander
        c.throttle_above_center, c.throttle_low = sticks.throttle > 0.2, sticks.throttle < -0.8
        c.sticks_seen_disarmed()
        bits, state = int(self.params["COM_RC_OVERRIDE"]), c.nav_state
        if self.manual.moving and c.armed and not c.terminated and (
                (bits & 1 and state in STICK_OVERRIDE_AUTO) or (bits & 2 and state is NavState.OFFBOARD)):
            self._refresh_requirements(now_s)
            c.stick_override(now_s)
        return self.manual.gesture

    def start_mission(self, now_s: float, here: Measurement, first_seq: float = -1) -> CommandResult:
        """MISSION_START (Commander.cpp): Mission mode and arm. ``first_seq`` is the command's
        param1: finite, >= -1 and below the item count, else DENIED; from 0 up it picks the
        first item (navigator_main.cpp), below 0 the mission goes on where it is."""
        mission = self.navigator.mission
        if not (mission.check.update(now_s, self) and mission.valid()):
            self.log.critical(now_s, MISSION_START_DENIED.message + "\t")
            self.log.event(now_s, MISSION_START_DENIED, Log.CRITICAL, Log.INFO)
            return CommandResult.DENIED
        if not (math.isfinite(first_seq) and -1 <= first_seq < len(mission.items)):
            return CommandResult.DENIED
        if first_seq >= 0:
            mission.set_current(int(first_seq), resolve_jump=True)  # goToItem
        if (self.set_nav_state(now_s, NavState.AUTO_MISSION) is not CommandResult.ACCEPTED
                or self.arm(now_s, here, reason=ArmReason.MISSION_START) is not CommandResult.ACCEPTED):
            return CommandResult.TEMPORARILY_REJECTED  # Commander says printRejectMode's text
        return CommandResult.ACCEPTED

    def goto(self, now_s: float, here: Measurement, lat_deg: float, lon_deg: float,
             alt_amsl_m: float, yaw_rad: float = math.nan, speed_mps: float = math.nan,
             what: str = "Reposition") -> CommandResult:
        """DO_REPOSITION / DO_CHANGE_ALTITUDE (vehicles/reposition.py)."""
        return reposition.goto(self, now_s, here, lat_deg, lon_deg, alt_amsl_m, yaw_rad,
                               speed_mps, what)

    def orbit(self, now_s: float, radius_m: float, speed_mps: float, yaw_behaviour: float,
              lat_deg: float, lon_deg: float, alt_amsl_m: float) -> CommandResult:
        """DO_ORBIT: switch to Orbit; its task takes the parameters at the next 50 Hz tick."""
        result = self.set_nav_state(now_s, NavState.ORBIT)
        if result is CommandResult.ACCEPTED:
            center = None
            if not (math.isnan(lat_deg) or math.isnan(lon_deg)):
                n, e, _ = self.origin.ned_of(GeoPoint(lat_deg, lon_deg, self.origin.alt_amsl_m))
                center = (n, e)
            down = self.origin.alt_amsl_m - alt_amsl_m if math.isfinite(alt_amsl_m) else math.nan
            self.tasks.orbit.pending = (radius_m, speed_mps, yaw_behaviour, center, down)
        return result

    def set_follow_target(self, now_s: float, lat_deg: float, lon_deg: float, alt_amsl_m: float,
                          velocity_ned_mps: tuple[float, float, float]) -> None:
        """FOLLOW_TARGET: where the target is (used in Follow Me)."""
        n, e, d = self.origin.ned_of(GeoPoint(lat_deg, lon_deg, alt_amsl_m))
        self.follow_target.set_target(now_s, (n, e, d), velocity_ned_mps)

    @property
    def orbit_status(self) -> OrbitStatus | None:
        if (self.commander.nav_state is not NavState.ORBIT or not self.stage.flying
                or self.tasks.orbit.failed is not None):  # FlightTaskFailsafe: no orbit_status
            return None
        return self.orbit_task.status()

    def change_speed(self, now_s: float, speed_mps: float) -> CommandResult:
        self.navigator.set_cruise_mps(speed_mps)
        return CommandResult.ACCEPTED

    def set_roi(self, now_s: float, command: int, params: Params7) -> CommandResult:
        self.navigator.set_roi(command, params, now_s)
        return CommandResult.ACCEPTED

    def set_home(self, now_s: float, here: Measurement, geo: GeoPoint | None = None,
                 yaw_rad: float = math.nan) -> CommandResult:
        """DO_SET_HOME: at ``geo`` facing ``yaw_rad`` (NaN: none, as HomePosition::setManually
        takes it), or where the vehicle is (``here``) when None."""
        if not int(self.params["COM_HOME_EN"]) or not self.commander.position_valid:
            return CommandResult.TEMPORARILY_REJECTED
        if geo is None:
            self._set_home(here, now_s)
            return CommandResult.ACCEPTED
        # PX4 denies non-finite coordinates; a point no position message can carry is denied too
        # (HOME_POSITION would overflow).
        if position_fault(geo.lat_deg, geo.lon_deg, geo.alt_amsl_m) is not None:
            return CommandResult.DENIED
        self.home = HomePosition(geo, self.origin.ned_of(geo), yaw_rad, now_s)  # setManually
        return CommandResult.ACCEPTED

    def terminate(self, now_s: float) -> CommandResult:
        return self.commander.terminate(now_s)

    # --- status ------------------------------------------------------------------------------
    @property
    def landed_state(self) -> LandedState:
        if self.land_detector.landed:
            return LandedState.ON_GROUND
        nav_sp = self.tasks.auto.setpoint
        if self.commander.nav_state is NavState.AUTO_TAKEOFF or (
                nav_sp is not None and nav_sp.taking_off):
            return LandedState.TAKEOFF
        if nav_sp is not None and nav_sp.landing:
            return LandedState.LANDING
        return LandedState.IN_AIR

    @property
    def thrust_norm(self) -> float:
        return self.stage.thrust

    def _set_home(self, here: Measurement, now_s: float) -> None:
        n, e, d = here.position_ned_m
        self.home = HomePosition(self.origin.offset_ned(n, e, d), (n, e, d), q_yaw(here.attitude_q), now_s)

    # --- the loop ----------------------------------------------------------------------------
    def step(self, meas: Measurement, now_s: float) -> InnerCommand:
        """The 50 Hz part on the state measured at ``now_s``: the inner loop's next command."""
        self.time_s = now_s
        self.last_meas = meas
        self._update_slow(now_s, meas)
        self.calibration.update(now_s)
        if self.motor_test.tests:
            self.motor_test.expire(now_s)
        return self._command()

    def poll(self, now_s: float) -> InnerCommand | None:
        """Between 50 Hz ticks: a new command when the motor mode changed since the last one
        (arm, disarm, termination) or new gains wait; else None (the inner loop keeps its)."""
        self.time_s = now_s
        if self._new_gains or self.motor_test.changed:
            return self._command()
        cmd = self.commander  # the motor mode as ``_command`` picks it (every physics step)
        if not cmd.armed or cmd.terminated:
            mode = MODE_OFF if cmd.armed or cmd.terminated or not self.motor_test.tests else MODE_TEST
        else:
            mode = self.stage.motor_mode()
        return self._command() if mode != self._out.mode else None

    def _command(self) -> InnerCommand:
        st = self.stage
        gains = None
        if self._new_gains:
            gains = (self.attitude_gains.coefficients(), self.rate_gains.vector(),
                     float(self.params["THR_MDL_FAC"]))
            self._new_gains = False
        sp = st.attitude
        cmd, test = self.commander, self.motor_test  # the motor mode
        if not cmd.armed or cmd.terminated:
            mode = MODE_OFF if cmd.armed or cmd.terminated or not test.tests else MODE_TEST
        else:
            mode = st.motor_mode()
        test.changed = False
        self._out = _new_tuple(InnerCommand, (
            mode, sp.attitude_q, sp.yawspeed_radps, sp.thrust_body_norm, st.rates,
            self.land_detector.landed, gains, st.reset_rates,
            test.values() if mode == MODE_TEST else ()))
        st.reset_rates = False
        return self._out

    @property
    def last_command(self) -> InnerCommand:
        """What the inner loop flies now (the last ``step`` or ``poll`` that built one)."""
        return self._out

    def set_position_aided(self, aided: bool, resets: list[float] | None = None) -> None:
        """The estimator's word on its position (vehicles/estimation.py: a fix within
        EKF2_NOAID_TOUT), which the commander's ``position_valid`` follows, and its resets
        (World.aiding: the counts and changes of E_XY_RESET, E_VXY_RESET, E_VZ_RESET)."""
        self.commander.position_aided = aided
        if resets is not None:
            self._resets = resets

    def position_setpoint_ned_m(self) -> Vec3 | None:
        """The trajectory's position setpoint while armed and flying under it."""
        return self.stage.setpoint_ned_m() if self.commander.armed else None

    def _failsafe_flags(self, now_s: float, pos: Vec3) -> FailsafeFlags:
        """(Called after ``_refresh_requirements``: the parameters are current.)"""
        remaining = self.battery.remaining
        low, critical, emergency = self._battery_thresholds  # the last one reached counts
        level = (3 if remaining <= emergency else 2 if remaining <= critical
                 else 1 if remaining <= low else 0)
        if level > self._battery_level:
            self.log.add(now_s, BATTERY_TEXTS[level][0], BATTERY_TEXTS[level][1])
        self._battery_level = level
        breach = None
        if self.geofence.enabled and self.home is not None and self._gf_action != 0:
            breach = self.geofence.check(pos, self.home.position_ned_m)
        if breach is not None and self._fence_breach is None:
            self.log.critical(now_s, breach)
        self._fence_breach = breach
        c, fd = self.commander, self.failure_detector
        at = c.armed_at_s  # failsafe.cpp's early takeoff phase: COM_SPOOLUP_TIME + 3 s
        early = at is not None and now_s < at + self._early_takeoff_s
        failure, finished = self.navigator.mission.progress.failure, self.navigator.mission.finished
        inputs = (c.armed, c.user_nav_state, c.gcs_lost, c.offboard_available, level,
                  breach is not None, c.manual_control_available, c.position_lost, fd.critical,
                  early, failure, finished)
        if inputs != self._flags_inputs:  # the flags are frozen: the last ones serve again
            self._flags_inputs = inputs
            self._flags = FailsafeFlags(
                armed=c.armed, user_nav_state=c.user_nav_state, gcs_lost=c.gcs_lost,
                offboard_lost=not c.offboard_available, battery_warning=level,
                geofence_breached=breach is not None,
                manual_control_lost=not c.manual_control_available,
                position_invalid=c.position_lost, fd_critical_failure=fd.critical,
                early_takeoff=early, mission_failure=failure, mission_finished=finished)
        return self._flags

    def _update_slow(self, now_s: float, meas: Measurement) -> None:
        cmd, st = self.commander, self.stage
        ld = self.land_detector
        # mc_hover_thrust_estimator on this local position and the last position setpoint;
        # mc_pos_control takes a new estimate (moving its integrator so the thrust holds).
        hover = self.hover_thrust.update(now_s, cmd.armed, ld.landed, -meas.position_ned_m[2],
                                         meas.velocity_ned_mps, meas.accel_ned_mps2[2],
                                         st.thrust_z_ned)
        pc = st.position_control
        if hover != pc.hover_thrust:
            pc.update_hover_thrust(hover, st.acc_sp[2])
        ld.update(now_s, cmd.armed, meas, st.vel_sp_z, st.thrust, hover, self.hover_thrust.valid)
        was_armed = cmd.armed
        pos, vel = meas.position_ned_m, meas.velocity_ned_mps
        self.failure_detector.update(now_s, meas.attitude_q, attitude_control(
            cmd.nav_state, self.offboard.setpoint), self.params)
        cmd.attitude_failure = self.failure_detector.roll or self.failure_detector.pitch
        self._refresh_requirements(now_s)
        if (not cmd.mission_valid and cmd.nav_state is NavState.AUTO_MISSION and cmd.armed
                and not ld.landed):
            cmd.switch_by_vehicle(NavState.AUTO_LOITER)  # mission cleared under our feet
        if cmd.update(now_s, ld.landed, self._failsafe_flags(now_s, pos)):
            self._set_home(meas, now_s)
        self.battery.update(now_s, cmd.armed, st.thrust if cmd.armed else 0.0)
        if was_armed and not cmd.armed:
            ld.update(now_s, False, meas, 0.0, 0.0, hover)
        yaw = q_yaw(meas.attitude_q)
        if not st.flying:
            st.trajectory.reset(pos, vel)
        auto = self.tasks.auto
        # (The trajectory does not move before the navigator has run: where its setpoint is can
        # wait until a mode asks for it.)
        ctx = NavContext(now_s, self.params, self.log, cmd.armed, ld.landed, pos, vel, yaw,
                         self.home, st.trajectory, self.origin, self._switch_by_vehicle,
                         self.navigator.cruise_mps, self.navigator.set_cruise_mps,
                         self.navigator.precland)
        self.navigator.publish_rtl_estimate(ctx, cmd.position_valid)
        state = cmd.nav_state
        entered = state is not self._prev_nav_state
        self._prev_nav_state = state
        st.begin_tick(now_s, cmd.armed)
        task = self.tasks.by_state[state]
        if not task.uses_navigator:
            self.navigator.deactivate(ctx)
            auto.setpoint = None
        t = _new_tuple(TaskInput, (now_s, self.dt_s * POSITION_CONTROL_DIVIDER, meas, yaw,
                                   cmd.armed, cmd.terminated, state, ctx))
        if entered:
            task.activate(t)
        self._resets_seen = check_resets(task, t, self._resets, self._resets_seen)
        task.update(t)

    def _switch_by_vehicle(self, nav_state: NavState, hold_at: tuple[float, float, float] | None
                           ) -> None:
        if (nav_state is NavState.AUTO_LOITER and self.commander.nav_state is NavState.AUTO_TAKEOFF
                and int(self.params["COM_TAKEOFF_ACT"]) == 1 and self.commander.mission_valid):
            nav_state = NavState.AUTO_MISSION  # Commander: takeoff done, COM_TAKEOFF_ACT 1
        if nav_state is NavState.AUTO_LOITER:
            self.navigator.hold.hint = hold_at
        if nav_state is NavState.AUTO_RTL and self.home is None:
            nav_state = NavState.AUTO_LAND
        self.commander.switch_by_vehicle(nav_state)

