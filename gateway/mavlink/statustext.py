"""STATUSTEXT: the vehicle's append-only text log → this link, with PX4's gating.

Source: PX4 mavlink_main.cpp (STATUSTEXT always streamed), mavlink_log texts (a trailing tab
marks an events-backed text).
Rules:
- A cursor per link drains ``vehicle.status_texts(after_seq)``; texts are consumed whether or
  not they are sent (PX4 drops them too), so nothing piles up while no GCS listens. A vehicle
  with ``changes`` is asked only once its ``status_texts`` generation has moved.
- Sent only while a MAV_TYPE_GCS heartbeat arrived on this link within GCS_PRESENT_S, and only
  texts younger than MAX_AGE_S.
- A trailing tab (PX4's mark of a text also sent as an event) is stripped: the vehicle's texts
  that are also events (events.py: takeoff, landing, arming denied) go out as plain texts.
- Texts longer than 50 bytes are chunked MAVLink-2 style: non-zero ``id`` shared by the chunks,
  ``chunk_seq`` 0.., the last chunk shorter than 50 (an empty one if the length divides by 50).
- ``local()`` queues a gateway-originated text (e.g. "Unsupported auto mode") for this link only.
"""

from __future__ import annotations

from collections.abc import Callable

from pymavlink.dialects.v20 import common as mavlink2

from gateway.mavlink.link import LinkContext
from vehicles.types import Changes, Severity

GCS_PRESENT_S = 2.5
MAX_AGE_S = 5.0
CHUNK_LEN = 50
MAX_PER_TICK = 20  # PX4 STATUSTEXT is limited to ~20 Hz; a burst beyond this waits a tick


class StatusTextService:
    """``gcs_present(now_s)``: whether a GCS heartbeat arrived on this link lately."""

    def __init__(self, ctx: LinkContext, gcs_present: Callable[[float], bool]) -> None:
        self.vehicle = ctx.vehicle
        self.encoder = ctx.encoder
        self.send = ctx.send
        self.gcs_present = gcs_present
        self._cursor = -1
        self._next_id = 1
        self._pending: list[tuple[float, int, str]] = []  # (time_s, severity, text)
        # The vehicle's generations (None: it has none, its log is asked at every poll) and the
        # one of its texts when they were last read (-1: never).
        self._changes: Changes | None = getattr(self.vehicle, "changes", None)
        self._seen_texts = -1

    def local(self, now_s: float, severity: Severity, text: str) -> None:
        self._pending.append((now_s, int(severity), text))

    def poll(self, now_s: float) -> None:
        changes = self._changes
        if changes is not None:
            if changes.status_texts != self._seen_texts:
                self._seen_texts = changes.status_texts
                self._drain()
        else:
            self._drain()
        if not self._pending:
            return
        if not self.gcs_present(now_s):
            self._pending.clear()
            return
        batch, self._pending = self._pending[:MAX_PER_TICK], self._pending[MAX_PER_TICK:]
        for time_s, severity, text in batch:
            if now_s - time_s < MAX_AGE_S:
                for frame in self.frames(severity, text):
                    self.send(frame)

    def _drain(self) -> None:
        """The vehicle's texts after the cursor onto ``_pending``."""
        texts = getattr(self.vehicle, "status_texts", None)
        if texts is not None:
            for t in texts(self._cursor):
                self._cursor = max(self._cursor, t.seq)
                self._pending.append((t.time_s, int(t.severity), t.text))

    def frames(self, severity: int, text: str) -> list[bytes]:
        data = text.rstrip("\t").encode("utf-8", "replace")
        enc = self.encoder
        cls = mavlink2.MAVLink_statustext_message
        if len(data) <= CHUNK_LEN:
            return [enc.pack(cls, severity, data, 0, 0)]
        msg_id = self._next_id
        self._next_id = self._next_id % 0xFFFF + 1
        chunks = [data[i:i + CHUNK_LEN] for i in range(0, len(data), CHUNK_LEN)]
        if len(chunks[-1]) == CHUNK_LEN:
            chunks.append(b"")
        return [enc.pack(cls, severity, c, msg_id, n) for n, c in enumerate(chunks)]
