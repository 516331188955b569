"""Sharded daemon: the vehicles split across the ranks of an MPI job, kept in lockstep.

``cornet run --vehicles N --shards K`` runs one MPI job of K + 1 ranks. Rank 0 is the
coordinator: it prints the ready and status lines, keeps the workers' simulated clocks together
and carries every vehicle's position to every worker, so distance-based network models see all
vehicles. Rank k (1..K) is the worker of shard k - 1: it simulates a contiguous block of
vehicles in its own PyBullet world and event kernel, binds those vehicles' PX4 ports itself and
paces itself on the wall clock — the same ``Daemon`` as one process runs, given
``first_vehicle`` and its share of ``vehicles``.

On one machine ``cornet run --shards K`` replaces itself with ``mpiexec -n K+1 <python> -m
gateway.cli run <the same arguments>`` (the mpiexec next to the Python interpreter first: the
``mpich`` wheel's, from ``pip install 'cornet[mpi]'``). Every rank runs the same command line;
``cornet run`` started by an MPI launcher (PMI_RANK, OMPI_COMM_WORLD_RANK or PMIX_RANK in its
environment) is a rank, not a launcher. So across machines one runs
``mpiexec -n K+1 -hosts a,b cornet run ... --shards K`` directly (docs/scaling.md).

Messages (MPI point-to-point between rank 0 and each worker; every message one small dict,
pickled by mpi4py; sends are ``isend``, receives are polled with ``improbe`` every
POLL_PERIOD_S, so no MPI call ever blocks an event loop — MPICH's blocking calls would spin a
core):

  worker → coordinator
    {"ready": k}                          ports bound, simulation built, simulated t = 0
    {"error": text, "code": 2}            could not start (e.g. a port in use); it exits
    {"sync": t, "positions": {node: (n, e, d)}}
                                          reached the sync point t (every sync period of the
                                          network, the CORNET mobility update); its vehicles'
                                          world-frame positions at t
    {"status": {counter: value}, "t": t}  every status period (wall), for the status line
    {"interrupt": true}                   it got SIGINT or SIGTERM: please stop everyone
    {"stopped": {counter: value}, "t": t} after a stop: final counters; then it exits 0
  coordinator → worker
    {"horizon": h, "positions": {...}}    run simulated time up to h; the other shards'
                                          vehicles were at these positions at the last sync
    {"stop": true}

This is a gather and a broadcast per sync point, written as point-to-point messages because
they must not block: a worker keeps simulating (up to its horizon) and serving UDP while its
report travels.

Lockstep rule: when every worker has reported sync point t, each is granted the horizon
t + 1.5·δ (δ = the sync period): it runs through the next sync point t + δ and stops short of
the one after. So no two shards are ever more than 1.5·δ apart in simulated time, and a shard
that falls behind holds the others (they slip, as one overloaded process would). A worker's
network sees the other shards' vehicles one sync period late (their positions at t arrive with
the grant that runs to t + δ).

Stopping: mpiexec forwards SIGINT and SIGTERM to every rank. The coordinator then sends
"stop" to every worker; a worker that gets the signal asks the coordinator to ("interrupt"),
so one signalled rank is enough. Workers answer with their final counters, the coordinator
logs the stop line, every rank exits 0. A rank that fails unexpectedly aborts the whole job
(MPI_Abort).

Limits: the embedded network only (an ns-3 engine belongs to one process); no --zmq-pub, --web,
--log-dir, --packet-trace, --metrics-port or SIGHUP reload with more than one shard yet.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import logging
import math
import os
import shutil
import signal
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from gateway.daemon.app import (
    STATUS_PERIOD_S,
    Daemon,
    PortInUse,
    RunConfig,
    _ports_text,
    format_status,
    settle_heap,
)
from gateway.daemon.sdnotify import Notifier

log = logging.getLogger(__name__)

START_TIMEOUT_S = 60.0
STOP_TIMEOUT_S = 5.0
HORIZON_PERIODS = 1.5
# How often a rank looks for MPI messages. A grant for sync point t is needed only when the
# worker reaches t + 0.5·δ (10 ms of simulated time at δ = 20 ms), so 1 ms costs nothing in
# lockstep and ~1000 cheap wake-ups a second per rank.
POLL_PERIOD_S = 0.001
TAG = 7
MPI_RANK_VARIABLES = ("PMI_RANK", "OMPI_COMM_WORLD_RANK", "PMIX_RANK")
MPI_MISSING = "--shards needs MPI (mpi4py and an MPI library): pip install 'cornet[mpi]'"
UNSUPPORTED_WITH_SHARDS = ("zmq_pub", "log_dir", "packet_trace", "metrics_port", "web")


class ShardError(RuntimeError):
    def __init__(self, message: str, code: int = 1) -> None:
        super().__init__(message)
        self.code = code


def split(vehicles: int, shards: int) -> list[tuple[int, int]]:
    """(first vehicle, count) per shard: contiguous blocks, sizes differing by at most one."""
    base, extra = divmod(vehicles, shards)
    out, first = [], 0
    for k in range(shards):
        n = base + (1 if k < extra else 0)
        out.append((first, n))
        first += n
    return out


def check(config: RunConfig) -> str | None:
    """Why ``config`` cannot run sharded, or None."""
    if config.shards < 1:
        return "--shards must be at least 1"
    if config.shards > config.vehicles:
        return f"--shards {config.shards} is more than --vehicles {config.vehicles}"
    if config.shards == 1:
        return None
    if config.network.backend != "embedded":
        return "--shards needs the embedded network (an ns-3 engine runs in one process)"
    for key in UNSUPPORTED_WITH_SHARDS:
        if getattr(config, key) is not None:
            return f"--{key.replace('_', '-')} is not supported with --shards > 1 yet"
    return None


# --- launching ----------------------------------------------------------------------------------
def in_mpi_job(environ: dict[str, str] | None = None) -> bool:
    """Whether this process was started by an MPI launcher (so it is a rank)."""
    env = os.environ if environ is None else environ
    return any(name in env for name in MPI_RANK_VARIABLES)


def mpiexec_command(shards: int, argv: list[str]) -> list[str]:
    """The MPI job that runs ``cornet <argv>`` with ``shards`` workers on this machine.
    Raises ShardError (code 2) when mpi4py or mpiexec is missing."""
    try:
        import mpi4py  # noqa: F401  (the package only; MPI starts in the ranks)
    except ImportError:
        raise ShardError(MPI_MISSING, 2) from None
    here = str(Path(sys.executable).parent)  # the venv's bin: where the mpich wheel puts it
    mpiexec = shutil.which("mpiexec", path=os.pathsep.join([here, os.environ.get("PATH", "")]))
    if mpiexec is None:
        raise ShardError("--shards needs mpiexec (none next to Python or on PATH): "
                         "pip install 'cornet[mpi]'", 2)
    return [mpiexec, "-n", str(shards + 1), sys.executable, "-m", "gateway.cli", *argv]


def launch(shards: int, argv: list[str]) -> None:
    """Replace this process with the MPI job (signals sent to this pid reach mpiexec, which
    forwards SIGINT/SIGTERM to every rank; its exit code is the job's; SIGHUP is ignored).
    Raises ShardError."""
    command = mpiexec_command(shards, argv)
    # Hydra's mpiexec dies of SIGHUP, taking the job with it; reloading is not supported
    # sharded, so the job ignores it (an ignored signal stays ignored across exec).
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(command[0], command)


def serve_rank(config: RunConfig, log_level: str) -> int:
    """This process's part of the MPI job: the coordinator on rank 0, a worker elsewhere."""
    import mpi4py

    mpi4py.rc.thread_level = "single"  # one thread per rank talks MPI
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    rank, size = comm.Get_rank(), comm.Get_size()
    k = config.shards
    if size != k + 1:
        if rank == 0:
            raise ShardError(f"--shards {k} needs an MPI job of {k + 1} ranks (a coordinator "
                             f"and {k} workers), not {size}", 2)
        return 2
    channel = Channel(comm)
    try:
        if rank == 0:
            return asyncio.run(_coordinator(config, channel))
        first, n = split(config.vehicles, k)[rank - 1]
        logging.basicConfig(
            level=log_level.upper(), stream=sys.stderr, force=True,
            format=f"%(asctime)s %(levelname)s shard {rank - 1} %(name)s: %(message)s")
        shard_config = replace(config, vehicles=n, first_vehicle=first, shards=1)
        return asyncio.run(_worker(shard_config, rank - 1, channel))
    except ShardError:
        raise
    except BaseException:
        log.exception("rank %d failed; ending the MPI job", rank)
        sys.stderr.flush()
        comm.Abort(1)
        raise


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


# --- the worker ---------------------------------------------------------------------------------
async def _worker(config: RunConfig, shard: int, channel: Channel) -> int:
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):  # the coordinator decides when everyone stops
        loop.add_signal_handler(sig, lambda: channel.send(0, {"interrupt": True}))
    loop.add_signal_handler(signal.SIGHUP, lambda: None)  # the coordinator answers SIGHUP
    try:
        daemon = Daemon(config)
        await daemon.open()
    except PortInUse as exc:
        channel.send(0, {"error": f"{exc}; is another cornet or PX4 SITL running?", "code": 2})
        await channel.flush()
        return 2
    settle_heap()  # as gateway.daemon.app.serve does
    own = {f"v{i + 1}" for i in daemon.sim.indices}
    pacer = daemon.pacer
    pacer.set_horizon(0.0)
    daemon.sim.on_sync = lambda t, pos: channel.send(0, {"sync": t, "positions": pos})
    started = [False]

    async def receive() -> None:
        while True:
            _, msg = await channel.receive()
            if msg.get("stop"):
                stop.set()
                return
            if "horizon" in msg:
                daemon.sim.remote_positions = {
                    k: tuple(v) for k, v in msg["positions"].items() if k not in own}
                if not started[0]:
                    started[0] = True
                    pacer.reanchor()
                pacer.set_horizon(msg["horizon"])

    async def report() -> None:
        while True:
            await asyncio.sleep(STATUS_PERIOD_S)
            channel.send(0, {"status": daemon.counters(), "t": daemon.sim.now})

    channel.send(0, {"ready": shard})
    tasks = [asyncio.create_task(pacer.run()), asyncio.create_task(receive()),
             asyncio.create_task(report()), asyncio.create_task(stop.wait())]
    try:
        done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        for task in done:
            failure = task.exception() if task is not tasks[3] else None
            if failure is not None:
                raise failure
    finally:
        for task in tasks:
            task.cancel()
        # Bounded: a task that ignored its cancel must not keep the whole job from stopping.
        _, stuck = await asyncio.wait(tasks, timeout=STOP_TIMEOUT_S / 2)
        if stuck:
            log.warning("%d task(s) did not end on cancel; stopping anyway", len(stuck))
        for task in set(tasks) - stuck:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                task.result()
        counters, now = daemon.counters(), daemon.sim.now
        daemon.close()
        channel.send(0, {"stopped": counters, "t": now})
        await channel.flush()
    return 0


