"""The event kernel: one heap that owns simulated time.

Rules and invariants (SimPy's core in miniature):
- ``now`` only moves forward, and only inside ``step``/``run``: it becomes the time of the event
  being processed. Nothing here reads a wall clock. It is a plain attribute, read at every event
  and datagram (a property would cost a call each time): only the kernel writes it.
- Events are ordered by (time, priority, seq). ``seq`` is a global insertion counter, so events
  at the same time and priority run in the order they were scheduled: runs are deterministic.
- Lower priority values run first. Physics uses ``PRIORITY_PHYSICS`` so that, at equal times,
  the world is stepped before packets are delivered and telemetry is sampled.
- A cancelled event stays in the heap (cancel is O(1)) and is skipped when popped.
- Heap entries are (time, priority, seq, event) tuples, so ordering is a C-level tuple
  comparison (``seq`` is unique, the event itself is never compared).
- Callbacks may schedule more events, including at ``now``; scheduling in the past is an error.
- A horizon (for a co-simulated network, netsim/ns3/bridge.py): before any event later than
  ``horizon`` runs — and before ``run`` moves ``now`` past it — ``on_horizon(t)`` is called with
  that time; it must either move ``horizon`` to ``t`` or later, or schedule an event earlier than
  ``t`` (a delivery the other simulator found on its way to ``t``). ``horizon`` is +inf when
  nobody needs the hook.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from typing import Any

PRIORITY_PHYSICS = 0
PRIORITY_NETWORK = 1
PRIORITY_DEFAULT = 2


class Event:
    """A handle on one scheduled callback."""

    __slots__ = ("time", "priority", "seq", "callback", "args", "cancelled")

    def __init__(self, time: float, priority: int, seq: int, callback: Callable[..., Any],
                 args: tuple) -> None:
        self.time = time
        self.priority = priority
        self.seq = seq
        self.callback = callback
        self.args = args
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True

    def __lt__(self, other: Event) -> bool:
        return (self.time, self.priority, self.seq) < (other.time, other.priority, other.seq)

    def __repr__(self) -> str:
        state = " cancelled" if self.cancelled else ""
        return f"<Event t={self.time:.6f} p={self.priority} #{self.seq} {self.callback!r}{state}>"


class SchedulingError(ValueError):
    pass


class Kernel:
    """Discrete-event scheduler over simulated seconds."""

    def __init__(self, start_s: float = 0.0) -> None:
        self.now = float(start_s)
        self._heap: list[tuple[float, int, int, Event]] = []
        self._seq = 0
        self.events_processed = 0
        self.horizon = math.inf
        self.on_horizon: Callable[[float], Any] | None = None

    def schedule(self, time_s: float, callback: Callable[..., Any], *args: Any,
                 priority: int = PRIORITY_DEFAULT) -> Event:
        """Run ``callback(*args)`` at simulated time ``time_s``."""
        if not time_s >= self.now:  # also rejects NaN
            raise SchedulingError(f"cannot schedule at {time_s!r}, now is {self.now!r}")
        seq = self._seq
        event = Event(time_s, priority, seq, callback, args)
        self._seq = seq + 1
        heapq.heappush(self._heap, (time_s, priority, seq, event))
        return event

    def reschedule(self, event: Event, time_s: float) -> Event:
        """Schedule ``event``, which has run, again at ``time_s`` with the same callback and
        arguments, as ``schedule`` would a new one (a fresh ``seq``): for a timer that re-arms
        itself from its own callback, without making a new Event every time."""
        if not time_s >= self.now:  # also rejects NaN
            raise SchedulingError(f"cannot schedule at {time_s!r}, now is {self.now!r}")
        seq = self._seq
        event.time = time_s
        event.seq = seq
        self._seq = seq + 1
        heapq.heappush(self._heap, (time_s, event.priority, seq, event))
        return event

    def call_later(self, delay_s: float, callback: Callable[..., Any], *args: Any,
                   priority: int = PRIORITY_DEFAULT) -> Event:
        return self.schedule(self.now + delay_s, callback, *args, priority=priority)

    def peek_key(self) -> tuple[float, int]:
        """(time, priority) of the next live event, or (+inf, 0) if there is none."""
        heap = self._heap
        while heap and heap[0][3].cancelled:
            heapq.heappop(heap)
        return (heap[0][0], heap[0][1]) if heap else (math.inf, 0)

    def peek(self) -> float:
        """Time of the next live event, or +inf if there is none."""
        heap = self._heap
        while heap and heap[0][3].cancelled:
            heapq.heappop(heap)
        return heap[0][0] if heap else math.inf

    def _cross(self, t: float) -> None:
        if self.on_horizon is None:
            raise SchedulingError(f"horizon {self.horizon!r} is set but on_horizon is not")
        self.on_horizon(t)

    def step(self) -> bool:
        """Process the next live event. False if there was none."""
        return self.step_until(math.inf)

    def step_until(self, until: float, priority: int | None = None) -> bool:
        """Process the next live event if ``run(until, priority)`` would: False (nothing run)
        when it lies beyond them. A caller that runs events one at a time up to a target (the
        daemon's pacer) asks and steps in one call."""
        heap = self._heap
        while heap:
            entry = heap[0]
            event = entry[3]
            if event.cancelled:
                heapq.heappop(heap)
                continue
            t = entry[0]
            if t > until or (t == until and priority is not None and entry[1] > priority):
                return False
            if t > self.horizon:
                self._cross(t)
                continue
            heapq.heappop(heap)
            self.now = t
            self.events_processed += 1
            event.callback(*event.args)
            return True
        return False

    def run(self, until: float | None = None, priority: int | None = None) -> None:
        """Process events with time <= ``until`` (all of them if None), then set now = until.
        ``priority``: of the events at ``until`` itself, only those of this priority or a lower
        value (a sharded run's barrier inside an instant: gateway/daemon/shard/)."""
        if until is None:
            while self.step():
                pass
            return
        if until < self.now:
            raise SchedulingError(f"cannot run until {until!r}, now is {self.now!r}")
        heap = self._heap
        pop = heapq.heappop
        while True:
            if heap:
                entry = heap[0]
                event = entry[3]
                if event.cancelled:
                    pop(heap)
                    continue
                t = entry[0]
            else:
                t = math.inf
            if t > until or (t == until and priority is not None and entry[1] > priority):
                if until > self.horizon:  # deliveries may be due before until
                    self._cross(until)
                    continue
                break
            if t > self.horizon:
                self._cross(t)
                continue
            pop(heap)
            self.now = t
            self.events_processed += 1
            event.callback(*event.args)
        self.now = until

    def __len__(self) -> int:
        return sum(1 for e in self._heap if not e[3].cancelled)


class Ticker:
    """Calls ``callback(now)`` every ``period_s`` at exact multiples of the period.

    Times are computed as ``start + n * period`` (not by accumulation), so a 250 Hz physics clock
    does not drift from its nominal grid however long it runs.
    """

    def __init__(self, kernel: Kernel, period_s: float, callback: Callable[[float], Any], *,
                 start_s: float | None = None, priority: int = PRIORITY_DEFAULT) -> None:
        if not period_s > 0:
            raise ValueError("period must be positive")
        self._kernel = kernel
        self.period_s = period_s
        self._callback = callback
        self._priority = priority
        self._start = kernel.now if start_s is None else start_s
        self._n = 0
        self._event: Event | None = kernel.schedule(self._start, self._fire, priority=priority)

    def _fire(self) -> None:
        kernel = self._kernel
        now = kernel.now
        self._n = n = self._n + 1
        t = self._start + n * self.period_s
        # ``kernel.reschedule(self._event, t)`` inlined (it runs at every physics step): the
        # event has just run, so it is out of the heap, and ``t`` is past ``now``.
        event = self._event
        assert event is not None  # a cancelled ticker's event never fires
        seq = kernel._seq
        event.time = t
        event.seq = seq
        kernel._seq = seq + 1
        heapq.heappush(kernel._heap, (t, self._priority, seq, event))
        self._callback(now)

    @property
    def next_s(self) -> float:
        """When it fires next (+inf once cancelled)."""
        return self._event.time if self._event is not None else math.inf

    def cancel(self) -> None:
        if self._event is not None:
            self._event.cancel()
            self._event = None
