"""A rank's signal handlers, and its deafness once its run has ended.

mpiexec forwards the user's SIGINT or SIGTERM to every rank, each in its own time: on a loaded
machine one rank may hear it only after the coordinator has already stopped the job and that
rank's event loop is closed. asyncio's ``loop.add_signal_handler`` puts the default disposition
back when its loop closes, so such a late signal would kill the rank (KeyboardInterrupt, or
SIGTERM's default action) and mpiexec would report the whole job as failed. A rank therefore
installs its handlers with ``signal.signal`` (each hands its work to the loop), and when its run
has ended it ignores them: the coordinator has already decided that everyone stops, and a rank
that hangs is ended by mpiexec (a second Ctrl-C) or MPI_Abort, not by these signals.

Before its handlers are in place a rank would die of those signals too, so it tells the launcher
when they are (``launch.mark_armed``): ``cornet run --shards K`` holds a signal that comes while
a rank is still starting, and relays it once every rank can take it.
"""

from __future__ import annotations

import asyncio
import signal
from collections.abc import Callable
from types import FrameType

from gateway.daemon.shard.launch import mark_armed

__all__ = ["RankSignals"]


class RankSignals:
    """Runs ``handlers[sig]()`` in ``loop`` when the process gets ``sig``; ``close()`` (or the
    end of a ``with`` block) makes every one of those signals ignored from then on."""

    def __init__(self, loop: asyncio.AbstractEventLoop,
                 handlers: dict[signal.Signals, Callable[[], None]]):
        self._loop = loop
        self._handlers = dict(handlers)
        self._closed = False
        for sig in self._handlers:
            signal.signal(sig, self._on_signal)
        mark_armed()  # the launcher relays signals once every rank is here

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        # Python runs this in the main thread between bytecodes, also while the loop waits in
        # select() (interrupted, then resumed): the loop is woken to run the handler.
        if self._closed or self._loop.is_closed():
            return
        self._loop.call_soon_threadsafe(self._handlers[signal.Signals(signum)])

    def close(self) -> None:
        self._closed = True
        for sig in self._handlers:
            signal.signal(sig, signal.SIG_IGN)

    def __enter__(self) -> RankSignals:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
