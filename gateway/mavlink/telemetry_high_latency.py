"""HIGH_LATENCY2 as PX4 v1.15 sends it (src/modules/mavlink/streams/HIGH_LATENCY2.hpp), once a
client sets its rate (SET_MESSAGE_INTERVAL) or asks for one (REQUEST_MESSAGE).

PX4's stream has two halves, and its quirks come from how they share subscriptions:
- ``update_data()`` runs at every pass of the link's loop and feeds analysers
  (mavlink_simple_analyzer.cpp) from new publications: the average groundspeed and the maximum
  climb rate (vehicle_local_position), the maximum eph/epv (vehicle_gps_position), the average
  battery remaining (battery_status), the average throttle (at each vehicle_status: the thrust
  setpoint while armed, else 0), the average wind speed (wind). It *consumes* those updates.
- ``send()`` at the stream's interval (and on a REQUEST_MESSAGE) fills the rest from
  ``write_*()``, each only if its topic has an update the subscription has not seen. For the
  topics ``update_data()`` consumed a moment before (vehicle_local_position, vehicle_status,
  battery_status, wind) there is none, so a streamed HIGH_LATENCY2 has latitude, longitude,
  altitude, heading, custom_mode and wind_heading 0, and no battery or sensor failure flags
  (mavlink/mavlink#1811). The others: target_heading from vehicle_attitude_setpoint's yaw,
  failure flags from estimator_status (any GPS check, filter fault or innovation check failing:
  ESTIMATOR, GPS checks also GPS), failsafe_flags (offboard signal lost, mission failure, manual
  control lost — the first and last are true on a vehicle flown without offboard setpoints or
  sticks) and geofence_result, wp_num from mission_result (only when the navigator published a
  new one since the last send: else UINT16_MAX). A multicopter has no airspeed, TECS or
  fixed-wing position controller status, and the default airframe no wind estimate (EKF2
  publishes wind only with drag fusion): airspeed, airspeed_sp, target_altitude,
  target_distance, windspeed 0, temperature INT8_MIN.
- After each send the analysers are reset. An analyser counts a sample only once the loop's
  filtered rate exceeds 1 Hz, which it does not at the loop's first pass; the stream's first
  send comes right then (``_last_sent`` 0), so it carries no averages (climb rate 0, eph/epv
  255) except the battery, whose average holds the sample all the same.
- A REQUEST_MESSAGE on a link without the stream makes a temporary one and calls ``send()``
  alone: its fresh subscriptions see every topic's latest publication, so that answer has the
  position, heading, mode and every failure flag, and no averages (the battery then reads 0).
  On a link with the stream, the request calls that stream's ``send()``.

Here ``update_data()`` runs at the vehicle's 50 Hz wake-ups of the link (the stream is woken
every SAMPLE_PERIOD_US and sends at its interval, as MavlinkStream::update decides); PX4
samples each of EKF2's ~100 Hz local positions, and vehicle_status at each publication (on
change, and at least every 500 ms: modelled so). The analysers compute in float32, as PX4's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.codec import FLT_MAX, Encoder, c_int, f32, payload_of
from gateway.mavlink.heartbeat import battery_connected
from gateway.mavlink.mission_items import mission_status_of
from gateway.mavlink.snapshot import Snapshot
from gateway.mavlink.telemetry import GPS_EPH_M, GPS_EPV_M, gps_fix_us, heading_deg
from gateway.mavlink.telemetry_estimator import gps_ctrl_of, innovation_test_ratios
from vehicles.custom_mode import custom_mode_of
from vehicles.estimation import F_ACC, F_BARO, F_GYRO, F_MAG
from vehicles.types import q_euler_rad

HL2 = M.MAVLINK_MSG_ID_HIGH_LATENCY2
SAMPLE_PERIOD_US = 20_000  # update_data's passes here (the link's 50 Hz wake-ups)
MAIN_LOOP_HZ = 1e6 / 1500  # the loop's rate at MAVLINK_MIN_INTERVAL, SITL's 4 MB/s links
STATUS_REPUBLISH_US = 500_000  # Commander publishes vehicle_status on change and at 2 Hz
WINDOW_S = 60.0  # SimpleAnalyzer's default window
FLT_MIN = 1.1754943508222875e-38
MAV_TYPE_QUADROTOR, MAV_AUTOPILOT_PX4 = 2, 12
INT8_MIN, UINT8_MAX, UINT16_MAX = -128, 255, 65535
_HIGH_LATENCY2 = payload_of(M.MAVLink_high_latency2_message)
_SENSOR_FLAGS = ((F_BARO, M.HL_FAILURE_FLAG_ABSOLUTE_PRESSURE), (F_ACC, M.HL_FAILURE_FLAG_3D_ACCEL),
                 (F_GYRO, M.HL_FAILURE_FLAG_3D_GYRO), (F_MAG, M.HL_FAILURE_FLAG_3D_MAG))


class Analyzer:
    """SimpleAnalyzer in AVERAGE or MAX mode, in float32."""

    __slots__ = ("average", "n", "result")

    def __init__(self, average: bool) -> None:
        self.average = average
        self.reset()

    def reset(self) -> None:
        self.n = 0
        self.result = 0.0 if self.average else FLT_MIN

    def add(self, value: float, update_rate: float) -> None:
        value = _float(value)
        if self.average:
            self.result = _float(_float(_float(self.result * self.n) + value) / (self.n + 1))
        elif value > self.result:
            self.result = value
        if self.n < update_rate * WINDOW_S and update_rate > 1.0:
            self.n += 1
        if not math.isfinite(self.result):
            self.reset()

    @property
    def valid(self) -> bool:
        return self.n > 0

    def scaled(self, factor: float, lo: int, hi: int) -> int:
        """get_scaled into an integer field: scaled in float32, rounded half away from zero
        (int_round), clamped, truncated."""
        x = f32(self.result * factor)
        x = x - 0.5 if x < 0 else x + 0.5
        return math.trunc(min(max(x, lo), hi))


@dataclass
class HighLatencyStream:
    """One link's HIGH_LATENCY2 stream: its analysers, its subscriptions' positions, its
    MavlinkStream timing. ``generation``: the link's stream deletions when it was made."""

    generation: int
    last_sent_us: int = 0
    loop_rate: float = 0.0  # update_data's low-passed call rate
    last_update_us: int = 0
    groundspeed: Analyzer = field(default_factory=lambda: Analyzer(True))
    climb_rate: Analyzer = field(default_factory=lambda: Analyzer(False))
    eph: Analyzer = field(default_factory=lambda: Analyzer(False))
    epv: Analyzer = field(default_factory=lambda: Analyzer(False))
    battery: Analyzer = field(default_factory=lambda: Analyzer(True))
    throttle: Analyzer = field(default_factory=lambda: Analyzer(True))
    battery_connected: bool = False
    gps_fix_us: int = -1  # the last vehicle_gps_position sampled (its timestamp)
    status_seen: tuple | None = None  # the last vehicle_status sampled, and when
    status_us: int = 0
    mission_seen: tuple | None = None  # the last mission_result send() saw

    def update_data(self, s: Snapshot) -> None:
        t = s.time_usec
        if t > self.last_update_us:
            # 0.97 * rate + 0.03 / dt: at the first pass dt is the time since boot, so the rate
            # stays under 1 Hz and that pass's samples do not count; from the next pass on it
            # is above 1 Hz, and settles at the loop's rate
            self.loop_rate = f32(0.03 / (t * 1e-6)) if self.last_update_us == 0 \
                else MAIN_LOOP_HZ
            self.last_update_us = t
        r = self.loop_rate
        status = s.status
        self.battery_connected = battery_connected(status.battery.voltage_v)
        self.battery.add(status.battery.remaining, r)
        vn, ve, vd = s.kin.velocity_ned_mps
        self.climb_rate.add(abs(vd), r)
        self.groundspeed.add(math.sqrt(f32(f32(vn * vn) + f32(ve * ve))), r)
        fix_us = gps_fix_us(s)
        if fix_us != self.gps_fix_us:
            self.gps_fix_us = fix_us
            self.eph.add(GPS_EPH_M, r)
            self.epv.add(GPS_EPV_M, r)
        seen = (status.armed, status.nav_state, status.landed_state, status.failsafe)
        if seen != self.status_seen or t - self.status_us >= STATUS_REPUBLISH_US:
            self.status_seen, self.status_us = seen, t
            self.throttle.add(status.extra.get("thrust_norm", 0.0) if status.armed else 0.0, r)

    def reset_analysers(self) -> None:
        for a in (self.groundspeed, self.climb_rate, self.eph, self.epv, self.battery,
                  self.throttle):
            a.reset()


