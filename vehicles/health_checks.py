"""PX4's health and arming checks report for the simulated multicopter, sent as events
(vehicles/events.py). Source: PX4 src/modules/commander/HealthAndArmingChecks (Common.cpp's
Report, checks/modeCheck.cpp) and ModeUtil/mode_requirements.cpp.

Rules:
- A mode group is ``1 << nav_state``. ``REQUIREMENTS`` are mode_requirements.cpp's for a rotary
  wing (the navigation states a vehicle here has). A failing requirement clears the can_run bits
  of the modes that have it; modeCheck.cpp's check reports its event (the modes, then the health
  component's index; "no modes" is reported as all, so that the UI still shows it), clears those
  modes' can_arm bits and marks its component's arming error (level <= Error) or warning.
- The checks run in HealthAndArmingChecks' order: accelerometer, barometer, estimator, failure
  detector, gyro, magnetometer, mission, modes. The sensor checks: a sensor whose data stopped
  (failure injection "off") SENSOR_TIMEOUT_S ago is a health failure of its component
  (Report::healthFailure: an error, no mode can arm) with its instance, 0; the barometer and
  the magnetometer only with SYS_HAS_BARO / SYS_HAS_MAG. A stuck sensor still publishes: no
  check fails. On an arming request each failing one says its "Preflight Fail: …" text
  (``preflight_texts``).
- estimatorCheck.cpp's checkEstimatorStatus: disarmed, estimator_status's height, velocity and
  position test ratios (vehicles/aiding.py) each over its COM_ARM_EKF_HGT, _VEL, _POS limit is
  an Error of the local position estimate in the modes that need an attitude, the ratio and the
  limit its event's arguments, "Preflight Fail: … estimate error" what an arming request says
  (the magnetometer's, COM_ARM_EKF_YAW: not checked, see ESTIMATOR_CHECKS).
- The failure detector's attitude check, then missionCheck.cpp's: the navigator's mission
  failure (mission_result.failure, a forced heading that timed out) is an error of every mode
  ("Mission cannot be completed"; each report also says it as a text, Report's legacy run).
- Then modeCheck.cpp's checks, in its order: mode not suitable for arming (disarmed only), local
  position, global position, mission (every mode with COM_ARM_MIS_REQ), offboard signal, home
  position, manual control (a Warning affecting no mode unless COM_RC_IN_MODE is 4, when it is
  an Error of the modes that need sticks; either way those modes can neither arm nor run).
- Health: the simulated sensors (accelerometer, gyro, magnetometer, barometer, GPS) and the
  battery are present; a GPS that is off is an error of the GPS component (the estimator's
  checks: no fixes).
- ``update`` runs at Commander's 10 Hz (or when the mode or arming changed). A report is one
  burst: the arming summary, each failing check's event, the health summary. It is sent when the
  results differ from the previous evaluation, at most every MIN_REPORT_INTERVAL_S (a change
  within it is sent once it passed), or at once when forced (MAV_CMD_RUN_PREARM_CHECKS).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from vehicles.aiding import gps_ctrl_of, published_ratios
from vehicles.estimation import (
    E_GPS_AGE,
    E_RATIOS,
    F_ACC_OFF,
    F_BARO_OFF,
    F_GPS_OFF,
    F_GYRO_OFF,
    F_MAG_OFF,
)
from vehicles.events import (
    ARMING_SUMMARY,
    CHECK_ACCEL_NO_DATA,
    CHECK_BARO_NO_DATA,
    CHECK_CANNOT_TAKEOFF,
    CHECK_EST_HGT,
    CHECK_EST_POS,
    CHECK_EST_VEL,
    CHECK_FD_PITCH,
    CHECK_FD_ROLL,
    CHECK_GLOBAL_POS,
    CHECK_GYRO_NO_DATA,
    CHECK_HOME,
    CHECK_LOCAL_POS,
    CHECK_MAG_NO_DATA,
    CHECK_MANUAL_CONTROL,
    CHECK_MISSION,
    CHECK_MISSION_FAILURE,
    CHECK_OFFBOARD,
    HEALTH_SUMMARY,
    EventDef,
    EventLog,
    Log,
)
from vehicles.status_log import StatusLog
from vehicles.types import NavState

UPDATE_PERIOD_S = 0.1
SENSOR_TIMEOUT_S = 1.0  # the checks' hrt_elapsed_time(&data.timestamp) < 1_s
MIN_REPORT_INTERVAL_S = 2.0  # Report::_min_reporting_interval
ALL_MODES = 0xFFFFFFFF  # NavModes::All

# health_component_t (events/enums.json, px4): component index i is the bit 1 << i; its label.
HEALTH_COMPONENTS = (
    ("none", "None"), ("absolute_pressure", "Absolute pressure"),
    ("differential_pressure", "Differential pressure"), ("gps", "GPS"),
    ("optical_flow", "Optical flow"), ("vision_position", "Vision position estimate"),
    ("distance_sensor", "Distance sensor"), ("remote_control", "Remote Control (RC or Joystick)"),
    ("motors_escs", "Motors/ESCs"), ("utm", "UTM"), ("logging", "Logging"),
    ("battery", "Battery"), ("communication_links", "Communication links"),
    ("rate_controller", "Rate controller"), ("attitude_controller", "Attitude controller"),
    ("position_controller", "Position controller"), ("attitude_estimate", "Attitude estimate"),
    ("local_position_estimate", "Local position estimate"), ("mission", "Mission"),
    ("avoidance", "Avoidance"), ("system", "System"), ("camera", "Camera"), ("gimbal", "Gimbal"),
    ("payload", "Payload"), ("global_position_estimate", "Global position estimate"),
    ("storage", "Storage"), ("parachute", "Parachute"), ("magnetometer", "Magnetometer"),
    ("accel", "Accelerometer"), ("gyro", "Gyroscope"), ("open_drone_id", "Open Drone ID system"))
INDEX = {name: i for i, (name, _label) in enumerate(HEALTH_COMPONENTS)}
SYSTEM, REMOTE_CONTROL = INDEX["system"], INDEX["remote_control"]
LOCAL_POSITION_ESTIMATE = INDEX["local_position_estimate"]
PRESENT = sum(1 << INDEX[c] for c in ("accel", "gyro", "magnetometer", "absolute_pressure", "gps",
                                      "battery"))
# (failure bit, event, component, the arming request's text); in the checks' order.
SENSOR_CHECKS = (
    (F_ACC_OFF, CHECK_ACCEL_NO_DATA, INDEX["accel"], "Preflight Fail: No valid data from Accel 0"),
    (F_BARO_OFF, CHECK_BARO_NO_DATA, INDEX["absolute_pressure"],
     "Preflight Fail: No valid data from Baro 0"),
    (F_GYRO_OFF, CHECK_GYRO_NO_DATA, INDEX["gyro"], "Preflight Fail: No valid data from Gyro 0"),
    (F_MAG_OFF, CHECK_MAG_NO_DATA, INDEX["magnetometer"],
     "Preflight Fail: No valid data from Compass 0"))
SENSORS_OFF = F_ACC_OFF | F_BARO_OFF | F_GYRO_OFF | F_MAG_OFF
# estimatorCheck.cpp checkEstimatorStatus, in its order: estimator_status's ratio (vehicles/aiding.py
# published_ratios: height, velocity, position, magnetometer), its limit parameter and default,
# the event and the arming request's text.
ESTIMATOR_CHECKS = (
    (2, "COM_ARM_EKF_HGT", 1.0, CHECK_EST_HGT, "Preflight Fail: height estimate error"),
    (0, "COM_ARM_EKF_VEL", 0.5, CHECK_EST_VEL, "Preflight Fail: velocity estimate error"),
    (1, "COM_ARM_EKF_POS", 0.5, CHECK_EST_POS, "Preflight Fail: position estimate error"))
# Not COM_ARM_EKF_YAW's: the magnetometer's ratio here is a heading-only stand-in for EKF2's
# 3-axis field innovations (whose variance holds EKF2's field states), and its noise alone would
# cross 0.5 every few minutes on the ground, where EKF2's does not.


def _modes(*states: NavState) -> int:
    return sum(1 << int(s) for s in states)


N = NavState
# navigation_mode_group_t (events/enums.json, px4): the group of each navigation state that has
# one (Position Slow, Descend and Termination have none there).
MODE_GROUPS = {
    N.MANUAL: ("manual", "Fully manual mode (w/o any controller support)"),
    N.ALTCTL: ("altctl", "Altitude mode"), N.POSCTL: ("posctl", "Position mode"),
    N.AUTO_MISSION: ("mission", "Mission mode"), N.AUTO_LOITER: ("loiter", "Loiter"),
    N.AUTO_RTL: ("rtl", "RTL"), N.ACRO: ("acro", "Acro"),
    N.OFFBOARD: ("offboard", "Offboard"), N.STAB: ("stab", "Stabilized"),
    N.AUTO_TAKEOFF: ("takeoff", "Takeoff"), N.AUTO_LAND: ("land", "Land"),
    N.AUTO_FOLLOW_TARGET: ("follow_target", "Follow Target"),
    N.AUTO_PRECLAND: ("precland", "Precision Land"), N.ORBIT: ("orbit", "Orbit")}
# mode_requirements.cpp, rotary wing: the modes that need each.
REQ_LOCAL_POSITION = _modes(N.AUTO_MISSION, N.AUTO_LOITER, N.AUTO_RTL, N.AUTO_TAKEOFF,
                            N.AUTO_FOLLOW_TARGET, N.AUTO_PRECLAND, N.ORBIT)
REQ_LOCAL_POSITION_RELAXED = _modes(N.POSCTL, N.POSITION_SLOW, N.AUTO_LAND)
REQ_GLOBAL_POSITION = _modes(N.AUTO_MISSION, N.AUTO_LOITER, N.AUTO_RTL)
REQ_MISSION = _modes(N.AUTO_MISSION)
REQ_OFFBOARD = _modes(N.OFFBOARD)
REQ_HOME = _modes(N.AUTO_RTL)
REQ_MANUAL_CONTROL = _modes(N.MANUAL, N.ALTCTL, N.POSCTL, N.POSITION_SLOW, N.ACRO, N.STAB)
REQ_ATTITUDE = ALL_MODES & ~_modes(N.MANUAL, N.ACRO, N.TERMINATION)
REQ_PREVENT_ARMING = _modes(N.AUTO_RTL, N.DESCEND, N.TERMINATION, N.AUTO_LAND,
                            N.AUTO_FOLLOW_TARGET, N.AUTO_PRECLAND, N.ORBIT)


@dataclass(frozen=True)
class CheckInputs:
    """What Commander's checks read (failsafe_flags and vehicle_status, as the vehicle has them)."""

    armed: bool
    nav_state: NavState
    position_valid: bool
    manual_control: bool  # stick input present
    mission_valid: bool
    offboard_available: bool
    home_valid: bool
    rc_in_mode: int  # COM_RC_IN_MODE
    mission_required: bool  # COM_ARM_MIS_REQ
    sensor_failures: int  # estimation.F_* bits
    required_sensors: int = SENSORS_OFF  # the F_*_OFF bits checked (SYS_HAS_BARO, SYS_HAS_MAG)
    sensors_no_data: int = 0  # the F_*_OFF bits off for SENSOR_TIMEOUT_S (HealthChecks.update)
    attitude_failure: int = 0  # failure_detector.py: 1 roll, 2 pitch
    mission_failure: bool = False  # the navigator's mission_result.failure
    # disarmed: (ESTIMATOR_CHECKS index, ratio, limit) of each test ratio over its limit
    estimator_failing: tuple[tuple[int, float, float], ...] = ()


