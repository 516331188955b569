"""The topics PX4's logger writes, with PX4's names and field names, read from a vehicle.

Source: PX4 src/modules/logger/logged_topics.cpp (add_default_topics, and the SITL block that
adds the ground truth and logs the estimator's outputs at full rate), the uORB messages of
PX4 1.15 (msg/*.msg) for the field names, and commander's ModeUtil/control_mode.cpp for
vehicle_control_mode. The sensor topics are in logged_sensors.py, the ground truth in
logged_truth.py, the status topics (takeoff, failure detector, mission result, MAVLink links) in
logged_status.py.
Rules:
- Each topic has a subset of PX4's fields with PX4's names and types, as CORNET has them; a
  field is never invented. A topic's ULog format and subscription carry its uORB topic name
  (vehicle_gps_position, not its message sensor_gps: Logger::write_formats names a format by
  o_name), instance 0; nested formats (position_setpoint, esc_report) are in NESTED_FORMATS.
- ``interval_s`` is logged_topics.cpp's (SITL build, default profile), the last add_topic of
  a topic setting it (estimator_status: the SITL block's 0 after 200 ms; vehicle_magnetometer:
  add_optional_topic_multi's 500 ms after 200 ms). The logger samples at 50 Hz; topics
  PX4 publishes at the sensors' rate have a ``step`` reader, and the logger writes one record
  per physics step (250 Hz) since its last sample, from the World's recent-steps ring, keeping
  the interval (sensor_combined and vehicle_attitude: every step; vehicle_angular_velocity and
  the attitude ground truth: every 10 ms). For the others an interval under 20 ms means "every
  tick". ``on_change`` topics (PX4: no interval, published on change) are logged when their
  values change. A topic logged at every update that its module publishes at a fixed rate
  has that ``period_s`` (cpuload: load_mon's 500 ms).
- ``read(vehicle, now_us)`` returns the field values in order, an array field's elements one by
  one (flat, as the record is packed), or None while PX4 would not publish the topic (home_position
  before home is set, vehicle_global_position without a valid position). A ``timestamp_sample``
  is the sampling instant ``now_us`` (the state read is the one of that instant).
- The ``*_groundtruth`` topics are the simulator's truth (PX4 SITL logs them), the others the
  estimate or the controllers' setpoints, as PX4 logs them.
- The topics sampled at every tick read the commander's state (``autopilot.commander``,
  ``autopilot.landed_state``) rather than ``status``, which builds a whole VehicleStatus from
  it at each read; the values are the same.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from gateway.mavlink.heartbeat import CPULOAD_LOAD, CPULOAD_RAM_USAGE
from gateway.mavlink.telemetry_estimator import gps_ctrl_of, innovation_test_ratios
from gateway.onboard.logged_commander import ACTUATOR_ARMED, RTL_TIME_ESTIMATE
from gateway.onboard.logged_sensors import (
    BATTERY_STATUS,
    SENSOR_BARO,
    SENSOR_COMBINED,
    VEHICLE_AIR_DATA,
    VEHICLE_GPS_POSITION,
    VEHICLE_IMU_STATUS,
    VEHICLE_MAGNETOMETER,
)
from gateway.onboard.logged_status import STATUS_TOPICS
from gateway.onboard.logged_truth import TRUTH_TOPICS
from gateway.onboard.topic import COMMANDER_REPUBLISH_S, U64, B, D, F, Topic
from vehicles.control.quat import q_rotate, q_yaw
from vehicles.estimation import (
    E_ACCURACY,
    E_QUAT_RESET,
    E_VXY_RESET,
    E_VZ_RESET,
    E_WIND,
    E_WIND_VAR,
    E_XY_RESET,
    E_Z_RESET,
    R_Q,
    R_RATES,
)
from vehicles.types import NavState

__all__ = ["TOPICS", "Topic"]

ARMING_STATE_DISARMED, ARMING_STATE_ARMED = 1, 2  # vehicle_status.arming_state (PX4 1.15)
U8 = "uint8_t"
VEHICLE_TYPE_ROTARY_WING = 1  # vehicle_status.vehicle_type
ACTUATOR_MOTORS = 12  # actuator_motors.control: NUM_CONTROLS
NAN3 = (math.nan, math.nan, math.nan)
LOAD_MON_PERIOD_S = 0.5  # LoadMon::start: ScheduleOnInterval(500_ms)


def _attitude(v: Any, now_us: int) -> tuple:
    return v.kinematics.attitude_q


def _local_position(v: Any, now_us: int) -> tuple:
    k = v.kinematics
    a = v.acceleration_ned_mps2
    heading = q_yaw(k.attitude_q)
    valid = v.autopilot.commander.position_valid
    e = v.estimator
    o = v.origin
    return (*k.position_ned_m, *k.velocity_ned_mps, *a, heading, e[E_QUAT_RESET + 1],
            int(e[E_QUAT_RESET]) & 0xFF, valid, valid, valid, valid,
            o.lat_deg, o.lon_deg, o.alt_amsl_m, e[E_ACCURACY], e[E_ACCURACY + 1],
            *_resets(e, E_XY_RESET), e[E_Z_RESET + 1], int(e[E_Z_RESET]) & 0xFF,
            *_resets(e, E_VXY_RESET), e[E_VZ_RESET + 1], int(e[E_VZ_RESET]) & 0xFF)


def _resets(e: Sequence[float], column: int) -> tuple:
    """An estimator reset's change (north, east) and its uint8 counter (estimation.E_*_RESET)."""
    return e[column + 1], e[column + 2], int(e[column]) & 0xFF


