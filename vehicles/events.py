"""PX4's events (src/lib/events, px4_platform_common/events.h, mavlink_events.h): what a vehicle
reports as EVENT messages, and the definitions its events metadata (all_events.json) names them by.

Rules:
- An event's id is the FNV-1a 32-bit hash of its name, low 24 bits, with PX4's component 1 in
  the top byte (events::ID); its arguments are packed little-endian without padding, at most
  MAX_ARGUMENTS bytes; ``log_levels`` has the internal level in the high nibble, the external
  one in the low nibble.
- ``EventLog.send`` numbers the events with a 16-bit sequence that starts at INITIAL_SEQUENCE
  (events.h: 65535 - 10, "so it wraps soon"; the first event is 65526) and keeps the newest
  BUFFER_SIZE (EventBuffer), which every link sends and sends again on REQUEST_EVENT.
- ``DEFINITIONS`` holds every event a vehicle here sends, with PX4's name, group, message and
  argument types: the metadata is built from it, so nothing is sent that a client cannot name.
"""

from __future__ import annotations

import enum
import struct
from collections import deque
from dataclasses import dataclass

from vehicles.types import NavState

N = NavState

INITIAL_SEQUENCE = 65535 - 10
BUFFER_SIZE = 20  # EventBuffer's default capacity
MAX_ARGUMENTS = 25  # libevents config.ini max_arguments_size
COMPONENT_AUTOPILOT = 1  # the px4 namespace's component (events::ID)


class Log(enum.IntEnum):
    """events::Log (libevents' levels; PROTOCOL: not shown to the user)."""

    EMERGENCY = 0
    ALERT = 1
    CRITICAL = 2
    ERROR = 3
    WARNING = 4
    NOTICE = 5
    INFO = 6
    DEBUG = 7
    PROTOCOL = 8
    DISABLED = 9


class ArmReason(enum.IntEnum):
    """arm_disarm_reason_t (src/lib/events/enums.json): why the vehicle armed or disarmed."""

    TRANSITION_TO_STANDBY = 0
    RC_STICK = 1
    RC_SWITCH = 2
    COMMAND_INTERNAL = 3
    COMMAND_EXTERNAL = 4
    MISSION_START = 5
    AUTO_DISARM_LAND = 6
    AUTO_DISARM_PREFLIGHT = 7
    KILL_SWITCH = 8
    LOCKDOWN = 9
    FAILURE_DETECTOR = 10
    SHUTDOWN = 11
    UNIT_TEST = 12
    RC_BUTTON = 13
    FAILSAFE = 14


# The enum's descriptions: what "Armed by {1}" shows, and Commander's arm_disarm_reason_str.
ARM_REASON_TEXT = {
    ArmReason.TRANSITION_TO_STANDBY: "Transition to standby", ArmReason.RC_STICK: "RC",
    ArmReason.RC_SWITCH: "RC (switch)", ArmReason.COMMAND_INTERNAL: "internal command",
    ArmReason.COMMAND_EXTERNAL: "external command", ArmReason.MISSION_START: "mission start",
    ArmReason.AUTO_DISARM_LAND: "landing",
    ArmReason.AUTO_DISARM_PREFLIGHT: "auto preflight disarming",
    ArmReason.KILL_SWITCH: "kill switch", ArmReason.LOCKDOWN: "lockdown",
    ArmReason.FAILURE_DETECTOR: "failure detector", ArmReason.SHUTDOWN: "shutdown request",
    ArmReason.UNIT_TEST: "unit tests", ArmReason.RC_BUTTON: "RC (button)",
    ArmReason.FAILSAFE: "failsafe"}


def event_id(name: str) -> int:
    """events::ID(name): FNV-1a 32 of the name, low 24 bits, component 1 on top."""
    h = 0x811C9DC5
    for c in name.encode():
        h = ((h ^ c) * 0x01000193) & 0xFFFFFFFF
    return (h & 0xFFFFFF) | (COMPONENT_AUTOPILOT << 24)