def inputs_of(autopilot: Any, params: Any, sensor_failures: int,
              estimator: Sequence[float] = ()) -> CheckInputs:
    """The checks' inputs from a vehicle's autopilot (its commander and home), params and
    estimator state (estimation.E_*: its test ratios as estimator_status publishes them; none:
    not checked)."""
    c = autopilot.commander
    required = F_ACC_OFF | F_GYRO_OFF
    if params.get("SYS_HAS_BARO", 1):
        required |= F_BARO_OFF
    if params.get("SYS_HAS_MAG", 1):
        required |= F_MAG_OFF
    fd = autopilot.failure_detector
    failing = []
    if len(estimator) and not c.armed:
        ratios = published_ratios(estimator[E_RATIOS:E_RATIOS + 4], estimator[E_GPS_AGE],
                                  gps_ctrl_of(params))
        for k, (column, name, default, _, _) in enumerate(ESTIMATOR_CHECKS):
            limit = params.get(name, default)
            limit = default if limit is None else float(limit)
            if ratios[column] > limit:  # (NaN: not fused, never over)
                failing.append((k, float(ratios[column]), limit))
    return CheckInputs(c.armed, c.nav_state, c.position_valid, c.manual_control_available,
                       c.mission_valid, c.offboard_available, autopilot.home is not None,
                       int(params.get("COM_RC_IN_MODE", 0) or 0),
                       bool(params.get("COM_ARM_MIS_REQ", 0)), sensor_failures, required,
                       attitude_failure=(1 if fd.roll else 0) | (2 if fd.pitch else 0),
                       mission_failure=autopilot.navigator.mission.progress.failure,
                       estimator_failing=tuple(failing))


