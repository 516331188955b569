"""Rank 0: the ready and status lines, the lockstep grants, the positions, the merged logs."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import zmq

from gateway.bus.zmq_pub import Publisher
from gateway.daemon.config import RunConfig
from gateway.daemon.metrics import MetricsServer
from gateway.daemon.sdnotify import Notifier
from gateway.daemon.shard.channel import START_TIMEOUT_S, STOP_TIMEOUT_S, Channel
from gateway.daemon.shard.launch import ShardError
from gateway.daemon.shard.outlets import BusMerger, ShardedExporter
from gateway.daemon.shard.reload import ReloadFlag, prepare
from gateway.daemon.shard.signals import RankSignals
from gateway.daemon.status import STATUS_PERIOD_S, format_status, ports_summary
from gateway.sim import logparts
from gateway.sim.flightlog import new_run_dir
from gateway.web import start as start_web
from gateway.web.address import WebListenError
from netsim.kernel import PRIORITY_PHYSICS

if TYPE_CHECKING:
    from gateway.web.server import WebServer

log = logging.getLogger(__name__)



async def coordinate(config: RunConfig, channel: Channel, ready_out=sys.stdout,
                       notifier: Notifier | None = None,
                       reload: Callable[[], RunConfig] | None = None) -> int:
    notifier = notifier if notifier is not None else Notifier.from_env()
    k = config.shards
    stop = asyncio.Event()
    reloading = asyncio.Event()  # SIGHUP (relayed by the launcher as SIGUSR1 + flag)
    flag = ReloadFlag()

    def on_sigusr1() -> None:  # not a relayed SIGHUP: the workers log link stats
        if flag.requested():
            reloading.set()

    signals = RankSignals(asyncio.get_running_loop(), {
        signal.SIGINT: stop.set, signal.SIGTERM: stop.set, signal.SIGHUP: reloading.set,
        signal.SIGUSR1: on_sigusr1})
    t0 = time.monotonic()
    # One epoch and one flight log directory for the whole run, chosen here.
    run_dir = None
    bus: BusMerger | None = None
    exporter: ShardedExporter | None = None
    metrics: MetricsServer | None = None
    web: WebServer | None = None
    counters: dict[int, dict] = {}
    sim_t: dict[int, float] = {}
    # Sync reports by sync point; a shard may report t = 0 before the last one is ready.
    reports: dict[float, dict[int, dict]] = {}
    ready: set[int] = set()
    failed: set[int] = set()
    finished: set[int] = set()

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
            reports.setdefault(msg["sync"], {})[shard] = msg
            sim_t[shard] = msg["sync"]
            if bus is not None:
                bus.take(shard, msg.get("bus", ()))
        elif "metrics" in msg:
            if exporter is not None:
                exporter.take(shard, msg["metrics"])
        elif "finished" in msg:  # --duration reached: stop when every shard has
            finished.add(shard)
            if len(finished) == k:
                stop.set()
        elif "status" in msg:
            counters[shard] = msg["status"]
        elif "stopped" in msg:
            failed.add(shard)
            raise ShardError(f"shard {shard} stopped on its own")

    try:
        # The outlets of every vehicle are here: a port in use stops the run before it starts.
        bus, exporter, metrics, web = await _open_outlets(config)
        if config.log_dir is not None:
            run_dir = new_run_dir(config.log_dir, time.strftime("run-%Y%m%d-%H%M%S"))
        setup = {"boot_unix_s": time.time(),
                 "run_dir": None if run_dir is None else str(run_dir)}
        for shard in range(k):
            channel.send(shard + 1, {"setup": setup})
        deadline = time.monotonic() + START_TIMEOUT_S
        while len(ready) < k and not stop.is_set():
            if time.monotonic() > deadline:
                raise ShardError(f"shards {sorted(set(range(k)) - ready)} did not start in "
                                 f"{START_TIMEOUT_S:g} s (see the log above)")
            with contextlib.suppress(asyncio.TimeoutError):
                take(*await channel.receive(0.5))
        if stop.is_set():
            return 0
        speed = "max" if math.isinf(config.speed) else f"{config.speed:g}x"
        announced = False  # ready once simulated time runs (the vehicles talk), as one process
        reloaded = False  # READY=1 again once every shard has applied the reload
        watchdog_s = notifier.watchdog_interval_s
        next_ping = time.monotonic()
        rtf_mark = (time.monotonic(), 0.0)
        next_status = time.monotonic() + STATUS_PERIOD_S
        while not stop.is_set():
            while (got := channel.next()) is not None:
                take(*got)  # one at a time: what follows an error stays for the stop
            if bus is not None and bus.subscriptions_changed():
                for s in range(k):
                    channel.send(s + 1, {"wants_packets": bus.wants_packets})
            # Lockstep: grant the next horizon once every shard reported the same sync point.
            for t in sorted(t for t, some in reports.items() if len(some) == k):
                change = None
                if reloaded:  # every shard reported the sync point after the reload's grant:
                    reloaded = False  # all of them run the new network
                    notifier.ready(status=f"serving {config.vehicles} vehicle(s) in {k} "
                                          f"shards, network {config.network.summary}")
                if reloading.is_set():
                    reloading.clear()
                    notifier.reloading(status="reloading the network")
                    config, change = prepare(config, reload)
                    reloaded = True
                everyone: dict[str, Any] = {}
                reported = reports.pop(t)
                for report in reported.values():
                    everyone.update(report["positions"])
                # Through the next sync point (the same on every shard: one period grid),
                # held right after its positions are reported.
                horizon = min(report["next"] for report in reported.values())
                grant = {"horizon": horizon, "priority": PRIORITY_PHYSICS, "t": t,
                         "positions": everyone, "reload": change}
                if t == 0.0:  # the first grant starts time: its wall-clock moment is t = 0's
                    grant["epoch"] = time.time()
                for s in range(k):
                    channel.send(s + 1, grant)
                if not announced and t > 0:  # every shard has run its first sync period
                    announced = True
                    print(f"cornet ready: {config.vehicles} vehicle(s) in {k} shards, "
                          f"network={config.network.summary}, speed {speed}, "
                          f"{ports_summary(config)}", file=ready_out, flush=True)
                    notifier.ready(status=f"serving {config.vehicles} vehicle(s) in {k} shards")
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
            await channel.wait()  # a worker's message rings, else the poll period
        return 0
    finally:
        signals.close()  # everyone stops: a late signal from mpiexec must not kill this rank
        notifier.stopping(status="stopping")
        final = await _stop_workers(channel, k, ready, failed, sim_t)
        t_min = min(sim_t.values(), default=0.0)
        wall = time.monotonic() - t0
        log.info("stopping after %.1f s: %s", wall,
                 format_status(t_min, t_min / wall if wall > 0 else 0.0, config.vehicles,
                               _sum({**counters, **final}), f"shards={k} "))
        _merge_logs(config, run_dir)
        if web is not None:
            await web.close()
        if metrics is not None:
            metrics.close()
        if bus is not None:
            bus.publisher.close()
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


async def _open_outlets(config: RunConfig) -> tuple[BusMerger | None, ShardedExporter | None,
                                                   MetricsServer | None, WebServer | None]:
    """--zmq-pub's socket, --metrics-port's server and --web's live view, for every shard's
    vehicles. Raises ShardError (code 2) naming the flag when one cannot be opened."""
    bus = exporter = metrics = web = None
    if config.zmq_pub is not None or config.web is not None:
        try:  # --web alone: a publisher without a socket, feeding the live view
            bus = BusMerger(Publisher(config.zmq_pub), config.shards)
        except zmq.ZMQError as exc:
            raise ShardError(f"--zmq-pub {config.zmq_pub}: {exc}", 2) from None
    try:
        if config.metrics_port is not None:
            exporter = ShardedExporter()
            metrics = MetricsServer(exporter, config.bind, config.metrics_port)
            try:
                await metrics.start()
            except OSError as exc:
                raise ShardError(f"--metrics-port {config.metrics_port}: {exc.strerror}; "
                                 "choose a free port", 2) from None
            log.info("metrics: http://%s:%d/metrics (every shard's vehicles)", config.bind,
                     metrics.port)
        if config.web is not None and bus is not None:
            try:
                web = await start_web(config.web, bus.publisher)
            except WebListenError as exc:
                raise ShardError(str(exc), 2) from None
    except ShardError:
        if metrics is not None:
            metrics.close()
        if bus is not None:
            bus.publisher.close()
        raise
    return bus, exporter, metrics, web


def _merge_logs(config: RunConfig, run_dir: Path | None) -> None:
    """The shards' parts of the files that hold every vehicle, made one file each."""
    try:
        if run_dir is not None:
            logparts.merge_run_dir(run_dir, config.shards)
            log.info("flight log: %s", run_dir)
        if config.packet_trace is not None:
            logparts.merge_trace(config.packet_trace, config.shards)
    except (OSError, ValueError) as exc:
        log.error("merging the shards' logs: %s", exc)


def _sum(per_shard: dict[int, dict]) -> dict[str, int]:
    out: dict[str, int] = {}
    for counters in per_shard.values():
        for key, value in counters.items():
            out[key] = out.get(key, 0) + value
    return out