def high_latency2(enc: Encoder, s: Snapshot) -> bytes | None:
    """The stream's pass (update_data, then send() when due), or a request's send()."""
    link = s.link
    scheduler = link.scheduler if link is not None else None
    if link is None or scheduler is None:  # a one-off build: a temporary stream's send()
        return _send(s, None)
    if scheduler.interval_us(HL2) == 0:  # no stream on this link: a request makes one
        return _send(s, None) if s.requested else None
    stream = link.hl2
    generation = scheduler.deletions(HL2)
    if stream is None or stream.generation != generation:
        stream = link.hl2 = HighLatencyStream(generation)
    if s.requested:
        return _send(s, stream)
    stream.update_data(s)
    interval, now = scheduler.interval_us(HL2), s.time_usec
    if stream.last_sent_us == 0:
        payload = _send(s, stream)
        stream.last_sent_us = now
        return payload
    dt = now - stream.last_sent_us
    if dt <= interval - MAIN_LOOP_DELAY_MARGIN_US:
        return None
    payload = _send(s, stream)
    stream.last_sent_us = stream.last_sent_us + interval if 1.5 * interval > dt else now
    return payload


# MavlinkStream::update sends once dt > interval - (main loop delay / 10) * 3
MAIN_LOOP_DELAY_MARGIN_US = 1500 // 10 * 3