@dataclass(frozen=True)
class EventDef:
    name: str
    group: str  # "default" (shown as a message), "arming_check", "health"
    message: str
    arguments: tuple[tuple[str, str], ...] = ()  # (type, name), in order
    type: str | None = None  # "summary" for the health report's frame events
    description: str | None = None

    @property
    def id(self) -> int:
        return event_id(self.name)


MODES = ("px4::navigation_mode_group_t", "modes")
COMPONENT_INDEX = ("uint8_t", "health_component_index")
HEALTH = "px4::health_component_t"


def _check(name: str, message: str, description: str | None = None) -> EventDef:
    """An arming check's event: the modes it affects and its health component come first
    (Report::armingCheckFailure)."""
    return EventDef(name, "arming_check", message, (MODES, COMPONENT_INDEX),
                    description=description)


def _health(name: str, message: str) -> EventDef:
    """A health failure's event (Report::healthFailure): the modes and the component first, then
    the sensor instance. PX4's events parser shifts the message's placeholders past the two it
    puts first, so PX4's "{1}" (the instance) is "{3}" here, as in all_events.json."""
    return EventDef(name, "health", message, (MODES, COMPONENT_INDEX, ("uint8_t", "arg0")))


ARMED_BY = EventDef("commander_armed_by", "default", "Armed by {1}",
                    (("px4::arm_disarm_reason_t", "arg0"),))
DISARMED_BY = EventDef("commander_disarmed_by", "default", "Disarmed by {1}",
                       (("px4::arm_disarm_reason_t", "arg0"),))
TAKEOFF_DETECTED = EventDef("commander_takeoff_detected", "default", "Takeoff detected")
LANDING_DETECTED = EventDef("commander_landing_detected", "default", "Landing detected")
ARM_DENIED = EventDef("commander_arm_denied_resolve_failures", "default",
                      "Arming denied: Resolve system health failures first")
ARM_DENIED_CALIBRATING = EventDef("commander_arm_denied_calibrating", "default",
                                  "Arming denied: calibrating")
# Commander::arm with stick input, Commander::disarm in the air
ARM_DENIED_THROTTLE_CENTER = EventDef("commander_arm_denied_throttle_center", "default",
                                      "Arming denied: throttle above center")
ARM_DENIED_THROTTLE_HIGH = EventDef("commander_arm_denied_throttle_high", "default",
                                    "Arming denied: high throttle")
ARM_DENIED_NOT_MANUAL = EventDef("commander_arm_denied_not_manual", "default",
                                 "Arming denied: switch to manual mode first")
MISSION_START_DENIED = EventDef("commander_mission_start_denied_no_mission", "default",
                                "Mission start denied! No valid mission")
DISARM_DENIED_NOT_LANDED = EventDef("commander_disarm_denied_not_landed", "default",
                                    "Disarming denied: not landed")
ARMING_SUMMARY = EventDef(
    "commander_arming_check_summary", "arming_check", "Arming check summary event",
    (("uint8_t", "chunk_idx"), (HEALTH, "error"), (HEALTH, "warning"),
     ("px4::navigation_mode_group_t", "can_arm"), ("px4::navigation_mode_group_t", "can_run")),
    type="summary")
HEALTH_SUMMARY = EventDef(
    "commander_health_summary", "health", "Health report summary event",
    (("uint8_t", "chunk_idx"), (HEALTH, "is_present"), (HEALTH, "error"), (HEALTH, "warning")),
    type="summary")
# modeCheck.cpp's checks, with its names, messages and descriptions.
CHECK_LOCAL_POS = _check("check_modes_local_pos", "No valid local position estimate")
CHECK_GLOBAL_POS = _check("check_modes_global_pos", "No valid global position estimate")
CHECK_MISSION = _check("check_modes_mission", "No valid mission available",
                       "Upload a mission first.")
