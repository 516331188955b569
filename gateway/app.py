"""The asyncio shell: binds the PX4 ports, runs the pacer, stops cleanly on SIGINT/SIGTERM.

Everything that touches sockets, signals or the wall clock lives here, in pacer.py and in
endpoint.py; the simulation itself (gateway/sim.py) runs on simulated time only.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import logging
import math
import signal
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from gateway import persist, zmq_pub
from gateway.endpoint import SourceLimiter, UdpEndpoint
from gateway.flightlog import FlightLog, new_run_dir
from gateway.mavlink.session import LinkKind
from gateway.pacer import Pacer
from gateway.sim import NetworkConfig, Simulation, px4_ports
from gateway.watch import format_link_table
from gateway.zmq_pub import Publisher
from netsim.link import Tracer, TraceWriter
from vehicles.params import ParamStore
from vehicles.types import PX4_SITL_HOME, GeoPoint

log = logging.getLogger(__name__)

STATUS_PERIOD_S = 10.0
# PX4 rcS multiplies these by PX4_SIM_SPEED_FACTOR (PX4_COMPAT.md §9).
SPEED_SCALED_PARAMS = ("COM_DL_LOSS_T", "COM_RC_LOSS_T", "COM_OF_LOSS_T", "COM_OBC_LOSS_T")


@dataclass(frozen=True)
class RunConfig:
    vehicles: int = 1
    network: NetworkConfig = field(default_factory=NetworkConfig)
    port_offset: int = 0
    bind: str = "127.0.0.1"
    remote_host: str = "127.0.0.1"
    speed: float = 1.0
    state_dir: Path | None = None  # parameters persist here, per vehicle
    zmq_pub: str | None = None  # e.g. tcp://127.0.0.1:5556: states, link stats, packet events
    home: GeoPoint = PX4_SITL_HOME  # the world's home: vehicles spawn around it
    packet_trace: Path | None = None  # the network's log: one line per datagram event
    log_dir: Path | None = None  # flight logs: DIR/run-<date>-<time>/
    params: dict[str, float] = field(default_factory=dict)  # set at every boot (--param)


def _fan_out(tracers: list[Tracer]) -> Tracer | None:
    if not tracers:
        return None
    if len(tracers) == 1:
        return tracers[0]

    def trace(*event) -> None:
        for tracer in tracers:
            tracer(*event)

    return trace


class PortInUse(OSError):
    def __init__(self, port: int, bind: str) -> None:
        super().__init__(errno.EADDRINUSE, f"UDP port {bind}:{port} is already in use")
        self.port = port

    def __str__(self) -> str:
        return str(self.strerror)


class Daemon:
    def __init__(self, config: RunConfig) -> None:
        self.config = config
        self.publisher = Publisher(config.zmq_pub) if config.zmq_pub else None
        self._trace_file = open(config.packet_trace, "w") if config.packet_trace else None
        self.flightlog = None
        if config.log_dir is not None:
            run = new_run_dir(config.log_dir, time.strftime("run-%Y%m%d-%H%M%S"))
            self.flightlog = FlightLog(run, boot_unix_s=time.time())
        tracers = [t for t in (self.publisher.packet_event if self.publisher else None,
                               TraceWriter(self._trace_file) if self._trace_file else None,
                               self.flightlog.tracer if self.flightlog else None) if t]
        self.sim = Simulation(config.vehicles, config.network, params_for=self._params_for,
                              tracer=_fan_out(tracers), home=config.home, realtime=True)
        if self.flightlog is not None:
            self.flightlog.attach(self.sim)
        if self.publisher is not None:
            pub, sim = self.publisher, self.sim
            sim.every(zmq_pub.STATE_PERIOD_S, lambda now: pub.vehicle_states(now, sim))
            sim.every(zmq_pub.LINKS_PERIOD_S, lambda now: pub.link_stats(now, sim))
        self.pacer = Pacer(self.sim.kernel, speed=config.speed)
        self.endpoints: dict[tuple[int, LinkKind], UdpEndpoint] = {}
        self.sim.on_downlink = self._send

    def _params_for(self, index: int) -> ParamStore:
        store = ParamStore({"MAV_SYS_ID": index + 1})
        if self.config.state_dir is not None:
            persist.attach(store, self.config.state_dir, index + 1)
        speed = self.config.speed
        if speed != 1.0 and math.isfinite(speed):
            # PX4's rcS with PX4_SIM_SPEED_FACTOR: time-outs that wait for clients, who live on
            # the wall clock, are counted in simulated time, so they are scaled by the factor.
            for name in SPEED_SCALED_PARAMS:
                store.set(name, store[name] * speed)
        for name, value in self.config.params.items():
            store.set(name, value)
        return store

    def _send(self, index: int, kind: LinkKind, datagram: bytes, peer: object) -> None:
        self.endpoints[(index, kind)].send(datagram, peer)  # type: ignore[arg-type]
        if self.flightlog is not None:
            self.flightlog.record_datagram("down", index, kind, datagram, self.sim.now)

    def _receiver(self, index: int, kind: LinkKind):
        def on_datagram(data: bytes, addr: tuple[str, int]) -> None:
            self.pacer.sync()  # stamp the datagram with the simulated time of its arrival
            if self.flightlog is not None:
                self.flightlog.record_datagram("up", index, kind, data, self.sim.now)
            self.sim.inject(index, kind, data, addr)

        return on_datagram

    async def open(self) -> None:
        loop = asyncio.get_running_loop()
        cfg = self.config
        try:
            for i in range(cfg.vehicles):
                for kind in (LinkKind.GCS, LinkKind.API):
                    ports = px4_ports(i, kind, cfg.port_offset)
                    endpoint = UdpEndpoint(f"vehicle {i + 1} {kind.name} :{ports.local}",
                                           (cfg.remote_host, ports.remote),
                                           self._receiver(i, kind),
                                           limiter=SourceLimiter(), clock=self.pacer.wall)
                    try:
                        endpoint.open(loop, (cfg.bind, ports.local))
                    except OSError as exc:
                        if exc.errno == errno.EADDRINUSE:
                            raise PortInUse(ports.local, cfg.bind) from exc
                        raise
                    self.endpoints[(i, kind)] = endpoint
        except BaseException:
            self.close()
            raise
        # Simulated time starts now that the ports are bound; the vehicle talks first (as PX4
        # SITL does): the first telemetry goes out as soon as the pacer runs.
        self.pacer = Pacer(self.sim.kernel, speed=cfg.speed)

    def close(self) -> None:
        for endpoint in self.endpoints.values():
            endpoint.close()
        self.sim.close()
        if self.publisher is not None:
            self.publisher.close()
        if self._trace_file is not None:
            self._trace_file.close()
        if self.flightlog is not None:
            self.flightlog.close()

    def status_line(self) -> str:
        stats = self.sim.link_stats()
        up = sum(s["delivered"] for n, s in stats.items() if n.endswith("/up"))
        down = sum(s["delivered"] for n, s in stats.items() if n.endswith("/down"))
        dropped = sum(sum(s["dropped"].values()) for s in stats.values())
        malformed = sum(link.session.stats.get("rx_malformed", 0)
                        for link in self.sim.links.values())
        limited = sum(e.stats.rx_rate_limited for e in self.endpoints.values())
        kernel_dropped = sum(e.stats.rx_kernel_dropped for e in self.endpoints.values())
        return (f"sim_t={self.sim.now:.1f}s rtf={self.pacer.real_time_factor():.2f} "
                f"vehicles={self.config.vehicles} datagrams_up={up} datagrams_down={down} "
                f"net_dropped={dropped} malformed={malformed} rate_limited={limited} "
                f"kernel_dropped={kernel_dropped} "
                f"internal_errors={self.sim.internal_errors} slips={self.pacer.slips}")

    def log_link_stats(self) -> None:
        """On SIGUSR1 and at exit: every link's counters and latency percentiles."""
        log.info("%s", format_link_table(self.sim.link_stats(), self.sim.now))

    async def _report(self) -> None:
        while True:
            await asyncio.sleep(STATUS_PERIOD_S)
            log.info("%s", self.status_line())


