"""A vehicle's one timer event: the earliest deadline of its links' sessions.

Rules and invariants:
- At most one pending kernel event per vehicle (``VehicleWake._event``), re-armed after every
  call into one of its links' sessions; ``arm`` while the wake runs waits for its end.
- Due links are woken in the order they were made (PX4 SITL's GCS link, then the API link,
  then extra radios), each flushed into its downlink before the next one runs.
"""

from __future__ import annotations

import math
from typing import Protocol

from gateway.mavlink.session import Session
from netsim.backend import NetLink
from netsim.kernel import Event, Kernel


class WakeLink(Protocol):
    """What the wake needs of a link (gateway/sim/simulation.py ``VehicleLink``)."""

    deadline_s: float  # when its session wants ``handle_timer`` next (inf: never)
    session: Session
    downlink: NetLink

    def timer_failed(self) -> None:
        """Its session's ``handle_timer`` raised."""


class VehicleWake:
    """The one timer event of a vehicle's links, at the earliest of their sessions' deadlines.

    The links of a vehicle fall due together most of the time (every stream of the GCS link is
    on the API link's 100 Hz grid), so one kernel event per instant serves them all: each link
    whose deadline has come gets ``handle_timer`` and is flushed, in the order the links were
    made (PX4 SITL's GCS link, then the API link, then extra radios). A link that is not due is
    not woken. ``arm`` called while the wake runs (a reply that a delivery brought back in the
    same instant) waits for its end, which re-arms once.
    """

    __slots__ = ("kernel", "links", "_event", "_at", "_running")

    def __init__(self, kernel: Kernel) -> None:
        self.kernel = kernel
        self.links: list[WakeLink] = []
        self._event: Event | None = None
        self._at = math.inf
        self._running = False

    def _earliest(self) -> float:
        at = math.inf
        for link in self.links:
            if link.deadline_s < at:
                at = link.deadline_s
        return at

    def arm(self) -> None:
        if self._running:
            return
        at = self._earliest()
        if at == self._at:
            return
        if self._event is not None:
            self._event.cancel()
            self._event = None
        self._at = at
        if at < math.inf:
            self._event = self.kernel.schedule(max(at, self.kernel.now), self._fire)

    def _fire(self) -> None:
        """Each due link: ``handle_timer``, its datagrams into the downlink, its next deadline
        (``VehicleLink.flush`` inlined: this runs at every telemetry instant)."""
        now = self.kernel.now
        self._running = True
        try:
            for link in self.links:
                if link.deadline_s <= now:
                    link.deadline_s = math.inf  # until its next one is read (stays if it raises)
                    session = link.session
                    try:
                        session.handle_timer(now)
                    except Exception:
                        link.timer_failed()
                    datagrams = session.datagrams_to_send(now)
                    if datagrams:
                        send = link.downlink.send
                        for datagram in datagrams:
                            send(datagram, session.peer)  # read each time: a reply may set it
                    deadline = session.get_timer()
                    link.deadline_s = math.inf if deadline is None else deadline
        finally:  # re-armed even if a link raised: its vehicle's other links go on
            self._running = False
            # ``arm`` without its checks: this event is spent and no other is pending.
            at = math.inf
            for link in self.links:
                if link.deadline_s < at:
                    at = link.deadline_s
            self._at = at
            event = self._event  # the one running now (``arm`` waits for the end of the wake)
            if at == math.inf:
                self._event = None
            elif event is not None:  # spent: out of the heap and not cancelled, so re-used
                self.kernel.reschedule(event, at if at > now else now)
            else:
                self._event = self.kernel.schedule(at if at > now else now, self._fire)
