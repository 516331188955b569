"""A one-way link that carries opaque byte packets through a model on the kernel's clock.

Rules and invariants:
- The link never looks inside a packet; ``meta`` rides along untouched (the gateway uses it for
  the UDP peer address) and is handed to ``deliver`` with the packet.
- Each packet is sent at ``kernel.now``; the model decides a delay or a drop.
- Per-packet delays are independent, as with netem: with jitter larger than the gap between
  packets they may arrive out of order, and the mean latency is the configured one. ``fifo=True``
  forbids overtaking instead (a queue or a MAC does not reorder), at the price of a higher mean.
- Counters: sent, delivered, bytes, dropped by reason, and in-flight. sent == delivered +
  sum(dropped) + in_flight at every instant.
- ``tracer``, when set, receives every send/drop/delivery: it is the network's log.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from netsim.kernel import PRIORITY_NETWORK, Kernel
from netsim.models import Drop, LinkModel

Deliver = Callable[[bytes, Any], None]
Tracer = Callable[[str, str, float, int, str], None]  # (event, link, time_s, size, detail)


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

    @property
    def dropped_total(self) -> int:
        return sum(self.dropped.values())

    def as_dict(self) -> dict[str, Any]:
        mean = self.latency_sum_s / self.delivered if self.delivered else 0.0
        return {
            "sent": self.sent,
            "delivered": self.delivered,
            "bytes_sent": self.bytes_sent,
            "bytes_delivered": self.bytes_delivered,
            "in_flight": self.in_flight,
            "dropped": dict(self.dropped),
            "latency_mean_ms": round(mean * 1e3, 3),
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
        self._deliver = deliver
        self._last_arrival_s = float("-inf")

    def send(self, packet: bytes, meta: Any = None) -> None:
        now = self.kernel.now
        size = len(packet)
        stats = self.stats
        stats.sent += 1
        stats.bytes_sent += size
        verdict = self.model.transit(size, now)
        if isinstance(verdict, Drop):
            stats.dropped[verdict.value] += 1
            if self.tracer is not None:
                self.tracer("drop", self.name, now, size, verdict.value)
            return
        arrival = now + verdict
        if self.fifo and arrival < self._last_arrival_s:
            arrival = self._last_arrival_s
        self._last_arrival_s = arrival
        stats.in_flight += 1
        if self.tracer is not None:
            self.tracer("send", self.name, now, size, f"{arrival - now:.6f}")
        self.kernel.schedule(arrival, self._arrive, packet, meta, now, priority=PRIORITY_NETWORK)

    def _arrive(self, packet: bytes, meta: Any, sent_at: float) -> None:
        stats = self.stats
        stats.in_flight -= 1
        stats.delivered += 1
        stats.bytes_delivered += len(packet)
        latency = self.kernel.now - sent_at
        stats.latency_sum_s += latency
        if latency > stats.latency_max_s:
            stats.latency_max_s = latency
        if self.tracer is not None:
            self.tracer("recv", self.name, self.kernel.now, len(packet), "")
        self._deliver(packet, meta)
