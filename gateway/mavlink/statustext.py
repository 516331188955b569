"""STATUSTEXT: the vehicle's append-only text log → this link, with PX4's gating and framing.

Source: PX4 src/modules/mavlink/streams/STATUSTEXT.hpp (the mavlink_log topic → STATUSTEXT) and
mavlink_log.h (mavlink_log_s.text: 127 chars with the terminator).
Rules:
- A cursor per link drains ``vehicle.status_texts(after_seq)`` into the link's queue, which
  keeps the newest QUEUE_LENGTH texts as the mavlink_log topic's uORB queue does (an older one
  is lost, counted in ``missed``). A vehicle with ``changes`` is asked only once its
  ``status_texts`` generation has moved.
- The stream runs at PX4's 20 Hz (mavlink_main.cpp: STATUSTEXT at 20/s), or at what
  SET_MESSAGE_INTERVAL set (``period_s``; stopped, the texts wait as for no listener): each run
  sends the
  oldest queued text younger than MAX_AGE_S (older ones are skipped), one text per run, and only
  while a MAV_TYPE_GCS or MAV_TYPE_ONBOARD_CONTROLLER heartbeat arrived on this link within
  GCS_PRESENT_S (``is_gcs_connected() || is_onboard_controller_connected()``); while none
  listens the queue waits, so a GCS that comes gets the last texts of the last 5 s.
- Sent as PX4 sends them: a trailing tab (PX4's mark of a text also sent as an event; QGC drops
  such texts from PX4 and shows the event) is kept; a text is cut to MAX_TEXT_BYTES; every text
  takes the link's next ``id`` (0, 1, 2, … for single-chunk texts too, wrapping at 65536);
  longer than 50 bytes it goes out in 50-byte chunks, ``chunk_seq`` 0.., and a text whose
  length divides by 50 ends with a full chunk (no empty one after it); an empty text sends
  nothing.
- ``local()`` queues a gateway-originated text (e.g. "Unsupported auto mode") for this link only.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

from pymavlink.dialects.v20 import common as mavlink2

from gateway.mavlink.link import LinkContext
from vehicles.types import Changes, Severity

GCS_PRESENT_S = 2.5
MAX_AGE_S = 5.0
CHUNK_LEN = 50
MAX_TEXT_BYTES = 126  # mavlink_log_s.text[127], NUL-terminated
QUEUE_LENGTH = 8  # MavlinkLog.msg ORB_QUEUE_LENGTH
PERIOD_S = 0.05  # the STATUSTEXT stream's 20 Hz


class StatusTextService:
    """``gcs_present(now_s)``: whether a GCS (or onboard controller) heartbeat arrived on this
    link lately."""

    def __init__(self, ctx: LinkContext, gcs_present: Callable[[float], bool],
                 period_s: Callable[[], float] = lambda: PERIOD_S) -> None:
        """``period_s()``: the stream's period (s; inf: stopped)."""
        self.vehicle = ctx.vehicle
        self.period_s = period_s
        self.encoder = ctx.encoder
        self.send = ctx.send
        self.gcs_present = gcs_present
        self._cursor = -1
        self._next_id = 0  # STATUSTEXT.hpp _id
        # (time_s, severity, text), the newest QUEUE_LENGTH; while any wait, the session polls
        # at ``due_s`` and at its first wake-up after a heartbeat (``recheck``: a listener may
        # have come)
        self.pending: deque[tuple[float, int, str]] = deque()
        self.recheck = False
        self.missed = 0  # texts the queue lost before they could be sent
        self.due_s = math.inf  # the next stream run while texts wait
        self._next_run_s = -math.inf
        # The vehicle's generations (None: it has none, its log is asked at every poll) and the
        # one of its texts when they were last read (-1: never); with nothing pending, the session
        # polls only once that moved.
        self._changes: Changes | None = getattr(self.vehicle, "changes", None)
        self.seen_texts = -1

    def local(self, now_s: float, severity: Severity, text: str) -> None:
        self._queue(now_s, int(severity), text)
        self.due_s = min(self.due_s, max(now_s, self._next_run_s))

    def _queue(self, time_s: float, severity: int, text: str) -> None:
        if len(self.pending) == QUEUE_LENGTH:
            self.pending.popleft()
            self.missed += 1
        self.pending.append((time_s, severity, text))

    def poll(self, now_s: float) -> None:
        self.recheck = False
        changes = self._changes
        if changes is not None:
            if changes.status_texts != self.seen_texts:
                self.seen_texts = changes.status_texts
                self._drain()
        else:
            self._drain()
        pending = self.pending
        if not pending:
            self.due_s = math.inf
            return
        if now_s < self._next_run_s - 1e-9:
            self.due_s = self._next_run_s
            return
        period_s = self.period_s()
        if not self.gcs_present(now_s) or period_s == math.inf:  # the queue waits
            self.due_s = math.inf
            return
        self._next_run_s = now_s + period_s
        while pending:
            time_s, severity, text = pending.popleft()
            if now_s - time_s < MAX_AGE_S:
                for frame in self.frames(severity, text):
                    self.send(frame)
                break
        self.due_s = self._next_run_s if pending else math.inf

    def _drain(self) -> None:
        """The vehicle's texts after the cursor onto ``_pending``."""
        texts = getattr(self.vehicle, "status_texts", None)
        if texts is not None:
            for t in texts(self._cursor):
                self._cursor = max(self._cursor, t.seq)
                self._queue(t.time_s, int(t.severity), t.text)

    def frames(self, severity: int, text: str) -> list[bytes]:
        data = text.encode("utf-8", "replace")[:MAX_TEXT_BYTES]
        msg_id = self._next_id
        self._next_id = (msg_id + 1) & 0xFFFF
        enc = self.encoder
        cls = mavlink2.MAVLink_statustext_message
        return [enc.pack(cls, severity, data[i:i + CHUNK_LEN], msg_id, n)
                for n, i in enumerate(range(0, len(data), CHUNK_LEN))]