def _global_position(v: Any, now_us: int) -> tuple | None:
    if not v.autopilot.commander.position_valid:  # EKF2 publishes it only while valid
        return None
    g, e = v.global_position, v.estimator
    return (g.lat_deg, g.lon_deg, g.alt_amsl_m, e[E_ACCURACY], e[E_ACCURACY + 1],
            int(e[E_XY_RESET]) & 0xFF, -e[E_Z_RESET + 1], int(e[E_Z_RESET]) & 0xFF)


def _status(v: Any, now_us: int) -> tuple:
    """Commander's vehicle_status of a multicopter: the user's mode beside the one flown,
    failsafe_and_user_took_over as Failsafe::userTakeoverActive, never a VTOL."""
    commander = v.autopilot.commander
    mav_type = v.params.get("MAV_TYPE", 2)
    return (ARMING_STATE_ARMED if commander.armed else ARMING_STATE_DISARMED,
            int(commander.user_nav_state), int(commander.nav_state), VEHICLE_TYPE_ROTARY_WING,
            bool(commander.failsafe_active), commander.failsafe.user_takeover_active,
            commander.gcs_lost,
            False, False, False, int(mav_type if mav_type is not None else 2))


def _failsafe_flags(v: Any, now_us: int) -> tuple | None:
    """Commander's failsafe_flags (the failsafe framework's inputs), those CORNET has; None
    until the autopilot's first pass."""
    commander = v.autopilot.commander
    flags = commander.failsafe.flags
    if flags is None:
        return None
    invalid = not commander.position_valid  # the global position is the local one's (origin)
    return (invalid, invalid, not commander.mission_valid, flags.offboard_lost,
            v.home is None, flags.manual_control_lost, flags.gcs_lost, flags.battery_warning,
            flags.geofence_breached, flags.mission_failure, flags.fd_critical_failure)


def _attitude_step(r: Sequence[float], t_us: int) -> Sequence[float]:
    return r[R_Q:R_Q + 4]


def _angular_velocity_step(r: Sequence[float], t_us: int) -> tuple:
    return (t_us, *r[R_RATES:R_RATES + 3])


def _actuator_outputs(v: Any, now_us: int) -> tuple:
    """The ESC outputs (the commanded rotor speeds, as SERVO_OUTPUT_RAW), unused ones 0."""
    outputs = v.targets.outputs[:16]
    return (len(outputs), *outputs, *(0.0,) * (16 - len(outputs)))