# missionCheck.cpp: the navigator's mission_result.failure (it sends the reason itself)
CHECK_MISSION_FAILURE = _check("check_mission_failure", "Mission cannot be completed")
CHECK_OFFBOARD = _check("check_modes_offboard_signal", "No offboard signal",
                        "The offboard component is not sending setpoints or the required "
                        "estimate (e.g. position) is missing.")
CHECK_HOME = _check("check_modes_home_position", "Home position not set")
CHECK_MANUAL_CONTROL = _check("check_modes_manual_control", "No manual control input",
                              "Connect and enable stick input or use autonomous mode.")
CHECK_CANNOT_TAKEOFF = _check("check_modes_cannot_takeoff", "Mode not suitable for arming",
                              "Switch to another mode first.")
# The sensor checks (accelerometerCheck.cpp, baroCheck.cpp, gyroCheck.cpp, magnetometerCheck.cpp):
# a sensor that published nothing for 1 s.
CHECK_ACCEL_NO_DATA = _health("check_accel_no_data", "No valid data from Accelerometer {3}")
CHECK_BARO_NO_DATA = _health("check_baro_no_data", "No valid data from barometer {3}")
CHECK_GYRO_NO_DATA = _health("check_gyro_no_data", "No valid data from Gyro {3}")
CHECK_MAG_NO_DATA = _health("check_mag_no_data", "No valid data from Compass {3}")
# estimatorCheck.cpp checkEstimatorStatus: an innovation test ratio of estimator_status over its
# COM_ARM_EKF_* limit while disarmed (the ratio and the limit follow the modes and the component).
def _ratio_check(name: str, message: str, param: str) -> EventDef:
    return EventDef(name, "arming_check", message,
                    (MODES, COMPONENT_INDEX, ("float", "arg0"), ("float", "arg1")),
                    description=f'<profile name="dev">\nTest ratio: {{3:.3}}, limit: {{4:.3}}.\n\n'
                    f"This check can be configured via <param>{param}</param> parameter.\n"
                    "</profile>")


CHECK_EST_HGT = _ratio_check("check_estimator_hgt_est_err", "Height estimate error",
                             "COM_ARM_EKF_HGT")
CHECK_EST_VEL = _ratio_check("check_estimator_vel_est_err", "Velocity estimate error",
                             "COM_ARM_EKF_VEL")
CHECK_EST_POS = _ratio_check("check_estimator_pos_est_err", "Position estimate error",
                             "COM_ARM_EKF_POS")
CHECK_EST_YAW = _ratio_check("check_estimator_yaw_est_err", "Yaw estimate error",
                             "COM_ARM_EKF_YAW")
# framework.cpp FailsafeBase::notifyUser: the first argument is the user's mode (its PX4 custom
# mode), then the action (failsafe_action_t), the hold's seconds, the cause (failsafe_cause_t).
_MODE_ARG = ("uint32_t", "arg0")
_APPEND = "append_health_and_arming_messages"
FAILSAFE_GENERIC_HOLD = EventDef(
    "commander_failsafe_enter_generic_hold", "default",
    "Failsafe activated: switching to {2} in {3} seconds",
    (_MODE_ARG, ("px4::failsafe_action_t", "arg1"), ("uint16_t", "arg2")), type=_APPEND)
FAILSAFE_HOLD = EventDef(
    "commander_failsafe_enter_hold", "default",
    "{4}: switching to {2} in {3} seconds",
    (_MODE_ARG, ("px4::failsafe_action_t", "arg1"), ("uint16_t", "arg2"),
     ("px4::failsafe_cause_t", "arg3")))
FAILSAFE_GENERIC_WARN = EventDef(
    "commander_failsafe_enter_generic_warn", "default", "Failsafe warning:",
    (_MODE_ARG,), type=_APPEND, description="No action is triggered.")
