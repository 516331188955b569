"""ULog streaming over MAVLink, the logger's half: the packets its MAVLink backend writes and the
two topics between it and the link that streams them (ulog_stream, ulog_stream_ack), sans-IO.

Source: PX4 src/modules/logger/log_writer_mavlink.cpp, msg/UlogStream.msg, msg/UlogStreamAck.msg.
Rules:
- The logger's bytes are cut into packets of DATA_LEN (249) bytes, LOGGING_DATA's payload. A
  packet's ``first_message_offset`` is where the first ULog message that starts in it starts;
  NO_MESSAGE_START (255) when none does (it continues a message). The first packet of a stream
  has 0 (it starts with the file header).
- ``msg_sequence`` numbers a stream's packets from 0 (uint16, wraps).
- Reliable transfer (the header and the definitions): packets are flagged FLAGS_NEED_ACK, one is
  published at a time and the logger waits for its ulog_stream_ack before going on. While it
  waits it samples nothing: PX4's logger thread blocks, so a file log that runs meanwhile misses
  samples too. No ack within ACK_TIMEOUT_S × ACK_MAX_TRIES (2.5 s) of publishing: "Ack timeout.
  Stopping mavlink log". Switching reliable transfer off publishes the partial packet reliably.
- ulog_stream keeps the newest ORB_QUEUE_LENGTH (16) packets: a reader that comes later than 16
  newer ones loses the older (it counts the gap, as MavlinkULog's perf counter does).
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from gateway.mavlink.log_streaming import (  # the link's side uses the same
    ACK_MAX_TRIES,
    ACK_TIMEOUT_S,
    DATA_LEN,
    NO_MESSAGE_START,
)

FLAGS_NEED_ACK = 1
ORB_QUEUE_LENGTH = 16

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Packet:
    """One ulog_stream message."""

    msg_sequence: int
    first_message_offset: int
    flags: int
    data: bytes  # ``length`` bytes

    @property
    def need_ack(self) -> bool:
        return bool(self.flags & FLAGS_NEED_ACK)


class Reader(Protocol):
    """The link that streams (gateway/mavlink/log_streaming.py)."""

    def on_published(self, now_s: float) -> None: ...


class UlogStreamTopic:
    """ulog_stream and ulog_stream_ack of one vehicle. The logger publishes packets and reads
    acks; the link that streams (at most one: ``owner``) reads packets and publishes acks, and
    hears of each packet when it is published."""

    def __init__(self) -> None:
        self.generation = 0  # packets published so far
        self._queue: deque[Packet] = deque(maxlen=ORB_QUEUE_LENGTH)
        self.owner: Reader | None = None
        self.on_ack: Callable[[int, float], None] | None = None  # the logger's writer

    def publish(self, packet: Packet, now_s: float) -> None:
        self.generation += 1
        self._queue.append(packet)
        if self.owner is not None:
            self.owner.on_published(now_s)

    def take(self, last: int) -> tuple[int, Packet]:
        """The packet after generation ``last`` (or the oldest kept, if it was overwritten) and
        its generation; only when ``generation > last``."""
        oldest = self.generation - len(self._queue) + 1
        gen = max(last + 1, oldest)
        return gen, self._queue[gen - oldest]

    def publish_ack(self, msg_sequence: int, now_s: float) -> None:
        if self.on_ack is not None:
            self.on_ack(msg_sequence, now_s)


class MavlinkLogWriter:
    """The logger's MAVLink backend (LogWriterMavlink, module rules)."""

    def __init__(self, topic: UlogStreamTopic) -> None:
        self.topic = topic
        topic.on_ack = self._on_ack
        self.started = False
        self.reliable = False
        self._buf = bytearray()
        self._first = 0
        self._seq = 0
        self._waiting: Packet | None = None  # published, NEED_ACK, not acked yet
        self._waiting_since_s = 0.0
        self._pending: deque[Packet] = deque()  # reliable packets behind the one waiting
        self.ack_timeouts = 0

    @property
    def blocked(self) -> bool:
        """The logger waits for an ack (module rules)."""
        return self._waiting is not None

    def start(self) -> None:
        self.started = True
        self._buf.clear()
        self._first = 0
        self._seq = 0
        self._waiting = None
        self._pending.clear()

    def stop(self) -> None:
        self.started = False
        self._buf.clear()
        self._waiting = None
        self._pending.clear()

    def set_reliable(self, reliable: bool, now_s: float) -> None:
        if not reliable and self.reliable and self._buf:
            self._publish(now_s)  # the rest of the reliable part, reliably
        self.reliable = reliable

    def write_raw(self, data: bytes | memoryview, now_s: float) -> None:
        """One message's bytes (the file header, which is not a framed ULog message)."""
        if not self.started:
            return
        buf = self._buf
        if self._first == NO_MESSAGE_START:
            self._first = len(buf)
        pos, n = 0, len(data)
        while pos < n:
            take = min(DATA_LEN - len(buf), n - pos)
            buf += data[pos:pos + take]
            pos += take
            if len(buf) >= DATA_LEN:
                self._publish(now_s)

    def write(self, data: bytes | bytearray | memoryview, now_s: float) -> None:
        """Whole ULog messages (``uint16 size, uint8 type, payload`` each), in order."""
        if not self.started:
            return
        view = memoryview(data)
        pos, n = 0, len(view)
        while pos < n:
            end = pos + 3 + (view[pos] | view[pos + 1] << 8)
            self.write_raw(view[pos:end], now_s)
            pos = end

    def poll(self, now_s: float) -> None:
        """The logger's wait for an ack ends in a stop after ACK_MAX_TRIES timeouts."""
        if self._waiting is not None and \
                now_s - self._waiting_since_s >= ACK_TIMEOUT_S * ACK_MAX_TRIES - 1e-9:
            log.warning("logger: Ack timeout. Stopping mavlink log")
            self.ack_timeouts += 1
            self.stop()

    def _publish(self, now_s: float) -> None:
        packet = Packet(self._seq, self._first, FLAGS_NEED_ACK if self.reliable else 0,
                        bytes(self._buf))
        self._seq = (self._seq + 1) & 0xFFFF
        self._buf.clear()
        self._first = NO_MESSAGE_START
        if not packet.need_ack:
            self.topic.publish(packet, now_s)
        elif self._waiting is None:
            self._send_reliable(packet, now_s)
        else:
            self._pending.append(packet)

    def _send_reliable(self, packet: Packet, now_s: float) -> None:
        self._waiting = packet
        self._waiting_since_s = now_s
        self.topic.publish(packet, now_s)

    def _on_ack(self, msg_sequence: int, now_s: float) -> None:
        if self._waiting is None or msg_sequence != self._waiting.msg_sequence:
            return
        self._waiting = None
        if self._pending:
            self._send_reliable(self._pending.popleft(), now_s)