@dataclass(frozen=True)
class Results:
    can_arm: int
    can_run: int
    error: int  # arming checks, health_component_t bits
    warning: int
    present: int  # health
    health_error: int
    health_warning: int
    # (event, level, modes, component index, sensor instance or None)
    checks: tuple[tuple[EventDef, Log, int, int, int | None], ...]
    preflight_texts: tuple[str, ...] = ()  # what an arming request says of the health failures
    report_texts: tuple[str, ...] = ()  # the legacy texts each report sends (mavlink_log_critical)
    # Per check, its float arguments after the modes and the component (None: none). Not
    # compared: a report goes out when the results change (Report's), not their values.
    check_args: tuple[tuple[float, ...] | None, ...] = field(default=(), compare=False)

    def can_arm_in(self, nav_state: NavState) -> bool:
        return bool(self.can_arm & (1 << int(nav_state)))


def evaluate(i: CheckInputs) -> Results:
    """One run of the checks (module rules)."""
    can_arm = can_run = ALL_MODES
    error = warning = health_error = 0
    checks: list[tuple[EventDef, Log, int, int, int | None]] = []
    args: list[tuple[float, ...] | None] = []
    texts: list[str] = []

    def failure(event: EventDef, level: Log, modes: int, component: int,
                values: tuple[float, ...] | None = None) -> None:
        nonlocal can_arm, error, warning
        if level <= Log.ERROR:
            error |= 1 << component
        elif level <= Log.WARNING:
            warning |= 1 << component
        can_arm &= ~modes
        checks.append((event, level, modes or ALL_MODES, component, None))
        args.append(values)

    def sensors(first: int, last: int) -> None:
        nonlocal can_arm, health_error
        for bit, event, component, text in SENSOR_CHECKS[first:last]:  # Report::healthFailure
            if i.sensors_no_data & i.required_sensors & bit:  # an Error of every mode
                health_error |= 1 << component
                can_arm = 0
                checks.append((event, Log.ERROR, ALL_MODES, component, 0))
                args.append(None)
                texts.append(text)

    sensors(0, 2)  # HealthAndArmingChecks' order: accelerometer, barometer, the estimator …
    for k, ratio, limit in i.estimator_failing:
        _, _, _, event, text = ESTIMATOR_CHECKS[k]
        failure(event, Log.ERROR, REQ_ATTITUDE, LOCAL_POSITION_ESTIMATE, (ratio, limit))
        texts.append(text)
    if i.attitude_failure:  # failureDetectorCheck.cpp: roll first, else pitch
        failure(CHECK_FD_ROLL if i.attitude_failure & 1 else CHECK_FD_PITCH, Log.CRITICAL,
                ALL_MODES, SYSTEM)
    sensors(2, 4)  # … the failure detector, the gyro, the magnetometer
    report_texts: tuple[str, ...] = ()
    if i.mission_failure:  # missionCheck.cpp, before modeCheck.cpp's
        failure(CHECK_MISSION_FAILURE, Log.ERROR, ALL_MODES, SYSTEM)
        report_texts = ("Mission cannot be completed\t",)
    if not i.armed and REQ_PREVENT_ARMING & (1 << int(i.nav_state)):
        failure(CHECK_CANNOT_TAKEOFF, Log.INFO, REQ_PREVENT_ARMING, SYSTEM)
    if not i.position_valid:
        local = REQ_LOCAL_POSITION | REQ_LOCAL_POSITION_RELAXED
        failure(CHECK_LOCAL_POS, Log.ERROR, local, SYSTEM)
        can_run &= ~local
        failure(CHECK_GLOBAL_POS, Log.ERROR, REQ_GLOBAL_POSITION, SYSTEM)
        can_run &= ~REQ_GLOBAL_POSITION
    if not i.mission_valid:
        failure(CHECK_MISSION, Log.INFO, ALL_MODES if i.mission_required else REQ_MISSION, SYSTEM)
        can_run &= ~REQ_MISSION
    if not i.offboard_available:
        failure(CHECK_OFFBOARD, Log.ERROR, REQ_OFFBOARD, SYSTEM)
        can_run &= ~REQ_OFFBOARD
    if not i.home_valid:
        failure(CHECK_HOME, Log.INFO, REQ_HOME, SYSTEM)
        can_run &= ~REQ_HOME
    if not i.manual_control:
        disabled = i.rc_in_mode == 4
        failure(CHECK_MANUAL_CONTROL, Log.ERROR if disabled else Log.WARNING,
                REQ_MANUAL_CONTROL if disabled else 0, REMOTE_CONTROL)
        can_arm &= ~REQ_MANUAL_CONTROL
        can_run &= ~REQ_MANUAL_CONTROL
    if i.sensor_failures & F_GPS_OFF:
        health_error |= 1 << INDEX["gps"]
    return Results(can_arm, can_run, error, warning, PRESENT, health_error, 0, tuple(checks),
                   tuple(texts), report_texts, tuple(args))