def _setpoint(v: Any, now_us: int) -> tuple:
    """mc_pos_control's output: the position setpoint, PositionControl's velocity and
    acceleration setpoints and its thrust vector (NED: q_d's body z × the collective thrust),
    the heading setpoint; NaN while no position control runs."""
    sp = v.position_setpoint_ned_m
    pos = tuple(sp) if sp is not None else NAN3
    t = v.targets
    vel = t.velocity_ned_mps
    thrust = q_rotate(t.attitude_q, (0.0, 0.0, -t.thrust_norm)) if pos[2] == pos[2] else NAN3
    return (*pos, *vel, *t.acceleration_ned_mps2, *thrust, t.yaw_rad, t.yawspeed_radps)


def _trajectory_setpoint(v: Any, now_us: int) -> tuple:
    sp = v.position_setpoint_ned_m
    return (*(sp if sp is not None else NAN3), *NAN3)


def _land_detected(v: Any, now_us: int) -> tuple:
    landed = int(v.autopilot.landed_state) == 1  # MAV_LANDED_STATE_ON_GROUND
    return (landed, landed, landed)


def _estimator_status(v: Any, now_us: int) -> tuple:
    """The innovation test ratios and accuracies, the state resets' counts (uint8, wrapping);
    EKF2 1.15 leaves health_flags and timeout_flags 0, and time_slip (IMU time missed) is 0 in
    lockstep."""
    e = v.estimator
    resets = (int(e[c]) & 0xFF for c in (E_VXY_RESET, E_VZ_RESET, E_XY_RESET, E_Z_RESET,
                                          E_QUAT_RESET))
    return (*innovation_test_ratios(e, gps_ctrl_of(v.params)), e[E_ACCURACY], e[E_ACCURACY + 1],
            0.0, *resets, 0, 0)


def _wind(v: Any, now_us: int) -> tuple:
    e = v.estimator
    return (e[E_WIND], e[E_WIND + 1], e[E_WIND_VAR] / 2, e[E_WIND_VAR] / 2)


def _attitude_setpoint(v: Any, now_us: int) -> tuple:
    t = v.targets
    return (t.yawspeed_radps, *t.attitude_q, 0.0, 0.0, -t.thrust_norm)


def _rates_setpoint(v: Any, now_us: int) -> tuple:
    t = v.targets
    return (*t.rates_frd_radps, 0.0, 0.0, -t.thrust_norm)


def _angular_velocity(v: Any, now_us: int) -> tuple:
    k = v.kinematics
    return (now_us, *k.rates_frd_radps)


def _thrust_setpoint(v: Any, now_us: int) -> tuple:
    t = v.targets
    return (now_us, 0.0, 0.0, -t.thrust_norm)


def _triplet(v: Any, now_us: int) -> tuple:
    """The navigator's position_setpoint_triplet.current while position control flies to one
    (global: lat, lon, alt AMSL, NaN without an altitude), else invalid (reset_triplets)."""
    target = v.targets.global_target_ned_m
    if target is None or target[0] != target[0] or target[1] != target[1]:
        return (False, math.nan, math.nan, math.nan)
    n, e, d = target
    g = v.origin.offset_ned(n, e, 0.0 if d != d else d)
    return (True, g.lat_deg, g.lon_deg, g.alt_amsl_m if d == d else math.nan)


def _torque_setpoint(v: Any, now_us: int) -> tuple:
    """mc_rate_control's output: the rate controller's normalized torque (FRD)."""
    return (now_us, *v.targets.torque_sp)


def _rate_ctrl_status(v: Any, now_us: int) -> tuple:
    """mc_rate_control's rate_ctrl_status: the rate integrators."""
    return v.targets.rate_integral


def _actuator_motors(v: Any, now_us: int) -> tuple:
    """The allocator's normalized motor commands, from the ESC outputs (SIM_GZ_EC_MIN + control
    × (SIM_GZ_EC_MAX − SIM_GZ_EC_MIN)); 0 while disarmed; NaN past the vehicle's motors."""
    t = v.targets
    frame = v.airframe
    low, span = frame.esc_min_radps, frame.esc_max_radps - frame.esc_min_radps
    controls = [max(0.0, (out - low) / span) if out > 0.0 else 0.0
                for out in t.outputs[:ACTUATOR_MOTORS]]
    controls += [math.nan] * (ACTUATOR_MOTORS - len(controls))
    return (now_us, 0, *controls)


