"""HEARTBEAT, SYS_STATUS, EXTENDED_SYS_STATE and CURRENT_MODE from the commander's VehicleStatus.

Source: PX4 v1.15 streams HEARTBEAT.hpp, SYS_STATUS.hpp, CURRENT_MODE.hpp; MAVSDK's health rules.
- HEARTBEAT: type = MAV_TYPE param, autopilot PX4 (12), mavlink_version 3, modes from modes.py.
- system_status: FLIGHT_TERMINATION once terminated, else CRITICAL armed in failsafe, ACTIVE
  armed; disarmed STANDBY while pre_flight_checks_pass (canArm in the current mode, our
  prearm_ok), else UNINIT. PX4 never sends BOOT.
- SYS_STATUS bits come from the commander's health_report, one MAV_SYS_STATUS bit per health
  component (fillOutComponent): present if the check found it, healthy unless an arming check or
  health check flagged it (error or warning; an absent component is healthy), enabled if present
  or unhealthy. PREARM_CHECK is only ever a health bit (canArm in the current mode). Bits without
  a component (attitude, position control, logging ...) are never set, and
  MAV_SYS_STATUS_EXTENSION_USED is not either, though the extended fields carry the parachute
  (RECOVERY_SYSTEM): healthy, absent.
  Why MAVSDK cares (telemetry_impl.cpp): is_global_position_ok = GPS (32) present, enabled AND
  healthy → GPS health follows position_valid; is_armable = PREARM_CHECK in health; RC_RECEIVER
  present → rc_status available. Without stick input the manual-control mode requirement
  ("No manual control input", modeCheck.cpp) flags remote_control: unhealthy, so enabled.
- SYS_STATUS battery: the filtered voltage (mV) and current (cA) converted as C does
  (truncating), remaining ceilf'd to a percent.
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20 import development

from gateway.mavlink.codec import c_int, f32_mul, payload_of
from gateway.mavlink.modes import heartbeat_modes
from vehicles.estimation import F_ACC, F_BARO, F_GPS_OFF, F_GYRO, F_MAG
from vehicles.types import NavState, VehicleStatus

MAV_AUTOPILOT_PX4 = 12
MAV_TYPE_QUADROTOR = 2
MAVLINK_VERSION = 3
# load_mon's cpuload (LoadMon.cpp, Linux): load is the PX4 process's CPU time over the elapsed
# time, ram_usage the host's used RAM fraction (/proc/meminfo, as free(1)). Neither has a
# simulated counterpart, so both are constants, of a lockstep SITL on a desktop host; SYS_STATUS
# sends load x 1000 (SYS_STATUS.hpp) and the logger logs the same topic.
CPULOAD_LOAD, CPULOAD_RAM_USAGE = 0.2, 0.35

# MAV_STATE
MAV_STATE_UNINIT = 0
MAV_STATE_STANDBY = 3
MAV_STATE_ACTIVE = 4
MAV_STATE_CRITICAL = 5
MAV_STATE_FLIGHT_TERMINATION = 8

# MAV_SYS_STATUS_SENSOR bits of SYS_STATUS.hpp's health components
SENSOR_3D_GYRO, SENSOR_3D_ACCEL, SENSOR_3D_MAG, SENSOR_ABSOLUTE_PRESSURE = 0x1, 0x2, 0x4, 0x8
SENSOR_DIFFERENTIAL_PRESSURE = 0x10
SENSOR_GPS = 0x20
SENSOR_MOTOR_OUTPUTS = 0x8000  # motors_escs
SENSOR_RC_RECEIVER = 0x10000  # remote_control (joystick or RC)
SENSOR_AHRS = 0x200000  # local_position_estimate
SENSOR_BATTERY = 0x2000000
SENSOR_PREARM_CHECK = 0x10000000
SENSOR_OBSTACLE_AVOIDANCE = 0x20000000  # avoidance
# Every bit SYS_STATUS.hpp fills from a health component.
SENSORS_MAPPED = (SENSOR_3D_GYRO | SENSOR_3D_ACCEL | SENSOR_3D_MAG | SENSOR_ABSOLUTE_PRESSURE
                  | SENSOR_DIFFERENTIAL_PRESSURE | SENSOR_GPS | SENSOR_MOTOR_OUTPUTS
                  | SENSOR_RC_RECEIVER | SENSOR_AHRS | SENSOR_BATTERY | SENSOR_OBSTACLE_AVOIDANCE)
# The components PX4 SITL's checks find: gyro, accel, mag, baro, GPS (once fused), estimator,
# battery.
SENSORS_PRESENT = (SENSOR_3D_GYRO | SENSOR_3D_ACCEL | SENSOR_3D_MAG | SENSOR_ABSOLUTE_PRESSURE
                   | SENSOR_GPS | SENSOR_AHRS | SENSOR_BATTERY)  # 0x0220002F
# MAV_SYS_STATUS_SENSOR_EXTENDED: the parachute component, absent and so healthy.
SENSOR_EXT_RECOVERY_SYSTEM = 0x1

MAV_VTOL_STATE_UNDEFINED = 0
LITHIUM_BATTERY_RECOGNITION_V = 2.1
MSG_ID_CURRENT_MODE = development.MAVLINK_MSG_ID_CURRENT_MODE
_HEARTBEAT = payload_of(mavlink2.MAVLink_heartbeat_message)
_SYS_STATUS = payload_of(mavlink2.MAVLink_sys_status_message)
_EXTENDED_SYS_STATE = payload_of(mavlink2.MAVLink_extended_sys_state_message)
_CURRENT_MODE = payload_of(development.MAVLink_current_mode_message)

# A failed sensor (off or stuck) → its SYS_STATUS health bit, as PX4's sensor checks report a
# sensor that times out or stops changing.
FAILED_SENSOR_BITS = ((F_GPS_OFF, SENSOR_GPS), (F_BARO, SENSOR_ABSOLUTE_PRESSURE),
                      (F_MAG, SENSOR_3D_MAG), (F_GYRO, SENSOR_3D_GYRO), (F_ACC, SENSOR_3D_ACCEL))


def battery_connected(voltage_v: float) -> bool:
    """lib/battery Battery::updateBatteryStatus: a filtered voltage under
    LITHIUM_BATTERY_RECOGNITION_VOLTAGE means no battery (the simulator says connected)."""
    return not voltage_v < LITHIUM_BATTERY_RECOGNITION_V  # NaN: connected, as in PX4


def system_status(status: VehicleStatus) -> int:
    if status.terminated:
        return MAV_STATE_FLIGHT_TERMINATION
    if status.armed:
        return MAV_STATE_CRITICAL if status.failsafe else MAV_STATE_ACTIVE
    return MAV_STATE_STANDBY if status.prearm_ok else MAV_STATE_UNINIT


def sensor_bits(status: VehicleStatus) -> tuple[int, int, int]:
    """(present, enabled, health) of SYS_STATUS."""
    present = SENSORS_PRESENT
    health = SENSORS_MAPPED
    if not status.position_valid:
        # estimatorCheck sets gps present only while EKF2 fuses it (CS_GPS); its checks fail
        # until the fix is good enough
        present &= ~SENSOR_GPS
        health &= ~SENSOR_GPS
    if not status.extra.get("estimator_ok", True):  # an innovation test failing
        health &= ~SENSOR_AHRS
    failed = status.extra.get("sensor_failures", 0)
    if failed:
        for bits, sensor in FAILED_SENSOR_BITS:
            if failed & bits:
                health &= ~sensor
    if status.extra.get("manual_control") == "present":  # sticks (MANUAL_CONTROL) are there
        present |= SENSOR_RC_RECEIVER
    else:  # never there, or lost: "No manual control input" (a warning) flags the component
        health &= ~SENSOR_RC_RECEIVER
    enabled = present | (SENSORS_MAPPED & ~health)  # present, or required but unhealthy
    if status.prearm_ok:
        health |= SENSOR_PREARM_CHECK
    return present, enabled, health


def build_heartbeat(status: VehicleStatus, mav_type: int) -> bytes:
    base, custom = heartbeat_modes(status.nav_state, status.armed)
    return _HEARTBEAT(mav_type, MAV_AUTOPILOT_PX4, base, custom,
                      system_status(status), MAVLINK_VERSION)


def build_sys_status(status: VehicleStatus) -> bytes:
    present, enabled, health = sensor_bits(status)
    bat = status.battery
    if battery_connected(bat.voltage_v):
        voltage_mv = c_int(f32_mul(bat.voltage_v, 1000.0), 0, 65535)
        current_ca = c_int(f32_mul(bat.current_a, 100.0), -32768, 32767)
        pct = f32_mul(bat.remaining, 100.0)
        remaining = c_int(math.ceil(pct), -128, 127) if math.isfinite(pct) else 0
    else:
        voltage_mv, current_ca, remaining = 65535, -1, -1
    return _SYS_STATUS(present, enabled, health,
                       int(CPULOAD_LOAD * 1000.0), voltage_mv, current_ca, remaining, 0, 0, 0,
                       0, 0, 0, 0, 0, SENSOR_EXT_RECOVERY_SYSTEM)


def build_extended_sys_state(status: VehicleStatus) -> bytes:
    return _EXTENDED_SYS_STATE(MAV_VTOL_STATE_UNDEFINED,
                               int(status.landed_state))


# lib/modes/standard_modes.hpp getStandardModeFromNavState: the only navigation states that map to
# a MAV_STANDARD_MODE (PX4's StandardMode numbers, those of its MAVLink definitions; pymavlink
# 2.4.50's development dialect numbers them differently); every other is NON_STANDARD (0).
STANDARD_MODE_RETURN_HOME, STANDARD_MODE_MISSION, STANDARD_MODE_LAND, STANDARD_MODE_TAKEOFF = (
    5, 7, 8, 9)
STANDARD_MODES: dict[NavState, int] = {
    NavState.AUTO_RTL: STANDARD_MODE_RETURN_HOME, NavState.AUTO_MISSION: STANDARD_MODE_MISSION,
    NavState.AUTO_LAND: STANDARD_MODE_LAND, NavState.AUTO_TAKEOFF: STANDARD_MODE_TAKEOFF}


def build_current_mode(status: VehicleStatus) -> bytes:
    """CURRENT_MODE.hpp (development dialect, which PX4 SITL builds with): the standard mode of
    nav_state, its custom mode, and the custom mode of the user's intention
    (nav_state_user_intention: what the user selected, whatever a failsafe flies)."""
    nav = status.nav_state
    user = status.extra.get("user_nav_state", nav)
    return _CURRENT_MODE(STANDARD_MODES.get(nav, 0),
                         heartbeat_modes(nav, False)[1], heartbeat_modes(user, False)[1])
