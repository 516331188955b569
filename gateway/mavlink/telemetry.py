"""Telemetry messages: one builder per streamed message, from a ``Snapshot`` of the vehicle.

Source: PX4's stream classes (src/modules/mavlink/streams/*.hpp) for the field conventions, and
its SITL sensor simulation (sensor_gps_sim, sensor_mag_sim, the barometer) for the constants.
Rules:
- A builder is ``(encoder, snapshot) -> payload | None``: the packed payload of its stream's
  message, untrimmed, which the link frames with its own sequence numbers (and signature) in one
  loop over a wake-up's due streams (codec.Encoder.frame_streams); each message's packer is
  bound once (codec.payload_of). It returns None when it has nothing to say (HOME_POSITION
  before home is set, ORBIT_EXECUTION_STATUS while not orbiting).
- Messages that depend only on the kinematics and the time are ``_shared``: their payload is
  packed once per vehicle and instant (snapshot.py) and framed per link.
- Which builder runs when, and at what rate on which link: streams.py. The estimator's own
  messages (ESTIMATOR_STATUS, VIBRATION, WIND_COV) are in telemetry_estimator.py.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from operator import attrgetter
from typing import Any

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.codec import Encoder, c_int, f32_mul, packer_of, payload_of
from gateway.mavlink.heartbeat import (
    battery_connected,
    build_current_mode,
    build_extended_sys_state,
    build_heartbeat,
    build_sys_status,
)
from gateway.mavlink.mission_items import mission_current_payload, mission_status_of
from gateway.mavlink.snapshot import Snapshot
from gateway.mavlink.telemetry_baro import baro_alt_m, baro_sample
from vehicles.estimation import (
    E_ACCURACY,
    E_AID_AGE,
    E_GPS_AGE,
    E_QUAT_RESET,
    E_VXY_RESET,
    E_VZ_RESET,
    E_XY_RESET,
    E_Z_RESET,
    F_GPS_OFF,
    GPS_EPH_M,
    GPS_EPV_M,
    GPS_HDOP,
    GPS_S_VARIANCE_MPS,
    GPS_SATELLITES_USED,
    GPS_VDOP,
    S_ACC,
    S_GPS_POS,
    S_GPS_VEL,
    S_GYRO,
    S_MAG,
)
from vehicles.params import ParamStore

# GPS_RAW_INT constants of PX4's SITL GPS (sensor_gps_sim's fix, vehicles/estimation.py):
# GPS_RAW_INT.hpp sends eph/epv as hdop/vdop x 100, h_acc/v_acc/vel_acc as eph/epv/s_variance
# x 1000 (mm), each through float (whole numbers for sensor_gps_sim's values).
GPS_FIX_TYPE_3D = 3
GPS_SATELLITES = GPS_SATELLITES_USED
GPS_EPH_CM = round(GPS_HDOP * 100.0)
GPS_EPV_CM = round(GPS_VDOP * 100.0)
GPS_H_ACC_MM = round(GPS_EPH_M * 1000.0)
GPS_V_ACC_MM = round(GPS_EPV_M * 1000.0)
GPS_VEL_ACC_MM = round(GPS_S_VARIANCE_MPS * 1000.0)
UINT16_UNKNOWN = 65535
INT16_MAX = 32767

MAV_FRAME_GLOBAL = 0

# BATTERY_STATUS enums
MAV_BATTERY_FUNCTION_ALL = 1
MAV_BATTERY_TYPE_LIPO = 1
MAV_BATTERY_CHARGE_STATE_OK = 1
MAV_BATTERY_CHARGE_STATE_LOW = 2
MAV_BATTERY_CHARGE_STATE_CRITICAL = 3
MAV_BATTERY_CHARGE_STATE_EMERGENCY = 4
_GPS_RAW_INT = payload_of(M.MAVLink_gps_raw_int_message)
_VFR_HUD = payload_of(M.MAVLink_vfr_hud_message)
_BATTERY_STATUS = payload_of(M.MAVLink_battery_status_message)
_HOME_POSITION = payload_of(M.MAVLink_home_position_message)
_SYSTEM_TIME = payload_of(M.MAVLink_system_time_message)
_SCALED_PRESSURE = payload_of(M.MAVLink_scaled_pressure_message)
_ORBIT_EXECUTION_STATUS = payload_of(M.MAVLink_orbit_execution_status_message)

Builder = Callable[[Encoder, Snapshot], "bytes | None"]


def _deg_e7(deg: float) -> int:
    return int(round(deg * 1e7))


TWO_PI = 2.0 * math.pi


def heading_deg(rad: float) -> float:
    """math::degrees(matrix::wrap_2pi(heading)): [0, 360) degrees, for C to truncate."""
    return math.degrees(rad % TWO_PI)


def heartbeat(enc: Encoder, s: Snapshot) -> bytes:
    return build_heartbeat(s.status, s.mav_type)


def sys_status(enc: Encoder, s: Snapshot) -> bytes:
    return build_sys_status(s.status)


def extended_sys_state(enc: Encoder, s: Snapshot) -> bytes:
    return build_extended_sys_state(s.status)


def current_mode(enc: Encoder, s: Snapshot) -> bytes:
    return build_current_mode(s.status)


def _shared(cls: type[M.MAVLink_message], key: Callable[[Snapshot], Any] | None = None,
            ) -> Callable[[Callable[[Snapshot], tuple]], Builder]:
    """A builder from ``args(snapshot)`` (``cls``'s constructor arguments) for a message that
    depends only on the vehicle's kinematics, the time and ``key(snapshot)``: its payload is
    packed once per ``Sample`` and key, whichever link asks first (each link frames it)."""
    p = packer_of(cls)
    msg_id, pack = p.msg_id, p.raw

    def wrap(args: Callable[[Snapshot], tuple]) -> Builder:
        if key is None:
            def build(enc: Encoder, s: Snapshot) -> bytes:
                payloads = s.payloads
                payload = payloads.get(msg_id)
                if payload is None:
                    payload = payloads[msg_id] = pack(*args(s))
                return payload
        else:
            def build(enc: Encoder, s: Snapshot) -> bytes:
                payloads = s.payloads
                k = (msg_id, key(s))
                payload = payloads.get(k)
                if payload is None:
                    payload = payloads[k] = pack(*args(s))
                return payload

        build.__name__ = build.__qualname__ = args.__name__
        build.__doc__ = args.__doc__
        return build

    return wrap


# A C-level read of the Snapshot's lazy attribute (no Python call of its own per build).
_home_alt_m = attrgetter("home_alt_m")


@_shared(M.MAVLink_attitude_message)
def attitude(s: Snapshot) -> tuple:
    return (s.time_boot_ms, *s.sample.euler, *s.kin.rates_frd_radps)


@_shared(M.MAVLink_attitude_quaternion_message)
def attitude_quaternion(s: Snapshot) -> tuple:
    kin = s.kin
    return (s.time_boot_ms, *kin.attitude_q, *kin.rates_frd_radps)


@_shared(M.MAVLink_local_position_ned_message)
def local_position_ned(s: Snapshot) -> tuple:
    kin = s.kin
    return (s.time_boot_ms, *kin.position_ned_m, *kin.velocity_ned_mps)


def global_position_int(enc: Encoder, s: Snapshot) -> bytes | None:
    """GLOBAL_POSITION_INT.hpp sends at each vehicle_global_position, which EKF2 publishes only
    while the position is valid (global_position_is_valid: not dead-reckoning for longer than
    EKF2_NOAID_TOUT): none while the estimator has fused no GPS position or velocity for that
    long, as the commander's position_valid says."""
    e = s.sample.estimator
    if e is not None and e[E_AID_AGE] >= float(
            s.vehicle.params.get("EKF2_NOAID_TOUT", 5_000_000) or 5_000_000) * 1e-6:
        return None
    return _global_position_int(enc, s)


@_shared(M.MAVLink_global_position_int_message, key=_home_alt_m)  # relative_alt: from home
def _global_position_int(s: Snapshot) -> tuple:
    """GLOBAL_POSITION_INT.hpp: every field a C conversion of the estimate (truncating), the
    heading wrapped to [0, 360) degrees (``heading_deg`` inlined); relative_alt above home
    (above the origin without)."""
    g = s.sample.geo
    vx, vy, vz = s.kin.velocity_ned_mps
    alt = g.alt_amsl_m
    return (s.time_boot_ms, int(g.lat_deg * 1e7), int(g.lon_deg * 1e7), int(alt * 1000.0),
            int((alt - s.home_alt_m) * 1000.0), int(vx * 100.0), int(vy * 100.0),
            int(vz * 100.0), int(math.degrees(s.sample.euler[2] % TWO_PI) * 100.0))


GPS_NO_GPS_INTERVAL_US = 1_000_000  # GPS_RAW_INT.hpp kNoGpsSendInterval
GPS_FIX_TYPE_NO_GPS = 0
UINT8_UNKNOWN = 255


def gps_raw_int(enc: Encoder, s: Snapshot) -> bytes | None:
    """GPS_RAW_INT.hpp: each GPS sample; with the GPS off (failure injection: the simulated
    receiver stops publishing) nothing, then once the last was sent over 1 s ago a NO_GPS
    message (fix 0, the unknowns at their maxima, the rest 0) at most every second."""
    link = s.link
    if not s.status.extra.get("sensor_failures", 0) & F_GPS_OFF:
        if link is not None:
            link.gps_sent_us = s.time_usec
        return _gps_fix(enc, s)
    if link is None or link.gps_sent_us == 0 or \
            s.time_usec <= link.gps_sent_us + GPS_NO_GPS_INTERVAL_US:
        return None
    link.gps_sent_us = s.time_usec
    return _GPS_RAW_INT(0, GPS_FIX_TYPE_NO_GPS, 0, 0, 0,
                        UINT16_UNKNOWN, UINT16_UNKNOWN, UINT16_UNKNOWN, UINT16_UNKNOWN,
                        UINT8_UNKNOWN, 0, 0, 0, 0, 0)


def gps_fix(s: Snapshot) -> tuple[float, float, float, float, float, float]:
    """The latest GPS fix (vehicles/estimation.py: sensor_gps_sim's, noisy): (lat, lon, alt
    AMSL, vn, ve, vd), as GPS_RAW_INT and the Open Drone ID messages report it."""
    sensed = s.sample.sensors
    if sensed is None:
        g = s.sample.geo
        vn, ve, vd = s.kin.velocity_ned_mps
    else:
        g = s.vehicle.origin.offset_ned(sensed[S_GPS_POS], sensed[S_GPS_POS + 1],
                                        sensed[S_GPS_POS + 2])
        vn, ve, vd = sensed[S_GPS_VEL], sensed[S_GPS_VEL + 1], sensed[S_GPS_VEL + 2]
    return g.lat_deg, g.lon_deg, g.alt_amsl_m, vn, ve, vd


def gps_fix_us(s: Snapshot) -> int:
    """When the latest GPS fix was published (µs): sensor_gps's timestamp; now for a vehicle
    without an estimator."""
    e = s.sample.estimator
    return s.time_usec if e is None else max(0, s.time_usec - int(round(e[E_GPS_AGE] * 1e6)))


@_shared(M.MAVLink_gps_raw_int_message)
def _gps_fix(s: Snapshot) -> tuple:
    lat_deg, lon_deg, alt_amsl_m, vn, ve, _ = gps_fix(s)
    # GPS_RAW_INT.hpp converts as C does (truncating); cog of every sample, however slow:
    # sensor_gps_sim's course is atan2 of its noisy velocity, so at rest it wanders.
    speed_cm = min(int(math.hypot(vn, ve) * 100.0), UINT16_UNKNOWN)
    cog = int(math.degrees(math.atan2(ve, vn)) % 360.0 * 100.0) % 36000
    alt_mm = int(round(alt_amsl_m * 1000.0))
    # time_usec is the fix's sensor_gps timestamp (when the receiver published it), not now.
    fix_us = gps_fix_us(s)
    return (fix_us, GPS_FIX_TYPE_3D, _deg_e7(lat_deg), _deg_e7(lon_deg), alt_mm,
            GPS_EPH_CM, GPS_EPV_CM, speed_cm, cog, GPS_SATELLITES, alt_mm,
            GPS_H_ACC_MM, GPS_V_ACC_MM, GPS_VEL_ACC_MM, 0, 0)


def vfr_hud(enc: Encoder, s: Snapshot) -> bytes:
    """VFR_HUD.hpp: airspeed is airspeed_validated's, which nothing publishes on a multicopter
    (airspeed_selector starts only for fixed wings and VTOLs): 0. The heading and the throttle
    (|thrust setpoint| in percent while armed) are truncated as C converts them."""
    vn, ve, vd = s.kin.velocity_ned_mps
    throttle = s.status.extra.get("thrust_norm", 0.0) if s.status.armed else 0.0
    return _VFR_HUD(0.0, math.hypot(vn, ve),
                    int(heading_deg(s.sample.euler[2])), c_int(abs(throttle) * 100.0, 0, 0xFFFF),
                    s.sample.geo.alt_amsl_m, -vd)


@_shared(M.MAVLink_altitude_message, key=_home_alt_m)  # altitude_relative: from home
def altitude(s: Snapshot) -> tuple:
    """ALTITUDE.hpp: altitude_monotonic is the barometric altitude (vehicle_air_data
    baro_alt_meter), the others the estimate's; no range finder, so terrain and bottom
    clearance NaN."""
    amsl = s.sample.geo.alt_amsl_m
    local = -s.kin.position_ned_m[2]
    return (s.time_usec, baro_alt_m(s), amsl, local, amsl - s.home_alt_m, math.nan, math.nan)


def _param(params: ParamStore, name: str, default: float) -> float:
    value = params.get(name, default)
    return default if value is None else value


def _charge_state(remaining: float, params: ParamStore) -> int:
    """lib/battery Battery::determineWarning: strictly below a threshold (both float32)."""
    remaining = f32_mul(remaining, 1.0)
    if remaining < _param(params, "BAT_EMERGEN_THR", 0.05):
        return MAV_BATTERY_CHARGE_STATE_EMERGENCY
    if remaining < _param(params, "BAT_CRIT_THR", 0.07):
        return MAV_BATTERY_CHARGE_STATE_CRITICAL
    if remaining < _param(params, "BAT_LOW_THR", 0.15):
        return MAV_BATTERY_CHARGE_STATE_LOW
    return MAV_BATTERY_CHARGE_STATE_OK


BATTERY_CELL_SLOTS = 10
UINT16_CHUNK_MV = 65534  # UINT16_MAX - 1
_VOLTAGES_UNKNOWN = [UINT16_UNKNOWN] * BATTERY_CELL_SLOTS


def battery_voltages(voltage_v: float) -> list[int]:
    """BATTERY_STATUS.hpp voltages[] for a battery whose cell voltages are unknown (lib/battery
    never fills voltage_cell_v): the total in the first field, split into 65534 mV chunks
    when it does not fit, the rest unknown; out of spec (over 655 V) all unknown."""
    mv = f32_mul(voltage_v, 1000.0)
    out = list(_VOLTAGES_UNKNOWN)
    if not math.isfinite(mv):
        out[0] = 0  # a NaN voltage converts to 0, as on ARM
        return out
    fields = c_int(mv, -(2**31), 2**31 - 1) // UINT16_CHUNK_MV + 1  # C: toward zero
    if mv < 0:
        fields = 1
    if fields <= BATTERY_CELL_SLOTS:
        for i in range(fields - 1):
            out[i] = UINT16_CHUNK_MV
        out[fields - 1] = c_int(mv - UINT16_CHUNK_MV * (fields - 1), 0, UINT16_UNKNOWN)
    return out


def battery_status(enc: Encoder, s: Snapshot) -> bytes:
    """BATTERY_STATUS.hpp from lib/battery's battery_status (the simulator's one battery, id
    1 → 0): C conversions (truncating; remaining roundf), no temperature, no time remaining
    (BAT1_CAPACITY unset), and -1 / unknown everywhere when no battery is recognised."""
    bat = s.status.battery
    if not battery_connected(bat.voltage_v):
        return _BATTERY_STATUS(0, MAV_BATTERY_FUNCTION_ALL,
                               MAV_BATTERY_TYPE_LIPO, INT16_MAX, _VOLTAGES_UNKNOWN, -1, -1, -1, -1, 0,
                               _charge_state(bat.remaining, s.vehicle.params), [0, 0, 0, 0], 0, 0)
    pct = f32_mul(bat.remaining, 100.0)
    # roundf: halves away from zero
    remaining = c_int(math.copysign(math.floor(abs(pct) + 0.5), pct), -128, 127) \
        if math.isfinite(pct) else 0
    return _BATTERY_STATUS(0, MAV_BATTERY_FUNCTION_ALL,
                           MAV_BATTERY_TYPE_LIPO, INT16_MAX, battery_voltages(bat.voltage_v),
                           c_int(f32_mul(bat.current_a, 100.0), -32768, 32767),
                           c_int(bat.consumed_mah, -(2**31), 2**31 - 1), -1, remaining, 0,
                           _charge_state(bat.remaining, s.vehicle.params), [0, 0, 0, 0], 0, 0)


def home_position(enc: Encoder, s: Snapshot) -> bytes | None:
    home = s.status.home
    if home is None:
        return None
    x, y, z = home.position_ned_m
    q = [math.cos(home.yaw_rad / 2.0), 0.0, 0.0, math.sin(home.yaw_rad / 2.0)]
    # HOME_POSITION.hpp: lat/lon/alt converted as C does (truncating)
    return _HOME_POSITION(int(home.geo.lat_deg * 1e7),
                          int(home.geo.lon_deg * 1e7), int(f32_mul(home.geo.alt_amsl_m, 1000.0)),
                          float(x), float(y), float(z), q, 0.0, 0.0, 0.0, int(home.time_s * 1e6))


SYSTEM_TIME_VALID_US = 978307200000000  # SYSTEM_TIME.hpp: 2001-01-01, else "definitely wrong"


def system_time(enc: Encoder, s: Snapshot) -> bytes | None:
    """SYSTEM_TIME.hpp: sent only while the real-time clock is past 2001 (without a boot epoch
    CORNET has no Unix time: nothing)."""
    if s.boot_unix_s is None:
        return None
    unix_us = int((s.boot_unix_s + s.now_s) * 1e6)
    if unix_us <= SYSTEM_TIME_VALID_US:
        return None
    return _SYSTEM_TIME(unix_us, s.time_boot_ms)


def mission_current(enc: Encoder, s: Snapshot) -> bytes:
    # The 1 Hz copy; mission.py sends it on every change of the current item.
    return mission_current_payload(mission_status_of(s.vehicle))


# Sensors as PX4 SITL reports them from its simulated IMU, magnetometer and barometer.
G = 9.80665
# The Earth's field at PX4's SITL home (Zurich), gauss NED: 48 µT, inclination 63.5°,
# declination 3° east (WMM; PX4's sensor_mag_sim uses the same model at the home position).
MAG_NED_GAUSS = (0.2145, 0.0112, 0.4296)
HIGHRES_IMU_FIELDS = 0x1BFF  # acc, gyro, mag, abs pressure, pressure alt, temperature
MAV_FRAME_LOCAL_NED = 1
MAV_ESTIMATOR_TYPE_AUTOPILOT = 8


def to_body(q: tuple[float, float, float, float], v: tuple[float, float, float]
             ) -> tuple[float, float, float]:
    """NED vector ``v`` in the body frame of attitude ``q`` (FRD → NED): Rᵀ v."""
    w, x, y, z = q
    a, b, c = v
    return ((1 - 2 * (y * y + z * z)) * a + 2 * (x * y + w * z) * b + 2 * (x * z - w * y) * c,
            2 * (x * y - w * z) * a + (1 - 2 * (x * x + z * z)) * b + 2 * (y * z + w * x) * c,
            2 * (x * z + w * y) * a + 2 * (y * z - w * x) * b + (1 - 2 * (x * x + y * y)) * c)


def imu_sample(s: Snapshot) -> tuple[float, ...]:
    """The IMU's specific force (m/s²) and rates (rad/s), body FRD, and the magnetometer
    (gauss): ``(fx, fy, fz, p, q, r, mx, my, mz)`` of the simulated sensors, or what the
    kinematics give for a vehicle without them."""
    sensed = s.sample.sensors
    if sensed is None:
        kin = s.kin
        an, ae, ad = s.vehicle.acceleration_ned_mps2
        return (*to_body(kin.attitude_q, (an, ae, ad - G)), *kin.rates_frd_radps,
                *to_body(kin.attitude_q, MAG_NED_GAUSS))
    return (*sensed[S_ACC:S_ACC + 3], *sensed[S_GYRO:S_GYRO + 3], *sensed[S_MAG:S_MAG + 3])


@_shared(M.MAVLink_highres_imu_message)
def highres_imu(s: Snapshot) -> tuple:
    """The IMU's specific force and rates (body FRD), the magnetometer, the barometer.
    HIGHRES_IMU.hpp puts vehicle_air_data's baro_pressure_pa into abs_pressure as it is: Pa,
    though the message documents hPa; pressure_alt is its baro_alt_meter, temperature its
    baro_temp_celcius (the gz bridge's 288.15)."""
    fx, fy, fz, p, q, r, mx, my, mz = imu_sample(s)
    pressure_pa, alt_m, temp_c = baro_sample(s)
    return (s.time_usec, fx, fy, fz, p, q, r, mx, my, mz, pressure_pa, 0.0, alt_m, temp_c,
            HIGHRES_IMU_FIELDS, 0)


COVARIANCE_UNKNOWN = (math.nan,) * 21


def _odometry_covariances(s: Snapshot) -> tuple[list[float], tuple[float, ...]]:
    """ODOMETRY.hpp's pose and velocity covariances: NaN but for the diagonal, which holds EKF2's
    variances. The position's follow the estimate's accuracies (get_ekf_lpos_accuracy: eph is
    sqrt(var_x + var_y), epv sqrt(var_z)); the orientation's and the velocity's are not modelled
    here and stay NaN (unknown)."""
    pose = [math.nan] * 21
    e = s.sample.estimator
    if e is not None:
        eph, epv = e[E_ACCURACY], e[E_ACCURACY + 1]
        pose[0] = pose[6] = eph * eph / 2.0
        pose[11] = epv * epv
    return pose, COVARIANCE_UNKNOWN


@_shared(M.MAVLink_odometry_message)
def odometry(s: Snapshot) -> tuple:
    """ODOMETRY.hpp from EKF2's vehicle_odometry (EKF2::PublishOdometry): position and velocity
    both in the local NED frame (pose_frame and velocity_frame NED, so child_frame_id
    LOCAL_NED), body rates, estimator type AUTOPILOT, quality 0 (EKF2 never sets it); the reset
    counter is the sum of the estimator's reset counts (quaternion, velocity NE and D, position NE
    and D; 9 once the GNSS fusion started: vehicles/ekf_resets.py), as a uint8."""
    kin = s.kin
    x, y, z = kin.position_ned_m
    vx, vy, vz = kin.velocity_ned_mps
    p, q, r = kin.rates_frd_radps
    pose, vel = _odometry_covariances(s)
    e = s.sample.estimator
    resets = 0 if e is None else int(e[E_XY_RESET] + e[E_VXY_RESET] + e[E_VZ_RESET]
                                     + e[E_Z_RESET] + e[E_QUAT_RESET]) & 0xFF
    return (s.time_usec, MAV_FRAME_LOCAL_NED, MAV_FRAME_LOCAL_NED, x, y, z, kin.attitude_q,
            vx, vy, vz, p, q, r, pose, vel, resets, MAV_ESTIMATOR_TYPE_AUTOPILOT, 0)


def scaled_pressure(enc: Encoder, s: Snapshot) -> bytes:
    """SCALED_PRESSURE.hpp from sensor_baro: the pressure in hPa, roundf(temperature x 100) (the
    gz bridge's 288.15: 28815); no differential pressure sensor."""
    pressure_pa, _, temp_c = baro_sample(s)
    return _SCALED_PRESSURE(s.time_boot_ms, pressure_pa * 0.01, 0.0,
                            int(round(temp_c * 100.0)), 0)


def orbit_execution_status(enc: Encoder, s: Snapshot) -> bytes | None:
    """While orbiting (PX4 publishes orbit_status only then): signed radius, centre, altitude
    AMSL (frame GLOBAL)."""
    st = getattr(s.vehicle, "orbit_status", None)
    if st is None:
        return None
    g = s.vehicle.origin.offset_ned(st.center_ne_m[0], st.center_ne_m[1], st.down_m)
    return _ORBIT_EXECUTION_STATUS(s.time_usec, st.radius_m,
                                   MAV_FRAME_GLOBAL, int(g.lat_deg * 1e7), int(g.lon_deg * 1e7), g.alt_amsl_m)