def _hover_thrust(v: Any, now_us: int) -> tuple:
    hte = v.autopilot.hover_thrust
    ekf = hte.ekf
    return (now_us, ekf.hover_thr, ekf.state_var, ekf.innov, ekf.innov_var,
            ekf.innov_test_ratio, ekf.acc_var * ekf.acc_var_scale, hte.valid)


def _home(v: Any, now_us: int) -> tuple | None:
    home = v.home
    if home is None:
        return None
    g = home.geo
    return (g.lat_deg, g.lon_deg, g.alt_amsl_m, *home.position_ned_m, home.yaw_rad, True, True,
            True)


_MANUAL = {NavState.MANUAL: 0b0000011, NavState.STAB: 0b0000011, NavState.ACRO: 0b0000001,
           NavState.ALTCTL: 0b0001111, NavState.POSCTL: 0b0111111,
           NavState.POSITION_SLOW: 0b0111111}
_AUTO = frozenset({NavState.AUTO_RTL, NavState.AUTO_LAND, NavState.AUTO_PRECLAND,
                   NavState.AUTO_MISSION, NavState.AUTO_LOITER, NavState.AUTO_TAKEOFF})
# Controller bits: rates, attitude, altitude, climb rate, position, velocity, acceleration.
_RATES, _ATT, _ALT, _CLIMB, _POS, _VEL, _ACC = (1 << i for i in range(7))


def _control_mode(v: Any, now_us: int) -> tuple:
    """commander's getVehicleControlMode for a multicopter (ModeUtil/control_mode.cpp)."""
    commander = v.autopilot.commander
    nav = commander.nav_state
    manual = auto = offboard = termination = False
    bits = 0
    if nav in _MANUAL:
        manual, bits = True, _MANUAL[nav]
    elif nav in _AUTO:
        auto, bits = True, _RATES | _ATT | _ALT | _CLIMB | _POS | _VEL
    elif nav is NavState.DESCEND:
        auto, bits = True, _RATES | _ATT | _CLIMB
    elif nav is NavState.TERMINATION:
        termination = True
    elif nav in (NavState.AUTO_FOLLOW_TARGET, NavState.ORBIT):
        bits = _RATES | _ATT | _ALT | _CLIMB | _POS | _VEL
    elif nav is NavState.OFFBOARD:
        offboard = True
        sp = v.autopilot.offboard.setpoint  # offboard_control_mode, in the switch's order
        if sp is None:
            pass
        elif sp.attitude_q is None and sp.has_body_rates:
            bits = _RATES
        elif sp.attitude_q is not None:
            bits = _RATES | _ATT
        elif sp.has_acceleration:
            bits = _ACC | _RATES | _ATT
        elif sp.has_velocity:
            bits = _VEL | _ALT | _CLIMB | _ACC | _RATES | _ATT
        elif sp.has_position:
            bits = _POS | _VEL | _ALT | _CLIMB | _ACC | _RATES | _ATT
    mc_position = bool(bits & (_ALT | _CLIMB | _POS | _VEL | _ACC))
    return (commander.armed, mc_position, manual, auto, offboard, bool(bits & _RATES),
            bool(bits & _ATT), bool(bits & _ACC), bool(bits & _VEL), bool(bits & _POS),
            bool(bits & _ALT), bool(bits & _CLIMB), termination)


def _manual_control(v: Any, now_us: int) -> tuple:
    """manual_control_setpoint as ManualControl publishes it (vehicles/manual_setpoint.py),
    stamped with its publication: the zero setpoint, invalid, from boot; each stick sample the
    vehicle flies on (timestamp_sample: when it came), again at each 200 ms timer Run while it
    is fresh; once lost, the last sticks marked invalid, then nothing new."""
    manual = v.autopilot.manual
    published = manual.setpoint
    _, at_s, valid = published.latest(now_us * 1e-6, float(v.params["COM_RC_LOSS_T"]))
    sticks = published.sticks
    sample_s = published.input_s
    # mavlink_receiver's MANUAL_CONTROL: flaps and aux1-6 0, the buttons passed on
    return (round(at_s * 1e6), 0 if sample_s is None else round(sample_s * 1e6), valid,
            sticks.roll, sticks.pitch, sticks.yaw, sticks.throttle, 0.0, *_AUX, manual.moving,
            sticks.buttons & 0xFFFF)


