"""The pacer: the only place that maps the wall clock onto simulated time.

``speed`` scales the mapping (PX4_SIM_SPEED_FACTOR): at 10, ten simulated seconds pass per wall
second. ``speed = inf`` ("max") runs the kernel flat out in small chunks, yielding to the event
loop between chunks so that datagrams still get in; it is meant for runs without clients that
keep wall-clock time-outs.

``sync()`` runs the kernel up to the simulated time that corresponds to "now" on the wall clock;
``run()`` sleeps until the wall-clock moment of the kernel's next event and syncs again. If the
CPU cannot keep up, the pacer lets simulated time slip (the physics never stalls, it just runs
slower than real time) rather than trying to catch up in a burst; slips and the achieved
real-time factor are counted.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Callable

from netsim.kernel import Kernel

MAX_LAG_S = 0.2  # wall-clock lag beyond which simulated time slips instead of catching up
MAX_SLEEP_S = 0.05
# While simulating, the pacer looks for waiting datagrams every POLL_EVERY_S of wall time (one
# non-blocking poll, ~1 µs) and gives the event loop a turn at once when there are some; it
# gives other tasks (status line, watchdog, shard messages) a turn every YIELD_EVERY_S anyway.
POLL_EVERY_S = 0.00005
YIELD_EVERY_S = 0.002
FLAT_OUT_CHUNK_S = 0.05  # speed "max": simulated time run between two looks at the sockets


ALL_PRIORITIES = 1 << 30  # a horizon that takes every event of its instant


class Pacer:
    def __init__(self, kernel: Kernel, speed: float = 1.0,
                 clock: Callable[[], float] = time.monotonic,
                 input_pending: Callable[[], bool] | None = None,
                 end_s: float | None = None) -> None:
        """``input_pending()``: whether datagrams are waiting on the shell's sockets (None:
        the pacer cannot tell, and yields every POLL_EVERY_S). ``end_s``: ``run`` returns once
        every event up to this simulated time has run (``cornet run --duration``)."""
        if not speed > 0:
            raise ValueError("speed must be positive")
        self.kernel = kernel
        self.speed = speed
        self._clock = clock
        self._input_pending = input_pending or (lambda: True)
        self._wall0 = clock()
        self._sim0 = kernel.now
        self.slips = 0
        self.slipped_s = 0.0
        self._rtf_wall0 = self._wall0
        self._rtf_sim0 = self._sim0
        # Sharded runs: simulated time never passes the horizon the coordinator granted
        # (gateway/daemon/shard/); one process alone has none. Of the events at the horizon
        # itself, only those of priority <= horizon_priority run (a barrier inside an instant).
        self.end_s = end_s
        self.horizon = math.inf if end_s is None else end_s
        self.horizon_priority = ALL_PRIORITIES
        self._horizon_moved: asyncio.Event | None = None

    def reanchor(self) -> None:
        """Map the wall clock's present to the present simulated time (no slip counted): a
        shard does this when the coordinator first lets time run."""
        self._wall0 = self._rtf_wall0 = self._clock()
        self._sim0 = self._rtf_sim0 = self.kernel.now

    def set_horizon(self, horizon_s: float, priority: int | None = None) -> None:
        """Run no event later than ``horizon_s``, and of the events at ``horizon_s`` only those
        of ``priority`` or a lower value (None: all of them)."""
        if self.end_s is not None and horizon_s >= self.end_s:
            horizon_s, priority = self.end_s, None
        self.horizon = horizon_s
        self.horizon_priority = ALL_PRIORITIES if priority is None else priority
        if self._horizon_moved is not None:
            self._horizon_moved.set()

    async def _wait_horizon(self, timeout_s: float) -> None:
        # Not asyncio.wait_for: before Python 3.12 it swallows a cancellation that comes as the
        # event is set (a shard's last grant and its stop arrive together), and the pacer
        # would outlive the cancel of its task.
        if self._horizon_moved is None:
            self._horizon_moved = asyncio.Event()
        self._horizon_moved.clear()
        wake = asyncio.get_running_loop().call_later(timeout_s, self._horizon_moved.set)
        try:
            await self._horizon_moved.wait()
        finally:
            wake.cancel()

    def wall(self) -> float:
        """The wall clock the pacer runs on (for the shell's wall-clock needs, e.g. rate
        limits); the simulation never reads it."""
        return self._clock()

    def _target(self, wall: float) -> float:
        return self._sim0 + (wall - self._wall0) * self.speed

    @property
    def flat_out(self) -> bool:
        return math.isinf(self.speed)

    def _bound(self, until: float) -> int | None:
        """The priority bound of ``kernel.run(until=until)`` under the horizon."""
        return self.horizon_priority if until >= self.horizon else None

    def _beyond(self, until: float) -> bool:
        """Whether the next event lies beyond ``until`` (and the horizon's barrier)."""
        t, priority = self.kernel.peek_key()
        return t > until or (t == until and until >= self.horizon
                             and priority > self.horizon_priority)

    @property
    def finished(self) -> bool:
        """Every event up to ``end_s`` has run."""
        return (self.end_s is not None and self.kernel.now >= self.end_s
                and self.kernel.peek() > self.end_s)

    def run_due(self) -> None:
        """Run what is due at the present simulated time (within the horizon's barrier)."""
        now = self.kernel.now
        if not self._beyond(now):
            self.kernel.run(until=now, priority=self._bound(now))

    def sync(self) -> None:
        """Bring the kernel to the simulated time of the present wall-clock moment."""
        target = self._sync_target()
        if target is not None:
            self.kernel.run(until=target, priority=self._bound(target))

    def _sync_target(self) -> float | None:
        """The simulated time of the present wall-clock moment (after slip and horizon rules),
        or None when there is nothing to run."""
        if self.flat_out:
            return None  # no wall-clock target: time advances in run()
        target = self._target(self._clock())
        now = self.kernel.now
        if target <= now:  # events of the present instant a horizon held may run now
            return None if self._beyond(now) else now
        lag = (target - now) / self.speed
        if lag > MAX_LAG_S:
            # Fell behind (CPU overload, a stalled event loop): re-anchor so we stay MAX_LAG_S
            # behind the wall clock instead of running a long burst.
            slip = target - now - MAX_LAG_S * self.speed
            self._sim0 -= slip
            self.slips += 1
            self.slipped_s += slip
            target -= slip
        if target > self.horizon:
            target = self.horizon
            if target < now:
                return None
        return target

    async def _run_sliced(self, target: float) -> None:
        """``kernel.run(until=target)``, giving the event loop a turn as soon as a datagram
        waits (looked for every POLL_EVERY_S of wall time) and every YIELD_EVERY_S anyway, so
        that clients are answered while a long burst (many vehicles at one instant) is being
        simulated."""
        kernel, clock, pending = self.kernel, self._clock, self._input_pending
        t = clock()
        check_at, slice_end = t + POLL_EVERY_S, t + YIELD_EVERY_S
        bound = self._bound(target)  # the horizon moves only while this yields (set_horizon)
        while True:
            # The next event unless it lies beyond ``target`` (``_beyond``), in one call.
            if not kernel.step_until(target, bound):
                if target > kernel.now:
                    kernel.run(until=target, priority=self._bound(target))
                return
            t = clock()
            if t >= check_at:
                if t >= slice_end or pending():
                    await asyncio.sleep(0)  # arrivals may run the kernel further meanwhile
                    bound = self._bound(target)
                    t = clock()
                    slice_end = t + YIELD_EVERY_S
                check_at = t + POLL_EVERY_S

    def sync_arrival(self) -> None:
        """Before a datagram goes in: move the clock to the simulated time of its arrival when
        no event is due before that (the usual case: the pacer was asleep). When events are due
        (the datagram came in mid-burst, or ahead of the pacer's own wake-up), they are not run
        first: the datagram is stamped with the present simulated time — earlier than its
        arrival by at most the work still due — and handled at once, as PX4's MAVLink receive
        thread answers while its control loops run. A burst of many vehicles' physics and
        telemetry then never sits between a client's request and the reply."""
        if self.flat_out:
            return
        kernel = self.kernel
        target = min(self._target(self._clock()), self.horizon)
        if target > kernel.now and kernel.peek() > target:
            kernel.run(until=target)  # nothing is due before the arrival: only the clock moves

    def real_time_factor(self) -> float:
        """Simulated seconds per wall second since the previous call."""
        wall = self._clock()
        sim = self.kernel.now
        dw = wall - self._rtf_wall0
        rtf = (sim - self._rtf_sim0) / dw if dw > 0 else 0.0
        self._rtf_wall0, self._rtf_sim0 = wall, sim
        return rtf

    async def run(self, on_loop: Callable[[], None] | None = None) -> None:
        """Run forever (until cancelled). ``on_loop`` is called after every run of the kernel:
        the shell feeds systemd's watchdog from there, so the pings stop when this loop does."""
        if self.flat_out:
            while True:
                until = min(self.kernel.now + FLAT_OUT_CHUNK_S, self.horizon)
                if until > self.kernel.now or not self._beyond(until):
                    self.kernel.run(until=until, priority=self._bound(until))
                if on_loop is not None:
                    on_loop()
                if self.finished:
                    return
                if self.kernel.now >= self.horizon:
                    await self._wait_horizon(MAX_SLEEP_S)
                else:
                    await asyncio.sleep(0)
        while True:
            target = self._sync_target()
            if target is not None:
                await self._run_sliced(target)
            if on_loop is not None:
                on_loop()
            if self.finished:
                return
            nxt = self.kernel.peek()
            if self._beyond(self.horizon):  # held: wake when the coordinator moves the horizon
                await self._wait_horizon(MAX_SLEEP_S)
                continue
            if math.isinf(nxt):
                delay = MAX_SLEEP_S
            else:
                delay = (nxt - self._target(self._clock())) / self.speed
                delay = min(max(delay, 0.0), MAX_SLEEP_S)
            await asyncio.sleep(delay)
