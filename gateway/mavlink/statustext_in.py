"""STATUSTEXT received from the vehicle's own system (a companion computer's): PX4 v1.15.2
MavlinkReceiver::handle_message_statustext with MavlinkStatustextHandler, which puts it together
from its chunks into a log_message that the logger writes into the flight log (ULog 'L'); it is
not sent on as STATUSTEXT. Texts of other systems are not logged.

The reassembly follows MavlinkStatustextHandler.cpp byte for byte over log_message's char[127]
(C strings: strncpy's padding, the terminations it writes, "[ missing ... ]" where a chunk is
missing, including its quirks: ``should_publish_previous`` marks the text again each time it is
asked while an unfinished message waits). Sans-IO: time is an argument.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

TEXT_SIZE = 127  # log_message_s::text
CHUNK_SIZE = 50  # mavlink_statustext_t::text
MISSING = b"[ missing ... ]"


def _strlen(buf: bytearray | bytes, limit: int | None = None) -> int:
    end = len(buf) if limit is None else min(limit, len(buf))
    i = buf.find(b"\0", 0, end)
    return end if i < 0 else i


def _strncpy(buf: bytearray, at: int, src: bytes, n: int) -> None:
    """strncpy(buf + at, src, n): the bytes of ``src`` up to its NUL, then NULs, n in all."""
    src = src[:_strlen(src)]
    data = (src[:n] + b"\0" * n)[:n]
    buf[at:at + n] = data


@dataclass
class Statustext:
    """What handle_message_statustext decodes: severity, the 50 text bytes, id, chunk_seq."""
    severity: int
    text: bytes
    id: int = 0
    chunk_seq: int = 0


class StatustextHandler:
    def __init__(self) -> None:
        self.text = bytearray(TEXT_SIZE)
        self.severity = 0
        self.timestamp_us = 0
        self._last_id = 0
        self._last_chunk_seq = -1

    @property
    def message(self) -> str:
        """log_message's text as a string (up to its NUL)."""
        return self.text[:_strlen(self.text)].decode("utf-8", "replace")

    def _mark_missing(self) -> int:
        offset = _strlen(self.text)
        _strncpy(self.text, offset, MISSING, TEXT_SIZE - offset)
        return offset

    def should_publish_previous(self, msg: Statustext) -> bool:
        if self._last_id > 0 and msg.id != self._last_id:
            self._mark_missing()
            self.text[TEXT_SIZE - 1] = 0
            return True
        return False

    def should_publish_current(self, msg: Statustext, now_us: int) -> bool:
        raw = bytes(msg.text[:CHUNK_SIZE]).ljust(CHUNK_SIZE, b"\0")
        if msg.id > 0:
            if self._last_id != msg.id:
                self.timestamp_us, self.severity = now_us, msg.severity
            if msg.chunk_seq == 0:
                _strncpy(self.text, 0, raw, min(TEXT_SIZE, CHUNK_SIZE))
                self.text[CHUNK_SIZE] = 0
            else:
                if msg.chunk_seq != self._last_chunk_seq + 1:
                    offset = self._mark_missing()
                    self.text[TEXT_SIZE - offset - 1] = 0  # (sic)
                offset = _strlen(self.text)
                add = min(TEXT_SIZE - offset - 1, CHUNK_SIZE)
                _strncpy(self.text, offset, raw, add)
                self.text[min(offset + add, TEXT_SIZE - 1)] = 0
            self._last_chunk_seq = msg.chunk_seq
            full = _strlen(self.text) == TEXT_SIZE - 1
            if full or _strlen(raw, CHUNK_SIZE) < CHUNK_SIZE:
                self._last_id, self._last_chunk_seq = 0, -1
                return True
            self._last_id = msg.id
            return False
        self.timestamp_us, self.severity = now_us, msg.severity
        _strncpy(self.text, 0, raw, min(TEXT_SIZE, CHUNK_SIZE))
        self.text[CHUNK_SIZE - 1] = 0
        self._last_id = 0
        return True

    def receive(self, msg: Statustext, now_us: int) -> list[tuple[int, int, str]]:
        """handle_message_statustext's publications: (timestamp µs, severity, text) each."""
        out = []
        if self.should_publish_previous(msg):
            out.append((self.timestamp_us, self.severity, self.message))
        if self.should_publish_current(msg, now_us):
            out.append((self.timestamp_us, self.severity, self.message))
        return out


class StatustextInService:
    """A link's STATUSTEXT receiver (each MAVLink instance has its own handler): the texts of
    the vehicle's own system go to its command journal's log messages (the logger's)."""

    def __init__(self, ctx: Any) -> None:
        self.sysid = ctx.sysid
        self._journal = getattr(ctx.vehicle, "commands", None)
        self._handler = StatustextHandler()

    def on_statustext(self, msg: Any, now_s: float) -> None:
        if msg.get_srcSystem() != self.sysid or self._journal is None:
            return
        text = msg.text.encode("utf-8", "replace") if isinstance(msg.text, str) else msg.text
        st = Statustext(int(msg.severity), bytes(text), int(getattr(msg, "id", 0) or 0),
                        int(getattr(msg, "chunk_seq", 0) or 0))
        for timestamp_us, severity, message in self._handler.receive(st, int(now_s * 1e6)):
            self._journal.log_message(timestamp_us, severity, message)
