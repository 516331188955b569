"""A one-way link that carries opaque byte packets through a model on the kernel's clock.

Rules and invariants:
- The link never looks inside a packet; ``meta`` rides along untouched (the gateway uses it for
  the UDP peer address) and is handed to ``deliver`` with the packet. ``deliver`` may be
  replaced at any time (the gateway points it straight at a link's client).
- Each packet is sent at ``kernel.now``; the model decides a delay or a drop.
- Per-packet delays are independent, as with netem: with jitter larger than the gap between
  packets they may arrive out of order, and the mean latency is the configured one. ``fifo=True``
  forbids overtaking instead (a queue or a MAC does not reorder), at the price of a higher mean.
- Counters: sent, delivered, bytes, dropped by reason, and in-flight. sent == delivered +
  sum(dropped) + in_flight at every instant.
- ``tracer``, when set, receives every send/drop/delivery: it is the network's log.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from operator import itemgetter
from typing import Any

from netsim.kernel import PRIORITY_NETWORK, Kernel
from netsim.models import Drop, LinkModel
from netsim.models.fixed import IdealModel

Deliver = Callable[[bytes, Any], None]
Tracer = Callable[[str, str, float, int, str], None]  # (event, link, time_s, size, detail)


# Latency histogram bucket upper edges: 0, then 10 µs × 1.25^k up to ~60 s (about 70 buckets):
# percentiles to within 25 % without keeping every sample.
LATENCY_EDGES_S: tuple[float, ...] = (0.0,) + tuple(10e-6 * 1.25**k for k in range(71))


@dataclass
class LinkStats:
    sent: int = 0
    delivered: int = 0
    bytes_sent: int = 0
    bytes_delivered: int = 0
    in_flight: int = 0
    dropped: Counter = field(default_factory=Counter)
    latency_sum_s: float = 0.0
    latency_max_s: float = 0.0
    latency_histogram: list[int] = field(default_factory=lambda: [0] * (len(LATENCY_EDGES_S) + 1))
    late_delivered: int = 0  # external backends: delivered after their sync cycle (policy deliver)

    @property
    def dropped_total(self) -> int:
        return sum(self.dropped.values())

    def record_delivery(self, latency_s: float, size: int) -> None:
        self.delivered += 1
        self.bytes_delivered += size
        self.latency_sum_s += latency_s
        if latency_s > self.latency_max_s:
            self.latency_max_s = latency_s
        self.latency_histogram[bisect_left(LATENCY_EDGES_S, latency_s)] += 1

    def latency_percentile_s(self, q: float) -> float:
        """Upper edge of the histogram bucket holding the q-quantile (0 < q <= 1)."""
        n = sum(self.latency_histogram)
        if n == 0:
            return 0.0
        rank = q * n
        seen = 0
        for i, count in enumerate(self.latency_histogram):
            seen += count
            if seen >= rank:
                return min(LATENCY_EDGES_S[min(i, len(LATENCY_EDGES_S) - 1)], self.latency_max_s)
        return self.latency_max_s

    def as_dict(self) -> dict[str, Any]:
        mean = self.latency_sum_s / self.delivered if self.delivered else 0.0
        return {
            "sent": self.sent,
            "delivered": self.delivered,
            "bytes_sent": self.bytes_sent,
            "bytes_delivered": self.bytes_delivered,
            "in_flight": self.in_flight,
            "dropped": dict(self.dropped),
            "late_delivered": self.late_delivered,
            "latency_mean_ms": round(mean * 1e3, 3),
            "latency_p50_ms": round(self.latency_percentile_s(0.5) * 1e3, 3),
            "latency_p99_ms": round(self.latency_percentile_s(0.99) * 1e3, 3),
            "latency_max_ms": round(self.latency_max_s * 1e3, 3),
        }


class Link:
    def __init__(self, kernel: Kernel, model: LinkModel, deliver: Deliver, *, name: str,
                 fifo: bool = False, tracer: Tracer | None = None) -> None:
        self.kernel = kernel
        self.model = model
        self.name = name
        self.fifo = fifo
        self.tracer = tracer
        self.stats = LinkStats()
        self.deliver = deliver
        self._last_arrival_s = float("-inf")
        if isinstance(model, IdealModel):
            # An instance attribute shadows the method: an ideal link (the daemon's default
            # network) skips the model, which never delays or drops.
            self.send = self._send_ideal  # type: ignore[method-assign]

    @property
    def tracer(self) -> Tracer | None:
        return self._tracer

    @tracer.setter
    def tracer(self, tracer: Tracer | None) -> None:
        self._tracer = tracer
        # A tracer that writes a packet sent and delivered in one instant in one call (an
        # ideal link's every packet): ``instant(link, time_s, size)`` (InstantSortedTrace).
        self._trace_instant: Callable[[str, float, int], None] | None = \
            getattr(tracer, "instant", None)

    def _send_ideal(self, packet: bytes, meta: Any = None) -> None:
        """``send`` through an ideal model: delivered at once, counted as ``send`` counts it."""
        size = len(packet)
        stats = self.stats
        stats.sent += 1
        stats.bytes_sent += size
        stats.delivered += 1
        stats.bytes_delivered += size
        stats.latency_histogram[0] += 1
        tracer = self._tracer
        if tracer is not None:
            if self._trace_instant is not None:
                self._trace_instant(self.name, self.kernel.now, size)
            else:
                now = self.kernel.now
                tracer("send", self.name, now, size, "0.000000")
                tracer("recv", self.name, now, size, "")
        self.deliver(packet, meta)

    def send(self, packet: bytes, meta: Any = None) -> None:
        now = self.kernel.now
        size = len(packet)
        stats = self.stats
        stats.sent += 1
        stats.bytes_sent += size
        verdict = self.model.transit(size, now)
        tracer = self._tracer
        if verdict.__class__ is not float and isinstance(verdict, Drop):
            stats.dropped[verdict.value] += 1
            if tracer is not None:
                tracer("drop", self.name, now, size, verdict.value)
            return
        arrival = now + verdict
        if self.fifo and arrival < self._last_arrival_s:
            arrival = self._last_arrival_s
        self._last_arrival_s = arrival
        if arrival == now:
            # No delay (an ideal link): delivered in the same instant, without an event. This is
            # ``record_delivery(0.0, size)`` inlined (the hot path of every ideal link): a zero
            # latency only counts in the first histogram bucket, sum and max stay as they are.
            stats.delivered += 1
            stats.bytes_delivered += size
            stats.latency_histogram[0] += 1
            if tracer is not None:
                tracer("send", self.name, now, size, f"{arrival - now:.6f}")
                tracer("recv", self.name, now, size, "")
            self.deliver(packet, meta)
            return
        if tracer is not None:
            tracer("send", self.name, now, size, f"{arrival - now:.6f}")
        stats.in_flight += 1
        self.kernel.schedule(arrival, self._arrive, packet, meta, now, priority=PRIORITY_NETWORK)

    def _arrive(self, packet: bytes, meta: Any, sent_at: float) -> None:
        stats = self.stats
        stats.in_flight -= 1
        stats.record_delivery(self.kernel.now - sent_at, len(packet))
        if self._tracer is not None:
            self._tracer("recv", self.name, self.kernel.now, len(packet), "")
        self.deliver(packet, meta)


class TraceWriter:
    """The packet trace as text, one line per event: ``time event link size detail``.

    Times are printed with 9 decimals (the kernel's float seconds), so two runs with the same
    seed and inputs produce the same bytes. ``out`` is any text stream.
    """

    def __init__(self, out) -> None:
        self._out = out
        self.lines = 0

    def __call__(self, event: str, link: str, time_s: float, size: int, detail: str) -> None:
        self._out.write(f"{time_s:.9f} {event} {link} {size} {detail}\n")
        self.lines += 1


# InstantSortedTrace writes its finished instants' lines once this many entries wait: a few
# KiB, one write and one join for many instants
TRACE_BATCH = 256


class InstantSortedTrace:
    """A TraceWriter whose lines of one instant (one printed time) come group by group: sorted by
    ``group(link name)``, in the order they happened within a group. A run split over several
    simulations (gateway/daemon/shard/), each simulating some groups, then writes exactly the
    lines one simulation of every group writes once its parts are merged by time. The lines
    of the present instant are held until time moves on, those of the instants before it
    until TRACE_BATCH entries wait or ``flush`` is called."""

    def __init__(self, out, group: Callable[[str], int]) -> None:
        self._out = out
        self._group = group
        self._groups: dict[str, int] = {}  # ``group`` of each link name seen (a run has few)
        self._time = ""
        self._time_s = math.nan  # the float ``_time`` was printed from (an instant has many)
        self._held: list[tuple[int, str]] = []  # not written yet, the present instant's last
        self._start = 0  # where the present instant's entries start in ``_held``
        self._last_group = -math.inf  # of the last line held; a smaller one next: sort them
        self._sorted = True  # the present instant's entries
        self._written = 0  # entries written so far
        self._pairs = 0  # entries of two lines (``instant``), held or written

    @property
    def lines(self) -> int:
        return self._written + len(self._held) + self._pairs

    def __call__(self, event: str, link: str, time_s: float, size: int, detail: str) -> None:
        if time_s != self._time_s:
            self._move_to(time_s)
        group = self._groups.get(link)  # as in ``instant``
        if group is None:
            group = self._groups[link] = self._group(link)
        if group < self._last_group:
            self._sorted = False
        self._last_group = group
        self._held.append((group, f"{self._time} {event} {link} {size} {detail}\n"))

    def instant(self, link: str, time_s: float, size: int) -> None:
        """``send`` with no delay, then ``recv``, of one packet (what an ideal link traces), as
        one held entry: the two lines stay together whatever the sort does."""
        if time_s != self._time_s:  # printed once per float, not once per line
            self._move_to(time_s)
        group = self._groups.get(link)
        if group is None:
            group = self._groups[link] = self._group(link)
        if group < self._last_group:  # the instant's lines are no longer sorted
            self._sorted = False
        self._last_group = group
        t = self._time
        self._held.append((group, f"{t} send {link} {size} 0.000000\n{t} recv {link} {size} \n"))
        self._pairs += 1

    def _move_to(self, time_s: float) -> None:
        """The instant of ``time_s``: the last one ends there if it is a new one."""
        self._time_s = time_s
        stamp = f"{time_s:.9f}"  # one instant: one printed time (floats that print alike)
        if stamp != self._time:
            self._end_instant()
            if len(self._held) >= TRACE_BATCH:
                self._write()
            self._time = stamp

    def _end_instant(self) -> None:
        """The present instant's entries sorted by group (stable: a group's keep their order)."""
        held = self._held
        if not self._sorted:
            held[self._start:] = sorted(held[self._start:], key=itemgetter(0))
            self._sorted = True
        self._start = len(held)
        self._last_group = -math.inf

    def _write(self) -> None:
        held = self._held
        if held:
            self._out.write("".join([line for _, line in held]))
            self._written += len(held)
            held.clear()
            self._start = 0

    def flush(self) -> None:
        """Write the held lines, the present instant's too (the file's own flush stays the
        caller's)."""
        self._end_instant()
        self._write()


def fan_out(tracers: Sequence[Tracer]) -> Tracer | None:
    """One tracer that calls each of ``tracers`` (None for none)."""
    if not tracers:
        return None
    if len(tracers) == 1:
        return tracers[0]

    def trace(*event) -> None:
        for tracer in tracers:
            tracer(*event)

    return trace
