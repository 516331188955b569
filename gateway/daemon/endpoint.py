"""UDP endpoints: bytes in and out of one vehicle link. They never parse.

PX4 behaviour (mavlink_main.cpp, UDP mode): the vehicle talks first to its preset remote
(127.0.0.1:14550 or :14540+i) and, once it hears a client, replies to that client. Which client
counts as heard is decided by the simulation (a datagram that held a valid MAVLink frame); the
endpoint only hands the sender's address along and sends to the address it is given.

Load rules (one client must not starve the others):
- The socket is read with ``loop.add_reader``, at most ``MAX_BATCH`` datagrams per wake-up, so a
  flooded port gets no more turns of the event loop than a quiet one; what the kernel cannot
  buffer meanwhile (``RCVBUF_BYTES``) is dropped by the kernel and counted (SO_RXQ_OVFL).
- Each source address has a token bucket (``SourceLimiter``): datagrams beyond its rate are
  dropped before anything looks at them, and counted.
- Nothing queues in user space: a send that would block is dropped and counted.
"""

from __future__ import annotations

import asyncio
import errno
import logging
import socket
import struct
import sys
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import asdict, dataclass

log = logging.getLogger(__name__)

MAX_BATCH = 64  # datagrams read per wake-up of one socket
MAX_DATAGRAM = 65535
RCVBUF_BYTES = 1 << 20
# Linux: a per-socket counter of datagrams the kernel dropped for lack of buffer, delivered
# with each datagram (socket(7)). Python's socket module does not name it.
SO_RXQ_OVFL = getattr(socket, "SO_RXQ_OVFL", 40)
_OVFL_SPACE = socket.CMSG_SPACE(4)

# Per source: what a busy legitimate client sends is far below this (MAVSDK or QGC on one link:
# tens to a few hundred datagrams per second, parameter and mission bursts included).
DEFAULT_RATE_PER_S = 2000.0
DEFAULT_BURST = 1000.0
MAX_SOURCES = 256  # remembered per endpoint; the least recently heard is forgotten first


class SourceLimiter:
    """Token bucket per source address; ``now`` (seconds, any monotonic clock) is an argument."""

    def __init__(self, rate_per_s: float = DEFAULT_RATE_PER_S, burst: float = DEFAULT_BURST,
                 max_sources: int = MAX_SOURCES) -> None:
        if not rate_per_s > 0 or not burst >= 1:
            raise ValueError("rate must be > 0 and burst >= 1")
        self.rate = rate_per_s
        self.burst = burst
        self.max_sources = max_sources
        self._buckets: OrderedDict[object, list[float]] = OrderedDict()

    def allow(self, source: object, now: float) -> bool:
        b = self._buckets.get(source)
        if b is None:
            if len(self._buckets) >= self.max_sources:
                self._buckets.popitem(last=False)
            b = self._buckets[source] = [self.burst, now]
        else:
            self._buckets.move_to_end(source)
            tokens = b[0] + (now - b[1]) * self.rate
            b[0] = tokens if tokens < self.burst else self.burst
            b[1] = now
        if b[0] >= 1.0:
            b[0] -= 1.0
            return True
        return False

    def __len__(self) -> int:
        return len(self._buckets)


@dataclass
class EndpointStats:
    rx_datagrams: int = 0  # accepted and handed on
    rx_rate_limited: int = 0  # dropped by the source's token bucket
    rx_kernel_dropped: int = 0  # dropped by the kernel: receive buffer full (SO_RXQ_OVFL)
    tx_datagrams: int = 0
    tx_dropped: int = 0  # the send would have blocked: dropped, never queued
    tx_errors: int = 0  # ICMP port unreachable and the like (normal before a client listens)

    def as_dict(self) -> dict[str, int]:
        return asdict(self)