FAILSAFE_GENERIC = EventDef(
    "commander_failsafe_enter_generic", "default",
    "Failsafe activated: Autopilot disengaged, switching to {2}",
    (_MODE_ARG, ("px4::failsafe_action_t", "arg1")), type=_APPEND)
FAILSAFE_LOW_BAT = EventDef("commander_failsafe_enter_low_bat", "default",
                            "Low battery level, return advised")
FAILSAFE_CRIT_BAT = EventDef("commander_failsafe_enter_crit_bat_warn", "default",
                             "Critical battery level, land now")
FAILSAFE_EMERGENCY_BAT = EventDef("commander_failsafe_enter_crit_low_bat_warn", "default",
                                  "Emergency battery level, land immediately")
FAILSAFE_WARN = EventDef(
    "commander_failsafe_enter_warn", "default", "Failsafe warning: {2}",
    (_MODE_ARG, ("px4::failsafe_cause_t", "arg1")), description="No action is triggered.")
FAILSAFE_ENTER = EventDef(
    "commander_failsafe_enter", "default", "{3}: switching to {2}",
    (_MODE_ARG, ("px4::failsafe_action_t", "arg1"), ("px4::failsafe_cause_t", "arg2")))
# failureDetectorCheck.cpp: the attitude beyond FD_FAIL_R / FD_FAIL_P (failure_detector.py)
CHECK_FD_ROLL = _check("check_failure_detector_roll", "Attitude failure detected",
                       "The vehicle exceeded the maximum configured roll angle.")
CHECK_FD_PITCH = _check("check_failure_detector_pitch", "Attitude failure detected",
                        "The vehicle exceeded the maximum configured pitch angle.")
# rcAndDataLinkCheck.cpp (stick input: events only) and Commander's dataLinkCheck (GCS link)
RC_LOST = EventDef("commander_rc_lost", "default", "Manual control lost")
RC_REGAINED = EventDef("commander_rc_regained", "default", "Manual control regained after {1:.1} s",
                       (("float", "arg0"),))
GCS_LOST = EventDef("commander_gcs_lost", "default", "Connection to ground control station lost")
GCS_REGAINED = EventDef("commander_dl_regained", "default", "GCS connection regained")
# The navigator's (mission_base.cpp, rtl_direct.cpp, takeoff.cpp): each beside its text
MISSION_EXECUTE = EventDef("mission_execute", "default", "Executing Mission")
MISSION_FINISHED = EventDef("mission_finished", "default", "Mission finished, landed")
MISSION_FINISHED_LOITER = EventDef("mission_finished_loiter", "default",
                                   "Mission finished, loitering")
MISSION_NOT_VALID_REFUSE = EventDef("mission_not_valid_refuse", "default",
                                    "No valid mission available, refusing takeoff")
MISSION_NOT_VALID_LOITER = EventDef("mission_not_valid_loiter", "default",
                                    "No valid mission available, loitering")
MISSION_CLIMB = EventDef("mission_climb_before_start", "default", "Climb to {1:.1m_v} above home",
                         (("float", "arg0"),))
MISSION_FAILURE_HEADING = EventDef("navigator_mission_failure_heading", "default",
                                   "Mission failure: unable to reach heading within timeout")
MISSION_READ_FAILED = EventDef("mission_failed_to_read_wp", "default",
                               "Waypoint {1} could not be read from storage",
                               (("uint16_t", "arg0"),))
RTL_RETURN_AT = EventDef("vrtl_return_at", "default",
                         "RTL: start return at {1m_v} ({2m_v} above destination)",
                         (("int32_t", "arg0"), ("int32_t", "arg1")))
RTL_LAND = EventDef("rtl_land_at_destination", "default", "RTL: land at destination")
RTL_COMPLETED_LOITER = EventDef("rtl_completed_loiter", "default", "RTL: completed, loitering")
RTL_UNSUPPORTED_FRAME = EventDef("rtl_unsupported_mav_frame", "default",
                                 "RTL: unsupported MAV_FRAME ({1})", (("uint8_t", "arg0"),))
