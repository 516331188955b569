"""ULog streaming over MAVLink, the link's half: MAV_CMD_LOGGING_START / LOGGING_STOP,
LOGGING_DATA and LOGGING_DATA_ACKED out, LOGGING_ACK in (PX4's MavlinkULog and the receiver's part).

Source: PX4 src/modules/mavlink/mavlink_ulog.cpp, mavlink_receiver.cpp (MAV_CMD_LOGGING_START,
LOGGING_ACK), mavlink_main.cpp (the ack that starts and stops the stream).
Rules:
- The vehicle's logger (its ``topic``, attached by the shell; None: no logger, the commands are
  UNSUPPORTED) answers the commands; a link only checks first that it has the bandwidth: a
  datarate below MIN_DATARATE_B_S is DENIED with "Not enough bandwidth to enable log streaming".
- LOGGING_START makes this link the vehicle's one stream (the first link to ask keeps it) for the
  sender's system and component, then waits for the logger's COMMAND_ACK of it: nothing within
  INITIAL_ACK_TIMEOUT_S and the link gives up, silently. From that ack on, every packet the
  logger publishes goes out: NEED_ACK ones as LOGGING_DATA_ACKED, sent again every
  ACK_TIMEOUT_S until the client's LOGGING_ACK of that sequence (more than ACK_MAX_TRIES
  sends and the stream stops: "mavlink ulog stream update failed"), the others as LOGGING_DATA.
- At most MAX_RATE_FACTOR of the link's datarate goes to the stream, counted in packets per
  RATE_PERIOD_S. The link looks for packets one MAVLink loop (LOOP_S) after one was published or
  acked, as PX4's mavlink thread does on its next iteration.
- The logger's ACCEPTED answer to LOGGING_STOP ends the stream on every link.
"""

from __future__ import annotations

import logging
import math
from typing import Any, Protocol

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.link import DATARATE_B_S, LinkContext, Say
from vehicles.types import CommandResult, Severity

MIN_DATARATE_B_S = 5000
MAX_RATE_FACTOR = 0.7  # Mavlink::try_start_ulog_streaming
RATE_PERIOD_S = 0.1
FRAME_BYTES = 255 + 12  # MAVLINK_MSG_ID_LOGGING_DATA_LEN + MAVLINK_NUM_NON_PAYLOAD_BYTES
INITIAL_ACK_TIMEOUT_S = 0.3
ACK_TIMEOUT_S = 0.050  # ulog_stream_ack ACK_TIMEOUT (ms)
ACK_MAX_TRIES = 50
LOOP_S = 0.0015  # the mavlink thread's loop at 4 MB/s (MAVLINK_MIN_INTERVAL)
DATA_LEN = 249  # LOGGING_DATA.data, ulog_stream.data
NO_MESSAGE_START = 255  # first_message_offset: no message starts in this packet

log = logging.getLogger(__name__)


class StreamPacket(Protocol):
    @property
    def msg_sequence(self) -> int: ...
    @property
    def first_message_offset(self) -> int: ...
    @property
    def need_ack(self) -> bool: ...
    @property
    def data(self) -> bytes: ...


class StreamTopic(Protocol):
    """ulog_stream / ulog_stream_ack of the vehicle (gateway/onboard/ulog_stream.py)."""

    generation: int
    owner: Any  # the link that streams: a LogStreamingService, or None

    def take(self, last: int) -> tuple[int, StreamPacket]: ...

    def publish_ack(self, msg_sequence: int, now_s: float) -> None: ...


