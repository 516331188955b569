"""The events protocol on one link: PX4's mavlink_events.cpp SendProtocol over the vehicle's
event log (vehicles/events.py).

Rules:
- Every wake-up sends, in order, the vehicle's events this link has not sent yet (those still
  in the log's buffer) as EVENT, broadcast (destination 0/0). Before the first one it sends
  CURRENT_EVENT_SEQUENCE with the RESET flag, as PX4 SITL's first event does.
- CURRENT_EVENT_SEQUENCE (the newest sequence; RESET while the vehicle has sent no event) every
  SEQUENCE_PERIOD_S, so a client that missed the newest event asks for it.
- REQUEST_EVENT for first..last (wrapping): each buffered event is sent again as it was; for
  one no longer buffered, RESPONSE_EVENT_ERROR (UNAVAILABLE) to the requester with the oldest
  sequence still available after it. A range longer than the buffer gets one error for its
  first sequence and only its newest BUFFER_SIZE are served.
- A vehicle without an event log (a test's fake) sends nothing and answers nothing.
"""

from __future__ import annotations

from typing import Any

from gateway.mavlink.event_messages import CURRENT_EVENT_SEQUENCE, EVENT, RESPONSE_EVENT_ERROR
from gateway.mavlink.link import LinkContext
from vehicles.events import BUFFER_SIZE, Event, EventLog

SEQUENCE_PERIOD_S = 3.0  # mavlink_events.h current_sequence_interval
FLAG_RESET = 1  # MAV_EVENT_CURRENT_SEQUENCE_FLAGS_RESET
REASON_UNAVAILABLE = 0  # MAV_EVENT_ERROR_REASON_UNAVAILABLE


class EventsService:
    def __init__(self, ctx: LinkContext) -> None:
        self.encoder = ctx.encoder
        self.send = ctx.send
        log = getattr(ctx.vehicle, "events", None)
        self.log: EventLog | None = log if isinstance(log, EventLog) else None
        # the newest sent here; the session polls only once the log's moved past it or due_s
        self.sent = self.log.latest if self.log is not None else 0
        self._started = False
        self.due_s = 0.0 if self.log is not None else float("inf")  # CURRENT_EVENT_SEQUENCE

    def poll(self, now_s: float) -> None:
        log = self.log
        if log is None:
            return
        if log.latest != self.sent:
            if not self._started:
                self._started = True
                self._send_sequence(FLAG_RESET)
            for event in log.after(self.sent):
                self._send_event(event)
            self.sent = log.latest
        if now_s >= self.due_s:
            self.due_s = now_s + SEQUENCE_PERIOD_S
            self._send_sequence(0 if len(log) else FLAG_RESET)

    def on_request_event(self, msg: Any, now_s: float) -> None:
        log = self.log
        if log is None:
            return
        first, last = msg.first_sequence & 0xFFFF, msg.last_sequence & 0xFFFF
        span = (last - first) & 0xFFFF
        if span >= BUFFER_SIZE:
            self._send_error(msg, first)
            first = (last - BUFFER_SIZE + 1) & 0xFFFF
            span = BUFFER_SIZE - 1
        for k in range(span + 1):
            seq = (first + k) & 0xFFFF
            event = log.get(seq)
            if event is None:
                self._send_error(msg, seq)
            else:
                self._send_event(event)

    def _send_event(self, e: Event) -> None:
        self.send(self.encoder.pack(EVENT, 0, 0, e.id, e.time_boot_ms, e.sequence, e.log_levels,
                                    e.arguments.ljust(40, b"\0")))

    def _send_sequence(self, flags: int) -> None:
        assert self.log is not None
        self.send(self.encoder.pack(CURRENT_EVENT_SEQUENCE, self.log.latest, flags))

    def _send_error(self, msg: Any, seq: int) -> None:
        assert self.log is not None
        self.send(self.encoder.pack(RESPONSE_EVENT_ERROR, msg.get_srcSystem(),
                                    msg.get_srcComponent(), seq, self.log.oldest_after(seq),
                                    REASON_UNAVAILABLE))
