"""Telemetry streams: one table of (message, builder, default rate per link kind), one scheduler.

Source: PX4 mavlink_main.cpp configure_streams_to_default (NORMAL plus the SITL overrides for
the GCS link, ONBOARD for the API link).
Rules:
- Deadlines are integer microseconds of simulated time, so streams of commensurate rates fire
  in the same wake-up (all 50 Hz streams go out together) and counts are exact.
- A late wake-up sends each due stream once and re-phases it; it never bursts to catch up.
- The table has every stream of PX4 v1.15's mavlink_messages.cpp streams_list that PX4 SITL's
  dialect and ours share: SET_MESSAGE_INTERVAL may set any of them (ACCEPTED, as
  Mavlink::configure_stream finds it) but HEARTBEAT, whose rate is fixed. Messages PX4 has no
  stream for (RAW_IMU, ACTUATOR_CONTROL_TARGET, UTM_GLOBAL_POSITION — which PX4 #21663 took out
  of the list before v1.15 — MISSION_CURRENT, which the mission manager sends on its own) FAIL
  as in PX4. PROTOCOL_VERSION and COMPONENT_INFORMATION/METADATA, streams of PX4's that
  pymavlink's dialect lacks, answer requests only (command_requests.py); PX4 streams the first
  at a set rate and never the other two.
- Due streams come out in table order, so a wake-up's frames are always in the same order.
- A ``silent`` stream is one whose uORB topic nothing publishes in this simulation, so its
  send() never sends: RC_CHANNELS (no RC input), DISTANCE_SENSOR (no range finder),
  NAV_CONTROLLER_OUTPUT (position_controller_status: fixed-wing only), MOUNT_ORIENTATION and the
  gimbal streams (no mount), GPS_STATUS (sensor_gps_sim publishes no satellite_info), the second
  and third sensors' streams, AVAILABLE_MODES (its send() waits for a change of the mode
  list)… It is never scheduled; PX4 configures many of them all the same (MESSAGE_INTERVAL
  reports their rate, ``mavlink status streams`` lists them, telemetry_status counts them) and a
  REQUEST_MESSAGE for one is DENIED, as its send() has nothing.
- UNLIMITED (configure_stream's rate −1: every loop that has an update; MESSAGE_INTERVAL says
  −1) is what the onboard mode gives GPS_RAW_INT, GPS2_RAW, ADSB_VEHICLE, COLLISION and the
  camera's streams. Such a stream with data runs at its topic's rate (``data_hz``).
- ``boot`` streams (STATUSTEXT at 20 Hz, COMMAND_LONG unlimited) are configured on every link by
  Mavlink::task_main, not by the mode: a request for the default rate stops them, as
  configure_streams_to_default does with any stream the mode's list lacks. STATUSTEXT is sent by
  statustext.py at the interval set here.
- WIND_COV is a default stream but EKF2 publishes no wind without drag fusion.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.available_modes import MSG_ID_AVAILABLE_MODES, available_modes_monitor
from gateway.mavlink.codec import Encoder, crc_extra_of
from gateway.mavlink.heartbeat import MSG_ID_CURRENT_MODE
from gateway.mavlink.link import LinkKind
from gateway.mavlink.link_status import link_node_status
from gateway.mavlink.snapshot import Snapshot
from gateway.mavlink.telemetry import (
    Builder,
    altitude,
    attitude,
    attitude_quaternion,
    battery_status,
    current_mode,
    extended_sys_state,
    global_position_int,
    gps_raw_int,
    heartbeat,
    highres_imu,
    home_position,
    local_position_ned,
    mission_current,
    odometry,
    orbit_execution_status,
    scaled_pressure,
    sys_status,
    system_time,
    vfr_hud,
)
from gateway.mavlink.telemetry_control import (
    attitude_target,
    esc_info,
    esc_status,
    position_target_global_int,
    position_target_local_ned,
    servo_output_raw,
)
from gateway.mavlink.telemetry_estimator import estimator_status, vibration, wind_cov
from gateway.mavlink.telemetry_high_latency import SAMPLE_PERIOD_US as HL2_SAMPLE_US
from gateway.mavlink.telemetry_high_latency import high_latency2
from gateway.mavlink.telemetry_link import (
    gps_global_origin,
    ping,
    time_estimate_to_target,
    timesync,
)
from gateway.mavlink.telemetry_odid import open_drone_id_location, open_drone_id_system
from gateway.mavlink.telemetry_requested import (
    actuator_output_status,
    autopilot_state_for_gimbal_device,
    distance_sensor,
    flight_information,
    hil_state_quaternion,
    manual_control,
    rc_channels,
    scaled_imu,
    unpublished,
)
from gateway.mavlink.telemetry_version import autopilot_version, storage_information
from gateway.mavlink.wip_dialect import (
    ESC_INFO,
    ESC_STATUS,
    LINK_NODE_STATUS,
    TIME_ESTIMATE_TO_TARGET,
)

UNLIMITED = -1.0  # configure_stream's unlimited_rate


@dataclass(frozen=True)
class StreamSpec:
    msg_id: int
    builder: Builder  # (encoder, snapshot) -> the message's payload, None: nothing to send
    gcs_hz: float  # PX4 "normal" mode with the SITL px4-rc.mavlink overrides (0: not configured)
    api_hz: float  # PX4 "onboard" mode
    silent: bool = False  # its topic is never published here: never scheduled
    data_hz: float = 0.0  # at UNLIMITED rate: how often its topic updates, which it runs at
    boot: bool = False  # configured by Mavlink::task_main on every link, not by the mode
    stream: bool = True  # False: sent by another part of PX4's mavlink (no stream to set)
    # update_data's cadence (µs; 0: none): a stream that samples its topics between sends is
    # woken this often while it exists, and its builder decides when it sends
    sample_us: int = 0
    # Bound ahead for the framing (Encoder.frame_streams): CRC_EXTRA, the header's id fields.
    crc_extra: int = field(init=False)
    id_low16: int = field(init=False)
    id_high8: int = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "crc_extra", crc_extra_of(self.msg_id))
        object.__setattr__(self, "id_low16", self.msg_id & 0xFFFF)
        object.__setattr__(self, "id_high8", self.msg_id >> 16)

    def default_hz(self, kind: LinkKind) -> float:
        """The rate the link starts with."""
        return self.gcs_hz if kind is LinkKind.GCS else self.api_hz

    def mode_hz(self, kind: LinkKind) -> float:
        """The rate a request for the default gives (configure_streams_to_default of this one
        stream: the mode's rate, 0 — stopped — for a stream the mode does not configure)."""
        return 0.0 if self.boot else self.default_hz(kind)

    def frame(self, enc: Encoder, snapshot: Snapshot) -> bytes | None:
        """One message of this stream framed by ``enc`` (a REQUEST_MESSAGE's answer); None:
        nothing to send."""
        payload = self.builder(enc, snapshot)
        return None if payload is None else enc.frame(self.msg_id, self.crc_extra, payload)


STREAMS: tuple[StreamSpec, ...] = (
    StreamSpec(M.MAVLINK_MSG_ID_HEARTBEAT, heartbeat, 1.0, 1.0),
    StreamSpec(M.MAVLINK_MSG_ID_TIMESYNC, timesync, 0.0, 10.0),
    StreamSpec(M.MAVLINK_MSG_ID_SYS_STATUS, sys_status, 1.0, 5.0),
    StreamSpec(M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, extended_sys_state, 1.0, 5.0),
    # development dialect (PX4 SITL's). AVAILABLE_MODES answers requests; its stream would send
    # AVAILABLE_MODES_MONITOR after the mode list changed, which it never does here.
    StreamSpec(MSG_ID_AVAILABLE_MODES, available_modes_monitor, 0.3, 0.3, silent=True),
    # On every vehicle_status, which commander publishes ≥ 2 Hz
    StreamSpec(MSG_ID_CURRENT_MODE, current_mode, 0.5, 0.5),
    StreamSpec(M.MAVLINK_MSG_ID_ATTITUDE, attitude, 50.0, 100.0),
    StreamSpec(M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION, attitude_quaternion, 50.0, 50.0),
    StreamSpec(M.MAVLINK_MSG_ID_ATTITUDE_TARGET, attitude_target, 50.0, 10.0),
    StreamSpec(M.MAVLINK_MSG_ID_LOCAL_POSITION_NED, local_position_ned, 50.0, 30.0),
    StreamSpec(M.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED, position_target_local_ned, 50.0, 10.0),
    StreamSpec(M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, global_position_int, 50.0, 50.0),
    StreamSpec(M.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT, position_target_global_int, 1.0, 10.0),
    StreamSpec(M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, servo_output_raw, 50.0, 10.0),
    # On esc_status, which the gz bridge publishes with every motor-speed message (common.xml's
    # work-in-progress messages, which PX4 builds with: wip_dialect.py).
    StreamSpec(ESC_INFO.id, esc_info, 1.0, 10.0),
    StreamSpec(ESC_STATUS.id, esc_status, 1.0, 10.0),
    # Onboard sends GPS_RAW_INT on every sensor_gps update: SITL's sensor_gps_sim publishes at
    # 8 Hz (SensorGpsSim ScheduleOnInterval 125 ms; gz's navsat only feeds the ground truth).
    StreamSpec(M.MAVLINK_MSG_ID_GPS_RAW_INT, gps_raw_int, 5.0, UNLIMITED, data_hz=8.0),
    StreamSpec(M.MAVLINK_MSG_ID_HOME_POSITION, home_position, 0.5, 0.5),
    StreamSpec(M.MAVLINK_MSG_ID_VFR_HUD, vfr_hud, 4.0, 10.0),
    StreamSpec(M.MAVLINK_MSG_ID_ALTITUDE, altitude, 1.0, 10.0),
    StreamSpec(M.MAVLINK_MSG_ID_BATTERY_STATUS, battery_status, 0.5, 0.5),
    StreamSpec(M.MAVLINK_MSG_ID_SYSTEM_TIME, system_time, 0.0, 1.0),
    # MavlinkMissionManager's, at its 1 Hz slow rate: no stream of PX4's.
    StreamSpec(M.MAVLINK_MSG_ID_MISSION_CURRENT, mission_current, 1.0, 1.0, stream=False),
    StreamSpec(M.MAVLINK_MSG_ID_ORBIT_EXECUTION_STATUS, orbit_execution_status, 2.0, 5.0),
    StreamSpec(M.MAVLINK_MSG_ID_HIGHRES_IMU, highres_imu, 0.0, 50.0),
    StreamSpec(M.MAVLINK_MSG_ID_ODOMETRY, odometry, 0.0, 30.0),
    StreamSpec(M.MAVLINK_MSG_ID_SCALED_PRESSURE, scaled_pressure, 1.0, 1.0),
    StreamSpec(M.MAVLINK_MSG_ID_ESTIMATOR_STATUS, estimator_status, 0.5, 1.0),
    StreamSpec(M.MAVLINK_MSG_ID_VIBRATION, vibration, 0.1, 0.5),
    StreamSpec(M.MAVLINK_MSG_ID_WIND_COV, wind_cov, 0.5, 10.0),
    StreamSpec(M.MAVLINK_MSG_ID_PING, ping, 0.1, 1.0),
    StreamSpec(M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, gps_global_origin, 1.0, 1.0),
    StreamSpec(M.MAVLINK_MSG_ID_OPEN_DRONE_ID_LOCATION, open_drone_id_location, 1.0, 1.0),
    StreamSpec(M.MAVLINK_MSG_ID_OPEN_DRONE_ID_SYSTEM, open_drone_id_system, 1.0, 1.0),
    StreamSpec(TIME_ESTIMATE_TO_TARGET.id, time_estimate_to_target, 1.0, 1.0),
    StreamSpec(LINK_NODE_STATUS.id, link_node_status, 1.0, 1.0),
    # Not streamed by default; PX4 SITL sends them once asked (MAVSDK's telemetry.set_rate_*).
    StreamSpec(M.MAVLINK_MSG_ID_SCALED_IMU, scaled_imu, 0.0, 0.0),
    StreamSpec(M.MAVLINK_MSG_ID_HIL_STATE_QUATERNION, hil_state_quaternion, 0.0, 0.0),
    StreamSpec(M.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS, actuator_output_status, 0.0, 0.0),
    StreamSpec(M.MAVLINK_MSG_ID_FLIGHT_INFORMATION, flight_information, 0.0, 0.0),
    StreamSpec(M.MAVLINK_MSG_ID_MANUAL_CONTROL, manual_control, 0.0, 0.0),  # the sticks' echo
    StreamSpec(M.MAVLINK_MSG_ID_AUTOPILOT_STATE_FOR_GIMBAL_DEVICE,
               autopilot_state_for_gimbal_device, 0.0, 0.0),
    # What a request answers, sent at every interval once a client sets one.
    StreamSpec(M.MAVLINK_MSG_ID_AUTOPILOT_VERSION, autopilot_version, 0.0, 0.0),
    StreamSpec(M.MAVLINK_MSG_ID_STORAGE_INFORMATION, storage_information, 0.0, 0.0),
    # Samples its topics between sends (telemetry_high_latency.py)
    StreamSpec(M.MAVLINK_MSG_ID_HIGH_LATENCY2, high_latency2, 0.0, 0.0, sample_us=HL2_SAMPLE_US),
    # Streams whose topic nothing publishes here (the module docstring). px4-rc.mavlink sets
    # RC_CHANNELS to 20 Hz and OPTICAL_FLOW_RAD to 10 Hz on the GCS link.
    # STATUSTEXT: statustext.py sends the texts at this stream's interval.
    StreamSpec(M.MAVLINK_MSG_ID_STATUSTEXT, unpublished, 20.0, 20.0, silent=True, boot=True),
    StreamSpec(M.MAVLINK_MSG_ID_COMMAND_LONG, unpublished, UNLIMITED, UNLIMITED, silent=True,
               boot=True),
    StreamSpec(M.MAVLINK_MSG_ID_RC_CHANNELS, rc_channels, 20.0, 20.0, silent=True),
    StreamSpec(M.MAVLINK_MSG_ID_DISTANCE_SENSOR, distance_sensor, 0.5, 10.0, silent=True),
    *(StreamSpec(msg_id, unpublished, gcs_hz, api_hz, silent=True) for msg_id, gcs_hz, api_hz in (
        (M.MAVLINK_MSG_ID_GPS_STATUS, 1.0, 1.0),
        (M.MAVLINK_MSG_ID_GPS2_RAW, 1.0, UNLIMITED),
        (M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, 1.0, 10.0),
        (M.MAVLINK_MSG_ID_MOUNT_ORIENTATION, 10.0, 10.0),
        (M.MAVLINK_MSG_ID_GIMBAL_DEVICE_ATTITUDE_STATUS, 1.0, 1.0),
        (M.MAVLINK_MSG_ID_GIMBAL_DEVICE_SET_ATTITUDE, 5.0, 5.0),
        (M.MAVLINK_MSG_ID_GIMBAL_MANAGER_STATUS, 0.5, 0.5),
        (M.MAVLINK_MSG_ID_OPTICAL_FLOW_RAD, 10.0, 10.0),
        (M.MAVLINK_MSG_ID_OBSTACLE_DISTANCE, 1.0, 10.0),
        (M.MAVLINK_MSG_ID_RAW_RPM, 2.0, 5.0),
        (M.MAVLINK_MSG_ID_EFI_STATUS, 2.0, 2.0),
        (M.MAVLINK_MSG_ID_HYGROMETER_SENSOR, 0.1, 1.0),
        (M.MAVLINK_MSG_ID_TRAJECTORY_REPRESENTATION_WAYPOINTS, 0.0, 5.0),
        (M.MAVLINK_MSG_ID_ADSB_VEHICLE, UNLIMITED, UNLIMITED),
        (M.MAVLINK_MSG_ID_COLLISION, UNLIMITED, UNLIMITED),
        (M.MAVLINK_MSG_ID_CAMERA_TRIGGER, 0.0, UNLIMITED),
        (M.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED, UNLIMITED, UNLIMITED),
        (M.MAVLINK_MSG_ID_DEBUG, 1.0, 10.0),
        (M.MAVLINK_MSG_ID_DEBUG_VECT, 1.0, 10.0),
        (M.MAVLINK_MSG_ID_DEBUG_FLOAT_ARRAY, 1.0, 10.0),
        (M.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT, 1.0, 10.0),
        # in the list, configured by no mode of these links
        (M.MAVLINK_MSG_ID_SCALED_IMU2, 0.0, 0.0),
        (M.MAVLINK_MSG_ID_SCALED_IMU3, 0.0, 0.0),
        (M.MAVLINK_MSG_ID_SCALED_PRESSURE2, 0.0, 0.0),
        (M.MAVLINK_MSG_ID_SCALED_PRESSURE3, 0.0, 0.0),
        (M.MAVLINK_MSG_ID_LANDING_TARGET, 0.0, 0.0),
        (M.MAVLINK_MSG_ID_MAG_CAL_REPORT, 0.0, 0.0),
        (M.MAVLINK_MSG_ID_GIMBAL_MANAGER_INFORMATION, 0.0, 0.0),
        (M.MAVLINK_MSG_ID_GIMBAL_DEVICE_INFORMATION, 0.0, 0.0),
        (M.MAVLINK_MSG_ID_HIL_ACTUATOR_CONTROLS, 0.0, 0.0),
        (M.MAVLINK_MSG_ID_OPEN_DRONE_ID_BASIC_ID, 0.0, 0.0),
        (M.MAVLINK_MSG_ID_GPS_RTCM_DATA, 0.0, 0.0),
    )),
)
STREAMS_BY_ID: dict[int, StreamSpec] = {spec.msg_id: spec for spec in STREAMS}
# HEARTBEAT rate is fixed (PX4: SET_MESSAGE_INTERVAL on it → FAILED).
FIXED_RATE_IDS = frozenset({M.MAVLINK_MSG_ID_HEARTBEAT})

NEVER = 1 << 62
# Mavlink::task_main's loop runs at most every MAVLINK_MIN_INTERVAL µs (its "hard limit to 1000 Hz
# at max"; SITL's 4 MB/s datarate asks for less), and a stream sends at most once per loop: a
# shorter interval is accepted and reported as set, and streams at this period.
MAVLINK_MIN_INTERVAL_US = 1500
# A group of streams that fire together: [deadline µs, table position of its first stream,
# interval µs, the streams in table order]; a list, whose deadline ``due`` advances in place.
Group = list[Any]


_heapreplace = heapq.heapreplace


def _interval_us(hz: float) -> int:
    """Mavlink::configure_stream's interval: µs for a rate above 1e-6 Hz (truncated), −1 for a
    negative rate (unlimited), 0 (no stream) otherwise."""
    return int(1e6 / hz) if hz > 1e-6 else -1 if hz < 0 else 0


def _period_us(spec: StreamSpec, interval_us: int) -> int:
    """How often a stream set to ``interval_us`` is sent here (0: never): its interval, no
    shorter than the main loop's; unlimited, as often as its topic updates."""
    if spec.silent:
        return 0
    if spec.sample_us and interval_us != 0:
        return min(max(interval_us, MAVLINK_MIN_INTERVAL_US), spec.sample_us) \
            if interval_us > 0 else spec.sample_us
    if interval_us > 0:
        return max(interval_us, MAVLINK_MIN_INTERVAL_US)
    return _interval_us(spec.data_hz) if interval_us < 0 else 0


_ORDER = {spec.msg_id: i for i, spec in enumerate(STREAMS)}  # frames go out in table order


class Scheduler:
    """Per-stream integer-µs deadlines; ``next_us`` is the earliest of them (``next_s`` in
    seconds, inf when none).

    Streams with the same deadline and period fire together until one of them is re-set, so
    they are kept as one group in a heap of (deadline, table position of the group's first
    stream, period, streams): a wake-up touches the groups that are due, not every stream.
    """

    def __init__(self, kind: LinkKind, now_s: float) -> None:
        self.kind = kind
        start = int(round(now_s * 1e6))
        # Each stream's interval as PX4 keeps it (µs; −1 unlimited; 0 no stream), and how often
        # it is sent here (µs; 0 never).
        self._interval_us: dict[int, int] = {}
        self._period_us: dict[int, int] = {}
        self._deletions: dict[int, int] = {}  # how often each stream was set to rate 0
        nexts: dict[int, int] = {}
        for spec in STREAMS:
            iv = _interval_us(spec.default_hz(kind))
            # A message no stream sends (MISSION_CURRENT) has no interval to report.
            self._interval_us[spec.msg_id] = iv if spec.stream else 0
            period = self._period_us[spec.msg_id] = _period_us(spec, iv)
            nexts[spec.msg_id] = start if period else NEVER
        self._group(nexts)

    def _group(self, next_us: dict[int, int]) -> None:
        groups: dict[tuple[int, int], list[StreamSpec]] = {}
        for spec in STREAMS:
            nxt = next_us[spec.msg_id]
            if nxt < NEVER:
                groups.setdefault((nxt, self._period_us[spec.msg_id]), []).append(spec)
        # The sentinel never fires (now < NEVER), so the heap is never empty.
        heap: list[Group] = [[NEVER, len(STREAMS), 0, ()]]
        heap += [[nxt, _ORDER[specs[0].msg_id], period, tuple(specs)]
                 for (nxt, period), specs in groups.items()]
        heapq.heapify(heap)
        self._heap = heap
        # Streams of the groups due together (keyed by their first positions), in table order.
        self._merged: dict[int, tuple[StreamSpec, ...]] = {}
        self._next(heap[0][0])

    def _next(self, next_us: int) -> None:
        """The earliest deadline, in µs and as the session's timer reads it (s; inf: none)."""
        self.next_us = next_us
        self.next_s = next_us * 1e-6 if next_us < NEVER else math.inf

    def _deadlines(self) -> dict[int, int]:
        """Each stream's next deadline (NEVER: stopped), read back from the groups."""
        out = dict.fromkeys(self._interval_us, NEVER)
        for nxt, _, _, specs in self._heap:
            for spec in specs:
                out[spec.msg_id] = nxt
        return out

    def interval_us(self, msg_id: int) -> int:
        """What MESSAGE_INTERVAL reports (MavlinkReceiver::get_message_interval): the stream's
        interval in µs, −1 for an unlimited one, 0 when the link has no such stream (none in
        PX4's list, not configured by the link's mode, or stopped: PX4 deletes a stream set to
        rate 0)."""
        return self._interval_us.get(msg_id, 0)

    def deletions(self, msg_id: int) -> int:
        """How many times the stream was stopped (PX4 deletes a stream set to rate 0: one
        set again later is a new object, with fresh state)."""
        return self._deletions.get(msg_id, 0)

    def period_s(self, msg_id: int) -> float:
        """How often the stream is sent (s; 0 as often as the loop runs, inf never), for a
        stream that is sent by a service of its own (STATUSTEXT)."""
        iv = self._interval_us.get(msg_id, 0)
        return math.inf if iv == 0 else 0.0 if iv < 0 \
            else max(iv, MAVLINK_MIN_INTERVAL_US) * 1e-6

    def set_interval(self, msg_id: int, interval_us: float, now_s: float) -> bool:
        """SET_MESSAGE_INTERVAL p2 as MavlinkReceiver::set_message_interval reads it: below
        -1e-5 stop; above 1e-5 the rate 1e6 / p2, whose interval (Mavlink::configure_stream,
        truncated to whole µs) is 0, i.e. stopped, for rates of 1e-6 Hz and less and for
        intervals under 1 µs (inf, 3e38 …); anything else (0, NaN) the mode's default
        (``StreamSpec.mode_hz``). False if the message has no stream or is HEARTBEAT."""
        spec = STREAMS_BY_ID.get(msg_id)
        if spec is None or not spec.stream or msg_id in FIXED_RATE_IDS:
            return False
        if interval_us < -1e-5:
            iv = 0
        elif interval_us > 1e-5:
            iv = _interval_us(1e6 / interval_us)
        else:  # 0, tiny or NaN
            iv = _interval_us(spec.mode_hz(self.kind))
        nexts = self._deadlines()
        if iv == 0 and self._interval_us.get(msg_id, 0) != 0:
            self._deletions[msg_id] = self._deletions.get(msg_id, 0) + 1
        self._interval_us[msg_id] = iv
        period = self._period_us[msg_id] = _period_us(spec, iv)
        nexts[msg_id] = int(round(now_s * 1e6)) if period else NEVER
        self._group(nexts)
        return True

    def due(self, now_s: float) -> tuple[StreamSpec, ...]:
        """Streams due at ``now_s`` in table order, with their deadlines advanced."""
        now_us = round(now_s * 1e6)  # an int: round() of a float without ndigits
        if now_us < self.next_us:
            return ()
        heap = self._heap
        # The first due group; most wake-ups have no other (then no merging either). Its entry
        # is advanced in place and sifted down.
        group = heap[0]
        nxt = group[0] + group[2]
        group[0] = nxt if nxt > now_us else now_us + group[2]  # late: re-phase, never burst
        _heapreplace(heap, group)
        nxt = heap[0][0]
        if nxt > now_us:
            self.next_us = nxt  # ``_next`` inlined: this runs at every wake-up
            self.next_s = nxt * 1e-6 if nxt < NEVER else math.inf
            return group[3]
        mask = 1 << group[1]
        while nxt <= now_us:
            group = heap[0]
            nxt = group[0] + group[2]
            group[0] = nxt if nxt > now_us else now_us + group[2]
            _heapreplace(heap, group)
            mask |= 1 << group[1]
            nxt = heap[0][0]
        self._next(nxt)
        out = self._merged.get(mask)
        if out is None:
            out = tuple(sorted((spec for g in heap if mask >> g[1] & 1 for spec in g[3]),
                               key=lambda spec: _ORDER[spec.msg_id]))
            self._merged[mask] = out
        return out
