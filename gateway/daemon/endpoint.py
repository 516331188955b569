"""UDP endpoints: bytes in and out of one vehicle link. They never parse.

PX4 behaviour (mavlink_main.cpp, UDP mode): the vehicle talks first to its preset remote
(127.0.0.1:14550 or :14540+i) and, once it hears a client, replies to that client. Which client
counts as heard is decided by the simulation (a datagram that held a valid MAVLink frame); the
endpoint only hands the sender's address along and sends to the address it is given.

Load rules (one client must not starve the others):
- The socket is read with ``loop.add_reader``, at most ``MAX_BATCH`` datagrams per wake-up, so a
  flooded port gets no more turns of the event loop than a quiet one; what the kernel cannot
  buffer meanwhile (``RCVBUF_BYTES``) is dropped by the kernel and counted (SO_RXQ_OVFL).
- Admission (gateway/daemon/admission.py): token buckets in units of what handling a datagram
  costs, per source address, per source host and for the whole port; what does not fit is
  dropped before anything parses it, and counted by the bucket that refused it.
- Nothing queues in user space: a send that would block is dropped and counted.
"""

from __future__ import annotations

import asyncio
import errno
import logging
import socket
import struct
import sys
from collections.abc import Callable
from dataclasses import asdict, dataclass

from gateway.daemon.admission import Admission

log = logging.getLogger(__name__)

MAX_BATCH = 64  # datagrams read per wake-up of one socket
MAX_DATAGRAM = 65535
RCVBUF_BYTES = 1 << 20
# Linux: a per-socket counter of datagrams the kernel dropped for lack of buffer, delivered
# with each datagram (socket(7)). Python's socket module does not name it.
SO_RXQ_OVFL = getattr(socket, "SO_RXQ_OVFL", 40)
_OVFL_SPACE = socket.CMSG_SPACE(4)

@dataclass
class EndpointStats:
    rx_datagrams: int = 0  # accepted and handed on
    rx_rate_limited: int = 0  # shed by admission (source, host or port budget)
    rx_kernel_dropped: int = 0  # dropped by the kernel: receive buffer full (SO_RXQ_OVFL)
    tx_datagrams: int = 0
    tx_dropped: int = 0  # the send would have blocked: dropped, never queued
    tx_errors: int = 0  # ICMP port unreachable and the like (normal before a client listens)

    def as_dict(self) -> dict[str, int]:
        return asdict(self)


class UdpEndpoint:
    def __init__(self, name: str, default_peer: tuple[str, int],
                 on_datagram: Callable[[bytes, tuple[str, int]], None], *,
                 admission: Admission | None = None,
                 clock: Callable[[], float] | None = None,
                 broadcast: tuple[str, int] | None = None) -> None:
        """``admission``: the port's budgets (None: everything is let in); ``clock``: the
        monotonic clock they run on (the daemon passes the pacer's); ``broadcast``: also send
        to this broadcast address while no ground station is connected (PX4's
        MAV_BROADCAST = 1)."""
        self.name = name
        self.default_peer = default_peer
        self.broadcast = broadcast
        self._on_datagram = on_datagram
        self.admission = admission
        self._clock = clock
        if admission is not None and clock is None:
            raise ValueError("admission needs a clock")
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
            if self.broadcast is not None:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
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
        admission = self.admission
        clock = self._clock
        now = clock() if clock is not None else 0.0  # admission always comes with a clock
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
            if admission is not None and not admission.admit(addr, data, now):
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
    def send(self, data: bytes, peer: tuple[str, int] | None, gcs_connected: bool = False
             ) -> None:
        """To ``peer`` (the client last heard; None: the default partner). ``gcs_connected``:
        a ground station's HEARTBEAT arrived on this link lately."""
        sock = self.sock
        if sock is None:
            return
        try:  # ``_send_to`` inlined: every datagram of every vehicle comes this way
            sock.sendto(data, peer or self.default_peer)
            self.stats.tx_datagrams += 1
        except (BlockingIOError, InterruptedError):
            self.stats.tx_dropped += 1
        except OSError:
            self.stats.tx_errors += 1
        if self.broadcast is not None and (peer is None or not gcs_connected):
            # PX4 (mavlink_main.cpp, send_finish): a normal-mode link with MAV_BROADCAST = 1
            # sends to the network's broadcast address too until a client is heard, and again
            # whenever no ground station is connected (its HEARTBEATs stopped).
            self._send_to(sock, data, self.broadcast)

    def _send_to(self, sock: socket.socket, data: bytes, peer: tuple[str, int]) -> None:
        try:
            sock.sendto(data, peer)
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


SIOCGIFADDR = 0x8915
SIOCGIFBRDADDR = 0x8919


def _interface_address(sock: socket.socket, name: str, request: int) -> str | None:
    import fcntl

    try:
        raw = fcntl.ioctl(sock.fileno(), request, struct.pack("256s", name.encode()[:15]))
    except OSError:
        return None
    return socket.inet_ntoa(raw[20:24])


def broadcast_address(bind: str) -> str | None:
    """The broadcast address MAV_BROADCAST sends to, as PX4's find_broadcast_address: that of
    the interface holding ``bind``, or with 0.0.0.0 the first interface that has one (not the
    loopback). None where there is none (a loopback bind)."""
    if not sys.platform.startswith("linux"):
        return None if bind.startswith("127.") else "255.255.255.255"
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        for _index, name in socket.if_nameindex():
            address = _interface_address(sock, name, SIOCGIFADDR)
            if address is None or address.startswith("127.") or bind not in ("0.0.0.0", address):
                continue
            found = _interface_address(sock, name, SIOCGIFBRDADDR)
            if found not in (None, "0.0.0.0"):
                return found
    return None
