"""HEARTBEAT, SYS_STATUS and EXTENDED_SYS_STATE from the commander's VehicleStatus.

Source: PX4 streams HEARTBEAT.hpp and SYS_STATUS.hpp; MAVSDK's health rules.
- HEARTBEAT: type = MAV_TYPE param, autopilot PX4 (12), mavlink_version 3, modes from modes.py.
- system_status: UNINIT until the position estimate is valid, STANDBY disarmed, ACTIVE armed,
  CRITICAL armed in failsafe, FLIGHT_TERMINATION once terminated. PX4 never sends BOOT.
- SYS_STATUS bits, and why (MAVSDK telemetry_impl.cpp):
  is_global_position_ok = GPS (32) in present AND health → GPS health follows position_valid;
  is_armable = PREARM_CHECK in health; QGC "Ready To Fly" additionally needs PREARM in enabled.
  Gyro/accel/mag present+healthy → MAVSDK calibration flags true.
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as mavlink2

from gateway.mavlink.codec import Encoder, sat_round
from gateway.mavlink.modes import heartbeat_modes
from vehicles.estimation import F_ACC, F_BARO, F_GPS_OFF, F_GYRO, F_MAG
from vehicles.types import VehicleStatus

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

# MAV_SYS_STATUS_SENSOR bits used below
SENSOR_3D_GYRO, SENSOR_3D_ACCEL, SENSOR_3D_MAG, SENSOR_ABSOLUTE_PRESSURE = 0x1, 0x2, 0x4, 0x8
SENSOR_GPS = 0x20
SENSOR_XY_POSITION_CONTROL = 0x4000  # PX4 maps its local position estimate here
SENSOR_RC_RECEIVER = 0x10000  # PX4's remote_control health component (joystick or RC)
SENSOR_AHRS = 0x200000  # PX4 reports the estimator's health here
SENSOR_PREARM_CHECK = 0x10000000

# Healthy PX4 SITL: gyro|accel|mag|baro|gps|att_stab|xy_pos|ahrs|logging|battery.
SENSORS_PRESENT = 0x0320482F
# All mapped bits healthy (absent components still report healthy in PX4), without PREARM.
SENSORS_HEALTH = 0x0321C83F
POSITION_SENSORS = SENSOR_GPS | SENSOR_XY_POSITION_CONTROL

MAV_VTOL_STATE_UNDEFINED = 0

# A failed sensor (off or stuck) → its SYS_STATUS health bit, as PX4's sensor checks report a
# sensor that times out or stops changing.
FAILED_SENSOR_BITS = ((F_GPS_OFF, SENSOR_GPS), (F_BARO, SENSOR_ABSOLUTE_PRESSURE),
                      (F_MAG, SENSOR_3D_MAG), (F_GYRO, SENSOR_3D_GYRO), (F_ACC, SENSOR_3D_ACCEL))


def system_status(status: VehicleStatus) -> int:
    if status.terminated:
        return MAV_STATE_FLIGHT_TERMINATION
    if status.armed:
        return MAV_STATE_CRITICAL if status.failsafe else MAV_STATE_ACTIVE
    return MAV_STATE_STANDBY if status.position_valid else MAV_STATE_UNINIT


def sensor_bits(status: VehicleStatus) -> tuple[int, int, int]:
    """(present, enabled, health) of SYS_STATUS."""
    present = SENSORS_PRESENT
    enabled = SENSORS_PRESENT
    health = SENSORS_HEALTH
    if not status.position_valid:
        health &= ~POSITION_SENSORS
    if not status.extra.get("estimator_ok", True):  # an innovation test failing
        health &= ~SENSOR_AHRS
    failed = status.extra.get("sensor_failures", 0)
    if failed:
        for bits, sensor in FAILED_SENSOR_BITS:
            if failed & bits:
                health &= ~sensor
    if status.prearm_ok:
        health |= SENSOR_PREARM_CHECK
        enabled |= SENSOR_PREARM_CHECK
    sticks = status.extra.get("manual_control")
    if sticks == "present":  # a joystick (MANUAL_CONTROL) is there: MAVSDK rc_status available
        present |= SENSOR_RC_RECEIVER
        enabled |= SENSOR_RC_RECEIVER
    elif sticks == "lost":  # it was there and is gone: PX4 reports the component unhealthy
        present |= SENSOR_RC_RECEIVER
        enabled |= SENSOR_RC_RECEIVER
        health &= ~SENSOR_RC_RECEIVER
    return present, enabled, health


def build_heartbeat(enc: Encoder, status: VehicleStatus, mav_type: int) -> bytes:
    base, custom = heartbeat_modes(status.nav_state, status.armed)
    return enc.pack(mavlink2.MAVLink_heartbeat_message, mav_type, MAV_AUTOPILOT_PX4, base, custom,
                    system_status(status), MAVLINK_VERSION)


def build_sys_status(enc: Encoder, status: VehicleStatus) -> bytes:
    present, enabled, health = sensor_bits(status)
    bat = status.battery
    voltage_mv = sat_round(bat.voltage_v * 1000.0, 0, 65534)
    current_ca = sat_round(bat.current_a * 100.0, -1, 32767)
    remaining = sat_round(bat.remaining * 100.0, 0, 100)
    return enc.pack(mavlink2.MAVLink_sys_status_message, present, enabled, health,
                    int(CPULOAD_LOAD * 1000.0), voltage_mv, current_ca, remaining, 0, 0, 0,
                    0, 0, 0)


def build_extended_sys_state(enc: Encoder, status: VehicleStatus) -> bytes:
    return enc.pack(mavlink2.MAVLink_extended_sys_state_message, MAV_VTOL_STATE_UNDEFINED,
                    int(status.landed_state))