# --- the coordinator ----------------------------------------------------------------------------
async def _coordinator(config: RunConfig, channel: Channel, ready_out=sys.stdout,
                       notifier: Notifier | None = None) -> int:
    notifier = notifier if notifier is not None else Notifier.from_env()
    k = config.shards
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    loop.add_signal_handler(signal.SIGHUP, lambda: log.warning(
        "SIGHUP: reloading is not supported with --shards > 1; restart to apply changes"))
    t0 = time.monotonic()
    counters: dict[int, dict] = {}
    sim_t: dict[int, float] = {}
    # Sync reports by sync point; a shard may report t = 0 before the last one is ready.
    reports: dict[float, dict[int, dict]] = {}
    ready: set[int] = set()
    failed: set[int] = set()

    def take(rank: int, msg: dict) -> None:
        shard = rank - 1
        if "error" in msg:
            failed.add(shard)
            raise ShardError(f"shard {shard}: {msg['error']}", int(msg.get("code", 1)))
        if "interrupt" in msg:
            stop.set()
        elif "ready" in msg:
            ready.add(shard)
        elif "sync" in msg:
            reports.setdefault(msg["sync"], {})[shard] = msg["positions"]
            sim_t[shard] = msg["sync"]
        elif "status" in msg:
            counters[shard] = msg["status"]
        elif "stopped" in msg:
            failed.add(shard)
            raise ShardError(f"shard {shard} stopped on its own")

    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while len(ready) < k and not stop.is_set():
            if time.monotonic() > deadline:
                raise ShardError(f"shards {sorted(set(range(k)) - ready)} did not start in "
                                 f"{START_TIMEOUT_S:g} s (see the log above)")
            with contextlib.suppress(asyncio.TimeoutError):
                take(*await channel.receive(0.5))
        if stop.is_set():
            return 0
        delta = config.network.sync_period_s
        speed = "max" if math.isinf(config.speed) else f"{config.speed:g}x"
        print(f"cornet ready: {config.vehicles} vehicle(s) in {k} shards, "
              f"network={config.network.summary}, speed {speed}, {_ports_text(config)}",
              file=ready_out, flush=True)
        notifier.ready(status=f"serving {config.vehicles} vehicle(s) in {k} shards")
        watchdog_s = notifier.watchdog_interval_s
        next_ping = time.monotonic()
        rtf_mark = (time.monotonic(), 0.0)
        next_status = time.monotonic() + STATUS_PERIOD_S
        while not stop.is_set():
            while (got := channel.next()) is not None:
                take(*got)  # one at a time: what follows an error stays for the stop
            # Lockstep: grant the next horizon once every shard reported the same sync point.
            for t in sorted(t for t, got in reports.items() if len(got) == k):
                everyone: dict[str, Any] = {}
                for pos in reports.pop(t).values():
                    everyone.update(pos)
                for s in range(k):
                    channel.send(s + 1, {"horizon": t + HORIZON_PERIODS * delta,
                                         "positions": everyone})
                now = time.monotonic()
                if watchdog_s is not None and now >= next_ping:
                    notifier.watchdog()  # simulated time advanced on every shard
                    next_ping = now + watchdog_s
            if time.monotonic() >= next_status and counters:
                now, t_min = time.monotonic(), min(sim_t.values(), default=0.0)
                rtf = (t_min - rtf_mark[1]) / (now - rtf_mark[0])
                rtf_mark = (now, t_min)
                next_status = now + STATUS_PERIOD_S
                log.info("%s", format_status(t_min, rtf, config.vehicles, _sum(counters),
                                             f"shards={k} "))
            await asyncio.sleep(POLL_PERIOD_S)
        return 0
    finally:
        notifier.stopping(status="stopping")
        final = await _stop_workers(channel, k, ready, failed, sim_t)
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            loop.remove_signal_handler(sig)
        t_min = min(sim_t.values(), default=0.0)
        wall = time.monotonic() - t0
        log.info("stopping after %.1f s: %s", wall,
                 format_status(t_min, t_min / wall if wall > 0 else 0.0, config.vehicles,
                               _sum({**counters, **final}), f"shards={k} "))
        notifier.close()
        if len(final) + len(failed) < k:
            log.error("shards %s did not stop; aborting the MPI job",
                      sorted(set(range(k)) - set(final) - failed))
            sys.stderr.flush()
            channel.comm.Abort(1)