async def serve(config: RunConfig, ready_out=sys.stdout) -> int:
    daemon = Daemon(config)
    await daemon.open()
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    loop.add_signal_handler(signal.SIGUSR1, daemon.log_link_stats)
    cfg = config
    ports = ", ".join(
        f"v{i + 1} gcs {px4_ports(i, LinkKind.GCS, cfg.port_offset).local}"
        f"->{px4_ports(i, LinkKind.GCS, cfg.port_offset).remote}"
        f" api {px4_ports(i, LinkKind.API, cfg.port_offset).local}"
        f"->{px4_ports(i, LinkKind.API, cfg.port_offset).remote}"
        for i in range(min(cfg.vehicles, 4))
    ) + (" ..." if cfg.vehicles > 4 else "")
    speed = "max" if math.isinf(cfg.speed) else f"{cfg.speed:g}x"
    print(f"cornet ready: {cfg.vehicles} vehicle(s), network={cfg.network.summary}, "
          f"speed {speed}, {ports}",
          file=ready_out, flush=True)
    t0 = time.monotonic()
    tasks = [asyncio.create_task(daemon.pacer.run(), name="pacer"),
             asyncio.create_task(daemon._report(), name="status"),
             asyncio.create_task(stop.wait(), name="stop")]
    try:
        done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        for task in done:
            if task.get_name() != "stop" and task.exception() is not None:
                raise task.exception()  # a crashed pacer must not look like a clean stop
    finally:
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1):
            loop.remove_signal_handler(sig)
        daemon.log_link_stats()
        log.info("stopping after %.1f s: %s", time.monotonic() - t0, daemon.status_line())
        daemon.close()
    return 0