# geofence.cpp _updateFence: an area dropped at load
GF_INVALID_HOME = EventDef("navigator_geofence_invalid_against_home", "default",
                           "Geofence invalid, doesn't contain Home position")
GF_INVALID_POSITION = EventDef("navigator_geofence_invalid_against_cur_pos", "default",
                               "Geofence invalid, doesn't contain current vehicle position")
TAKEOFF_DEFAULT_ALT = EventDef("navigator_takeoff_default_alt", "default",
                               "Using default takeoff altitude: {1:.2m}", (("float", "arg0"),))
TAKEOFF_ALREADY_HIGHER = EventDef("navigator_takeoff_already_higher", "default",
                                  "Already higher than takeoff altitude (not descending)")
# navigator_main.cpp: a DO_REPOSITION / DO_CHANGE_ALTITUDE target outside the geofence
REPOSITION_OUTSIDE_FENCE = EventDef("navigator_reposition_outside_geofence", "default",
                                    "Reposition is outside geofence")
CHANGE_ALT_OUTSIDE_FENCE = EventDef("navigator_change_altitude_outside_geofence", "default",
                                    "Altitude change is outside geofence")
# Commander's answers to NAV_RETURN_TO_LAUNCH and NAV_LAND (a mission's Return item sends the
# former too)
COMMANDER_RTL = EventDef("commander_rtl", "default", "Returning to launch")
COMMANDER_LAND = EventDef("commander_landing_current_pos", "default",
                          "Landing at current position")
# Commander::handle_command's refusals: printRejectMode (the user's mode as its PX4 custom mode,
# then the mode as navigation_mode_t), an unknown AUTO sub mode, an ARM_DISARM param1 that is
# neither arm nor disarm
MODE_NOT_AVAILABLE = EventDef(
    "commander_modeswitch_not_avail", "default",
    "Switching to mode '{2}' is currently not possible",
    (_MODE_ARG, ("px4::navigation_mode_t", "arg1")), type=_APPEND)
UNSUPPORTED_AUTO_MODE = EventDef("commander_unsupported_auto_mode", "default",
                                 "Unsupported auto mode")
UNSUPPORTED_ARM_PARAM = EventDef("commander_unsupported_arm_disarm_param", "default",
                                 "Unsupported ARM_DISARM param: {1:.3}", (("float", "arg0"),))
# Commander's stick override (auto mode or Offboard, COM_RC_OVERRIDE), and the failsafe
# framework's takeover when a failsafe acts
RC_OVERRIDE = EventDef("commander_rc_override", "default", "Pilot took over using sticks")
FAILSAFE_RC_OVERRIDE = EventDef("failsafe_rc_override", "default", "Pilot took over using sticks")
# The navigator's mission feasibility check (MissionFeasibility/FeasibilityChecker.cpp,
# mission_feasibility_checker.cpp), each beside its text
_U16, _U32, _I16 = ("uint16_t", "arg0"), ("uint32_t", "arg0"), ("int16_t", "arg0")
MIS_NO_HOME_REL_ALT = EventDef(
    "navigator_mis_no_home_rel_alt", "default",
    "Mission rejected: No home position, waypoint {1} uses relative altitude", (_I16,))
MIS_UNSUPPORTED_CMD = EventDef("navigator_mis_unsup_cmd", "default",
                               "Mission rejected: item {1}: unsupported command: {2}",
                               (_U16, ("uint16_t", "arg1")))
MIS_STARTS_WITH_LANDING = EventDef("navigator_mis_starts_w_landing", "default",
                                   "Mission rejected: starts with landing")
MIS_TAKEOFF_TOO_LOW = EventDef("navigator_mis_takeoff_too_low", "default",
                               "Mission rejected: takeoff altitude too low! Minimum: {1:.1m_v}",
                               (("float", "arg0"),))
