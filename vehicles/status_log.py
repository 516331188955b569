"""Append-only, bounded log of status texts (PX4 mavlink_log_* → STATUSTEXT).

Invariants: ``seq`` starts at 1 and increases by one per text, never reused; only the newest
``capacity`` texts are kept; ``after(seq)`` returns texts with a larger seq, oldest first, so each
gateway session keeps its own cursor. A text that PX4 also sends as an event ends with PX4's
tab, and ``event`` sends that event to the vehicle's EventLog (``events``, when attached).
"""

from __future__ import annotations

import logging
from collections import deque

from vehicles.events import EventDef, EventLog, Log
from vehicles.types import Changes, Severity, StatusText

log = logging.getLogger(__name__)

STATUS_LOG_CAPACITY = 100


class StatusLog:
    def __init__(self, name: str = "", capacity: int = STATUS_LOG_CAPACITY,
                 changes: Changes | None = None) -> None:
        """``changes``: the vehicle's generations (``status_texts`` moves with every text)."""
        self._texts: deque[StatusText] = deque(maxlen=capacity)
        self._seq = 0
        self._name = name
        self._changes = changes if changes is not None else Changes()
        self.events: EventLog | None = None  # the vehicle's events (vehicles/events.py)

    @property
    def name(self) -> str:
        return self._name

    @property
    def last_seq(self) -> int:
        return self._seq

    def add(self, time_s: float, severity: Severity, text: str) -> StatusText:
        self._seq += 1
        entry = StatusText(self._seq, time_s, severity, text)
        self._texts.append(entry)
        self._changes.status_texts += 1
        log.info("%s t=%.3f [%s] %s", self._name, time_s, severity.name, text)
        return entry

    def info(self, time_s: float, text: str) -> None:
        self.add(time_s, Severity.INFO, text)

    def warning(self, time_s: float, text: str) -> None:
        self.add(time_s, Severity.WARNING, text)

    def critical(self, time_s: float, text: str) -> None:
        self.add(time_s, Severity.CRITICAL, text)

    def event(self, time_s: float, event: EventDef, external: Log = Log.INFO,
              internal: Log | None = None, fmt: str = "", *args: float) -> None:
        """events::send, beside the text PX4 sends with it."""
        if self.events is not None:
            self.events.send(time_s, event, external, internal, fmt, *args)

    def after(self, seq: int) -> list[StatusText]:
        if seq >= self._seq:
            return []
        return [t for t in self._texts if t.seq > seq]