class UdpEndpoint:
    def __init__(self, name: str, default_peer: tuple[str, int],
                 on_datagram: Callable[[bytes, tuple[str, int]], None], *,
                 limiter: SourceLimiter | None = None,
                 clock: Callable[[], float] | None = None) -> None:
        """``limiter``: per-source rate limit (None: none); ``clock``: the monotonic clock the
        limiter runs on (the daemon passes the pacer's)."""
        self.name = name
        self.default_peer = default_peer
        self._on_datagram = on_datagram
        self.limiter = limiter
        self._clock = clock
        if limiter is not None and clock is None:
            raise ValueError("a rate limiter needs a clock")
        self.stats = EndpointStats()
        self.sock: socket.socket | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._ovfl_seen = 0

    # --- lifecycle ----------------------------------------------------------------------------
    def open(self, loop: asyncio.AbstractEventLoop, local_addr: tuple[str, int]) -> None:
        """Bind (raises OSError, e.g. EADDRINUSE) and start reading."""
        family = socket.AF_INET6 if ":" in local_addr[0] else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_DGRAM)
        try:
            sock.setblocking(False)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RCVBUF_BYTES)
            if sys.platform.startswith("linux"):
                sock.setsockopt(socket.SOL_SOCKET, SO_RXQ_OVFL, 1)
            sock.bind(local_addr)
        except BaseException:
            sock.close()
            raise
        self.sock = sock
        self._loop = loop
        loop.add_reader(sock.fileno(), self._readable)

    def close(self) -> None:
        if self.sock is not None:
            if self._loop is not None and not self._loop.is_closed():
                self._loop.remove_reader(self.sock.fileno())
            self.sock.close()
            self.sock = None

    @property
    def local_port(self) -> int:
        assert self.sock is not None
        return self.sock.getsockname()[1]

    # --- in -------------------------------------------------------------------------------------
    def _readable(self) -> None:
        sock = self.sock
        if sock is None:
            return
        st = self.stats
        limiter = self.limiter
        clock = self._clock
        now = clock() if clock is not None else 0.0  # a limiter always comes with a clock
        for _ in range(MAX_BATCH):
            try:
                data, anc, _flags, addr = sock.recvmsg(MAX_DATAGRAM, _OVFL_SPACE)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:  # e.g. ECONNREFUSED queued by an earlier send
                if exc.errno not in (errno.ECONNREFUSED, errno.EHOSTUNREACH, errno.ENETUNREACH):
                    log.debug("%s: recv error %s", self.name, exc)
                st.tx_errors += 1
                continue
            if anc:
                self._overflow(anc)
            if limiter is not None and not limiter.allow(addr, now):
                st.rx_rate_limited += 1
                continue
            st.rx_datagrams += 1
            self._on_datagram(data, addr[:2])

    def _overflow(self, anc: list) -> None:
        for level, kind, payload in anc:
            if level == socket.SOL_SOCKET and kind == SO_RXQ_OVFL and len(payload) >= 4:
                total = struct.unpack("=I", payload[:4])[0]
                if total != self._ovfl_seen:
                    self.stats.rx_kernel_dropped += (total - self._ovfl_seen) & 0xFFFFFFFF
                    self._ovfl_seen = total

    # --- out ------------------------------------------------------------------------------------
    def send(self, data: bytes, peer: tuple[str, int] | None) -> None:
        sock = self.sock
        if sock is None:
            return
        try:
            sock.sendto(data, peer or self.default_peer)
            self.stats.tx_datagrams += 1
        except (BlockingIOError, InterruptedError):
            self.stats.tx_dropped += 1
        except OSError:
            # ICMP port unreachable while nobody listens on the remote port: normal before a
            # client; also a peer address of the wrong family.
            self.stats.tx_errors += 1

    # kept for the status line and older callers
    @property
    def rx_datagrams(self) -> int:
        return self.stats.rx_datagrams

    @property
    def tx_datagrams(self) -> int:
        return self.stats.tx_datagrams