def _send(s: Snapshot, stream: HighLatencyStream | None) -> bytes:
    """send(): the analysers (``stream``; None: a fresh stream's, all empty) and the write_*
    topics with updates its subscriptions have not seen."""
    status = s.status
    fresh = stream is None
    flags = _failure_flags(s, fresh)
    lat = lon = altitude = heading = custom_mode = 0
    if fresh:  # write_global_position, write_vehicle_status: fresh subscriptions see them
        g = s.sample.geo
        lat, lon = c_int(g.lat_deg * 1e7, -2**31, 2**31 - 1), c_int(g.lon_deg * 1e7, -2**31, 2**31 - 1)
        alt = f32(g.alt_amsl_m)
        altitude = _int16(alt + 0.5 if alt > 0 else alt - 0.5)
        heading = _half_degrees(s.sample.euler[2])
        custom_mode = custom_mode_of(status.nav_state) >> 16  # custom_mode_hl
    mission = mission_status_of(s.vehicle)
    seen = (mission.current_seq, mission.count, mission.reached_count, mission.state)
    wp_num = UINT16_MAX
    if stream is None or seen != stream.mission_seen:
        wp_num = mission.current_seq & 0xFFFF
        if stream is not None:
            stream.mission_seen = seen
    targets = s.targets
    target_heading = 0 if targets is None else _half_degrees(q_euler_rad(targets.attitude_q)[2])
    a = stream if stream is not None else HighLatencyStream(0)
    battery = -1
    if fresh:
        battery = 0 if battery_connected(status.battery.voltage_v) else -1
    elif a.battery_connected:
        battery = a.battery.scaled(100.0, -128, 127)
    payload = _HIGH_LATENCY2(
        int(s.now_s * 1000.0) & 0xFFFFFFFF, MAV_TYPE_QUADROTOR, MAV_AUTOPILOT_PX4, custom_mode,
        lat, lon, altitude, 0, heading, target_heading, 0,
        a.throttle.scaled(100.0, 0, 255) if a.throttle.valid else 0,
        0, 0,  # airspeed, airspeed_sp
        a.groundspeed.scaled(5.0, 0, 255) if a.groundspeed.valid else 0,
        0, 0,  # windspeed, wind_heading
        a.eph.scaled(10.0, 0, 255) if a.eph.valid else UINT8_MAX,
        a.epv.scaled(10.0, 0, 255) if a.epv.valid else UINT8_MAX,
        INT8_MIN,  # temperature_air
        a.climb_rate.scaled(10.0, 0, 255) if a.climb_rate.valid else 0,
        battery, wp_num, flags, INT8_MIN, INT8_MIN, INT8_MIN)
    if stream is not None:
        stream.reset_analysers()
    return payload


def _failure_flags(s: Snapshot, fresh: bool) -> int:
    flags = 0
    e = s.sample.estimator
    if e is not None:  # write_estimator_status: EKF2 publishes it at every filter update
        ratios = innovation_test_ratios(e, gps_ctrl_of(s.vehicle.params))
        if any(r > 1.0 for r in ratios):  # innovation_check_flags
            flags |= M.HL_FAILURE_FLAG_ESTIMATOR
    autopilot = getattr(s.vehicle, "autopilot", None)
    failsafe = None if autopilot is None else autopilot.commander.failsafe.flags
    if failsafe is not None:  # write_failsafe_flags, write_geofence_result
        if failsafe.offboard_lost:
            flags |= M.HL_FAILURE_FLAG_OFFBOARD_LINK
        if failsafe.mission_failure:
            flags |= M.HL_FAILURE_FLAG_MISSION
        if failsafe.manual_control_lost:
            flags |= M.HL_FAILURE_FLAG_RC_RECEIVER
        if failsafe.geofence_breached:
            flags |= M.HL_FAILURE_FLAG_GEOFENCE
        if fresh and failsafe.battery_warning > 1:  # write_battery_status: above LOW
            flags |= M.HL_FAILURE_FLAG_BATTERY
    if fresh:  # write_vehicle_status: the health report's sensor errors
        failed = s.status.extra.get("sensor_failures", 0)
        for bits, flag in _SENSOR_FLAGS:
            if failed & bits:
                flags |= flag
    return flags


def _float(x: float) -> float:
    """``x`` as a C float: rounded to float32, ±inf beyond its range, NaN as it is."""
    if not math.isfinite(x) or abs(x) > FLT_MAX:
        return math.copysign(math.inf, x) if not math.isnan(x) else x
    return f32(x)


def _half_degrees(rad: float) -> int:
    """static_cast<uint8_t>(math::degrees(matrix::wrap_2pi(x)) * 0.5f) (0 for NaN)."""
    return c_int(f32(heading_deg(rad)) * 0.5, 0, UINT8_MAX) if math.isfinite(rad) else 0


def _int16(x: float) -> int:
    """convert_limit_safe into int16_t: clamped, truncated."""
    return c_int(x, -32768, 32767)
