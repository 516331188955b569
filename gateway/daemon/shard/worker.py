"""A worker rank: a normal Daemon for its block of vehicles, held to the coordinator's horizon."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import signal
from dataclasses import replace
from pathlib import Path

from gateway.daemon.app import Daemon, PortInUse, RunConfig
from gateway.daemon.heap import settle_heap
from gateway.daemon.metrics import SNAPSHOT_PERIOD_S, Exporter
from gateway.daemon.shard.channel import START_TIMEOUT_S, STOP_TIMEOUT_S, Channel
from gateway.daemon.shard.outlets import RelayPublisher
from gateway.daemon.shard.reload import ReloadFlag
from gateway.daemon.shard.signals import RankSignals
from gateway.daemon.status import STATUS_PERIOD_S
from netsim.kernel import PRIORITY_PHYSICS

log = logging.getLogger(__name__)



async def work(config: RunConfig, shard: int, channel: Channel) -> int:
    daemon_ref: list[Daemon] = []
    flag = ReloadFlag()

    def interrupt() -> None:  # the coordinator decides when everyone stops
        channel.send(0, {"interrupt": True})

    handlers = {signal.SIGINT: interrupt, signal.SIGTERM: interrupt,
                signal.SIGHUP: lambda: None,  # the coordinator answers SIGHUP
                signal.SIGUSR1: lambda: None if flag.requested() or not daemon_ref
                else daemon_ref[0].log_link_stats()}
    with RankSignals(asyncio.get_running_loop(), handlers):
        return await _run(config, shard, channel, daemon_ref)


async def _run(config: RunConfig, shard: int, channel: Channel,
               daemon_ref: list[Daemon]) -> int:
    stop = asyncio.Event()
    try:
        setup = await _setup(channel)
        if setup is None:  # stopped before it started (the coordinator could not start)
            channel.send(0, {"stopped": {}, "t": 0.0})
            await channel.flush()
            return 0
        run_dir = setup.get("run_dir")
        relay = RelayPublisher() if config.zmq_pub is not None or config.web is not None \
            else None
        daemon = Daemon(config, boot_unix_s=setup["boot_unix_s"], part=shard, publisher=relay,
                        run_dir=Path(run_dir) if run_dir is not None else None)
        await daemon.open()
    except PortInUse as exc:
        channel.send(0, {"error": f"{exc}; is another cornet or PX4 SITL running?", "code": 2})
        await channel.flush()
        return 2
    daemon_ref.append(daemon)
    settle_heap()  # as gateway.daemon.app.serve does
    own = {f"v{i + 1}" for i in daemon.sim.indices}
    pacer = daemon.pacer
    pacer.set_horizon(0.0, PRIORITY_PHYSICS)  # through sync point 0: its positions

    def on_sync(t: float, positions: dict) -> None:
        msg = {"sync": t, "positions": positions, "next": daemon.sim.next_sync_s}
        if relay is not None:
            msg["bus"] = relay.take()  # what it published since the last sync point
        channel.send(0, msg)

    daemon.sim.on_sync = on_sync
    started = [False]

    async def receive() -> None:
        while True:
            _, msg = await channel.receive()
            if msg.get("stop"):
                stop.set()
                return
            if "wants_packets" in msg and relay is not None:
                relay.wants_packets = msg["wants_packets"]
            if "horizon" in msg:
                if msg.get("reload"):  # SIGHUP: the new network from this sync point on
                    _apply_reload(daemon, msg["reload"])
                # Held right after sync point t: every vehicle's position at t, before any
                # event after it (one process pushes them all at once at t).
                daemon.sim.set_remote_positions(msg["t"], {
                    k: tuple(v) for k, v in msg["positions"].items() if k not in own})
                if not started[0]:
                    started[0] = True
                    if "epoch" in msg:
                        daemon.set_epoch(msg["epoch"])
                    pacer.reanchor()
                pacer.set_horizon(msg["horizon"], msg.get("priority"))

    async def pace() -> None:
        await pacer.run()  # returns only at the end of --duration: then wait for the others
        channel.send(0, {"finished": daemon.sim.now})
        await stop.wait()

    async def report() -> None:
        exporter = Exporter(daemon, clock=pacer.wall) if config.metrics_port is not None \
            else None
        period = SNAPSHOT_PERIOD_S if exporter is not None else STATUS_PERIOD_S
        next_status = asyncio.get_running_loop().time() + STATUS_PERIOD_S
        while True:
            if exporter is not None:  # served by the coordinator's /metrics
                channel.send(0, {"metrics": exporter.snapshot()})
            await asyncio.sleep(period)
            if asyncio.get_running_loop().time() >= next_status:
                next_status += STATUS_PERIOD_S
                channel.send(0, {"status": daemon.counters(), "t": daemon.sim.now})

    channel.send(0, {"ready": shard})
    tasks = [asyncio.create_task(pace()), asyncio.create_task(receive()),
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
        daemon.log_link_stats()  # as one process does at its stop
        daemon.close()
        channel.send(0, {"stopped": counters, "t": now})
        await channel.flush()
    return 0


def _apply_reload(daemon: Daemon, change: dict) -> None:
    """The coordinator's reload (reload.py), at the sync point this worker is held at."""
    sim = daemon.sim
    if change["wind"] != daemon.config.wind:
        sim.set_wind(change["wind"])
    on_sync, sim.on_sync = sim.on_sync, None  # the sync point is already reported
    try:
        sim.reload_network(change["network"])
    except ValueError as exc:  # the coordinator checked it; a shard must not die of it
        log.error("reload failed, keeping the running network: %s", exc)
        return
    finally:
        sim.on_sync = on_sync
    daemon.config = replace(daemon.config, network=change["network"], wind=change["wind"])
    log.info("reload: the network is now %s from t=%.3f s", change["network"].summary, sim.now)


async def _setup(channel: Channel) -> dict | None:
    """The coordinator's first word: what every shard must share (the epoch of simulated t = 0,
    the flight log's run directory); None if it says stop instead."""
    while True:
        _, msg = await channel.receive(START_TIMEOUT_S)
        if "setup" in msg:
            return msg["setup"]
        if msg.get("stop"):
            return None