MIS_TAKEOFF_NOT_FIRST = EventDef("navigator_mis_takeoff_not_first", "default",
                                 "Mission rejected: takeoff is not the first waypoint item")
MIS_VTOL_ITEMS = EventDef("navigator_mis_vtol_items", "default",
                          "Mission rejected: Mission contains VTOL items but vehicle is not a VTOL")
MIS_FIRST_WP_TOO_FAR = EventDef("navigator_mis_first_wp_too_far", "default",
                                "First waypoint too far away: {1m} (maximum: {2m})",
                                (_U32, ("uint32_t", "arg1")))
MIS_WP_GATE_TOO_CLOSE = EventDef(
    "navigator_mis_wp_gate_too_close", "default",
    "Distance between waypoint and gate too close: {1:.3m} (minimum: {2:.3m})",
    (("float", "arg0"), ("float", "arg1")))
MIS_TAKEOFF_MISSING = EventDef("navigator_mis_takeoff_missing", "default",
                               "Mission rejected: Takeoff waypoint required")
MIS_LAND_MISSING = EventDef("navigator_mis_land_missing", "default",
                            "Mission rejected: Landing waypoint/pattern required")
MIS_TAKEOFF_OR_LAND_MISSING = EventDef("navigator_mis_takeoff_or_land_missing", "default",
                                       "Mission rejected: Takeoff or Landing item missing")
MIS_ADD_LAND_OR_RM_TAKEOFF = EventDef("navigator_mis_add_land_or_rm_to", "default",
                                      "Mission rejected: Add Landing item or remove Takeoff")
MIS_ADD_TAKEOFF_OR_RM_LAND = EventDef("navigator_mis_add_to_or_rm_land", "default",
                                      "Mission rejected: Add Takeoff item or remove Landing")
MIS_IN_AIR_LANDING_REQ = EventDef("feasibility_mis_in_air_landing_req", "default",
                                  "Mission rejected: Landing waypoint/pattern required")
MIS_GEOFENCE_VIOLATION = EventDef("navigator_mis_geofence_violation", "default",
                                  "Geofence violation for waypoint {1}", (_I16,))
MISSION_FEASIBILITY = (
    MIS_NO_HOME_REL_ALT, MIS_UNSUPPORTED_CMD, MIS_STARTS_WITH_LANDING, MIS_TAKEOFF_TOO_LOW,
    MIS_TAKEOFF_NOT_FIRST, MIS_VTOL_ITEMS, MIS_FIRST_WP_TOO_FAR, MIS_WP_GATE_TOO_CLOSE,
    MIS_TAKEOFF_MISSING, MIS_LAND_MISSING, MIS_TAKEOFF_OR_LAND_MISSING, MIS_ADD_LAND_OR_RM_TAKEOFF,
    MIS_ADD_TAKEOFF_OR_RM_LAND, MIS_IN_AIR_LANDING_REQ, MIS_GEOFENCE_VIOLATION)
# MulticopterPositionControl::parameters_update's corrections (vehicles/position_params.py)
_F32 = (("float", "arg0"),)
TILT_SET = EventDef("mc_pos_ctrl_tilt_set", "default",
                    "Maximum tilt limit has been constrained to a safe value", _F32)
LAND_TILT_SET = EventDef("mc_pos_ctrl_land_tilt_set", "default",
                         "Land tilt limit has been constrained by maximum tilt", _F32)
CRUISE_SET = EventDef("mc_pos_ctrl_cruise_set", "default",
                      "Cruise speed has been constrained by maximum speed", _F32)
MAN_VEL_SET = EventDef("mc_pos_ctrl_man_vel_set", "default",
                       "Manual speed has been constrained by maximum speed", _F32)
UP_VEL_SET = EventDef("mc_pos_ctrl_up_vel_set", "default",
                      "Ascent speed has been constrained by max speed", _F32)