_AUX = (0.0,) * 6


def _cpuload(v: Any, now_us: int) -> tuple | None:
    """load_mon's cpuload (heartbeat.py has the values); none before its second run, the
    first only taking the times."""
    if now_us < LOAD_MON_PERIOD_S * 1e6:
        return None
    return (CPULOAD_LOAD, CPULOAD_RAM_USAGE)


ESC_REPORTS = 8  # esc_status_s::CONNECTED_ESC_MAX


def _esc_status(v: Any, now_us: int) -> tuple:
    """gz_bridge's GZMixingInterfaceESC::motorSpeedCallback: one report per commanded rotor
    speed, its value (an integer, the mixer's output) as esc_rpm, every ESC online, armed while
    its command is above 0; the reports beyond the motors zero."""
    outputs = v.targets.outputs[:ESC_REPORTS]
    armed = 0
    reports: list[int] = []
    for i, out in enumerate(outputs):
        if out > 0:
            armed |= 1 << i
        reports += (now_us, int(out))
    reports += (0, 0) * (ESC_REPORTS - len(outputs))
    return (len(outputs), (1 << len(outputs)) - 1, armed, *reports)


TOPICS: tuple[Topic, ...] = (
    Topic("vehicle_attitude", (("float[4]", "q"),), 0.0, _attitude, step=_attitude_step),
    Topic("vehicle_local_position", ((F, "x"), (F, "y"), (F, "z"), (F, "vx"), (F, "vy"), (F, "vz"),
                                     (F, "ax"), (F, "ay"), (F, "az"), (F, "heading"),
                                     (F, "delta_heading"), (U8, "heading_reset_counter"),
                                     (B, "xy_valid"), (B, "z_valid"), (B, "v_xy_valid"),
                                     (B, "v_z_valid"), (D, "ref_lat"), (D, "ref_lon"),
                                     (F, "ref_alt"), (F, "eph"), (F, "epv"),
                                     ("float[2]", "delta_xy"), (U8, "xy_reset_counter"),
                                     (F, "delta_z"), (U8, "z_reset_counter"),
                                     ("float[2]", "delta_vxy"), (U8, "vxy_reset_counter"),
                                     (F, "delta_vz"), (U8, "vz_reset_counter")),
          0.0, _local_position),
    Topic("vehicle_global_position", ((D, "lat"), (D, "lon"), (F, "alt"), (F, "eph"), (F, "epv"),
                                      (U8, "lat_lon_reset_counter"), (F, "delta_alt"),
                                      (U8, "alt_reset_counter")), 0.0, _global_position),
    Topic("vehicle_status", (("uint8_t", "arming_state"), ("uint8_t", "nav_state_user_intention"),
                             ("uint8_t", "nav_state"), ("uint8_t", "vehicle_type"),
                             (B, "failsafe"), (B, "failsafe_and_user_took_over"),
                             (B, "gcs_connection_lost"), (B, "is_vtol"),
                             (B, "is_vtol_tailsitter"), (B, "in_transition_mode"),
                             ("uint8_t", "system_type")), 0.0, _status, on_change=True,
          republish_s=COMMANDER_REPUBLISH_S),
    SENSOR_COMBINED,
    VEHICLE_GPS_POSITION,
    BATTERY_STATUS,
    Topic("actuator_outputs", (("uint32_t", "noutputs"), ("float[16]", "output")), 0.1,
          _actuator_outputs),
    Topic("vehicle_local_position_setpoint", ((F, "x"), (F, "y"), (F, "z"), (F, "vx"), (F, "vy"),
                                              (F, "vz"), ("float[3]", "acceleration"),
                                              ("float[3]", "thrust"), (F, "yaw"),
                                              (F, "yawspeed")), 0.1, _setpoint),
    Topic("trajectory_setpoint", (("float[3]", "position"), ("float[3]", "velocity")), 0.2,
          _trajectory_setpoint),
    Topic("vehicle_land_detected", ((B, "landed"), (B, "maybe_landed"), (B, "ground_contact")),
          0.0, _land_detected, on_change=True),
    Topic("estimator_status", ((F, "vel_test_ratio"), (F, "pos_test_ratio"),
                               (F, "hgt_test_ratio"), (F, "mag_test_ratio"),
                               (F, "pos_horiz_accuracy"), (F, "pos_vert_accuracy"),
                               (F, "time_slip"), (U8, "reset_count_vel_ne"),
                               (U8, "reset_count_vel_d"), (U8, "reset_count_pos_ne"),
                               (U8, "reset_count_pod_d"), (U8, "reset_count_quat"),
                               ("uint8_t", "health_flags"),
                               ("uint8_t", "timeout_flags")), 0.0, _estimator_status),
    Topic("wind", ((F, "windspeed_north"), (F, "windspeed_east"), (F, "variance_north"),
                   (F, "variance_east")), 0.0, _wind),
    Topic("vehicle_attitude_setpoint", ((F, "yaw_sp_move_rate"), ("float[4]", "q_d"),
                                        ("float[3]", "thrust_body")), 0.05, _attitude_setpoint),
    Topic("vehicle_rates_setpoint", ((F, "roll"), (F, "pitch"), (F, "yaw"),
                                     ("float[3]", "thrust_body")), 0.02, _rates_setpoint),
    Topic("vehicle_angular_velocity", ((U64, "timestamp_sample"), ("float[3]", "xyz")), 0.01,
          _angular_velocity, step=_angular_velocity_step),
    Topic("vehicle_thrust_setpoint", ((U64, "timestamp_sample"), ("float[3]", "xyz")), 0.02,
          _thrust_setpoint),
    Topic("actuator_motors", ((U64, "timestamp_sample"), ("uint16_t", "reversible_flags"),
                              (f"float[{ACTUATOR_MOTORS}]", "control")), 0.1, _actuator_motors),
    Topic("hover_thrust_estimate", ((U64, "timestamp_sample"), (F, "hover_thrust"),
                                    (F, "hover_thrust_var"), (F, "accel_innov"),
                                    (F, "accel_innov_var"), (F, "accel_innov_test_ratio"),
                                    (F, "accel_noise_var"), (B, "valid")), 0.1, _hover_thrust),
    Topic("home_position", ((D, "lat"), (D, "lon"), (F, "alt"), (F, "x"), (F, "y"), (F, "z"),
                            (F, "yaw"), (B, "valid_alt"), (B, "valid_hpos"), (B, "valid_lpos")),
          0.0, _home, on_change=True),
    Topic("vehicle_control_mode", tuple((B, f"flag_{name}") for name in (
        "armed", "multicopter_position_control_enabled", "control_manual_enabled",
        "control_auto_enabled", "control_offboard_enabled", "control_rates_enabled",
        "control_attitude_enabled", "control_acceleration_enabled", "control_velocity_enabled",
        "control_position_enabled", "control_altitude_enabled", "control_climb_rate_enabled",
        "control_termination_enabled")), 0.0, _control_mode, on_change=True,
          republish_s=COMMANDER_REPUBLISH_S),
    Topic("manual_control_setpoint", ((U64, "timestamp_sample"), (B, "valid"), (F, "roll"),
                                      (F, "pitch"), (F, "yaw"), (F, "throttle"), (F, "flaps"),
                                      *((F, f"aux{i}") for i in range(1, 7)),
                                      (B, "sticks_moving"), ("uint16_t", "buttons")), 0.2,
          _manual_control, on_change=True, stamped=True),
    VEHICLE_AIR_DATA,
    VEHICLE_MAGNETOMETER,
    *TRUTH_TOPICS,
    Topic("failsafe_flags", tuple((B, name) for name in (
        "local_position_invalid", "global_position_invalid", "auto_mission_missing",
        "offboard_control_signal_lost", "home_position_invalid", "manual_control_signal_lost",
        "gcs_connection_lost")) + (("uint8_t", "battery_warning"), (B, "geofence_breached"),
                                   (B, "mission_failure"), (B, "fd_critical_failure")), 0.0,
          _failsafe_flags, on_change=True),
    SENSOR_BARO,
    VEHICLE_IMU_STATUS,
    Topic("vehicle_torque_setpoint", ((U64, "timestamp_sample"), ("float[3]", "xyz")), 0.02,
          _torque_setpoint),
    Topic("rate_ctrl_status", ((F, "rollspeed_integ"), (F, "pitchspeed_integ"),
                               (F, "yawspeed_integ")), 0.2, _rate_ctrl_status),
    Topic("position_setpoint_triplet", (("position_setpoint", "current"),), 0.2, _triplet,
          on_change=True),
    Topic("cpuload", ((F, "load"), (F, "ram_usage")), 0.0, _cpuload, period_s=LOAD_MON_PERIOD_S),
    Topic("esc_status", (("uint8_t", "esc_count"), ("uint8_t", "esc_online_flags"),
                         ("uint8_t", "esc_armed_flags"), (f"esc_report[{ESC_REPORTS}]", "esc")),
          0.25, _esc_status),
    ACTUATOR_ARMED,
    RTL_TIME_ESTIMATE,
    *STATUS_TOPICS,
)
# The nested formats the topics use (PX4 writes each one's format beside the topics').
NESTED_FORMATS = {"position_setpoint": ((B, "valid"), (D, "lat"), (D, "lon"), (F, "alt")),
                  "esc_report": ((U64, "timestamp"), ("int32_t", "esc_rpm"))}


