"""Streams that belong to a link rather than to its vehicle alone: TIMESYNC and PING (PX4 asks
its peer, on the link's own clock and sequence), GPS_GLOBAL_ORIGIN (sent once per link, then
on change) and TIME_ESTIMATE_TO_TARGET (once per publication), with the little each link
remembers for them (snapshot.LinkTelemetry).

Source: PX4's stream classes src/modules/mavlink/streams/TIMESYNC.hpp, PING.hpp and
GPS_GLOBAL_ORIGIN.hpp; rates from mavlink_main.cpp configure_streams_to_default (TIMESYNC 10 Hz
on the onboard link only; PING 0.1 Hz normal, 1 Hz onboard; GPS_GLOBAL_ORIGIN 0.1 / 1 Hz).
Rules:
- TIMESYNC is a request (tc1 = 0, ts1 = the time since boot in ns); the peer's answer is
  ignored (ping.py), as the simulated clock needs no offset estimate.
- PING is a request to all (target 0/0) with time_usec since boot and the link's own sequence;
  replies (MAVSDK answers PX4's pings) are ignored.
- GPS_GLOBAL_ORIGIN: the estimator's origin (vehicle_local_position ref_lat/lon/alt, here the
  local frame's origin, fixed at start) once it is global (a position fix), then again only when
  it moves by more than 1e-7 deg / 1 mm; a REQUEST_MESSAGE always gets it. time_usec is the
  origin's time (ref_timestamp): when the estimator first had a position.
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.codec import Encoder, payload_of
from gateway.mavlink.snapshot import Snapshot
from gateway.mavlink.wip_dialect import TIME_ESTIMATE_TO_TARGET
from vehicles.cnum import c_int

LLA_MIN_DIFF_DEG = 1e-7
ALT_MIN_DIFF_M = 0.001
_TIMESYNC = payload_of(M.MAVLink_timesync_message)
_PING = payload_of(M.MAVLink_ping_message)
_GPS_GLOBAL_ORIGIN = payload_of(M.MAVLink_gps_global_origin_message)
_TIME_ESTIMATE_TO_TARGET_PAYLOAD = payload_of(TIME_ESTIMATE_TO_TARGET)


def timesync(enc: Encoder, s: Snapshot) -> bytes:
    return _TIMESYNC(0, s.time_usec * 1000)


def ping(enc: Encoder, s: Snapshot) -> bytes:
    link = s.link
    seq = 0
    if link is not None:
        seq = link.ping_seq
        link.ping_seq = (seq + 1) & 0xFFFFFFFF
    return _PING(s.time_usec, seq, 0, 0)


def gps_global_origin(enc: Encoder, s: Snapshot) -> bytes | None:
    link = s.link
    status = s.status
    if not status.position_valid:
        return None
    origin = s.vehicle.origin
    lat, lon, alt = origin.lat_deg, origin.lon_deg, origin.alt_amsl_m
    if link is None:
        time_us = s.time_usec
    else:
        if link.origin_time_us == 0:
            link.origin_time_us = s.time_usec
        time_us = link.origin_time_us
        last = link.origin_sent
        if not s.requested and last is not None and abs(last[0] - lat) <= LLA_MIN_DIFF_DEG \
                and abs(last[1] - lon) <= LLA_MIN_DIFF_DEG and abs(last[2] - alt) <= ALT_MIN_DIFF_M:
            return None
        link.origin_sent = (lat, lon, alt)
    return _GPS_GLOBAL_ORIGIN(int(round(lat * 1e7)),
                              int(round(lon * 1e7)), int(round(alt * 1e3)), time_us)


def time_estimate_to_target(enc: Encoder, s: Snapshot) -> bytes | None:
    """TIME_ESTIMATE_TO_TARGET.hpp: on each rtl_time_estimate RTL publishes (every ~2 s, so at
    1 Hz every other wake-up sends), safe_return its safe_time_estimate as int32 (0 while not
    valid, e.g. landed); the other four -1 (not supported in PX4). A request sends only a
    publication the link has not sent yet, as the stream's send() does."""
    published = getattr(s.vehicle, "rtl_time_estimate", None)
    if published is None:
        return None
    seq, estimate = published
    link = s.link
    if link is not None:
        if seq == link.rtl_estimate_seq:
            return None
        link.rtl_estimate_seq = seq
    elif seq == 0:
        return None
    return _TIME_ESTIMATE_TO_TARGET_PAYLOAD(c_int(estimate.safe_time_estimate_s), -1, -1, -1,
                                            -1)