DOWN_VEL_SET = EventDef("mc_pos_ctrl_down_vel_set", "default",
                        "Descent speed has been constrained by max speed", _F32)
HOVER_THRUST_SET = EventDef("mc_pos_ctrl_hover_thrust_set", "default",
                            "Hover thrust has been constrained by min/max thrust", _F32)
# FlightTaskOrbit::applyCommandParameters: a DO_ORBIT radius beyond [1 m, MC_ORBIT_RAD_MAX]
ORBIT_RADIUS_EXCEEDED = EventDef("orbit_radius_exceeded", "default", "Orbit radius limit exceeded")
LANDING_TARGET_UNSUPPORTED_FRAME = EventDef(  # mavlink_receiver.cpp handle_message_landing_target
    "mavlink_rcv_lnd_target_unsup_coord", "default",
    "Landing target: unsupported coordinate frame {1}", (("uint8_t", "arg0"),))
POSITION_PARAMS = (TILT_SET, LAND_TILT_SET, CRUISE_SET, MAN_VEL_SET, UP_VEL_SET, DOWN_VEL_SET,
                   HOVER_THRUST_SET)
DEFINITIONS: tuple[EventDef, ...] = (
    ARMED_BY, DISARMED_BY, TAKEOFF_DETECTED, LANDING_DETECTED, ARM_DENIED, ARM_DENIED_CALIBRATING,
    ARM_DENIED_THROTTLE_CENTER, ARM_DENIED_THROTTLE_HIGH, ARM_DENIED_NOT_MANUAL,
    DISARM_DENIED_NOT_LANDED, MISSION_START_DENIED, ARMING_SUMMARY,
    HEALTH_SUMMARY,
    CHECK_LOCAL_POS, CHECK_GLOBAL_POS, CHECK_MISSION, CHECK_MISSION_FAILURE, CHECK_OFFBOARD, CHECK_HOME,
    CHECK_MANUAL_CONTROL, CHECK_CANNOT_TAKEOFF, CHECK_ACCEL_NO_DATA, CHECK_BARO_NO_DATA,
    CHECK_GYRO_NO_DATA, CHECK_MAG_NO_DATA, CHECK_EST_HGT, CHECK_EST_VEL, CHECK_EST_POS,
    CHECK_EST_YAW, CHECK_FD_ROLL, CHECK_FD_PITCH,
    FAILSAFE_GENERIC_HOLD, FAILSAFE_HOLD, FAILSAFE_GENERIC_WARN, FAILSAFE_GENERIC, FAILSAFE_LOW_BAT,
    FAILSAFE_CRIT_BAT, FAILSAFE_EMERGENCY_BAT, FAILSAFE_WARN, FAILSAFE_ENTER, RC_OVERRIDE,
    FAILSAFE_RC_OVERRIDE, RC_LOST, RC_REGAINED, GCS_LOST, GCS_REGAINED, MISSION_EXECUTE,
    MISSION_FINISHED, MISSION_FINISHED_LOITER, MISSION_NOT_VALID_REFUSE, MISSION_NOT_VALID_LOITER,
    MISSION_READ_FAILED, MISSION_FAILURE_HEADING, MISSION_CLIMB, RTL_RETURN_AT, RTL_LAND,
    RTL_COMPLETED_LOITER, RTL_UNSUPPORTED_FRAME, GF_INVALID_HOME, GF_INVALID_POSITION,
    TAKEOFF_DEFAULT_ALT, TAKEOFF_ALREADY_HIGHER, REPOSITION_OUTSIDE_FENCE,
    CHANGE_ALT_OUTSIDE_FENCE, COMMANDER_RTL, COMMANDER_LAND, MODE_NOT_AVAILABLE,
    UNSUPPORTED_AUTO_MODE, UNSUPPORTED_ARM_PARAM, ORBIT_RADIUS_EXCEEDED,
    LANDING_TARGET_UNSUPPORTED_FRAME, *MISSION_FEASIBILITY, *POSITION_PARAMS)