# Topics logged at every message (logged_topics.cpp: no interval), from the vehicle's command
# journal (vehicles/command_journal.py) rather than sampled: the commands a link dispatched
# (mavlink_receiver publishes vehicle_command, from_external) and the ACKs sent back.
VEHICLE_COMMAND = ("vehicle_command", ((F, "param1"), (F, "param2"), (F, "param3"), (F, "param4"),
                                       (D, "param5"), (D, "param6"), (F, "param7"),
                                       ("uint32_t", "command"), ("uint8_t", "source_system"),
                                       ("uint16_t", "source_component"), (B, "from_external")))
VEHICLE_COMMAND_ACK = ("vehicle_command_ack", (("uint32_t", "command"), ("uint8_t", "result"),
                                               ("uint8_t", "target_system"),
                                               ("uint16_t", "target_component"),
                                               (B, "from_external")))
# The events (vehicles/events.py) as PX4's logger logs the `event` topic (msg/Event.msg); Flight
# Review and pyulog's PX4Events read them by these names.
EVENT = ("event", (("uint32_t", "id"), ("uint16_t", "event_sequence"),
                   ("uint8_t[25]", "arguments"), ("uint8_t", "log_levels")))
EVENT_TOPICS = (VEHICLE_COMMAND, VEHICLE_COMMAND_ACK, EVENT)


def event_values(event: Any) -> tuple:
    """event's fields of a vehicles.events.Event."""
    return (event.id, event.sequence, *event.arguments.ljust(25, b"\0"), event.log_levels)


def command_values(record: Any) -> tuple:
    """vehicle_command's fields of a CommandRecord."""
    return (*record.params, record.command, record.source_system & 0xFF,
            record.source_component & 0xFFFF, True)


def command_ack_values(record: Any) -> tuple:
    """vehicle_command_ack's fields of a CommandRecord that was answered."""
    return (record.command, record.result & 0xFF, record.source_system & 0xFF,
            record.source_component & 0xFFFF, True)


def onboard_ack_values(ack: Any) -> tuple:
    """vehicle_command_ack's fields of an answer a module gave on its own (an OnboardAck)."""
    return (ack.command, ack.result & 0xFF, ack.target_system & 0xFF,
            ack.target_component & 0xFFFF, False)
