"""OPEN_DRONE_ID_LOCATION and OPEN_DRONE_ID_SYSTEM, which PX4 v1.15 streams at 1 Hz on the normal
and the onboard link (Remote ID broadcast data from the GPS, the barometer, home and the land
detector).

Source: PX4 src/modules/mavlink/streams/OPEN_DRONE_ID_LOCATION.hpp and OPEN_DRONE_ID_SYSTEM.hpp,
and SITL's sensor_gps_sim (fix 3D, eph 0.9 m, epv 1.78 m, s_variance 0.4 m/s, no UTC time).
Rules:
- LOCATION starts from "unknown" in every field and fills what it has: the status from the land
  detector (EMERGENCY while armed in failsafe), the GPS fix (course rounded to whole degrees,
  speeds, accuracy classes) while it is under 10 s old, the barometric altitude, and the height
  above home once home is set. sensor_gps_sim gives no UTC time, so the timestamp stays unknown.
- SYSTEM needs a new GPS fix and a home: the operator at home (take-off location), one area of
  radius 0, no ceiling or floor. Its timestamp, seconds since 2019 from the GPS's UTC time, is
  0 / 1e6 - 1546300800 converted to uint32_t: x86-64's conversion (SITL's) keeps the low 32
  bits of the negative value.
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.codec import Encoder, payload_of
from gateway.mavlink.snapshot import Snapshot
from gateway.mavlink.telemetry import (
    GPS_H_ACC_MM,
    GPS_V_ACC_MM,
    GPS_VEL_ACC_MM,
    baro_alt_m,
    gps_fix,
)
from vehicles.estimation import E_GPS_AGE, F_GPS_OFF
from vehicles.types import LandedState

GPS_FRESH_S = 10.0  # hrt_elapsed_time(&vehicle_gps_position.timestamp) < 10_s
UNKNOWN_M = -1000.0
DIRECTION_UNKNOWN_CDEG = 36100
SPEED_UNKNOWN_CMPS = 25500
VERTICAL_SPEED_UNKNOWN_CMPS = 6300
TIMESTAMP_UNKNOWN = 0xFFFF
# 0 / 1e6 - 1546300800 (seconds since 2019 of a GPS without UTC time) as uint32_t on x86-64
ODID_SYSTEM_TIMESTAMP = (-1546300800) & 0xFFFFFFFF
_ID_OR_MAC = [0] * 20


def _horizontal_accuracy(eph_m: float) -> int:
    for limit, cls in ((1.0, M.MAV_ODID_HOR_ACC_1_METER), (3.0, M.MAV_ODID_HOR_ACC_3_METER),
                       (10.0, M.MAV_ODID_HOR_ACC_10_METER), (30.0, M.MAV_ODID_HOR_ACC_30_METER)):
        if eph_m < limit:
            return cls
    return M.MAV_ODID_HOR_ACC_UNKNOWN


def _vertical_accuracy(epv_m: float) -> int:
    for limit, cls in ((1.0, M.MAV_ODID_VER_ACC_1_METER), (3.0, M.MAV_ODID_VER_ACC_3_METER),
                       (10.0, M.MAV_ODID_VER_ACC_10_METER), (25.0, M.MAV_ODID_VER_ACC_25_METER),
                       (45.0, M.MAV_ODID_VER_ACC_45_METER), (150.0, M.MAV_ODID_VER_ACC_150_METER)):
        if epv_m < limit:
            return cls
    return M.MAV_ODID_VER_ACC_UNKNOWN


def _speed_accuracy(s_variance_mps: float) -> int:
    for limit, cls in ((0.3, M.MAV_ODID_SPEED_ACC_0_3_METERS_PER_SECOND),
                       (1.0, M.MAV_ODID_SPEED_ACC_1_METERS_PER_SECOND),
                       (3.0, M.MAV_ODID_SPEED_ACC_3_METERS_PER_SECOND),
                       (10.0, M.MAV_ODID_SPEED_ACC_10_METERS_PER_SECOND)):
        if s_variance_mps < limit:
            return cls
    return M.MAV_ODID_SPEED_ACC_UNKNOWN


# The classes of sensor_gps_sim's constant eph, epv and s_variance_m_s.
HOR_ACC = _horizontal_accuracy(GPS_H_ACC_MM / 1000.0)
VER_ACC = _vertical_accuracy(GPS_V_ACC_MM / 1000.0)
SPEED_ACC = _speed_accuracy(GPS_VEL_ACC_MM / 1000.0)
_OPEN_DRONE_ID_LOCATION = payload_of(M.MAVLink_open_drone_id_location_message)
_OPEN_DRONE_ID_SYSTEM = payload_of(M.MAVLink_open_drone_id_system_message)


def _roundf(x: float) -> float:
    """C's roundf: halves away from zero."""
    return math.copysign(math.floor(abs(x) + 0.5), x)


