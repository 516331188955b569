"""Sharded daemon: the vehicles split across worker processes, kept in lockstep.

``cornet run --vehicles N --shards K`` starts K worker processes. Worker k simulates a
contiguous block of vehicles in its own PyBullet world and event kernel, binds those vehicles'
PX4 ports itself and paces itself on the wall clock — the same ``Daemon`` as one process runs,
given ``first_vehicle`` and its share of ``vehicles``. This process is the coordinator: it
starts the workers, keeps their simulated clocks together and carries every vehicle's position
to every worker, so distance-based network models see all vehicles.

Protocol (pyzmq; the coordinator's ROUTER on an ephemeral loopback TCP port, each worker a
DEALER with identity ``shard-<k>``; every message one JSON object):

  worker → coordinator
    {"ready": k}                          ports bound, simulation built, simulated t = 0
    {"error": text, "code": 2}            could not start (e.g. a port in use); it exits
    {"sync": t, "positions": {node: [n, e, d]}}
                                          reached the sync point t (every sync period of the
                                          network, the CORNET mobility update); its vehicles'
                                          world-frame positions at t
    {"status": {counter: value}, "t": t}  every status period (wall), for the status line
    {"stopped": {counter: value}, "t": t} after a stop: final counters; then it exits 0
  coordinator → worker
    {"horizon": h, "positions": {...}}    run simulated time up to h; the other shards'
                                          vehicles were at these positions at the last sync
    {"stop": true}

Lockstep rule: when every worker has reported sync point t, each is granted the horizon
t + 1.5·δ (δ = the sync period): it runs through the next sync point t + δ and stops short of
the one after. So no two shards are ever more than 1.5·δ apart in simulated time, and a shard
that falls behind holds the others (they slip, as one overloaded process would). A worker's
network sees the other shards' vehicles one sync period late (their positions at t arrive with
the grant that runs to t + δ).

Limits: the embedded network only (an ns-3 engine belongs to one process); no --zmq-pub,
--log-dir, --packet-trace, --metrics-port or SIGHUP reload with more than one shard yet.
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
import json
import logging
import math
import multiprocessing
import signal
import sys
import time
from dataclasses import replace
from typing import Any

import zmq
import zmq.asyncio

from gateway.daemon.app import (
    STATUS_PERIOD_S,
    Daemon,
    PortInUse,
    RunConfig,
    _ports_text,
    format_status,
)
from gateway.daemon.sdnotify import Notifier

log = logging.getLogger(__name__)

START_TIMEOUT_S = 60.0
STOP_TIMEOUT_S = 5.0
HORIZON_PERIODS = 1.5
UNSUPPORTED_WITH_SHARDS = ("zmq_pub", "log_dir", "packet_trace", "metrics_port")


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


# --- the worker ---------------------------------------------------------------------------------
def worker_main(config: RunConfig, shard: int, endpoint: str, log_level: str) -> None:
    logging.basicConfig(level=log_level.upper(), stream=sys.stderr,
                        format=f"%(asctime)s %(levelname)s shard {shard} %(name)s: %(message)s")
    sys.exit(asyncio.run(_worker(config, shard, endpoint)))


async def _worker(config: RunConfig, shard: int, endpoint: str) -> int:
    ctx = zmq.asyncio.Context()
    sock = ctx.socket(zmq.DEALER)
    sock.setsockopt(zmq.IDENTITY, f"shard-{shard}".encode())
    sock.setsockopt(zmq.LINGER, 1000)
    sock.connect(endpoint)

    def send(msg: dict) -> None:
        sock.send(json.dumps(msg, separators=(",", ":")).encode())

    try:
        daemon = Daemon(config)
        await daemon.open()
    except PortInUse as exc:
        send({"error": f"{exc}; is another cornet or PX4 SITL running?", "code": 2})
        await asyncio.sleep(0.2)
        sock.close()
        ctx.term()
        return 2
    gc.collect()
    gc.freeze()  # as gateway.daemon.app.serve does
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    loop.add_signal_handler(signal.SIGHUP, lambda: None)  # the coordinator answers SIGHUP
    own = {f"v{i + 1}" for i in daemon.sim.indices}
    pacer = daemon.pacer
    pacer.set_horizon(0.0)
    daemon.sim.on_sync = lambda t, pos: send({"sync": t, "positions": pos})
    started = [False]

    async def receive() -> None:
        while True:
            msg = json.loads(await sock.recv())
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
            send({"status": daemon.counters(), "t": daemon.sim.now})

    send({"ready": shard})
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
        for task in tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        counters, now = daemon.counters(), daemon.sim.now
        daemon.close()
        send({"stopped": counters, "t": now})
        await asyncio.sleep(0.05)
        sock.close()
        ctx.term()
    return 0


# --- the coordinator ----------------------------------------------------------------------------
async def serve_sharded(config: RunConfig, log_level: str, ready_out=sys.stdout,
                        notifier: Notifier | None = None) -> int:
    notifier = notifier if notifier is not None else Notifier.from_env()
    k = config.shards
    ctx = zmq.asyncio.Context()
    router = ctx.socket(zmq.ROUTER)
    router.setsockopt(zmq.LINGER, 0)
    router.bind("tcp://127.0.0.1:*")
    endpoint = router.getsockopt_string(zmq.LAST_ENDPOINT)
    mp = multiprocessing.get_context("spawn")
    procs = []
    for shard, (first, n) in enumerate(split(config.vehicles, k)):
        cfg = replace(config, vehicles=n, first_vehicle=first, shards=1)
        p = mp.Process(target=worker_main, args=(cfg, shard, endpoint, log_level),
                       name=f"cornet-shard-{shard}")
        p.start()
        procs.append(p)

    async def recv(timeout_s: float | None = None) -> tuple[int, dict]:
        ident, data = await asyncio.wait_for(router.recv_multipart(), timeout_s)
        return int(ident.decode().split("-")[1]), json.loads(data)

    def send(shard: int, msg: dict) -> None:
        router.send_multipart([f"shard-{shard}".encode(),
                               json.dumps(msg, separators=(",", ":")).encode()])

    def stop_workers() -> None:
        for shard in range(k):
            with contextlib.suppress(zmq.ZMQError):
                send(shard, {"stop": True})

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
    try:
        ready: set[int] = set()
        deadline = time.monotonic() + START_TIMEOUT_S
        while len(ready) < k:
            left = deadline - time.monotonic()
            if left <= 0 or any(p.exitcode not in (None, 0) for p in procs):
                raise ShardError("a shard did not start (see its log above)")
            try:
                shard, msg = await recv(min(left, 0.5))
            except asyncio.TimeoutError:
                continue
            if "error" in msg:
                raise ShardError(f"shard {shard}: {msg['error']}", int(msg.get("code", 1)))
            if "ready" in msg:
                ready.add(shard)
            elif "sync" in msg:
                reports.setdefault(msg["sync"], {})[shard] = msg["positions"]
                sim_t[shard] = msg["sync"]
        delta = config.network.sync_period_s
        speed = "max" if math.isinf(config.speed) else f"{config.speed:g}x"
        print(f"cornet ready: {config.vehicles} vehicle(s) in {k} shards, "
              f"network={config.network.summary}, speed {speed}, {_ports_text(config)}",
              file=ready_out, flush=True)
        notifier.ready(status=f"serving {config.vehicles} vehicle(s) in {k} shards")
        watchdog_s = notifier.watchdog_interval_s
        next_ping = time.monotonic()
        # Lockstep: grant the next horizon once every shard reported the same sync point.
        rtf_mark = (time.monotonic(), 0.0)
        next_status = time.monotonic() + STATUS_PERIOD_S
        stop_task = asyncio.ensure_future(stop.wait())
        while not stop.is_set():
            recv_task = asyncio.ensure_future(recv())
            done, _ = await asyncio.wait({recv_task, stop_task}, timeout=1.0,
                                         return_when=asyncio.FIRST_COMPLETED)
            if recv_task not in done:
                recv_task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await recv_task
                if any(not p.is_alive() for p in procs):
                    raise ShardError("a shard process ended unexpectedly")
                continue
            shard, msg = recv_task.result()
            if "sync" in msg:
                reports.setdefault(msg["sync"], {})[shard] = msg["positions"]
                sim_t[shard] = msg["sync"]
            elif "status" in msg:
                counters[shard] = msg["status"]
            elif "stopped" in msg:
                raise ShardError(f"shard {shard} stopped on its own")
            for t in sorted(t for t, got in reports.items() if len(got) == k):
                everyone: dict[str, Any] = {}
                for pos in reports.pop(t).values():
                    everyone.update(pos)
                for s in range(k):
                    send(s, {"horizon": t + HORIZON_PERIODS * delta, "positions": everyone})
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
        stop_task.cancel()
        return 0
    finally:
        notifier.stopping(status="stopping")
        stop_workers()
        deadline = time.monotonic() + STOP_TIMEOUT_S
        final: dict[int, dict] = {}
        while len(final) < k and time.monotonic() < deadline:
            try:
                shard, msg = await recv(max(0.05, deadline - time.monotonic()))
            except (asyncio.TimeoutError, zmq.ZMQError):
                break
            if "stopped" in msg:
                final[shard] = msg["stopped"]
                sim_t[shard] = msg["t"]
        for p in procs:
            p.join(timeout=max(0.1, deadline - time.monotonic()))
            if p.is_alive():
                p.kill()
                p.join()
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            loop.remove_signal_handler(sig)
        t_min = min(sim_t.values(), default=0.0)
        wall = time.monotonic() - t0
        log.info("stopping after %.1f s: %s", wall,
                 format_status(t_min, t_min / wall if wall > 0 else 0.0, config.vehicles,
                               _sum({**counters, **final}), f"shards={k} "))
        router.close()
        ctx.term()
        notifier.close()


def _sum(per_shard: dict[int, dict]) -> dict[str, int]:
    out: dict[str, int] = {}
    for counters in per_shard.values():
        for key, value in counters.items():
            out[key] = out.get(key, 0) + value
    return out