async def _stop_workers(channel: Channel, k: int, ready: set[int], failed: set[int],
                        sim_t: dict[int, float]) -> dict[int, dict]:
    """Tell every live worker to stop; their final counters by shard. A worker still starting
    (compiling, binding) gets up to START_TIMEOUT_S to see the stop, the others STOP_TIMEOUT_S."""
    for shard in set(range(k)) - failed:
        channel.send(shard + 1, {"stop": True})
    wait_s = STOP_TIMEOUT_S if len(ready | failed) == k else START_TIMEOUT_S
    deadline = time.monotonic() + wait_s
    final: dict[int, dict] = {}
    while len(final) + len(failed) < k and time.monotonic() < deadline:
        try:
            rank, msg = await channel.receive(max(0.05, deadline - time.monotonic()))
        except asyncio.TimeoutError:
            break
        if "stopped" in msg:
            final[rank - 1] = msg["stopped"]
            sim_t[rank - 1] = msg["t"]
        elif "error" in msg:
            failed.add(rank - 1)
    await channel.flush()
    return final


def _sum(per_shard: dict[int, dict]) -> dict[str, int]:
    out: dict[str, int] = {}
    for counters in per_shard.values():
        for key, value in counters.items():
            out[key] = out.get(key, 0) + value
    return out