def open_drone_id_location(enc: Encoder, s: Snapshot) -> bytes:
    status = s.status
    odid_status = M.MAV_ODID_STATUS_GROUND if status.landed_state == LandedState.ON_GROUND \
        else M.MAV_ODID_STATUS_AIRBORNE
    if status.failsafe and status.armed:
        odid_status = M.MAV_ODID_STATUS_EMERGENCY
    direction, speed_h, speed_v = (DIRECTION_UNKNOWN_CDEG, SPEED_UNKNOWN_CMPS,
                                   VERTICAL_SPEED_UNKNOWN_CMPS)
    lat = lon = 0
    alt_geodetic = UNKNOWN_M
    h_acc = v_acc = speed_acc = M.MAV_ODID_HOR_ACC_UNKNOWN
    e = s.sample.estimator
    if e is None or e[E_GPS_AGE] < GPS_FRESH_S:
        lat_deg, lon_deg, alt_m, vn, ve, vd = gps_fix(s)
        course_deg = int(_roundf(math.degrees(math.atan2(ve, vn) % (2.0 * math.pi))))
        direction = max(0, min(35999, 100 * course_deg))
        speed_h = max(0, min(25425, int(math.hypot(vn, ve) * 100.0)))
        speed_v = max(-6200, min(6200, int(_roundf(-vd * 100.0))))
        speed_acc = SPEED_ACC
        lat, lon = int(round(lat_deg * 1e7)), int(round(lon_deg * 1e7))
        alt_geodetic = float(round(alt_m))
        h_acc, v_acc = HOR_ACC, VER_ACC
    height = UNKNOWN_M
    home = status.home
    if home is not None and status.position_valid:
        height = s.sample.geo.alt_amsl_m - home.geo.alt_amsl_m
    return _OPEN_DRONE_ID_LOCATION(0, 0, _ID_OR_MAC, odid_status,
                                   direction, speed_h, speed_v, lat, lon, baro_alt_m(s), alt_geodetic,
                                   M.MAV_ODID_HEIGHT_REF_OVER_TAKEOFF, height, h_acc, v_acc,
                                   M.MAV_ODID_VER_ACC_150_METER, speed_acc, float(TIMESTAMP_UNKNOWN),
                                   M.MAV_ODID_TIME_ACC_UNKNOWN)


def open_drone_id_system(enc: Encoder, s: Snapshot) -> bytes | None:
    status = s.status
    home = status.home
    if home is None or status.extra.get("sensor_failures", 0) & F_GPS_OFF:
        return None  # no home, or no new fix
    return _OPEN_DRONE_ID_SYSTEM(0, 0, _ID_OR_MAC,
                                 M.MAV_ODID_OPERATOR_LOCATION_TYPE_TAKEOFF,
                                 M.MAV_ODID_CLASSIFICATION_TYPE_UNDECLARED, int(home.geo.lat_deg * 1e7),
                                 int(home.geo.lon_deg * 1e7), 1, 0, UNKNOWN_M, UNKNOWN_M,
                                 M.MAV_ODID_CATEGORY_EU_UNDECLARED, M.MAV_ODID_CLASS_EU_UNDECLARED,
                                 home.geo.alt_amsl_m, ODID_SYSTEM_TIMESTAMP)