# navigation_mode_t (events/enums.json): mode_util::navigation_mode's value of each navigation
# state, with the enum's description, and mode_util::nav_state_names' name (what printRejectMode's
# text says).
NAVIGATION_MODE: dict[NavState, tuple[int, str, str]] = {
    N.MANUAL: (0, "Manual", "Manual"), N.ALTCTL: (1, "Altitude control", "Altitude"),
    N.POSCTL: (2, "Position control", "Position"), N.AUTO_MISSION: (3, "Mission", "Mission"),
    N.AUTO_LOITER: (4, "Hold", "Hold"), N.AUTO_RTL: (5, "RTL", "Return"),
    N.POSITION_SLOW: (9, "Position Slow", "Position Slow"), N.ACRO: (6, "Acro", "Acro"),
    N.OFFBOARD: (7, "Offboard", "Offboard"), N.STAB: (8, "Stabilized", "Stabilized"),
    N.AUTO_TAKEOFF: (10, "Takeoff", "Takeoff"), N.AUTO_LAND: (11, "Land", "Land"),
    N.AUTO_FOLLOW_TARGET: (12, "Follow Target", "Follow Target"),
    N.AUTO_PRECLAND: (13, "Precision Landing", "Precision Landing"),
    N.ORBIT: (14, "Orbit", "Orbit")}
NAVIGATION_MODE_UNKNOWN = 255  # "[Unknown]" (Descend, Termination)


@dataclass(frozen=True)
class Event:
    sequence: int
    id: int
    time_boot_ms: int
    log_levels: int  # internal << 4 | external
    arguments: bytes  # MAX_ARGUMENTS bytes at most
    time_s: float = 0.0  # simulated time it was sent (the logger's timestamp)


class EventLog:
    """One vehicle's events, as PX4's events::send and the MAVLink EventBuffer keep them."""

    def __init__(self, boot_time_s: float = 0.0) -> None:
        self.boot_time_s = boot_time_s
        self.latest = INITIAL_SEQUENCE  # the newest event's sequence (none yet: the initial)
        self._buffer: deque[Event] = deque(maxlen=BUFFER_SIZE)

    def __len__(self) -> int:
        return len(self._buffer)

    def send(self, now_s: float, event: EventDef, external: Log, internal: Log | None = None,
             fmt: str = "", *args: float) -> Event:
        """events::send: ``args`` packed little-endian by ``fmt`` (struct codes, no padding)."""
        payload = struct.pack("<" + fmt, *args) if fmt else b""
        if len(payload) > MAX_ARGUMENTS:
            raise ValueError(f"{event.name}: {len(payload)} argument bytes")
        self.latest = (self.latest + 1) & 0xFFFF
        level = external if internal is None else internal
        record = Event(self.latest, event.id, max(0, int((now_s - self.boot_time_s) * 1000)),
                       (int(level) << 4) | int(external), payload, now_s)
        self._buffer.append(record)
        return record

    def after(self, sequence: int) -> list[Event]:
        """The buffered events newer than ``sequence`` (16-bit wrap-around), oldest first."""
        return [e for e in self._buffer if 0 < (e.sequence - sequence) & 0xFFFF < 0x8000]

    def get(self, sequence: int) -> Event | None:
        for e in self._buffer:
            if e.sequence == sequence:
                return e
        return None

    def oldest_after(self, sequence: int) -> int:
        """EventBuffer::get_oldest_sequence_after: the buffered sequence closest after
        ``sequence`` (wrapping), the newest when none is buffered."""
        best, best_d = self.latest, None
        for e in self._buffer:
            d = (e.sequence - sequence) & 0xFFFF
            if d and (best_d is None or d < best_d):
                best, best_d = e.sequence, d
        return best
