"""Dicts between ranks without ever blocking an event loop (mpi4py point-to-point).

MPI has no file descriptor to wait on, and MPICH's blocking calls spin a core, so a rank finds
its messages by probing (``improbe``). To wake a rank the moment a message is sent rather than
at its next probe, each rank also binds a *doorbell*: a UDP socket on the loopback interface,
registered with its event loop. A sender rings the receiver's doorbell (one empty datagram)
after each ``isend``; the receiver then probes at once. Doorbells are exchanged with one
allgather at start (:meth:`Channel.open_doorbells`) and only between ranks on the same host;
a message from another host is found by the periodic probe (POLL_PERIOD_S). The probe stays
the rule in every case: a doorbell that is lost or rings early only costs that period.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import socket
import time
from typing import Any

STOP_TIMEOUT_S = 5.0
START_TIMEOUT_S = 60.0  # a worker compiling and binding its vehicles
# How often a rank probes for MPI messages whose sender could not ring its doorbell (another
# host): ~1000 cheap wake-ups a second per rank.
POLL_PERIOD_S = 0.001
# The same with every peer on this host (doorbells): only a safety net.
DOORBELL_POLL_PERIOD_S = 0.02
# A doorbell that rang before its message could be probed: keep probing this long at most.
EARLY_RING_WINDOW_S = 0.0005
TAG = 7


class Channel:
    """Dicts to and from other ranks without blocking: ``isend`` (requests kept until they
    complete), ``improbe`` polls, and doorbells between ranks of one host."""

    def __init__(self, comm: Any) -> None:
        self.comm = comm
        self._pending: list[Any] = []
        self._inbox: collections.deque[tuple[int, dict]] = collections.deque()
        self._bell: socket.socket | None = None
        self._peers: dict[int, tuple[str, int]] = {}  # rank -> its doorbell (same host only)
        self._rang: asyncio.Event | None = None
        self.poll_period_s = POLL_PERIOD_S

    def open_doorbells(self) -> None:
        """Collective (every rank calls it once, before its event loop runs): bind this rank's
        doorbell and learn those of the ranks on this host."""
        bell = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        bell.bind(("127.0.0.1", 0))
        bell.setblocking(False)
        self._bell = bell
        me = self.comm.Get_rank()
        host = socket.gethostname()
        everyone = self.comm.allgather((host, bell.getsockname()))
        self._peers = {rank: addr for rank, (h, addr) in enumerate(everyone)
                       if h == host and rank != me}
        if len(self._peers) == len(everyone) - 1:
            self.poll_period_s = DOORBELL_POLL_PERIOD_S

    def send(self, rank: int, msg: dict) -> None:
        self._pending.append(self.comm.isend(msg, dest=rank, tag=TAG))
        self._pending = [r for r in self._pending if not r.Test()]
        peer = self._peers.get(rank)
        if peer is not None and self._bell is not None:
            with contextlib.suppress(OSError):  # a full buffer: it rings already
                self._bell.sendto(b"", peer)

    def next(self) -> tuple[int, dict] | None:
        """The next message that has arrived, as (source rank, message), or None."""
        if not self._inbox:
            from mpi4py import MPI

            status = MPI.Status()
            while (m := self.comm.improbe(source=MPI.ANY_SOURCE, tag=TAG,
                                          status=status)) is not None:
                self._inbox.append((status.Get_source(), m.recv()))
        return self._inbox.popleft() if self._inbox else None

    async def wait(self, timeout_s: float | None = None) -> None:
        """Until a doorbell rings (then long enough for its message to be probed) or
        ``timeout_s`` (default: the poll period) has passed."""
        timeout_s = self.poll_period_s if timeout_s is None else timeout_s
        if self._bell is None:
            await asyncio.sleep(timeout_s)
            return
        if self._rang is None:
            self._rang = asyncio.Event()
            asyncio.get_running_loop().add_reader(self._bell.fileno(), self._on_ring)
        rang = self._rang
        if not rang.is_set():
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(rang.wait(), timeout_s)
        if rang.is_set():
            rang.clear()
            # The ring usually comes before MPI has the message to probe: a few more probes
            # (each one drives MPI's progress; microseconds on one host) find it.
            deadline = time.perf_counter() + EARLY_RING_WINDOW_S
            while not self._inbox and self._probe_once() is None \
                    and time.perf_counter() < deadline:
                pass

    def _probe_once(self) -> tuple[int, dict] | None:
        got = self.next()
        if got is not None:
            self._inbox.appendleft(got)
        return got

    def _on_ring(self) -> None:
        assert self._bell is not None and self._rang is not None
        with contextlib.suppress(OSError):
            while True:
                self._bell.recv(16)
        self._rang.set()

    async def receive(self, timeout_s: float | None = None) -> tuple[int, dict]:
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while (got := self.next()) is None:
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                raise asyncio.TimeoutError
            await self.wait(self.poll_period_s if left is None else min(left, self.poll_period_s))
        return got

    async def flush(self, timeout_s: float = STOP_TIMEOUT_S) -> None:
        """Before leaving: wait (polling) until every send has completed, dropping whatever
        still arrives, so that no message is left half-way when MPI finalizes."""
        deadline = time.monotonic() + timeout_s
        while True:
            while self.next() is not None:
                pass
            self._pending = [r for r in self._pending if not r.Test()]
            if not self._pending or time.monotonic() >= deadline:
                self.close()
                return
            await asyncio.sleep(POLL_PERIOD_S)

    def close(self) -> None:
        if self._bell is not None:
            if self._rang is not None:
                with contextlib.suppress(Exception):
                    asyncio.get_running_loop().remove_reader(self._bell.fileno())
            self._bell.close()
            self._bell, self._rang = None, None
