"""The queue model: a link of finite rate with a bounded drop-tail FIFO in front of it.

A packet of ``size`` bytes takes size·8 / rate_bps seconds to serialize; packets are served one
at a time in the order ``transit`` is called, so a packet waits for those ahead of it (the
model is stateful: it keeps when its transmitter will be free). delay = queueing wait +
serialization + latency_s (propagation). A packet that finds the FIFO full is dropped
(``Drop.QUEUE``): at most ``queue_packets`` packets and/or ``queue_bytes`` bytes held at once,
counting the one being serialized (an M/D/1/K queue with K = queue_packets). If neither limit is
given the queue holds 100 packets.

Used as a *shared* hop (HopSpec.shared_key), one instance serves every link that names the key:
a congested channel (an access point's air time) that many vehicles' packets queue for.

Arrival times are the ``now_s`` of each call, and packets are served in call order. Inside a
path a hop is called with the time the packet reaches it (send time + upstream delays), so calls
may come out of time order; a packet is then served behind one called before it even if that
one arrives later. Put a queue hop where arrivals come in time order — first in a path, or
behind hops of near-constant delay (the topologies do): behind a hop whose delay varies by tens
of ms, one late packet would hold up every packet called after it.

No random draws: the model is deterministic given the arrival sequence.
"""

from __future__ import annotations

from collections import deque

from netsim.models.base import MAX_QUEUE, MAX_RATE_BPS, Drop, check_delay, register_model
from netsim.rng import UniformStream

DEFAULT_QUEUE_PACKETS = 100


@register_model("queue")
class QueueModel:
    def __init__(self, rng: UniformStream | None = None, rate_bps: float | None = None,
                 queue_packets: int | None = None, queue_bytes: int | None = None,
                 latency_s: float = 0.0) -> None:
        del rng
        if rate_bps is None:
            raise ValueError("queue: rate_bps is required (link rate in bit/s)")
        if not 0 < rate_bps <= MAX_RATE_BPS:
            raise ValueError(f"queue: rate_bps must be > 0 and <= {MAX_RATE_BPS:g}, got {rate_bps!r}")
        if queue_packets is not None and not (isinstance(queue_packets, int)
                                              and 1 <= queue_packets <= MAX_QUEUE):
            raise ValueError(f"queue: queue_packets must be an integer >= 1, "
                             f"got {queue_packets!r}")
        if queue_bytes is not None and not (isinstance(queue_bytes, int)
                                            and 1 <= queue_bytes <= MAX_QUEUE):
            raise ValueError(f"queue: queue_bytes must be an integer >= 1, got {queue_bytes!r}")
        check_delay("queue", "latency_s", latency_s)
        if queue_packets is None and queue_bytes is None:
            queue_packets = DEFAULT_QUEUE_PACKETS
        self.rate_bps = float(rate_bps)
        self.queue_packets = queue_packets if queue_packets is not None else 1 << 62
        self.queue_bytes = queue_bytes if queue_bytes is not None else 1 << 62
        self.latency_s = float(latency_s)
        self._s_per_byte = 8.0 / self.rate_bps
        self._held: deque[tuple[float, int]] = deque()  # (serialization ends, size)
        self._held_bytes = 0
        self.busy_until_s = 0.0
        self.dropped = 0

    def backlog(self, now_s: float) -> tuple[int, int]:
        """(packets, bytes) held at ``now_s`` (after those finished by then leave)."""
        self._expire(now_s)
        return len(self._held), self._held_bytes

    def _expire(self, now_s: float) -> None:
        held = self._held
        while held and held[0][0] <= now_s:
            self._held_bytes -= held.popleft()[1]

    def transit(self, size_bytes: int, now_s: float) -> float | Drop:
        held = self._held
        if held and held[0][0] <= now_s:
            self._expire(now_s)
        if len(held) >= self.queue_packets or self._held_bytes + size_bytes > self.queue_bytes:
            self.dropped += 1
            return Drop.QUEUE
        start = self.busy_until_s if self.busy_until_s > now_s else now_s
        done = start + size_bytes * self._s_per_byte
        self.busy_until_s = done
        held.append((done, size_bytes))
        self._held_bytes += size_bytes
        return done - now_s + self.latency_s
