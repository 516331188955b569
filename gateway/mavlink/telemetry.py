"""Telemetry streams: one table of (message, builder, default rate per link kind), one scheduler.

Source: PX4 mavlink_main.cpp configure_streams_to_default (NORMAL plus the SITL overrides for
the GCS link, ONBOARD for the API link) and each stream's .hpp for the field conventions.
Rules:
- Deadlines are integer microseconds of simulated time, so streams of commensurate rates fire
  in the same wake-up (all 50 Hz streams go out together) and counts are exact.
- A late wake-up sends each due stream once and re-phases it; it never bursts to catch up.
- A builder returns None when it has nothing to say (HOME_POSITION before home is set).
- SET_MESSAGE_INTERVAL may enable any message that has a builder, on either link.
- Both links of a vehicle sample it at the same instants (every 50 Hz stream of one fires with
  the other's), so what depends only on the kinematics and the time (ATTITUDE, GLOBAL_POSITION_INT
  …) is computed and packed once per vehicle and instant (``Sample``) and framed per link.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2

from gateway.mavlink.codec import Encoder, packer_of
from gateway.mavlink.heartbeat import build_extended_sys_state, build_heartbeat, build_sys_status
from gateway.mavlink.link import LinkKind
from gateway.mavlink.mission_items import mission_status_of, pack_mission_current

M = mavlink2

# GPS_RAW_INT constants of PX4's SITL GPS (sensor_gps_sim / gz bridge).
GPS_FIX_TYPE_3D = 3
GPS_SATELLITES = 10
GPS_EPH_CM = 70
GPS_EPV_CM = 110
GPS_H_ACC_MM = 900
GPS_V_ACC_MM = 1780
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


class _once:
    """A lazily computed attribute, stored on the instance at first read (like
    functools.cached_property without its per-access lock, which 3.11 still takes)."""

    def __init__(self, fn: Callable[[Any], Any]) -> None:
        self.fn = fn
        self.name = fn.__name__

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            return self
        value = self.fn(obj)
        obj.__dict__[self.name] = value  # later reads never reach the descriptor
        return value


class Sample:
    """What one vehicle's kinematics at one instant give every link: derived values, and the
    payloads that depend on nothing else (see ``_shared``). Builders read it through
    ``Snapshot``; only what cannot change within an instant belongs here (status and home can:
    a command may arrive between the two links' wake-ups)."""

    def __init__(self, vehicle: Any, now_s: float, kin: Any) -> None:
        self.vehicle = vehicle
        self.now_s = now_s
        self.kin = kin
        self.payloads: dict[Any, bytes] = {}

    @_once
    def euler(self) -> tuple[float, float, float]:
        return self.kin.euler_rad()

    @_once
    def geo(self) -> Any:
        # The vehicle derives it from the same measured position as ``kinematics``.
        return self.vehicle.global_position


class SampleCache:
    """The latest ``Sample`` of one vehicle; the sessions of one vehicle share one cache."""

    def __init__(self) -> None:
        self._last: Sample | None = None

    def at(self, vehicle: Any, now_s: float) -> Sample:
        kin = vehicle.kinematics
        last = self._last
        # Keyed by identity: the vehicle makes a new Kinematics at each physics step, and as
        # the cache holds the old one, a new one can never take its id. A vehicle that builds
        # a new object on every read only loses the sharing.
        if last is None or last.kin is not kin or last.now_s != now_s or last.vehicle is not vehicle:
            last = self._last = Sample(vehicle, now_s, kin)
        return last


class Snapshot:
    """What one wake-up reads from the vehicle; each property is read at most once.

    ``samples``: the vehicle's ``SampleCache``, shared with its other links (None: a private
    one)."""

    def __init__(self, vehicle: Any, now_s: float, boot_unix_s: float | None,
                 samples: SampleCache | None = None) -> None:
        self.vehicle = vehicle
        self.now_s = now_s
        self.boot_unix_s = boot_unix_s
        self.samples = samples
        self.time_boot_ms = int(now_s * 1000.0) & 0xFFFFFFFF
        self.time_usec = int(now_s * 1e6)

    @_once
    def status(self) -> Any:
        return self.vehicle.status

    @_once
    def sample(self) -> Sample:
        samples = self.samples if self.samples is not None else SampleCache()
        return samples.at(self.vehicle, self.now_s)

    @_once
    def kin(self) -> Any:
        """``vehicle.kinematics``: position, velocity, attitude, rates as plain floats."""
        return self.sample.kin

    @_once
    def geo(self) -> Any:
        return self.sample.geo

    @_once
    def euler(self) -> tuple[float, float, float]:
        return self.sample.euler

    @_once
    def home_alt_m(self) -> float:
        home = self.vehicle.home
        return home.geo.alt_amsl_m if home is not None else self.vehicle.origin.alt_amsl_m

    @_once
    def mav_type(self) -> int:
        return int(self.vehicle.params.get("MAV_TYPE", 2))


Builder = Callable[[Encoder, Snapshot], "bytes | None"]


def _deg_e7(deg: float) -> int:
    return int(round(deg * 1e7))


def _cdeg(rad: float) -> int:
    return int(round(math.degrees(rad) % 360.0 * 100.0)) % 36000


def heartbeat(enc: Encoder, s: Snapshot) -> bytes:
    return build_heartbeat(enc, s.status, s.mav_type)


def sys_status(enc: Encoder, s: Snapshot) -> bytes:
    return build_sys_status(enc, s.status)


def extended_sys_state(enc: Encoder, s: Snapshot) -> bytes:
    return build_extended_sys_state(enc, s.status)


def _shared(cls: type[M.MAVLink_message], key: Callable[[Snapshot], Any] | None = None,
            ) -> Callable[[Callable[[Snapshot], tuple]], Builder]:
    """A builder from ``args(snapshot)`` (``cls``'s constructor arguments) for a message that
    depends only on the vehicle's kinematics, the time and ``key(snapshot)``: its payload is
    packed once per ``Sample`` and key, whichever link asks first, and framed per link."""
    p = packer_of(cls)
    msg_id, crc_extra, pack, defaults = p.msg_id, p.crc_extra, p.pack, p.defaults

    def wrap(args: Callable[[Snapshot], tuple]) -> Builder:
        def build(enc: Encoder, s: Snapshot) -> bytes:
            payloads = s.sample.payloads
            k = msg_id if key is None else (msg_id, key(s))
            payload = payloads.get(k)
            if payload is None:
                a = args(s)
                payload = payloads[k] = pack(a + defaults[len(a):])
            return enc.frame(msg_id, crc_extra, payload)

        build.__name__ = build.__qualname__ = args.__name__
        build.__doc__ = args.__doc__
        return build

    return wrap


def _home_alt_m(s: Snapshot) -> float:
    return s.home_alt_m


@_shared(M.MAVLink_attitude_message)
def attitude(s: Snapshot) -> tuple:
    roll, pitch, yaw = s.euler
    p, q, r = s.kin.rates_frd_radps
    return (s.time_boot_ms, roll, pitch, yaw, p, q, r)


@_shared(M.MAVLink_attitude_quaternion_message)
def attitude_quaternion(s: Snapshot) -> tuple:
    w, x, y, z = s.kin.attitude_q
    p, q, r = s.kin.rates_frd_radps
    return (s.time_boot_ms, w, x, y, z, p, q, r)


@_shared(M.MAVLink_local_position_ned_message)
def local_position_ned(s: Snapshot) -> tuple:
    x, y, z = s.kin.position_ned_m
    vx, vy, vz = s.kin.velocity_ned_mps
    return (s.time_boot_ms, x, y, z, vx, vy, vz)


@_shared(M.MAVLink_global_position_int_message, key=_home_alt_m)  # relative_alt: from home
def global_position_int(s: Snapshot) -> tuple:
    g = s.geo
    vx, vy, vz = s.kin.velocity_ned_mps
    return (s.time_boot_ms, _deg_e7(g.lat_deg), _deg_e7(g.lon_deg),
            int(round(g.alt_amsl_m * 1000.0)), int(round((g.alt_amsl_m - s.home_alt_m) * 1000.0)),
            int(round(vx * 100.0)), int(round(vy * 100.0)), int(round(vz * 100.0)),
            _cdeg(s.euler[2]))


@_shared(M.MAVLink_gps_raw_int_message)
def gps_raw_int(s: Snapshot) -> tuple:
    g = s.geo
    vn, ve, _ = s.kin.velocity_ned_mps
    speed = math.hypot(vn, ve)
    cog = _cdeg(math.atan2(ve, vn)) if speed > 0.1 else UINT16_UNKNOWN
    alt_mm = int(round(g.alt_amsl_m * 1000.0))
    return (s.time_usec, GPS_FIX_TYPE_3D, _deg_e7(g.lat_deg), _deg_e7(g.lon_deg), alt_mm,
            GPS_EPH_CM, GPS_EPV_CM, int(round(speed * 100.0)), cog, GPS_SATELLITES, alt_mm,
            GPS_H_ACC_MM, GPS_V_ACC_MM, 0, 0, 0)


def vfr_hud(enc: Encoder, s: Snapshot) -> bytes:
    vn, ve, vd = s.kin.velocity_ned_mps
    speed = math.hypot(vn, ve)
    # PX4: the collective thrust setpoint in percent while armed (vehicle_thrust_setpoint).
    throttle = s.status.extra.get("thrust_norm", 0.0) if s.status.armed else 0.0
    return enc.pack(M.MAVLink_vfr_hud_message, speed, speed, _cdeg(s.euler[2]) // 100,
                    int(round(max(0.0, min(1.0, throttle)) * 100.0)), s.geo.alt_amsl_m, -vd)


@_shared(M.MAVLink_altitude_message, key=_home_alt_m)  # altitude_relative: from home
def altitude(s: Snapshot) -> tuple:
    amsl = s.geo.alt_amsl_m
    local = -s.kin.position_ned_m[2]
    return (s.time_usec, amsl, amsl, local, amsl - s.home_alt_m, math.nan, math.nan)


def _charge_state(remaining: float, params: Any) -> int:
    if remaining <= params.get("BAT_EMERGEN_THR", 0.05):
        return MAV_BATTERY_CHARGE_STATE_EMERGENCY
    if remaining <= params.get("BAT_CRIT_THR", 0.07):
        return MAV_BATTERY_CHARGE_STATE_CRITICAL
    if remaining <= params.get("BAT_LOW_THR", 0.15):
        return MAV_BATTERY_CHARGE_STATE_LOW
    return MAV_BATTERY_CHARGE_STATE_OK


def battery_status(enc: Encoder, s: Snapshot) -> bytes:
    bat = s.status.battery
    cells = max(1, min(10, int(bat.cell_count)))
    cell_mv = min(int(round(bat.voltage_v * 1000.0 / cells)), 65534)
    voltages = [cell_mv] * cells + [UINT16_UNKNOWN] * (10 - cells)
    return enc.pack(M.MAVLink_battery_status_message, 0, MAV_BATTERY_FUNCTION_ALL,
                    MAV_BATTERY_TYPE_LIPO, INT16_MAX, voltages,
                    int(round(bat.current_a * 100.0)), int(round(bat.consumed_mah)), -1,
                    int(round(bat.remaining * 100.0)), 0,
                    _charge_state(bat.remaining, s.vehicle.params), [0, 0, 0, 0], 0, 0)


def home_position(enc: Encoder, s: Snapshot) -> bytes | None:
    home = s.status.home
    if home is None:
        return None
    x, y, z = home.position_ned_m
    q = [math.cos(home.yaw_rad / 2.0), 0.0, 0.0, math.sin(home.yaw_rad / 2.0)]
    return enc.pack(M.MAVLink_home_position_message, _deg_e7(home.geo.lat_deg),
                    _deg_e7(home.geo.lon_deg), int(round(home.geo.alt_amsl_m * 1000.0)),
                    float(x), float(y), float(z), q, 0.0, 0.0, 0.0, s.time_usec)


def system_time(enc: Encoder, s: Snapshot) -> bytes:
    unix_us = 0 if s.boot_unix_s is None else int((s.boot_unix_s + s.now_s) * 1e6)
    return enc.pack(M.MAVLink_system_time_message, unix_us, s.time_boot_ms)


def mission_current(enc: Encoder, s: Snapshot) -> bytes:
    # The 1 Hz copy; mission.py sends it on every change of the current item.
    return pack_mission_current(enc, mission_status_of(s.vehicle))


# Sensors as PX4 SITL reports them from its simulated IMU, magnetometer and barometer.
G = 9.80665
# The Earth's field at PX4's SITL home (Zurich), gauss NED: 48 µT, inclination 63.5°,
# declination 3° east (WMM; PX4's sensor_mag_sim uses the same model at the home position).
MAG_NED_GAUSS = (0.2145, 0.0112, 0.4296)
HIGHRES_IMU_FIELDS = 0x1BFF  # acc, gyro, mag, abs pressure, pressure alt, temperature
MAV_FRAME_LOCAL_NED = 1
MAV_FRAME_BODY_FRD = 12
MAV_ESTIMATOR_TYPE_NAIVE = 1
COVARIANCE_UNKNOWN = (math.nan,) + (0.0,) * 20  # first element NaN: unknown


def isa_pressure_hpa(alt_amsl_m: float) -> float:
    """International Standard Atmosphere static pressure (PX4's baro simulation)."""
    return 1013.25 * (1.0 - 2.25577e-5 * alt_amsl_m) ** 5.25588


def isa_temperature_c(alt_amsl_m: float) -> float:
    return 15.0 - 0.0065 * alt_amsl_m


def _to_body(q: tuple[float, float, float, float], v: tuple[float, float, float]
             ) -> tuple[float, float, float]:
    """NED vector ``v`` in the body frame of attitude ``q`` (FRD → NED): Rᵀ v."""
    w, x, y, z = q
    a, b, c = v
    return ((1 - 2 * (y * y + z * z)) * a + 2 * (x * y + w * z) * b + 2 * (x * z - w * y) * c,
            2 * (x * y - w * z) * a + (1 - 2 * (x * x + z * z)) * b + 2 * (y * z + w * x) * c,
            2 * (x * z + w * y) * a + 2 * (y * z - w * x) * b + (1 - 2 * (x * x + y * y)) * c)


@_shared(M.MAVLink_highres_imu_message)
def highres_imu(s: Snapshot) -> tuple:
    """Specific force and rates in the body frame (FRD), the field, the barometer."""
    kin = s.kin
    an, ae, ad = s.vehicle.acceleration_ned_mps2
    fx, fy, fz = _to_body(kin.attitude_q, (an, ae, ad - G))
    mx, my, mz = _to_body(kin.attitude_q, MAG_NED_GAUSS)
    p, q, r = kin.rates_frd_radps
    alt = s.geo.alt_amsl_m
    return (s.time_usec, fx, fy, fz, p, q, r, mx, my, mz, isa_pressure_hpa(alt), 0.0, alt,
            isa_temperature_c(alt), HIGHRES_IMU_FIELDS, 0)


@_shared(M.MAVLink_odometry_message)
def odometry(s: Snapshot) -> tuple:
    """PX4's ODOMETRY stream: local NED pose, velocity and rates in the body frame (FRD)."""
    kin = s.kin
    x, y, z = kin.position_ned_m
    vx, vy, vz = _to_body(kin.attitude_q, kin.velocity_ned_mps)
    p, q, r = kin.rates_frd_radps
    return (s.time_usec, MAV_FRAME_LOCAL_NED, MAV_FRAME_BODY_FRD, x, y, z, kin.attitude_q,
            vx, vy, vz, p, q, r, COVARIANCE_UNKNOWN, COVARIANCE_UNKNOWN, 0,
            MAV_ESTIMATOR_TYPE_NAIVE, 100)


def scaled_pressure(enc: Encoder, s: Snapshot) -> bytes:
    alt = s.geo.alt_amsl_m
    return enc.pack(M.MAVLink_scaled_pressure_message, s.time_boot_ms, isa_pressure_hpa(alt), 0.0,
                    int(round(isa_temperature_c(alt) * 100.0)), 0)


def orbit_execution_status(enc: Encoder, s: Snapshot) -> bytes | None:
    """While orbiting (PX4 publishes orbit_status only then): signed radius, centre, altitude
    AMSL (frame GLOBAL)."""
    st = getattr(s.vehicle, "orbit_status", None)
    if st is None:
        return None
    g = s.vehicle.origin.offset_ned(st.center_ne_m[0], st.center_ne_m[1], st.down_m)
    return enc.pack(M.MAVLink_orbit_execution_status_message, s.time_usec, st.radius_m,
                    MAV_FRAME_GLOBAL, _deg_e7(g.lat_deg), _deg_e7(g.lon_deg), g.alt_amsl_m)


@dataclass(frozen=True)
class StreamSpec:
    msg_id: int
    builder: Builder
    gcs_hz: float  # PX4 "normal" mode with the SITL px4-rc.mavlink overrides
    api_hz: float  # PX4 "onboard" mode

    def default_hz(self, kind: LinkKind) -> float:
        return self.gcs_hz if kind is LinkKind.GCS else self.api_hz


STREAMS: tuple[StreamSpec, ...] = (
    StreamSpec(M.MAVLINK_MSG_ID_HEARTBEAT, heartbeat, 1.0, 1.0),
    StreamSpec(M.MAVLINK_MSG_ID_SYS_STATUS, sys_status, 1.0, 5.0),
    StreamSpec(M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, extended_sys_state, 1.0, 5.0),
    StreamSpec(M.MAVLINK_MSG_ID_ATTITUDE, attitude, 50.0, 100.0),
    StreamSpec(M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION, attitude_quaternion, 50.0, 50.0),
    StreamSpec(M.MAVLINK_MSG_ID_LOCAL_POSITION_NED, local_position_ned, 50.0, 30.0),
    StreamSpec(M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, global_position_int, 50.0, 50.0),
    # Onboard sends GPS_RAW_INT on every GPS update; PX4's simulated GPS runs at 10 Hz.
    StreamSpec(M.MAVLINK_MSG_ID_GPS_RAW_INT, gps_raw_int, 5.0, 10.0),
    StreamSpec(M.MAVLINK_MSG_ID_HOME_POSITION, home_position, 0.5, 0.5),
    StreamSpec(M.MAVLINK_MSG_ID_VFR_HUD, vfr_hud, 4.0, 10.0),
    StreamSpec(M.MAVLINK_MSG_ID_ALTITUDE, altitude, 1.0, 10.0),
    StreamSpec(M.MAVLINK_MSG_ID_BATTERY_STATUS, battery_status, 0.5, 0.5),
    StreamSpec(M.MAVLINK_MSG_ID_SYSTEM_TIME, system_time, 0.0, 1.0),
    StreamSpec(M.MAVLINK_MSG_ID_MISSION_CURRENT, mission_current, 1.0, 1.0),
    StreamSpec(M.MAVLINK_MSG_ID_ORBIT_EXECUTION_STATUS, orbit_execution_status, 2.0, 0.0),
    StreamSpec(M.MAVLINK_MSG_ID_HIGHRES_IMU, highres_imu, 0.0, 50.0),
    StreamSpec(M.MAVLINK_MSG_ID_ODOMETRY, odometry, 0.0, 30.0),
    StreamSpec(M.MAVLINK_MSG_ID_SCALED_PRESSURE, scaled_pressure, 1.0, 1.0),
)
STREAMS_BY_ID: dict[int, StreamSpec] = {spec.msg_id: spec for spec in STREAMS}
# HEARTBEAT rate is fixed (PX4: SET_MESSAGE_INTERVAL on it → FAILED).
FIXED_RATE_IDS = frozenset({M.MAVLINK_MSG_ID_HEARTBEAT})

NEVER = 1 << 62


def _interval_us(hz: float) -> int:
    return int(round(1e6 / hz)) if hz > 0 else 0


_ORDER = {spec.msg_id: i for i, spec in enumerate(STREAMS)}  # frames go out in table order


class Scheduler:
    """Per-stream integer-µs deadlines; ``next_us`` is the earliest of them.

    Streams with the same deadline and interval fire together until one of them is re-set, so
    they are kept as one group in a heap of (deadline, table position of the group's first
    stream, interval, streams): a wake-up touches the groups that are due, not every stream.
    """

    def __init__(self, kind: LinkKind, now_s: float) -> None:
        self.kind = kind
        start = int(round(now_s * 1e6))
        self._interval_us: dict[int, int] = {}
        nexts: dict[int, int] = {}
        for spec in STREAMS:
            iv = _interval_us(spec.default_hz(kind))
            self._interval_us[spec.msg_id] = iv
            nexts[spec.msg_id] = start if iv else NEVER
        self._group(nexts)

    def _group(self, next_us: dict[int, int]) -> None:
        groups: dict[tuple[int, int], list[StreamSpec]] = {}
        for spec in STREAMS:
            nxt = next_us[spec.msg_id]
            if nxt < NEVER:
                groups.setdefault((nxt, self._interval_us[spec.msg_id]), []).append(spec)
        # The sentinel never fires (now < NEVER), so the heap is never empty.
        heap = [(NEVER, len(STREAMS), 0, ())]
        heap += [(nxt, _ORDER[specs[0].msg_id], iv, tuple(specs))
                 for (nxt, iv), specs in groups.items()]
        heapq.heapify(heap)
        self._heap = heap
        # Streams of the groups due together (keyed by their first positions), in table order.
        self._merged: dict[int, tuple[StreamSpec, ...]] = {}
        self.next_us = heap[0][0]

    def _deadlines(self) -> dict[int, int]:
        """Each stream's next deadline (NEVER: stopped), read back from the groups."""
        out = dict.fromkeys(self._interval_us, NEVER)
        for nxt, _, _, specs in self._heap:
            for spec in specs:
                out[spec.msg_id] = nxt
        return out

    def interval_us(self, msg_id: int) -> int:
        """MESSAGE_INTERVAL semantics: µs, −1 disabled, 0 unknown/not available."""
        if msg_id not in self._interval_us:
            return 0
        return self._interval_us[msg_id] or -1

    def set_interval(self, msg_id: int, interval_us: float, now_s: float) -> bool:
        """SET_MESSAGE_INTERVAL p2: −1 stop, 0 default, > 0 interval µs. False if refused."""
        spec = STREAMS_BY_ID.get(msg_id)
        if spec is None or msg_id in FIXED_RATE_IDS or math.isnan(interval_us):
            return False
        if interval_us < 0:
            iv = 0
        elif interval_us == 0:
            iv = _interval_us(spec.default_hz(self.kind))
        else:
            iv = max(1, int(round(interval_us)))
        nexts = self._deadlines()
        self._interval_us[msg_id] = iv
        nexts[msg_id] = int(round(now_s * 1e6)) if iv else NEVER
        self._group(nexts)
        return True

    def due(self, now_s: float) -> tuple[StreamSpec, ...]:
        """Streams due at ``now_s`` in table order, with their deadlines advanced."""
        now_us = int(round(now_s * 1e6))
        if now_us < self.next_us:
            return ()
        heap = self._heap
        fired = []
        mask = 0
        while heap[0][0] <= now_us:
            nxt, first, iv, specs = heap[0]
            nxt += iv
            if nxt <= now_us:  # late wake-up: re-phase, never burst
                nxt = now_us + iv
            heapq.heapreplace(heap, (nxt, first, iv, specs))
            fired.append(specs)
            mask |= 1 << first
        self.next_us = heap[0][0]
        if len(fired) == 1:
            return fired[0]
        out = self._merged.get(mask)
        if out is None:
            out = tuple(sorted((spec for specs in fired for spec in specs),
                               key=lambda spec: _ORDER[spec.msg_id]))
            self._merged[mask] = out
        return out