class HealthChecks:
    """Commander's HealthAndArmingChecks and its Report (module rules)."""

    def __init__(self, events: EventLog,
                 on_results: Callable[[Results], None] | None = None,
                 log: StatusLog | None = None) -> None:
        """``log``: where each report's legacy texts go (HealthAndArmingChecks' second run)."""
        self.events = events
        self.log = log
        self.on_results = on_results  # told every evaluation (the commander's arming)
        self._off_since: dict[int, float] = {}  # F_*_OFF bit → when its data stopped
        self.results: Results | None = None
        self._next_s = 0.0
        self._last_report_s = -MIN_REPORT_INTERVAL_S
        self._unreported = False
        self._mode: tuple[bool, NavState] | None = None
        self._checked: CheckInputs | None = None  # what ``results`` were evaluated on

    def update(self, now_s: float, armed: bool, nav_state: NavState,
               inputs: Callable[[], CheckInputs], force: bool = False) -> bool:
        """Run the checks on ``inputs()`` if due (or ``force``); report as the module rules
        say. True: a report was sent."""
        mode = (armed, nav_state)
        if not force and now_s < self._next_s and mode == self._mode:
            return False
        self._next_s, self._mode = now_s + UPDATE_PERIOD_S, mode
        checked = self._with_timeouts(now_s, inputs())
        previous = results = self.results
        if results is None or checked != self._checked:  # (the checks are pure)
            self._checked = checked
            self.results = results = evaluate(checked)
        if self.on_results is not None:
            self.on_results(results)
        changed = self._unreported or (results is not previous and results != previous)
        if now_s - self._last_report_s < MIN_REPORT_INTERVAL_S and not force:
            self._unreported = self._unreported or changed
            return False
        if not (changed or force):
            return False
        self._last_report_s, self._unreported = now_s, False
        self._report(now_s)
        return True

    def _with_timeouts(self, now_s: float, checked: CheckInputs) -> CheckInputs:
        """``checked`` with ``sensors_no_data``: its sensors off for SENSOR_TIMEOUT_S."""
        off, since = checked.sensor_failures & SENSORS_OFF, self._off_since
        if not off and not since:  # the usual case, at every evaluation of every vehicle
            return checked
        for bit in list(since):
            if not off & bit:
                del since[bit]
        stale = 0
        for bit in (F_ACC_OFF, F_BARO_OFF, F_GYRO_OFF, F_MAG_OFF):
            if off & bit and now_s - since.setdefault(bit, now_s) >= SENSOR_TIMEOUT_S - 1e-9:
                stale |= bit
        return replace(checked, sensors_no_data=stale) if stale else checked

    def _report(self, now_s: float) -> None:
        r = self.results
        assert r is not None
        send = self.events.send
        send(now_s, ARMING_SUMMARY, Log.PROTOCOL, None, "BIIII", 0, r.error, r.warning,
             r.can_arm, r.can_run)
        for k, (event, level, modes, component, instance) in enumerate(r.checks):
            values = r.check_args[k] if k < len(r.check_args) else None
            if values is not None:
                send(now_s, event, level, None, "IB" + "f" * len(values), modes, component,
                     *values)
            elif instance is None:
                send(now_s, event, level, None, "IB", modes, component)
            else:
                send(now_s, event, level, None, "IBB", modes, component, instance)
        send(now_s, HEALTH_SUMMARY, Log.PROTOCOL, None, "BIII", 0, r.present, r.health_error,
             r.health_warning)
        if self.log is not None:
            for text in r.report_texts:
                self.log.critical(now_s, text)