class LogStreamingService:
    def __init__(self, ctx: LinkContext, say: Say) -> None:
        self.sysid = ctx.sysid
        self.encoder = ctx.encoder
        self.send = ctx.send
        self.say = say
        self.topic: StreamTopic | None = None
        self.datarate_b_s = DATARATE_B_S
        self.max_messages = max(1, math.ceil(RATE_PERIOD_S * MAX_RATE_FACTOR * DATARATE_B_S
                                             / FRAME_BYTES))
        self.due_s = math.inf  # when ``handle_timer`` has work next; inf: none
        self.target = (0, 0)
        self.missed = 0  # packets the logger published that this link never saw
        self.current_rate_factor = MAX_RATE_FACTOR  # of the datarate, over the last period
        self._last_gen = 0
        self._waiting_initial = False
        self._started_s = 0.0
        self._waiting_for: StreamPacket | None = None  # a NEED_ACK packet that is out
        self._last_sent_s = 0.0  # when it was last sent
        self._ack_received = False
        self._tries = 0
        self._count = 0
        self._next_rate_check_s = 0.0

    @property
    def active(self) -> bool:
        return self.topic is not None and self.topic.owner is self

    # --- commands (CommandService hands them over) ---------------------------------------------
    def on_command(self, command: int, source: tuple[int, int], now_s: float) -> int | None:
        """LOGGING_START / LOGGING_STOP before the logger sees them: a MAV_RESULT to answer at
        once, or None (the logger answers)."""
        if self.topic is None:
            return CommandResult.UNSUPPORTED
        if command == M.MAV_CMD_LOGGING_START:
            if self.datarate_b_s < MIN_DATARATE_B_S:
                self.say(now_s, Severity.CRITICAL, "Not enough bandwidth to enable log streaming")
                return CommandResult.DENIED
            if self.topic.owner is None:  # MavlinkULog::try_start
                self.topic.owner = self
                self.target = source
                self._last_gen = self.topic.generation  # no old packets
                self._waiting_initial = True
                self._started_s = now_s
                self._waiting_for = None
                self._count = 0
                self._next_rate_check_s = now_s + RATE_PERIOD_S
                self.current_rate_factor = MAX_RATE_FACTOR
                self.due_s = now_s + INITIAL_ACK_TIMEOUT_S + LOOP_S
        return None

    def on_logger_ack(self, command: int, result: int, now_s: float) -> None:
        """The logger's COMMAND_ACK, as this link sends it on."""
        if not self.active:
            return
        if command == M.MAV_CMD_LOGGING_START:
            if self._waiting_initial:
                self._waiting_initial = False
                self.due_s = now_s
        elif command == M.MAV_CMD_LOGGING_STOP and result == CommandResult.ACCEPTED:
            self._stop()

    def on_published(self, now_s: float) -> None:
        """The logger published a packet (the shell then re-arms this link's timer)."""
        if self.active and not self._waiting_initial and self._waiting_for is None:
            self.due_s = min(self.due_s, now_s + LOOP_S)

    # --- inbound -------------------------------------------------------------------------------
    def on_logging_ack(self, msg: M.MAVLink_logging_ack_message, now_s: float) -> None:
        waiting = self._waiting_for
        if self.active and waiting is not None and msg.sequence == waiting.msg_sequence:
            self._ack_received = True
            self.topic.publish_ack(msg.sequence, now_s)  # type: ignore[union-attr]
            self.due_s = min(self.due_s, now_s + LOOP_S)

    # --- the mavlink loop ----------------------------------------------------------------------
    def handle_timer(self, now_s: float) -> None:
        """MavlinkULog::handle_update."""
        topic = self.topic
        if topic is None or topic.owner is not self:
            self.due_s = math.inf
            return
        if self._waiting_initial:
            if now_s - self._started_s > INITIAL_ACK_TIMEOUT_S:
                log.warning("vehicle %d: no ack from logger (is it running?)", self.sysid)
                self._stop()
            return
        if self._waiting_for is not None:
            if not self._ack_received:
                if now_s - self._last_sent_s > ACK_TIMEOUT_S:
                    self._tries += 1
                    if self._tries > ACK_MAX_TRIES:
                        log.warning("vehicle %d: mavlink ulog stream update failed, stopping "
                                    "(-110)", self.sysid)
                        self._stop()
                        return
                    self._last_sent_s = now_s
                    self._send(self._waiting_for, now_s)
                self.due_s = self._last_sent_s + ACK_TIMEOUT_S + LOOP_S
                return
            self._waiting_for = None
        while self._count < self.max_messages and topic.generation > self._last_gen:
            gen, packet = topic.take(self._last_gen)
            self.missed += gen - self._last_gen - 1
            self._last_gen = gen
            if packet.need_ack:
                self._tries = 1
                self._last_sent_s = now_s
                self._waiting_for = packet
                self._ack_received = False
            self._send(packet, now_s)
            self._count += 1
        if now_s > self._next_rate_check_s:
            self.current_rate_factor = MAX_RATE_FACTOR * min(1.0, self._count / self.max_messages)
            self._count = 0
            self._next_rate_check_s = now_s + RATE_PERIOD_S
        if self._waiting_for is not None:
            self.due_s = self._last_sent_s + ACK_TIMEOUT_S + LOOP_S
        elif topic.generation > self._last_gen:  # held back by the rate limit
            self.due_s = max(self._next_rate_check_s + LOOP_S, now_s + LOOP_S)
        else:
            self.due_s = math.inf  # until the logger publishes again (``on_published``)

    def _send(self, packet: StreamPacket, now_s: float) -> None:
        cls = M.MAVLink_logging_data_acked_message if packet.need_ack \
            else M.MAVLink_logging_data_message
        data = packet.data
        self.send(self.encoder.pack(cls, self.target[0], self.target[1], packet.msg_sequence,
                                    len(data), packet.first_message_offset,
                                    data.ljust(DATA_LEN, b"\0")))

    def _stop(self) -> None:
        if self.topic is not None and self.topic.owner is self:
            self.topic.owner = None
        self._waiting_initial = False
        self._waiting_for = None
        self.due_s = math.inf
