"""A ULog stream put back together on the client's side, as PX4's Tools/mavlink_ulog_streaming.py
and MAVSDK's log_streaming plugin do it.

Rules:
- Packets are fed as LOGGING_DATA / LOGGING_DATA_ACKED carry them (sequence, length,
  first_message_offset, data). A repeated sequence (a NEED_ACK packet sent again) is dropped.
- After a gap in the sequence the message in progress is lost: bytes are skipped up to the next
  packet's first_message_offset (255: no message starts in it).
- ``ulog()`` is every whole message received so far, behind the 16-byte file header: a file
  pyulog and Flight Review read.
"""

from __future__ import annotations

import struct

from gateway.mavlink.log_streaming import NO_MESSAGE_START

HEADER_LEN = 16  # the file header (magic, version, timestamp) before the first message


class UlogReceiver:
    def __init__(self) -> None:
        self._data = bytearray()  # whole messages, and the one in progress at its end
        self._last_seq: int | None = None
        self._synced = True  # the bytes at the end of _data belong to a message we have whole
        self._complete = 0  # bytes of _data known to end on a message boundary
        self.packets = 0
        self.lost = 0

    def feed(self, sequence: int, length: int, first_message_offset: int, data: bytes) -> None:
        if sequence == self._last_seq:
            return
        if self._last_seq is not None and sequence != (self._last_seq + 1) & 0xFFFF:
            self.lost += (sequence - self._last_seq - 1) & 0xFFFF
            self._data = self._data[:self._boundary()]
            self._synced = False
        self._last_seq = sequence
        self.packets += 1
        chunk = data[:min(length, len(data))]
        if not self._synced:
            if first_message_offset == NO_MESSAGE_START or first_message_offset > len(chunk):
                return
            chunk = chunk[first_message_offset:]
            self._synced = True
        self._data += chunk

    def _boundary(self) -> int:
        """Bytes of the received data that end on a message boundary."""
        data, pos = self._data, max(self._complete, HEADER_LEN)
        if len(data) < HEADER_LEN:
            return 0
        while pos + 3 <= len(data):
            (size,) = struct.unpack_from("<H", data, pos)
            if pos + 3 + size > len(data):
                break
            pos += 3 + size
        self._complete = pos
        return pos

    def ulog(self) -> bytes:
        return bytes(self._data[:self._boundary()])
