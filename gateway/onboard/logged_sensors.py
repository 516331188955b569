"""The sensor topics PX4's logger writes (logged_topics.py has the rules): the IMU, the GPS, the
barometer, the magnetometer and the battery, as PX4 1.15's SITL sensors publish them.

Source: PX4 1.15 msg/SensorCombined.msg, SensorGps.msg, VehicleAirData.msg, SensorBaro.msg,
VehicleMagnetometer.msg, VehicleImuStatus.msg, BatteryStatus.msg; the values the SITL drivers
put in what CORNET does not model: src/modules/simulation/sensor_gps_sim (fix, accuracies,
dilution, no UTC time, no jamming), src/lib/battery (no temperature), VehicleIMU.cpp (the
vibration metrics, which the sensor simulation computes: vehicles/estimation.py S_VIB).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from gateway.mavlink.telemetry import GPS_FIX_TYPE_3D
from gateway.mavlink.telemetry_baro import GZ_BARO_TEMPERATURE_C, gz_pressure_pa, pressure_altitude_m
from gateway.onboard.topic import U64, B, D, F, Topic
from vehicles.estimation import (
    F_GPS_OFF,
    GPS_EPH_M,
    GPS_EPV_M,
    GPS_HDOP,
    GPS_S_VARIANCE_MPS,
    GPS_SATELLITES_USED,
    GPS_VDOP,
    R_ACC,
    R_GYRO,
    S_ACC,
    S_BARO_DOWN,
    S_GPS_POS,
    S_GPS_VEL,
    S_GYRO,
    S_MAG,
    S_VIB,
)

# sensor_gps_sim with a fix, in uORB's units (vehicles/estimation.py)
GPS_FIX_3D = GPS_FIX_TYPE_3D
GPS_S_VARIANCE, GPS_C_VARIANCE = GPS_S_VARIANCE_MPS, 0.1  # s_variance_m_s, c_variance_rad
AIR_GAS_CONST = 287.1  # PX4 CONSTANTS_AIR_GAS_CONST, J/(kg·K)
ABSOLUTE_NULL_C = -273.15  # CONSTANTS_ABSOLUTE_NULL_CELSIUS
IMU_INTEGRAL_DT_US = 4000  # one physics step: the IMU sample's integration interval


def _sensor_combined(v: Any, now_us: int) -> tuple:
    s = v.sensors
    return (*s[S_GYRO:S_GYRO + 3], IMU_INTEGRAL_DT_US, 0, *s[S_ACC:S_ACC + 3],
            IMU_INTEGRAL_DT_US)


def _sensor_combined_step(r: Sequence[float], t_us: int) -> tuple:
    return (*r[R_GYRO:R_GYRO + 3], IMU_INTEGRAL_DT_US, 0, *r[R_ACC:R_ACC + 3], IMU_INTEGRAL_DT_US)


def _gps(v: Any, now_us: int) -> tuple | None:
    """sensor_gps_sim's sample: the simulated receiver's position and velocity, its constants
    for the rest (altitude_ellipsoid_m = altitude_msl_m, time_utc_usec 0, heading NaN). None
    while the GPS is off (failure injection): the receiver publishes nothing, so the topic
    stops updating and the logger writes no record, as GPS_RAW_INT stops."""
    if v.status.extra.get("sensor_failures", 0) & F_GPS_OFF:
        return None
    s = v.sensors
    g = v.origin.offset_ned(s[S_GPS_POS], s[S_GPS_POS + 1], s[S_GPS_POS + 2])
    vn, ve, vd = s[S_GPS_VEL:S_GPS_VEL + 3]
    return (now_us, g.lat_deg, g.lon_deg, g.alt_amsl_m, g.alt_amsl_m, GPS_S_VARIANCE,
            GPS_C_VARIANCE, GPS_FIX_3D, GPS_EPH_M, GPS_EPV_M, GPS_HDOP, GPS_VDOP, 0, 0,
            math.hypot(vn, ve), vn, ve, vd, math.atan2(ve, vn), True, 0, GPS_SATELLITES_USED,
            math.nan, math.nan)


def _battery(v: Any, now_us: int) -> tuple:
    b = v.status.battery
    return (True, b.voltage_v, b.current_a, b.consumed_mah, b.remaining, math.nan, b.cell_count)


def _baro(v: Any) -> tuple[float, float, float]:
    """(baro_alt_meter m, temperature °C, pressure Pa) of the simulated barometer, as the gz
    bridge publishes it and vehicle_air_data derives it (telemetry.baro_sample)."""
    pressure_pa = gz_pressure_pa(v.origin.alt_amsl_m - v.sensors[S_BARO_DOWN])
    return pressure_altitude_m(pressure_pa), GZ_BARO_TEMPERATURE_C, pressure_pa


def _air_data(v: Any, now_us: int) -> tuple:
    alt, temp_c, pressure_pa = _baro(v)
    return (now_us, alt, temp_c, pressure_pa,
            pressure_pa / (AIR_GAS_CONST * (temp_c - ABSOLUTE_NULL_C)))


def _sensor_baro(v: Any, now_us: int) -> tuple:
    _, temp_c, pressure_pa = _baro(v)
    return (now_us, pressure_pa, temp_c)


def _magnetometer(v: Any, now_us: int) -> tuple:
    s = v.sensors
    return (now_us, *s[S_MAG:S_MAG + 3])


def _imu_status(v: Any, now_us: int) -> tuple:
    coning, gyro, accel = v.sensors[S_VIB:S_VIB + 3]
    return (accel, gyro, coning)


SENSOR_COMBINED = Topic(
    "sensor_combined", (("float[3]", "gyro_rad"), ("uint32_t", "gyro_integral_dt"),
                        ("int32_t", "accelerometer_timestamp_relative"),
                        ("float[3]", "accelerometer_m_s2"), ("uint32_t", "accelerometer_integral_dt")),
    0.0, _sensor_combined, step=_sensor_combined_step)
VEHICLE_GPS_POSITION = Topic(
    "vehicle_gps_position", ((U64, "timestamp_sample"), (D, "latitude_deg"),
                             (D, "longitude_deg"), (D, "altitude_msl_m"),
                             (D, "altitude_ellipsoid_m"), (F, "s_variance_m_s"),
                             (F, "c_variance_rad"), ("uint8_t", "fix_type"), (F, "eph"),
                             (F, "epv"), (F, "hdop"), (F, "vdop"), ("int32_t", "noise_per_ms"),
                             ("int32_t", "jamming_indicator"), (F, "vel_m_s"), (F, "vel_n_m_s"),
                             (F, "vel_e_m_s"), (F, "vel_d_m_s"), (F, "cog_rad"),
                             (B, "vel_ned_valid"), (U64, "time_utc_usec"),
                             ("uint8_t", "satellites_used"), (F, "heading"),
                             (F, "heading_offset")),
    0.1, _gps)
BATTERY_STATUS = Topic(
    "battery_status", ((B, "connected"), (F, "voltage_v"), (F, "current_a"),
                       (F, "discharged_mah"), (F, "remaining"), (F, "temperature"),
                       ("uint8_t", "cell_count")), 0.2, _battery)
VEHICLE_AIR_DATA = Topic(
    "vehicle_air_data", ((U64, "timestamp_sample"), (F, "baro_alt_meter"),
                         (F, "baro_temp_celcius"), (F, "baro_pressure_pa"), (F, "rho")),
    0.2, _air_data)
VEHICLE_MAGNETOMETER = Topic(
    "vehicle_magnetometer", ((U64, "timestamp_sample"), ("float[3]", "magnetometer_ga")),
    0.5, _magnetometer)
# add_topic_multi("sensor_baro", 1000, 4) and ("vehicle_imu_status", 1000, 4): instance 0
SENSOR_BARO = Topic("sensor_baro", ((U64, "timestamp_sample"), (F, "pressure"),
                                    (F, "temperature")), 1.0, _sensor_baro)
VEHICLE_IMU_STATUS = Topic(
    "vehicle_imu_status", ((F, "accel_vibration_metric"), (F, "gyro_vibration_metric"),
                           (F, "delta_angle_coning_metric")), 1.0, _imu_status)
