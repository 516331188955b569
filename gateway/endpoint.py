"""UDP endpoints: bytes in and out of one vehicle link. They never parse.

PX4 behaviour (PX4_COMPAT.md §1.2): the vehicle talks first to its preset remote
(127.0.0.1:14550 or :14540+i) and, once it hears a client, replies to that client. Which client
counts as heard is decided by the simulation (a datagram that held a valid MAVLink frame); the
endpoint only hands the sender's address along and sends to the address it is given.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable

log = logging.getLogger(__name__)


class UdpEndpoint(asyncio.DatagramProtocol):
    def __init__(self, name: str, default_peer: tuple[str, int],
                 on_datagram: Callable[[bytes, tuple[str, int]], None]) -> None:
        self.name = name
        self.default_peer = default_peer
        self._on_datagram = on_datagram
        self.transport: asyncio.DatagramTransport | None = None
        self.rx_datagrams = 0
        self.tx_datagrams = 0
        self.tx_errors = 0

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        self.rx_datagrams += 1
        self._on_datagram(data, addr)

    def send(self, data: bytes, peer: tuple[str, int] | None) -> None:
        if self.transport is None or self.transport.is_closing():
            return
        self.transport.sendto(data, peer or self.default_peer)
        self.tx_datagrams += 1

    def error_received(self, exc: Exception) -> None:
        # ICMP port unreachable while nobody listens on the remote port: normal before a client.
        self.tx_errors += 1

    def close(self) -> None:
        if self.transport is not None:
            self.transport.close()
