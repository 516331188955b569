"""PX4's logger for one vehicle, sans-IO: ULog bytes of its topics, messages and parameters.

Source: PX4 src/modules/logger (logger.cpp: SDLOG_MODE, the file names, what the definitions
section holds; logged_topics.cpp: the default profile's topics and intervals).
Rules:
- ``tick(now)`` (the shell calls it at 50 Hz of simulated time) starts and stops logs as
  SDLOG_MODE says (-1 never; 0 from arming to disarming; 1 from boot to disarming, then as 0;
  2 from boot on; 4 from the first arming on; 3, AUX1, as 0) and samples each topic when its
  interval has passed (0: every tick; topics marked on-change: when their values change).
- Topics carry PX4's names and field names (a subset of PX4's fields per topic, as CORNET has
  them); the values are the vehicle's estimate, as PX4 logs its estimator's output.
- A log holds the info fields (sys_name, ver_sw, sys_uuid, time_ref_utc), every parameter at its
  start, every parameter change ('P' in the data section), and every status text ('L').
- ``drain()`` hands the shell what to append to which file: (relative path, bytes, closed).
  Paths follow PX4: ``log/<YYYY-MM-DD>/<HH_MM_SS>.ulg`` (UTC) when the boot epoch is known,
  else ``log/sess<NNN>/log<NNN>.ulg``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from gateway.mavlink.vehicle_port import VehiclePort
from gateway.onboard import ulog
from vehicles.estimation import (
    E_ACCURACY,
    E_RATIOS,
    E_WIND,
    E_WIND_VAR,
    S_ACC,
    S_GPS_POS,
    S_GPS_VEL,
    S_GYRO,
)
from vehicles.params import ParamType
from vehicles.types import Severity

VER_SW = "CORNET"
SDLOG_OFF, SDLOG_ARMED, SDLOG_BOOT_TO_DISARM, SDLOG_BOOT_TO_SHUTDOWN, SDLOG_AUX1, \
    SDLOG_FIRST_ARM = -1, 0, 1, 2, 3, 4
ARMING_STATE_DISARMED, ARMING_STATE_ARMED = 1, 2  # vehicle_status.arming_state (PX4 1.15)
GPS_EPH_M, GPS_EPV_M, GPS_FIX_3D, GPS_SATELLITES = 0.9, 1.78, 3, 10  # sensor_gps_sim
LEVELS = {s: ord(str(int(s))) for s in Severity}  # syslog digit per MAV_SEVERITY

Fields = Sequence[tuple[str, str]]


@dataclass(frozen=True)
class Topic:
    name: str
    fields: Fields  # after the leading "uint64_t timestamp"
    interval_s: float  # logged_topics.cpp's interval (0: every tick)
    read: Callable[[Any], tuple]  # the vehicle → the field values
    on_change: bool = False  # log only when the values change (and at the start)


def _sensors(v: Any) -> list[float]:
    return v.sensors


def _attitude(v: Any) -> tuple:
    return (v.kinematics.attitude_q,)


def _local_position(v: Any) -> tuple:
    k = v.kinematics
    a = v.acceleration_ned_mps2
    w, x, y, z = k.attitude_q
    heading = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    valid = v.status.position_valid
    e = v.estimator
    o = v.origin
    return (*k.position_ned_m, *k.velocity_ned_mps, *a, heading, valid, valid, valid, valid,
            o.lat_deg, o.lon_deg, o.alt_amsl_m, e[E_ACCURACY], e[E_ACCURACY + 1])


def _global_position(v: Any) -> tuple:
    g = v.global_position
    e = v.estimator
    return (g.lat_deg, g.lon_deg, g.alt_amsl_m, e[E_ACCURACY], e[E_ACCURACY + 1])


def _status(v: Any) -> tuple:
    st = v.status
    mav_type = v.params.get("MAV_TYPE", 2)
    return (ARMING_STATE_ARMED if st.armed else ARMING_STATE_DISARMED, int(st.nav_state),
            bool(st.failsafe), int(mav_type if mav_type is not None else 2))


def _sensor_combined(v: Any) -> tuple:
    s = _sensors(v)
    return (tuple(s[S_GYRO:S_GYRO + 3]), 4000, 0, tuple(s[S_ACC:S_ACC + 3]), 4000)


def _gps(v: Any) -> tuple:
    s = _sensors(v)
    g = v.origin.offset_ned(s[S_GPS_POS], s[S_GPS_POS + 1], s[S_GPS_POS + 2])
    return (g.lat_deg, g.lon_deg, g.alt_amsl_m, GPS_EPH_M, GPS_EPV_M, *s[S_GPS_VEL:S_GPS_VEL + 3],
            GPS_FIX_3D, GPS_SATELLITES)


def _battery(v: Any) -> tuple:
    b = v.status.battery
    return (b.voltage_v, b.current_a, b.consumed_mah, b.remaining)


def _actuator_outputs(v: Any) -> tuple:
    speeds = list(v.status.extra.get("rotor_speed_radps", ()))[:16]
    return (len(speeds), tuple(speeds + [0.0] * (16 - len(speeds))))


def _setpoint(v: Any) -> tuple:
    sp = v.position_setpoint_ned_m
    pos = tuple(sp) if sp is not None else (math.nan,) * 3
    return (*pos, math.nan, math.nan, math.nan)


def _trajectory_setpoint(v: Any) -> tuple:
    sp = v.position_setpoint_ned_m
    return (tuple(sp) if sp is not None else (math.nan,) * 3, (math.nan,) * 3)


def _land_detected(v: Any) -> tuple:
    landed = int(v.status.landed_state) == 1  # MAV_LANDED_STATE_ON_GROUND
    return (landed, landed, landed)


def _estimator_status(v: Any) -> tuple:
    e = v.estimator
    return (*e[E_RATIOS:E_RATIOS + 4], e[E_ACCURACY], e[E_ACCURACY + 1])


def _wind(v: Any) -> tuple:
    e = v.estimator
    return (e[E_WIND], e[E_WIND + 1], e[E_WIND_VAR] / 2, e[E_WIND_VAR] / 2)


F, D, B = "float", "double", "bool"
TOPICS: tuple[Topic, ...] = (
    Topic("vehicle_attitude", (("float[4]", "q"),), 0.0, _attitude),
    Topic("vehicle_local_position", ((F, "x"), (F, "y"), (F, "z"), (F, "vx"), (F, "vy"), (F, "vz"),
                                     (F, "ax"), (F, "ay"), (F, "az"), (F, "heading"),
                                     (B, "xy_valid"), (B, "z_valid"), (B, "v_xy_valid"),
                                     (B, "v_z_valid"), (D, "ref_lat"), (D, "ref_lon"),
                                     (F, "ref_alt"), (F, "eph"), (F, "epv")), 0.0, _local_position),
    Topic("vehicle_global_position", ((D, "lat"), (D, "lon"), (F, "alt"), (F, "eph"), (F, "epv")),
          0.0, _global_position),
    Topic("vehicle_status", (("uint8_t", "arming_state"), ("uint8_t", "nav_state"),
                             (B, "failsafe"), ("uint8_t", "system_type")), 0.0, _status,
          on_change=True),
    Topic("sensor_combined", (("float[3]", "gyro_rad"), ("uint32_t", "gyro_integral_dt"),
                              ("int32_t", "accelerometer_timestamp_relative"),
                              ("float[3]", "accelerometer_m_s2"),
                              ("uint32_t", "accelerometer_integral_dt")), 0.0, _sensor_combined),
    Topic("vehicle_gps_position", ((D, "latitude_deg"), (D, "longitude_deg"),
                                   (D, "altitude_msl_m"), (F, "eph"), (F, "epv"),
                                   (F, "vel_n_m_s"), (F, "vel_e_m_s"), (F, "vel_d_m_s"),
                                   ("uint8_t", "fix_type"), ("uint8_t", "satellites_used")),
          0.1, _gps),
    Topic("battery_status", ((F, "voltage_v"), (F, "current_a"), (F, "discharged_mah"),
                             (F, "remaining")), 0.2, _battery),
    Topic("actuator_outputs", (("uint32_t", "noutputs"), ("float[16]", "output")), 0.1,
          _actuator_outputs),
    Topic("vehicle_local_position_setpoint", ((F, "x"), (F, "y"), (F, "z"), (F, "vx"), (F, "vy"),
                                              (F, "vz")), 0.1, _setpoint),
    Topic("trajectory_setpoint", (("float[3]", "position"), ("float[3]", "velocity")), 0.2,
          _trajectory_setpoint),
    Topic("vehicle_land_detected", ((B, "landed"), (B, "maybe_landed"), (B, "ground_contact")),
          0.0, _land_detected, on_change=True),
    Topic("estimator_status", ((F, "vel_test_ratio"), (F, "pos_test_ratio"),
                               (F, "hgt_test_ratio"), (F, "mag_test_ratio"),
                               (F, "pos_horiz_accuracy"), (F, "pos_vert_accuracy")), 0.2,
          _estimator_status),
    Topic("wind", ((F, "windspeed_north"), (F, "windspeed_east"), (F, "variance_north"),
                   (F, "variance_east")), 1.0, _wind),
)


def _flatten(values: tuple) -> list:
    out: list = []
    for x in values:
        if isinstance(x, (tuple, list)):
            out.extend(x)
        else:
            out.append(x)
    return out


class _Sample:
    """The vehicle as one sampling instant sees it: each property read once (``status``,
    ``estimator``, ``sensors`` build new objects on every read), shared by the topics."""

    def __init__(self, vehicle: Any) -> None:
        self._vehicle = vehicle

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._vehicle, name)
        setattr(self, name, value)
        return value


class VehicleLogger:
    """One vehicle's logs (module rules)."""

    def __init__(self, vehicle: VehiclePort, boot_unix_s: float | None,
                 topics: Sequence[Topic] = TOPICS) -> None:
        self.vehicle = vehicle
        self.boot_unix_s = boot_unix_s
        self.topics = tuple(topics)
        self._structs = [ulog.struct_of((("uint64_t", "timestamp"), *t.fields))
                         for t in self.topics]
        self._nested = [any("[" in ftype for ftype, _ in t.fields) for t in self.topics]
        self._path: str | None = None
        self._buf = bytearray()
        self._out: list[tuple[str, bytes, bool]] = []
        self._due = [0.0] * len(self.topics)
        self._last: list[tuple | None] = [None] * len(self.topics)
        self._params: dict[str, float] = {}
        self._text_seq = 0
        self._sessions = 0
        self._was_armed = False
        self._armed_once = False
        self._booted = False
        self._param_changes: list[tuple[str, float]] = []
        vehicle.params.on_change(self._on_param)
        self.files: list[str] = []  # every log started, oldest first

    @property
    def logging(self) -> bool:
        return self._path is not None

    @property
    def current(self) -> str | None:
        """The path of the log being written (relative to the vehicle's root), or None."""
        return self._path

    def _on_param(self, name: str, value: float) -> None:
        if self._path is not None:
            self._param_changes.append((name, value))

    def _name(self, now_s: float) -> str:
        if self.boot_unix_s is None:
            self._sessions += 1
            return f"log/sess{self._sessions:03d}/log001.ulg"
        t = time.gmtime(self.boot_unix_s + now_s)
        return f"log/{time.strftime('%Y-%m-%d', t)}/{time.strftime('%H_%M_%S', t)}.ulg"

    def _start(self, now_s: float) -> None:
        us = int(now_s * 1e6)
        self._path = self._name(now_s)
        self.files.append(self._path)
        v = self.vehicle
        sysid = v.params.get("MAV_SYS_ID", 1)
        parts = [ulog.header(us), ulog.flag_bits()]
        parts += [ulog.format_message(t.name, (("uint64_t", "timestamp"), *t.fields))
                  for t in self.topics]
        parts += [ulog.info("sys_name", "PX4"), ulog.info("ver_sw", VER_SW),
                  ulog.info("sys_uuid", f"CORNET{int(sysid or 1):04d}"),
                  ulog.info("sys_mcu", "SITL"), ulog.info("sys_os_name", "Linux")]
        if self.boot_unix_s is not None:
            parts.append(ulog.info("time_ref_utc", 0))
        for param, value in v.params.items():
            parts.append(ulog.parameter(param.name, value, param.type is ParamType.INT32))
        parts += [ulog.add_logged(i, t.name) for i, t in enumerate(self.topics)]
        parts.append(ulog.sync())
        self._buf += b"".join(parts)
        self._due = [now_s] * len(self.topics)
        self._last = [None] * len(self.topics)
        self._param_changes.clear()
        self._text_seq = max((t.seq for t in self._texts(0)), default=self._text_seq)

    def _stop(self) -> None:
        if self._path is not None:
            self._out.append((self._path, bytes(self._buf), True))
            self._buf.clear()
            self._path = None

    def _texts(self, after: int) -> list:
        texts = getattr(self.vehicle, "status_texts", None)
        return texts(after) if texts is not None else []

    def tick(self, now_s: float) -> None:
        """Start or stop a log as SDLOG_MODE says; sample what is due (module rules)."""
        mode = self.vehicle.params.get("SDLOG_MODE", SDLOG_ARMED)
        mode = SDLOG_ARMED if mode is None else int(mode)
        view = _Sample(self.vehicle)
        armed = view.status.armed
        boot = not self._booted
        self._booted = True
        if self._path is None:
            if (boot and mode in (SDLOG_BOOT_TO_DISARM, SDLOG_BOOT_TO_SHUTDOWN)) or (
                    armed and not self._was_armed and mode != SDLOG_OFF
                    and not (mode == SDLOG_FIRST_ARM and self._armed_once)):
                self._start(now_s)
        elif self._was_armed and not armed and mode in (SDLOG_ARMED, SDLOG_BOOT_TO_DISARM,
                                                        SDLOG_AUX1):
            self._sample(now_s, True, view)
            self._stop()
        self._armed_once = self._armed_once or armed
        self._was_armed = armed
        if self._path is not None:
            self._sample(now_s, False, view)

    def _sample(self, now_s: float, force: bool, view: _Sample) -> None:
        us = int(now_s * 1e6)
        buf = self._buf
        for name, value in self._param_changes:
            info = self.vehicle.params.info(name)
            buf += ulog.parameter(name, value, info.type is ParamType.INT32)
        self._param_changes.clear()
        for text in self._texts(self._text_seq):
            buf += ulog.logged_string(LEVELS.get(text.severity, ulog.LOG_INFO),
                                      int(text.time_s * 1e6), text.text)
            self._text_seq = text.seq
        for i, topic in enumerate(self.topics):
            if not force and now_s + 1e-9 < self._due[i]:
                continue
            values = topic.read(view)
            if topic.on_change and values == self._last[i] and not force:
                continue
            self._last[i] = values
            self._due[i] = now_s + topic.interval_s
            flat = _flatten(values) if self._nested[i] else values
            buf += ulog.data(i, self._structs[i].pack(us, *flat))

    def drain(self) -> list[tuple[str, bytes, bool]]:
        """What to append to which file since the last drain: (path, bytes, closed)."""
        out = self._out
        self._out = []
        if self._path is not None and self._buf:
            out.append((self._path, bytes(self._buf), False))
            self._buf.clear()
        return out

    def close(self) -> list[tuple[str, bytes, bool]]:
        """Shutdown: the log in progress ends."""
        self._stop()
        return self.drain()
