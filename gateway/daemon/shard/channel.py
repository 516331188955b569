"""Dicts between ranks without ever blocking an event loop (mpi4py point-to-point)."""

from __future__ import annotations

import asyncio
import collections
import time
from typing import Any

STOP_TIMEOUT_S = 5.0
# How often a rank looks for MPI messages. A grant for sync point t is needed only when the
# worker reaches t + 0.5·δ (10 ms of simulated time at δ = 20 ms), so 1 ms costs nothing in
# lockstep and ~1000 cheap wake-ups a second per rank.
POLL_PERIOD_S = 0.001
TAG = 7


class Channel:
    """Dicts to and from other ranks without blocking: ``isend`` (requests kept until they
    complete) and ``improbe`` polls."""

    def __init__(self, comm: Any) -> None:
        self.comm = comm
        self._pending: list[Any] = []
        self._inbox: collections.deque[tuple[int, dict]] = collections.deque()

    def send(self, rank: int, msg: dict) -> None:
        self._pending.append(self.comm.isend(msg, dest=rank, tag=TAG))
        self._pending = [r for r in self._pending if not r.Test()]

    def next(self) -> tuple[int, dict] | None:
        """The next message that has arrived, as (source rank, message), or None."""
        if not self._inbox:
            from mpi4py import MPI

            status = MPI.Status()
            while (m := self.comm.improbe(source=MPI.ANY_SOURCE, tag=TAG,
                                          status=status)) is not None:
                self._inbox.append((status.Get_source(), m.recv()))
        return self._inbox.popleft() if self._inbox else None

    async def receive(self, timeout_s: float | None = None) -> tuple[int, dict]:
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while (got := self.next()) is None:
            if deadline is not None and time.monotonic() >= deadline:
                raise asyncio.TimeoutError
            await asyncio.sleep(POLL_PERIOD_S)
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
                return
            await asyncio.sleep(POLL_PERIOD_S)


