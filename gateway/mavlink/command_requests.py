"""The commands PX4's MAVLink module answers itself, before Commander sees any command
(mavlink_receiver.cpp handle_message_command_both): requests for a message and message intervals.

Source: PX4 v1.15.2 mavlink_receiver.cpp (handle_message_command_both,
handle_request_message_command, set_message_interval, get_message_interval), mavlink_main.cpp
send_autopilot_capabilities, streams/AUTOPILOT_VERSION.hpp, STORAGE_INFORMATION.hpp,
AVAILABLE_MODES.hpp (gateway/mavlink/available_modes.py).
Rules:
- A requested message goes out before its ACK (same send buffer, in order). The answer is what
  the stream's request_message returns: ACCEPTED once it is sent, DENIED otherwise (no stream
  for the id — MESSAGE_INTERVAL and AVAILABLE_MODES_MONITOR have none in v1.15 —, or nothing to
  send yet): never UNSUPPORTED.
- SET_MESSAGE_INTERVAL and GET_MESSAGE_INTERVAL take the id as (int)roundf(param1); the
  former reads param3 as a link data rate (taken when above 0) and nothing else.
- Parameters are read as PX4's C casts read them (``c_int``: x86's conversions, NaN and
  out-of-range values give INT_MIN).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.available_modes import MSG_ID_AVAILABLE_MODES, available_modes
from gateway.mavlink.codec import (
    COMPONENT_INFORMATION,
    COMPONENT_METADATA,
    CRC_EXTRA_COMPONENT_INFORMATION,
    CRC_EXTRA_COMPONENT_METADATA,
    CRC_EXTRA_PROTOCOL_VERSION,
    MSG_ID_COMPONENT_INFORMATION,
    MSG_ID_COMPONENT_METADATA,
    MSG_ID_PROTOCOL_VERSION,
    PROTOCOL_VERSION_PAYLOAD,
)
from gateway.mavlink.link import LinkContext
from gateway.mavlink.snapshot import Snapshot
from gateway.mavlink.streams import STREAMS_BY_ID, Scheduler
from gateway.mavlink.telemetry_version import autopilot_version_payload, storage_information
from vehicles.types import CommandResult

ACCEPTED = CommandResult.ACCEPTED
DENIED = CommandResult.DENIED
FAILED = CommandResult.FAILED

Params = tuple[float, float, float, float, float, float, float]

class MetadataFiles(Protocol):
    """What COMPONENT_METADATA points at (gateway/onboard/metadata.py serves it over FTP)."""

    uri: str
    general_crc: int


class MessageRequests:
    """Uses the encoder, send and sysid of the link, ``snapshot(now_s)`` (what telemetry
    builders read) and the link's stream ``scheduler``. Each method returns a MAV_RESULT."""

    def __init__(self, ctx: LinkContext, snapshot: Callable[[float], Snapshot],
                 scheduler: Scheduler) -> None:
        self.encoder = ctx.encoder
        self.send = ctx.send
        self.sysid = ctx.sysid
        self.snapshot = snapshot
        self.scheduler = scheduler
        # Attached with the vehicle's FTP files; without them the request is DENIED.
        self.component_metadata: MetadataFiles | None = None

    def request_message(self, p: Params, now_s: float) -> int:
        """REQUEST_MESSAGE: the id is (uint16_t)roundf(param1); for MESSAGE_INTERVAL param2 is
        the id asked about, cast as GET_MESSAGE_INTERVAL casts its param1."""
        msg_id = c_int(roundf(p[0])) & 0xFFFF
        if msg_id == M.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            return self.autopilot_capabilities()
        if msg_id == MSG_ID_PROTOCOL_VERSION:
            return self.protocol_version()
        if msg_id == M.MAVLINK_MSG_ID_STORAGE_INFORMATION:
            return self.storage_information(p[1], now_s)
        if msg_id in (MSG_ID_COMPONENT_METADATA, MSG_ID_COMPONENT_INFORMATION):
            return self._component_metadata(msg_id, now_s)
        if msg_id == MSG_ID_AVAILABLE_MODES:
            return self.available_modes(p[1])
        spec = STREAMS_BY_ID.get(msg_id)
        if spec is None or not spec.stream:
            # e.g. AVAILABLE_MODES_MONITOR, which no PX4 stream has as its id, or
            # MISSION_CURRENT, which the mission manager sends
            return DENIED
        frame = spec.frame(self.encoder, self.snapshot(now_s))
        if frame is None:
            return DENIED  # e.g. HOME_POSITION before home is set
        self.send(frame)
        return ACCEPTED

    def request_flight_information(self, now_s: float) -> int:
        """The deprecated request command: PX4's mavlink receiver answers it as REQUEST_MESSAGE
        for FLIGHT_INFORMATION."""
        return self.request_message((float(M.MAVLINK_MSG_ID_FLIGHT_INFORMATION),) + (0.0,) * 6,
                                    now_s)

    def storage_information(self, storage_id: float, now_s: float) -> int:
        """STORAGE_INFORMATION.hpp: storage (int)roundf(param2) 0 (all) or 1 is the file system
        holding PX4's storage directory, as statfs tells (SITL: the host's disk; here a fixed
        STORAGE_TOTAL_MIB with STORAGE_FREE_MIB free), status 2 (available, formatted); another
        id is DENIED. MAV_CMD_REQUEST_STORAGE_INFORMATION asks for storage 0."""
        if c_int(roundf(storage_id)) not in (0, 1):
            return DENIED
        self.send(self.encoder.frame(M.MAVLINK_MSG_ID_STORAGE_INFORMATION,
                                     M.MAVLink_storage_information_message.crc_extra,
                                     storage_information(self.encoder, self.snapshot(now_s))))
        return ACCEPTED

    def available_modes(self, param2: float) -> int:
        """AVAILABLE_MODES.hpp request_message: ``int mode_index = roundf(param2)``; 0 is every
        mode, one frame each, before the ACK."""
        frames = available_modes(self.encoder, c_int(roundf(param2)))
        if frames is None:
            return DENIED
        for frame in frames:
            self.send(frame)
        return ACCEPTED

    def _component_metadata(self, msg_id: int, now_s: float) -> int:
        """PX4's COMPONENT_METADATA stream answers with the general metadata file's URI and
        CRC; its COMPONENT_INFORMATION (what older QGC asks) carries the same two."""
        meta = self.component_metadata
        if meta is None:
            return DENIED
        boot_ms = int(now_s * 1000.0) & 0xFFFFFFFF
        uri = meta.uri.encode()[:99]
        if msg_id == MSG_ID_COMPONENT_METADATA:
            payload = COMPONENT_METADATA.pack(boot_ms, meta.general_crc, uri)
            self.send(self.encoder.frame(msg_id, CRC_EXTRA_COMPONENT_METADATA, payload))
        else:
            payload = COMPONENT_INFORMATION.pack(boot_ms, meta.general_crc, 0, uri, b"")
            self.send(self.encoder.frame(msg_id, CRC_EXTRA_COMPONENT_INFORMATION, payload))
        return ACCEPTED

    def autopilot_capabilities(self) -> int:
        self.send(self.autopilot_version())
        return ACCEPTED

    def protocol_version(self) -> int:
        self.send(self.encoder.frame(MSG_ID_PROTOCOL_VERSION, CRC_EXTRA_PROTOCOL_VERSION,
                                     PROTOCOL_VERSION_PAYLOAD))
        return ACCEPTED

    def home_position(self, now_s: float) -> int:
        frame = STREAMS_BY_ID[M.MAVLINK_MSG_ID_HOME_POSITION].frame(self.encoder,
                                                                   self.snapshot(now_s))
        if frame is None:
            return DENIED
        self.send(frame)
        return ACCEPTED

    def set_message_interval(self, p: Params, now_s: float) -> int:
        """set_message_interval((int)roundf(param1), param2, param3): HEARTBEAT and a message
        without a stream fail. Param3 > 0 would set the link's data rate, which here stays
        DATARATE_B_S (PX4's stream rates only bend to it when a link is full); param4 to
        param7 are not read (PX4 main fails a response target, v1.15 does not)."""
        ok = self.scheduler.set_interval(c_int(roundf(p[0])), p[1], now_s)
        return ACCEPTED if ok else FAILED

    def get_message_interval(self, p: Params) -> int:
        """MavlinkReceiver: ``get_message_interval((int)roundf(param1))``, always ACCEPTED; an
        id no stream has (NaN: INT_MIN, message_id 0 on the wire) is answered with interval 0,
        and so is a stream this link's mode does not configure or a client stopped (PX4 deletes
        a stream set to rate 0: it is not in the list the answer is looked up in)."""
        return self._send_interval(c_int(roundf(p[0])))

    def _send_interval(self, msg_id: int) -> int:
        interval = self.scheduler.interval_us(msg_id)  # −1: unlimited, as PX4's int says
        self.send(self.encoder.pack(M.MAVLink_message_interval_message, msg_id & 0xFFFF,
                                    interval))
        return ACCEPTED

    def autopilot_version(self) -> bytes:
        return self.encoder.frame(M.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
                                  M.MAVLink_autopilot_version_message.crc_extra,
                                  autopilot_version_payload(self.sysid))


def roundf(value: float) -> float:
    """C's roundf: halves away from zero (Python's round() takes them to even)."""
    if not math.isfinite(value):
        return value
    return math.copysign(math.floor(abs(value) + 0.5), value)


def c_int(value: float) -> int:
    """C's ``(int)value`` as PX4 reads command parameters: truncation; NaN, infinities and
    values out of range (whose conversion C leaves undefined) give x86's INT_MIN."""
    if math.isnan(value) or math.isinf(value) or abs(value) >= 2**31:
        return -(2**31)
    return int(value)


def lroundf(value: float) -> int:
    """C's lroundf to a 64-bit long: NaN, infinities and values out of range give x86's
    LONG_MIN."""
    if not math.isfinite(value) or abs(value) >= 2.0**63:
        return -(2**63)
    return int(roundf(value))


def wrap_int(value: int, bits: int) -> int:
    """A C integer narrowed to a signed ``bits``-bit one (two's complement)."""
    half = 1 << (bits - 1)
    return ((value + half) & ((1 << bits) - 1)) - half

