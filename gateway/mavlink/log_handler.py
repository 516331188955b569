"""Log download (LOG_REQUEST_LIST / LOG_ENTRY / LOG_REQUEST_DATA / LOG_DATA / LOG_REQUEST_END /
LOG_ERASE), as PX4's MavlinkLogHandler.

Source: PX4 src/modules/mavlink/mavlink_log_handler.cpp.
Rules:
- The vehicle's logs come from a ``LogStore`` the shell attaches (``store``; None: no storage,
  so no logs, as a PX4 without an SD card). Ids are 0-based, oldest first; ``time_utc`` is the
  log's start (UTC seconds), ``size`` its bytes when the list was asked for.
- LOG_REQUEST_LIST: one LOG_ENTRY per id in [start, end] clamped to the logs there are
  (num_logs, last_log_num = the last id sent); with no logs, one entry with num_logs 0.
- LOG_REQUEST_DATA for an id that was listed: LOG_DATA of 90 bytes from ``ofs`` for ``count``
  bytes (clamped to the log), streamed at most ``BURST`` frames per ``PERIOD_S``; a short frame
  (or count 0 at the end) ends it. Unknown ids and requests before a list are ignored (PX4).
- LOG_REQUEST_END stops; LOG_ERASE erases every log that is not being written.
"""

from __future__ import annotations

import math
from typing import Any, Protocol

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.link import LinkContext

DATA_LEN = 90  # LOG_DATA.data
BURST = 128  # frames per wake-up: one MAVSDK chunk (128 × 90 bytes)
PERIOD_S = 0.01


class LogStore(Protocol):
    def entries(self) -> list[tuple[int, int]]: ...  # (size in bytes, start UTC s), oldest first

    def read(self, index: int, offset: int, count: int) -> bytes: ...

    def erase(self) -> None: ...


class LogHandlerService:
    def __init__(self, ctx: LinkContext) -> None:
        self.sysid = ctx.sysid
        self.encoder = ctx.encoder
        self.send = ctx.send
        self.store: LogStore | None = None
        self._listed: list[tuple[int, int]] | None = None
        self._sending: tuple[int, int, int] | None = None  # id, next offset, bytes remaining
        self.due_s = math.inf  # when ``handle_timer`` has work next (the download); inf: none

    def _for_us(self, msg: Any) -> bool:
        return msg.target_system in (0, self.sysid)

    def on_request_list(self, msg: M.MAVLink_log_request_list_message, now_s: float) -> None:
        if not self._for_us(msg):
            return
        self._sending = None
        self.due_s = math.inf
        self._listed = entries = self.store.entries() if self.store is not None else []
        if not entries:
            self.send(self.encoder.pack(M.MAVLink_log_entry_message, 0, 0, 0, 0, 0))
            return
        last = len(entries) - 1
        first, end = min(msg.start, last), min(msg.end, last)
        for i in range(first, end + 1):
            size, utc = entries[i]
            self.send(self.encoder.pack(M.MAVLink_log_entry_message, i, len(entries), end,
                                        utc & 0xFFFFFFFF, size & 0xFFFFFFFF))

    def on_request_data(self, msg: M.MAVLink_log_request_data_message, now_s: float) -> None:
        if not self._for_us(msg) or self._listed is None or msg.id >= len(self._listed):
            return
        size = self._listed[msg.id][0]
        remaining = max(0, min(size - msg.ofs, msg.count))
        self._sending = (msg.id, msg.ofs, remaining)
        self.due_s = now_s

    def on_request_end(self, msg: M.MAVLink_log_request_end_message, now_s: float) -> None:
        if self._for_us(msg):
            self._sending = None
            self._listed = None
            self.due_s = math.inf

    def on_erase(self, msg: M.MAVLink_log_erase_message, now_s: float) -> None:
        if not self._for_us(msg):
            return
        self._sending = None
        self._listed = None
        self.due_s = math.inf
        if self.store is not None:
            self.store.erase()

    def get_timer(self) -> float:
        return self.due_s

    def handle_timer(self, now_s: float) -> None:
        if self._sending is None or now_s < self.due_s:
            return
        log_id, offset, remaining = self._sending
        store = self.store
        for _ in range(BURST):
            want = min(DATA_LEN, remaining)
            data = store.read(log_id, offset, want) if store is not None and want else b""
            self.send(self.encoder.pack(M.MAVLink_log_data_message, log_id, offset, len(data),
                                        data.ljust(DATA_LEN, b"\0")))
            offset += len(data)
            remaining -= len(data)
            if len(data) < DATA_LEN or remaining == 0:
                self._sending = None
                self.due_s = math.inf
                return
        self._sending = (log_id, offset, remaining)
        self.due_s = now_s + PERIOD_S
