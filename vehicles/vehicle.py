"""One vehicle: autopilot + simulated GPS/home + battery, over a body owned by the physics World.

This is the object the gateway talks to (vehicles/README.md contract). Rules:
- Every method takes simulated time; nothing here touches the wall clock or PyBullet. ``state``
  and ``status`` are frozen snapshots built lazily (at most once per physics step).
- What the vehicle measures is its estimate (vehicles/estimation.py): the autopilot flies on it
  and ``kinematics``/``state`` report it; ``truth`` is the body's true state.
- Local NED is relative to ``origin`` (the spawn point on the ground, = EKF origin).
- The World owns the body and inner loop (vehicles/inner_loop.py); the vehicle reads its measurement
  at most once per physics step and hands it to the autopilot (which never reads it itself).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import Protocol

import numpy as np

from vehicles import estimation as est
from vehicles import failure_injection
from vehicles.airframe import Airframe
from vehicles.autopilot import Autopilot
from vehicles.command_journal import CommandJournal
from vehicles.control.quat import q_yaw
from vehicles.events import ArmReason, EventLog
from vehicles.health_checks import CheckInputs, HealthChecks, inputs_of
from vehicles.inner_loop import C_OUTPUTS, C_RATE_INT, C_RATES_SP, C_TORQUE_SP, InnerCommand
from vehicles.manual_control import Sticks
from vehicles.mode_table import NO_POSITION_CONTROL, NO_POSITION_HOLD, ArmEvent
from vehicles.nav_roi import Params7
from vehicles.nav_rtl import RtlTimeEstimate
from vehicles.orbit import OrbitStatus
from vehicles.params import ParamStore
from vehicles.plan_types import MissionStatus, OffboardSetpoint, PlanItem, PlanResult, PlanType
from vehicles.types import (
    Changes,
    CommandResult,
    GeoPoint,
    HomePosition,
    Kinematics,
    Measurement,
    NavState,
    StatusText,
    Targets,
    Vec3,
    VehicleState,
    VehicleStatus,
)

_NAN3 = (math.nan, math.nan, math.nan)
# NamedTuples made as tuples where they are read hundreds of times a second (``kinematics``,
# ``targets``): a NamedTuple's ``__new__`` is a Python function.
_new_tuple = tuple.__new__
IMU_INSTANCES = 3  # PX4's simulator takes instances 1..3 for the IMU (one is simulated here)


class WorldRow(Protocol):
    """What a vehicle reads of the World that owns its body (physics.World)."""

    time_s: float
    steps: int

    def measurement(self, row: int) -> Measurement: ...

    def truth(self, row: int) -> Measurement: ...

    def sensors(self, row: int) -> list[float]: ...

    def estimator(self, row: int) -> list[float]: ...

    def recent_steps(self, row: int, after_s: float | None) -> list[tuple[float, list[float]]]:
        ...

    def estimator_ratios(self, row: int) -> list[float]: ...

    def aiding(self, row: int) -> list[float]: ...

    def set_sensor_failed(self, row: int, bits: int, on: bool) -> None: ...

    def sensor_failures(self, row: int) -> int: ...

    def set_motor_off(self, row: int, motor: int, off: bool) -> None: ...

    def rotor_speeds(self, row: int) -> tuple[float, ...]: ...

    def commanded(self, row: int) -> list[float]: ...

    def disarmed_outputs(self, row: int) -> tuple[float, ...]: ...


def _reason(internal: bool) -> ArmReason:
    return ArmReason.COMMAND_INTERNAL if internal else ArmReason.COMMAND_EXTERNAL


class Vehicle:
    def __init__(self, index: int, params: ParamStore, airframe: Airframe, origin: GeoPoint,
                 dt_s: float, boot_time_s: float = 0.0, *, world: WorldRow, row: int) -> None:
        """``world`` owns the body and row ``row`` of its inner loop (physics.World)."""
        self.index = index
        self.params = params
        self.airframe = airframe
        self.origin = origin
        self._dt_s = dt_s
        self._world = world
        self._row = row
        self._autopilot = Autopilot(params, airframe, origin, dt_s, boot_time_s,
                                    name=f"vehicle {index + 1}")
        self.commands = CommandJournal()  # what the logger records as vehicle_command(_ack)
        self.commander = self._autopilot.commander  # its refusals' texts (gateway commands.py)
        self.events = EventLog(boot_time_s)  # what every link sends as EVENT (vehicles/events.py)
        ap = self._autopilot
        self._health = HealthChecks(self.events, ap.commander.set_health, ap.log)
        ap.commander.events = ap.commander.failsafe.events = ap.log.events = self.events
        self._autopilot.calibration.on_ack = self.commands.onboard_ack
        self._cache_step = -1  # the world step the cached views below belong to
        self._meas: Measurement | None = None
        self._state: VehicleState | None = None
        self._kin: Kinematics | None = None
        self._params_version = -1  # EKF2_NOAID_TOUT, read at the first 50 Hz tick
        self._noaid_timeout_s = 5.0

    # --- the World's --------------------------------------------------------------------------
    def step_functions(self) -> tuple[Callable[[float], InnerCommand],
                                      Callable[[float], InnerCommand | None]]:
        """What the World calls once per physics step at ``now_s``, before the inner loop runs:
        on every POSITION_CONTROL_DIVIDER-th step ``step`` (the autopilot's 50 Hz part), on the
        others the autopilot's ``poll`` (only a command that is due between ticks; None: the
        inner loop keeps the last command), directly: no call of the vehicle's between."""
        return self.step, self._autopilot.poll

    def step(self, now_s: float) -> InnerCommand:
        """The autopilot's 50 Hz part on the state measured at ``now_s`` (``step_functions``)."""
        ap, params, world, row = self._autopilot, self.params, self._world, self._row
        if params.version != self._params_version:
            self._params_version = params.version
            timeout = params.get("EKF2_NOAID_TOUT", 5_000_000) or 5_000_000
            self._noaid_timeout_s = timeout * 1e-6
        aid_age, *resets = world.aiding(row)
        ap.set_position_aided(aid_age < self._noaid_timeout_s, resets)
        calibration = ap.calibration
        if calibration.needs_sensors:
            sensed = world.sensors(row)
            calibration.sample(sensed[est.S_ACC:est.S_ACC + 3], sensed[est.S_GYRO:est.S_GYRO + 3])
        command = ap.step(self._measurement(), now_s)
        c = ap.commander
        self._health.update(now_s, c.armed, c.nav_state, self._check_inputs)
        return command

    def _check_inputs(self) -> CheckInputs:
        w, row = self._world, self._row
        return inputs_of(self._autopilot, self.params, w.sensor_failures(row), w.estimator(row))

    def run_prearm_checks(self, now_s: float) -> CommandResult:
        """MAV_CMD_RUN_PREARM_CHECKS: the health and arming report, at once (health_checks.py)."""
        c = self._autopilot.commander
        self._health.update(now_s, c.armed, c.nav_state, self._check_inputs, force=True)
        return CommandResult.ACCEPTED

    def _measurement(self) -> Measurement:
        """The state measured after the world's last step."""
        m = self._meas
        steps = self._world.steps
        if self._cache_step != steps or m is None:
            self._cache_step = steps
            self._state = self._kin = None
            m = self._meas = self._world.measurement(self._row)
        return m

    # --- README contract ---------------------------------------------------------------------
    @property
    def autopilot(self) -> Autopilot:
        return self._autopilot

    @property
    def rtl_time_estimate(self) -> tuple[int, RtlTimeEstimate]:
        """RTL's last rtl_time_estimate, and how many times it was published."""
        nav = self._autopilot.navigator
        return nav.rtl_estimate_seq, nav.rtl_estimate

    @property
    def state(self) -> VehicleState:
        m = self._measurement()
        if self._state is None:
            self._state = VehicleState(
                self._world.time_s, np.array(m.position_ned_m), np.array(m.velocity_ned_mps),
                np.array(m.accel_ned_mps2), np.array(m.attitude_q), np.array(m.rates_frd_radps),
            )
        return self._state

    @property
    def kinematics(self) -> Kinematics:
        kin = self._kin
        if kin is not None and self._cache_step == self._world.steps:
            return kin
        m = self._measurement()
        kin = self._kin = _new_tuple(Kinematics, (self._world.time_s, m.position_ned_m,
                                                  m.velocity_ned_mps, m.attitude_q,
                                                  m.rates_frd_radps))
        return kin

    @property
    def status(self) -> VehicleStatus:
        ap = self._autopilot
        c = ap.commander
        world, row = self._world, self._row
        return VehicleStatus(
            world.time_s, c.armed, c.nav_state, ap.landed_state, c.position_valid,
            c.prearm_ok(), c.failsafe_active, c.terminated, ap.battery.state(), ap.home,
            {"thrust_norm": ap.thrust_norm,
             "estimator_ok": not any(r > 1.0 for r in world.estimator_ratios(row)),
             "rotor_speed_radps": world.rotor_speeds(row),
             "manual_control": c.manual_control_state, "user_nav_state": c.user_nav_state,
             "sensor_failures": world.sensor_failures(row),
             "armed_at_s": c.armed_at_s, "takeoff_at_s": c.takeoff_at_s})

    @property
    def position_setpoint_ned_m(self) -> Vec3 | None:
        """The trajectory's position setpoint while armed and flying under it (else None)."""
        return self._autopilot.position_setpoint_ned_m()

    @property
    def targets(self) -> Targets:
        """The controllers' setpoints and the motors' commands, as PX4 publishes them."""
        ap = self._autopilot
        st, cmd = ap.stage, ap.commander
        out, world, row = ap.last_command, self._world, self._row
        commanded = tuple(world.commanded(row))
        nav = cmd.nav_state
        if nav in NO_POSITION_CONTROL:
            position_control = False
        else:  # Offboard attitude and rates bypass the position controller
            position_control = nav is not NavState.OFFBOARD or st.flying
        pos = vel = acc = _NAN3
        if st.flying:
            pos, vel, acc = st.trajectory.position_ned_m, st.vel_sp, st.acc_sp
        yaw = st.yaw_sp
        if yaw != yaw:  # NaN: PX4 holds the present heading
            yaw = q_yaw(self._measurement().attitude_q)
        target = None
        auto_sp = ap.tasks.auto.setpoint
        if position_control and auto_sp is not None and nav not in NO_POSITION_HOLD:
            target = auto_sp.target_ned_m
            if target[2] != target[2]:  # a landing: PX4's land setpoint is at the ground's altitude
                home = ap.home
                target = (target[0], target[1], home.position_ned_m[2] if home else 0.0)
        return _new_tuple(Targets, (
            st.tick_s, out.attitude_q, out.thrust_norm, commanded[C_RATES_SP:C_TORQUE_SP],
            position_control, pos, vel, acc, yaw, out.yawspeed_radps, target,
            commanded[C_OUTPUTS:] if cmd.armed or ap.motor_test else world.disarmed_outputs(row),
            commanded[C_TORQUE_SP:C_RATE_INT], commanded[C_RATE_INT:C_OUTPUTS]))

    @property
    def truth(self) -> Measurement:
        """The true state after the last physics step (the estimate is ``kinematics``)."""
        return self._world.truth(self._row)

    @property
    def sensors(self) -> list[float]:
        """The latest sensor samples (vehicles/estimation.py S_* columns; NED from ``origin``)."""
        return self._world.sensors(self._row)

    def recent_steps(self, after_s: float | None) -> list[tuple[float, list[float]]]:
        """The IMU samples, estimated and true attitude and rates (estimation.py R_* columns) of
        the physics steps taken after ``after_s`` (None: the last one; at most 64), oldest
        first, with the times they were taken at: what the logger records at the sensors' rate."""
        return self._world.recent_steps(self._row, after_s)

    @property
    def estimator(self) -> list[float]:
        """The estimator's state (vehicles/estimation.py E_* columns)."""
        return self._world.estimator(self._row)

    @property
    def acceleration_ned_mps2(self) -> Vec3:
        """The acceleration measured over the last physics step (what ``state`` carries)."""
        return self._measurement().accel_ned_mps2

    @property
    def home(self) -> HomePosition | None:
        """The home position (as in ``status.home``), without building the whole status."""
        return self._autopilot.home

    @property
    def global_position(self) -> GeoPoint:
        return self.origin.offset_ned(*self._measurement().position_ned_m)

    def status_texts(self, after_seq: int = 0) -> list[StatusText]:
        return self._autopilot.log.after(after_seq)

    def record_command(self, now_s: float, command: int,
                       params: tuple[float, float, float, float, float, float, float],
                       source: tuple[int, int], result: int | None) -> None:
        """A command a link dispatched and its ACK's result (vehicle_command(_ack))."""
        self.commands.record(now_s, command, params, source, result)

    @property
    def changes(self) -> Changes:
        """Generations of ``mission_progress`` and ``status_texts`` (one object: keep it)."""
        return self._autopilot.changes

    def arm(self, now_s: float, forced: bool = False, internal: bool = False) -> CommandResult:
        """``internal``: a command of the vehicle's own (its shell's ``commander arm``), which
        PX4 reports as arm_disarm_reason_t command_internal; else command_external."""
        return self._autopilot.arm(now_s, self._measurement(), forced, _reason(internal))

    def disarm(self, now_s: float, forced: bool = False, internal: bool = False) -> CommandResult:
        return self._autopilot.commander.disarm(now_s, forced, _reason(internal))

    def takeoff(self, now_s: float, alt_amsl_m: float = math.nan) -> CommandResult:
        return self._autopilot.takeoff(now_s, alt_amsl_m)

    def land(self, now_s: float) -> CommandResult:
        return self._autopilot.land(now_s)

    def return_to_launch(self, now_s: float) -> CommandResult:
        return self._autopilot.return_to_launch(now_s)

    def reposition(self, now_s: float, target_ned_m: tuple[float, float, float]) -> CommandResult:
        """Extra (not yet in the README contract): Hold at a local NED target, like DO_REPOSITION."""
        return self._autopilot.reposition(now_s, target_ned_m)

    def set_nav_state(self, now_s: float, nav_state: NavState) -> CommandResult:
        return self._autopilot.set_nav_state(now_s, nav_state)

    # --- plans (MISSION / FENCE / RALLY) --------------------------------------------------------
    def plan(self, plan_type: PlanType) -> tuple[PlanItem, ...]:
        return self._autopilot.plans.get(plan_type)

    def set_plan(self, now_s: float, plan_type: PlanType, items: Iterable[PlanItem]
                 ) -> PlanResult:
        return self._autopilot.plans.set(plan_type, tuple(items))

    def clear_plan(self, now_s: float, plan_type: PlanType) -> PlanResult:
        return self._autopilot.plans.clear(plan_type)

    def plan_id(self, plan_type: PlanType) -> int:
        return self._autopilot.plans.plan_id(plan_type)

    def set_current_mission_item(self, now_s: float, seq: int) -> bool:
        return self._autopilot.navigator.mission.set_current(seq)

    @property
    def mission_status(self) -> MissionStatus:
        ap = self._autopilot
        return ap.navigator.mission.status(ap.commander.nav_state)

    @property
    def mission_progress(self) -> tuple[int, int, int]:
        """(current item, item count, items reached so far): changes whenever
        ``mission_status.current_seq`` or ``.reached_count`` does (and then so does
        ``changes.mission_progress``)."""
        m = self._autopilot.navigator.mission
        return (m.current, len(m.items), m.progress.reached_count)

    def start_mission(self, now_s: float, first_seq: float = -1) -> CommandResult:
        return self._autopilot.start_mission(now_s, self._measurement(), first_seq)

    # --- offboard -----------------------------------------------------------------------------
    def set_offboard_setpoint(self, now_s: float, setpoint: OffboardSetpoint) -> None:
        self._autopilot.offboard.set(now_s, setpoint)

    # --- manual control -----------------------------------------------------------------------
    def manual_control(self, now_s: float, sticks: Sticks, source: object = None) -> None:
        """Stick input (MANUAL_CONTROL; PX4 manual_control_setpoint ranges, manual_control.py),
        from the first ``source`` while its input is fresh; its gestures arm and disarm (RC)."""
        gesture = self._autopilot.manual_control(now_s, sticks, source)
        if gesture is ArmEvent.ARM:
            self._autopilot.arm(now_s, self._measurement(), reason=ArmReason.RC_STICK)
        elif gesture is ArmEvent.DISARM:
            self._autopilot.commander.disarm(now_s, reason=ArmReason.RC_STICK)

    # --- actions ------------------------------------------------------------------------------
    def goto(self, now_s: float, lat_deg: float, lon_deg: float, alt_amsl_m: float,
             yaw_rad: float = math.nan, speed_mps: float = math.nan, what: str = "Reposition"
             ) -> CommandResult:
        return self._autopilot.goto(now_s, self._measurement(), lat_deg, lon_deg, alt_amsl_m,
                                    yaw_rad, speed_mps, what)

    def orbit(self, now_s: float, radius_m: float = math.nan, speed_mps: float = math.nan,
              yaw_behaviour: float = math.nan, lat_deg: float = math.nan,
              lon_deg: float = math.nan, alt_amsl_m: float = math.nan) -> CommandResult:
        """DO_ORBIT (vehicles/orbit.py): NaN keeps the present value."""
        return self._autopilot.orbit(now_s, radius_m, speed_mps, yaw_behaviour, lat_deg, lon_deg,
                                     alt_amsl_m)

    def set_follow_target(self, now_s: float, lat_deg: float, lon_deg: float, alt_amsl_m: float,
                          velocity_ned_mps: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        """FOLLOW_TARGET: the target Follow Me follows (vehicles/follow_target.py)."""
        self._autopilot.set_follow_target(now_s, lat_deg, lon_deg, alt_amsl_m, velocity_ned_mps)

    # SET_VELOCITY_LIMITS, LANDING_TARGET; manual_control_setpoint, which MANUAL_CONTROL echoes
    set_velocity_limits = property(lambda self: self._autopilot.velocity_limits.publish)
    landing_target = property(lambda self: self._autopilot.navigator.landing_target.report)
    manual_control_setpoint = property(lambda self: self._autopilot.manual.published)

    @property
    def orbit_status(self) -> OrbitStatus | None:  # ORBIT_EXECUTION_STATUS (local NED), or None
        return self._autopilot.orbit_status

    def change_speed(self, now_s: float, speed_mps: float) -> CommandResult:
        return self._autopilot.change_speed(now_s, speed_mps)

    def set_roi(self, now_s: float, command: int, params: Params7) -> CommandResult:
        """A ROI command (DO_SET_ROI*, NAV_ROI) for the navigator (nav_roi.py)."""
        return self._autopilot.set_roi(now_s, command, params)

    def set_home(self, now_s: float, geo: GeoPoint | None = None, yaw_rad: float = math.nan
                 ) -> CommandResult:
        return self._autopilot.set_home(now_s, self._measurement(), geo, yaw_rad)

    def inject_failure(self, now_s: float, unit: int, failure_type: int, instance: int
                       ) -> CommandResult | None:
        """A vehicle_command INJECT_FAILURE (vehicles/failure_injection.py): the answer of the
        module that takes the unit, which it also ACKs to every link (system 0, component 0);
        None when no module takes it. (The MAVLink module's SYS_FAILURE_EN gate is not here.)"""
        result = failure_injection.answer(unit, failure_type, instance)
        if result is not None:
            if result is CommandResult.ACCEPTED:
                self.apply_failure(unit, failure_type, instance)
            self.commands.onboard_ack(now_s, failure_injection.MAV_CMD_INJECT_FAILURE,
                                      int(result), (0, 0))
        return result

    def apply_failure(self, unit: int, failure_type: int, instance: int) -> None:
        """A failure's effect (vehicles/failure_injection.py), also for the fault timeline."""
        failure_injection.apply(_FailureTarget(self), self.airframe.rotor_count, unit,
                                failure_type, instance)

    def calibrate(self, now_s: float, kind: str, source: tuple[int, int] = (0, 0)
                  ) -> CommandResult | None:
        """MAV_CMD_PREFLIGHT_CALIBRATION for ``kind``: one of vehicles/calibration.py KINDS,
        "radio", "esc", or "cancel" (every parameter 0, from ``source``)."""
        ap = self._autopilot
        cal, armed = ap.calibration, ap.commander.armed
        if kind == "cancel":
            return cal.cancel(now_s, source)
        if kind == "radio":
            return cal.start_radio(now_s, armed)
        if kind == "esc":
            return cal.start_esc(now_s, armed)
        if kind == "temperature":  # Commander leaves it to a module SITL does not run: no ACK
            return CommandResult.TEMPORARILY_REJECTED if armed or cal.kind is not None else None
        return cal.start(now_s, kind, armed)

    def motor_test_allowed(self) -> bool:
        """Commander's gate of both motor tests: disarmed and COM_MOT_TEST_EN 1."""
        return (not self._autopilot.commander.armed
                and int(self.params.get("COM_MOT_TEST_EN", 1) or 0) == 1)

    def actuator_test(self, now_s: float, function: int, value: float,
                      timeout_s: float) -> CommandResult:
        """MAV_CMD_ACTUATOR_TEST (vehicles/actuator_test.py); DENIED unless allowed."""
        if not self.motor_test_allowed():
            return CommandResult.DENIED
        return self._autopilot.motor_test.command(now_s, function, value, timeout_s)

    def param_storage(self, now_s: float, action: int) -> CommandResult | None:
        """MAV_CMD_PREFLIGHT_STORAGE param1, as PX4's commander worker: 0 load and 1 save (the
        parameters are saved as they change, so the file already holds them), 2 reset all but
        the flight-time counters (QGC's "Reset all to firmware's defaults"), 3 reset the sensor
        calibrations, 4 reset all; to the defaults with the launch's values (``set_default``).
        Armed or calibrating: TEMPORARILY_REJECTED. Another action: no answer, as PX4."""
        ap = self._autopilot
        if ap.commander.armed or ap.calibration.kind is not None:
            return CommandResult.TEMPORARILY_REJECTED
        if action in (0, 1):
            return CommandResult.ACCEPTED
        selected = {2: lambda n: n not in ("LND_FLIGHT_T_HI", "LND_FLIGHT_T_LO", "COM_FLIGHT_UUID"),
                    3: lambda n: n.startswith(("CAL_ACC", "CAL_GYRO", "CAL_MAG")),
                    4: lambda n: True}.get(action)
        if selected is None:
            return None
        self.params.reset(selected)
        return CommandResult.ACCEPTED

    def terminate(self, now_s: float) -> CommandResult:
        return self._autopilot.terminate(now_s)

    def on_gcs_heartbeat(self, now_s: float) -> None:
        self._autopilot.commander.on_gcs_heartbeat(now_s)


class _FailureTarget:
    """What a failure acts on (failure_injection.Target): this vehicle's row in the World."""

    def __init__(self, vehicle: Vehicle) -> None:
        self._world, self._row = vehicle._world, vehicle._row
        self._battery = vehicle._autopilot.battery

    def set_sensor_failed(self, bits: int, failed: bool) -> None:
        if bits:
            self._world.set_sensor_failed(self._row, bits, failed)

    def set_motor_off(self, motor: int, off: bool) -> None:
        self._world.set_motor_off(self._row, motor, off)

    def set_battery_empty(self, empty: bool) -> None:
        self._battery.force_empty = empty
