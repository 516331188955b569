"""The asyncio shell: binds the PX4 ports, runs the pacer, stops cleanly on SIGINT/SIGTERM.

Everything that touches sockets, signals, systemd or the wall clock lives here, in pacer.py,
endpoint.py and sdnotify.py; the simulation itself (gateway/sim/simulation.py) runs on simulated time only.

Under systemd (Type=notify, systemd/cornet.service): READY=1 once every port is bound and the
vehicles have started talking; WATCHDOG=1 from the pacer's loop while the simulation is healthy
(``sdnotify.Watchdog``); SIGHUP re-reads the configuration file and rebuilds the network (RELOADING=1 …
READY=1); SIGTERM/SIGINT send STOPPING=1, close the logs and exit 0.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import ipaddress
import logging
import math
import os
import select
import signal
import sys
import time
from collections.abc import Callable
from dataclasses import fields, replace
from pathlib import Path

from gateway.bus import zmq_pub
from gateway.bus.watch import format_link_table
from gateway.bus.zmq_pub import Publisher
from gateway.daemon import state
from gateway.daemon.admission import Admission
from gateway.daemon.config import RunConfig  # re-exported: the daemon's settings
from gateway.daemon.endpoint import UdpEndpoint
from gateway.daemon.heap import settle_heap
from gateway.daemon.metrics import Exporter, MetricsServer
from gateway.daemon.pacer import Pacer
from gateway.daemon.progress import ProgressLine
from gateway.daemon.px4_sitl import first_peers, home_text, log_first_peer, speed_text
from gateway.daemon.sdnotify import Notifier, Watchdog
from gateway.daemon.status import STATUS_PERIOD_S, format_status, ports_summary
from gateway.mavlink.signing import SigningConfig, SigningState
from gateway.onboard.files import attach_ftp
from gateway.onboard.logs import Logs
from gateway.onboard.shell import attach_shells
from gateway.sim.flightlog import FlightLog, link_vehicle, new_run_dir, part_name, split_frames
from gateway.sim.radios import LinkTag, tag_name
from gateway.sim.scenario import ScenarioError
from gateway.sim.simulation import Simulation
from gateway.web import start as start_web
from netsim.link import InstantSortedTrace, fan_out
from vehicles.params import ParamStore

log = logging.getLogger(__name__)

LIVE_LINE_PERIOD_S = 0.5
# PX4 rcS multiplies these by PX4_SIM_SPEED_FACTOR (ROMFS init.d-posix/rcS).
SPEED_SCALED_PARAMS = ("COM_DL_LOSS_T", "COM_RC_LOSS_T", "COM_OF_LOSS_T", "COM_OBC_LOSS_T")


class MetricsPortError(OSError):
    """The metrics HTTP port could not be opened."""


class PortInUse(OSError):
    def __init__(self, port: int, bind: str, code: int = errno.EADDRINUSE) -> None:
        what = "is already in use" if code == errno.EADDRINUSE else \
            f"cannot be bound ({os.strerror(code)}: {bind} is not an address of this machine)"
        super().__init__(code, f"UDP port {bind}:{port} {what}")
        self.port = port
        self.in_use = code == errno.EADDRINUSE

    def __str__(self) -> str:
        return str(self.strerror)


class Daemon:
    def __init__(self, config: RunConfig, notifier: Notifier | None = None, *,
                 boot_unix_s: float | None = None, run_dir: Path | None = None,
                 part: int | None = None, publisher: Publisher | None = None) -> None:
        """A shard of a sharded run (gateway/daemon/shard/) is given the flight log ``run_dir``
        (the coordinator's), and the run's epoch with its first grant (``set_epoch``); it writes
        its ``part`` of the files (gateway/sim/logparts.py merges them) and publishes into the
        ``publisher`` it is given (the coordinator's socket publishes)."""
        self.config = config
        self.part = part
        self.notifier = notifier or Notifier()  # no socket: notifications are no-ops
        self.publisher = publisher if publisher is not None else \
            Publisher(config.zmq_pub) if config.zmq_pub or config.web else None
        trace = config.packet_trace
        self._trace_file = open(trace.with_name(part_name(trace.name, part)), "w") \
            if trace is not None else None
        self.flightlog = None
        if boot_unix_s is None:  # simulated t = 0 on the wall clock until time starts (set_epoch)
            boot_unix_s = time.time()
        if config.log_dir is not None:
            run = run_dir if run_dir is not None else new_run_dir(
                config.log_dir, time.strftime("run-%Y%m%d-%H%M%S"))
            self.flightlog = FlightLog(run, boot_unix_s=boot_unix_s, part=part)
        signing = None
        self._state_writer = state.StateWriter() if config.state_dir is not None else None
        self._signing_keeper: state.SigningKeeper | None = None
        if (key := config.signing_key) is not None:
            if config.state_dir is not None and self._state_writer is not None:
                self._signing_keeper = state.SigningKeeper(self._state_writer, config.state_dir,
                                                           config.first_vehicle + 1, key,
                                                           config.ignore_bad_state)
            signing = SigningConfig(key, epoch_unix_s=boot_unix_s, state=(
                self._signing_keeper.state if self._signing_keeper else SigningState()))
            log.info("MAVLink 2 signing on (key %s): unsigned and badly signed frames are "
                     "refused", key.fingerprint)
        self._vehicle_states: dict[int, state.VehicleState] = {}
        self._trace = InstantSortedTrace(self._trace_file, link_vehicle) \
            if self._trace_file is not None else None
        tracers = [t for t in (self.publisher.packet_event if self.publisher else None,
                               self._trace,
                               self.flightlog.tracer if self.flightlog else None) if t]
        self.sim = Simulation(config.vehicles, config.network, params_for=self._params_for,
                              tracer=fan_out(tracers), home=config.home, realtime=True,
                              signing=signing, first_index=config.first_vehicle, wind=config.wind,
                              sensors=config.sensors, faults=config.faults, boot_unix_s=boot_unix_s,
                              spawn_ned_m=config.spawn_ned_m, commands=config.commands)
        self._restore_plans()
        if self._signing_keeper is not None:
            self.sim.every(1.0, self._signing_keeper.save)
        if self.flightlog is not None:
            self.flightlog.attach(self.sim)
        # PX4's logger, when there is somewhere to keep its logs (PX4 needs its SD card too):
        # <state dir>/vehicle-<sysid>/log/… and <run dir>/vehicle-<sysid>/log/….
        roots = [d for d in (config.state_dir, self.flightlog.dir if self.flightlog else None)
                 if d is not None]
        attach_ftp(self.sim, lambda sysid: [state.vehicle_dir(r, sysid) for r in roots])
        # Without storage the loggers only stream (MAV_CMD_LOGGING_START).
        self.logs = Logs(self.sim, lambda sysid: [state.vehicle_dir(r, sysid) for r in roots],
                         boot_unix_s, storage=bool(roots))
        attach_shells(self.sim, self.logs.loggers.get, self._transport)
        if self.publisher is not None:
            pub, sim = self.publisher, self.sim
            sim.every(zmq_pub.STATE_PERIOD_S, lambda now: pub.vehicle_states(now, sim))
            sim.every(zmq_pub.LINKS_PERIOD_S, lambda now: pub.link_stats(now, sim))
            sim.fault_observers.append(pub.fault)
        self.pacer = Pacer(self.sim.kernel, speed=config.speed, end_s=config.duration)
        self.endpoints: dict[tuple[int, LinkTag], UdpEndpoint] = {}
        self._waiting: select.epoll | None = None  # every endpoint's socket, once open

    def _params_for(self, index: int) -> ParamStore:
        """Boot one vehicle's parameters: PX4's defaults, the saved values, the speed-scaled
        time-outs not saved, ``--param`` (gateway/daemon/state.py says why in that order)."""
        sysid = index + 1
        store = ParamStore({"MAV_SYS_ID": sysid})
        cfg = self.config
        saved = state.Saved()
        if cfg.state_dir is not None:
            saved = state.load(cfg.state_dir, sysid, cfg.ignore_bad_state)
            state.apply_params(store, saved.params, state.params_path(cfg.state_dir, sysid))
        speed = cfg.speed
        if speed != 1.0 and math.isfinite(speed):
            # PX4's rcS with PX4_SIM_SPEED_FACTOR: time-outs that wait for clients, who live on
            # the wall clock, are counted in simulated time, so they are scaled by the factor.
            for name in SPEED_SCALED_PARAMS:
                if name not in saved.params:
                    store.set_default(name, state.scaled_value(store, name, speed))
        # Launch values are defaults (PX4's rcS ``param set-default``): a reset keeps them.
        for name, value in {**cfg.params, **cfg.vehicle_params.get(sysid, {})}.items():
            store.set_default(name, value)
        if cfg.state_dir is not None and self._state_writer is not None:
            kept = state.VehicleState(self._state_writer, cfg.state_dir, sysid, saved)
            self._vehicle_states[sysid] = kept
            # From now on what clients set, and what PX4 saves without notification.
            store.on_change(kept.on_param, quiet=True)
            store.on_stored(kept.on_param_stored)  # written with the next save, as PX4 does
        return store

    def _restore_plans(self) -> None:
        """The saved mission, geofence and rally points (PX4's dataman), then keep them."""
        for vehicle in self.sim.vehicles:
            kept = self._vehicle_states.get(int(vehicle.params["MAV_SYS_ID"]))
            if kept is not None:
                state.restore_plans(vehicle, kept)

    def _route(self, index: int, kind: LinkTag, endpoint: UdpEndpoint) -> Callable[[bytes, object], None]:
        """Where link (index, kind)'s downlink delivers: its endpoint, then the flight log; without
        broadcast and log, ``endpoint.send`` itself (the path of every datagram of every vehicle)."""
        record = None if self.flightlog is None else self.flightlog.recorder("down", index, kind)
        if endpoint.broadcast is None and record is None:
            return endpoint.send  # type: ignore[return-value]  # peer: the address it heard
        session, kernel = self.sim.links[(index, kind)].session, self.sim.kernel

        def send(datagram: bytes, peer: object) -> None:
            endpoint.send(datagram, peer,  # type: ignore[arg-type]
                          endpoint.broadcast is not None and session.gcs_present(kernel.now))
            if record is not None:
                record(split_frames(datagram), kernel.now)

        return send

    def _transport(self, index: int, tag: LinkTag) -> tuple[int, int, bool] | None:
        """``mavlink status``'s view of a link's UDP port (None before it is open)."""
        endpoint = self.endpoints.get((index, tag))
        if endpoint is None:
            return None
        ports = self.sim.ports(index, tag, self.config.port_offset)
        return ports.local, ports.remote, endpoint.broadcast is not None

    def _receiver(self, index: int, kind: LinkTag):
        link = self.sim.links[(index, kind)]  # its uplink is ``sim.inject``'s, without lookup
        record = None if self.flightlog is None else self.flightlog.recorder("up", index, kind)
        def on_datagram(data: bytes, addr: tuple[str, int]) -> None:
            self.pacer.sync_arrival()  # stamp it with its arrival time, never behind a burst
            if record is not None:
                record(split_frames(data), self.sim.now)
            link.uplink.send(data, addr)
            # What the network delivers at once (an ideal link) is handled now, as PX4 answers
            # at once: a reply does not wait for the pacer's next wake-up.
            self.pacer.run_due()

        return on_datagram

    async def open(self) -> None:
        loop = asyncio.get_running_loop()
        cfg = self.config
        try:
            for i, kind in self.sim.links:  # PX4 SITL's two links, then the extra radios
                ports = self.sim.ports(i, kind, cfg.port_offset)
                peer, broadcast = first_peers(self.sim, i, kind, ports.remote, bind=cfg.bind,
                                              remote_host=cfg.remote_host, gcs=cfg.gcs)
                endpoint = UdpEndpoint(f"vehicle {i + 1} {tag_name(kind)} :{ports.local}",
                                       peer, self._receiver(i, kind), broadcast=broadcast,
                                       admission=Admission(), clock=self.pacer.wall)
                try:
                    endpoint.open(loop, (cfg.bind, ports.local))
                except OSError as exc:
                    if exc.errno in (errno.EADDRINUSE, errno.EADDRNOTAVAIL):
                        raise PortInUse(ports.local, cfg.bind, exc.errno) from exc
                    raise
                self.endpoints[(i, kind)] = endpoint
                self.sim.links[(i, kind)].on_downlink = self._route(i, kind, endpoint)
        except BaseException:
            self.close()
            raise
        first, last = self.sim.indices[0], self.sim.indices[-1]
        for radio in self.sim.radios:
            a, b = (self.sim.ports(i, radio.name, cfg.port_offset) for i in (first, last))
            log.info("extra radio %s: vehicles %d..%d bind %d..%d, talk first to %d", radio.name,
                     first + 1, last + 1, a.local, b.local, a.remote)
        # The pacer asks this between events, so that a datagram waiting on any vehicle port
        # is read at once, not after the rest of a burst of simulation.
        waiting = self._waiting = select.epoll()
        for endpoint in self.endpoints.values():
            if endpoint.sock is not None:
                waiting.register(endpoint.sock.fileno(), select.EPOLLIN)
        # Simulated time starts now that the ports are bound (a shard's: at the coordinator's
        # first grant); the vehicles talk first, as PX4 SITL does.
        self.pacer = Pacer(self.sim.kernel, speed=cfg.speed, input_pending=self._input_pending,
                           end_s=cfg.duration)
        if self.part is None:
            self.set_epoch(time.time())

    def set_epoch(self, boot_unix_s: float) -> None:
        """Simulated t = 0 is Unix time ``boot_unix_s``: SYSTEM_TIME, signing, the logs' stamps."""
        self.sim.set_epoch(boot_unix_s)
        self.logs.set_epoch(boot_unix_s)
        if self.flightlog is not None:
            self.flightlog.set_epoch(boot_unix_s)

    def _input_pending(self) -> bool:
        waiting = self._waiting
        return waiting is not None and bool(waiting.poll(0, 1))

    def close(self) -> None:
        if self._waiting is not None:
            self._waiting.close()
            self._waiting = None
        for endpoint in self.endpoints.values():
            endpoint.close()
        if self.logs is not None:
            self.logs.close()
        self.sim.close()
        if self.publisher is not None:
            self.publisher.close()
        if self._trace is not None and self._trace_file is not None:
            self._trace.flush()
            self._trace_file.close()
        if self.flightlog is not None:
            self.flightlog.close()
        if self._signing_keeper is not None:
            self._signing_keeper.save()
        if self._state_writer is not None:
            self._state_writer.close()  # what clients changed last is on disk before we exit

    def counters(self) -> dict[str, int]:
        """What the status line counts (summed over shards by the coordinator)."""
        stats = self.sim.link_stats()
        sessions = [link.session.stats for link in self.sim.links.values()]
        out = {
            "datagrams_up": sum(s["delivered"] for n, s in stats.items() if n.endswith("/up")),
            "datagrams_down": sum(s["delivered"] for n, s in stats.items()
                                  if n.endswith("/down")),
            "net_dropped": sum(sum(s["dropped"].values()) for s in stats.values()),
            "malformed": sum(st.rx_malformed for st in sessions),
            "rate_limited": sum(e.stats.rx_rate_limited for e in self.endpoints.values()),
            "kernel_dropped": sum(e.stats.rx_kernel_dropped for e in self.endpoints.values()),
        }
        if self.config.signing_key is not None:
            out["unsigned"] = sum(st.rx_unsigned for st in sessions)
            out["bad_signature"] = sum(st.rx_bad_signature + st.rx_replayed for st in sessions)
        out["internal_errors"] = self.sim.internal_errors
        out["slips"] = self.pacer.slips
        return out

    def status_line(self) -> str:
        return format_status(self.sim.now, self.pacer.real_time_factor(), self.config.vehicles,
                             self.counters())

    def short_status(self) -> str:
        """systemd's STATUS= (what `systemctl status cornet` shows)."""
        return (f"{self.config.vehicles} vehicle(s), network {self.sim.network.summary}, "
                f"sim_t={self.sim.now:.0f}s, internal_errors={self.sim.internal_errors}")

    def log_link_stats(self) -> None:
        """On SIGUSR1 and at exit: every link's counters and latency percentiles."""
        log.info("%s", format_link_table(self.sim.link_stats(), self.sim.now))

    def reload(self, load: Callable[[], RunConfig] | None) -> bool:
        """SIGHUP: re-read the configuration file and rebuild the running simulation's network
        and wind from it; vehicles, sessions and parameters stay. Other changes in the file take
        effect at the next start (each is logged). An invalid file, or a network that cannot be swapped
        (ns-3), keeps the running network. True if the file's network is now in effect."""
        if load is None:
            log.warning("SIGHUP: started without --config or --scenario; nothing to re-read")
            return False
        running = self.sim.network.summary
        try:
            new = load()
        except ScenarioError as exc:
            log.error("reload failed, keeping the running network (%s): %s", running, exc)
            return False
        if new.wind != self.config.wind:
            self.sim.set_wind(new.wind)
            log.info("reload: the wind is now %s (was %s)", new.wind, self.config.wind)
            self.config = replace(self.config, wind=new.wind)
        for f in fields(RunConfig):
            before, after = getattr(self.config, f.name), getattr(new, f.name)
            if f.name != "network" and after != before:
                log.warning("reload: %s changed (%s -> %s); it takes effect at the next start",
                            f.name, before, after)
        if new.network == self.sim.network:
            log.info("reload: the network is unchanged (%s)", running)
            return True
        self.pacer.sync()  # the new network starts at the present moment
        try:
            self.sim.reload_network(new.network)
        except ValueError as exc:
            log.error("reload failed, keeping the running network (%s): %s", running, exc)
            return False
        self.config = replace(self.config, network=new.network)
        log.info("reload: the network is now %s (was %s) from t=%.3f s; vehicles and sessions "
                 "kept", new.network.summary, running, self.sim.now)
        return True

    async def _live_line(self, line: ProgressLine) -> None:
        """Faster-than-real-time runs on a terminal: one line redrawn in place (simulated time,
        real-time factor, vehicle 1's mode), cleared before each log record."""
        def clear_first(record: logging.LogRecord) -> bool:
            line.clear()
            return True

        handlers = logging.getLogger().handlers
        for h in handlers:
            h.addFilter(clear_first)
        try:
            prev = (self.pacer.wall(), self.sim.now)
            while True:
                await asyncio.sleep(LIVE_LINE_PERIOD_S)
                wall, now = self.pacer.wall(), self.sim.now
                rtf = (now - prev[1]) / (wall - prev[0]) if wall > prev[0] else 0.0
                prev = (wall, now)
                st = self.sim.vehicles[0].status
                line.update(now, f"sim_t={now:.0f}s rtf={rtf:.0f}x "
                                 f"vehicles={self.config.vehicles} v1: {st.nav_state.name}"
                                 f"{' armed' if st.armed else ''}", force=True)
        finally:
            for h in handlers:
                h.removeFilter(clear_first)
            line.close()

    async def _report(self) -> None:
        while True:
            await asyncio.sleep(STATUS_PERIOD_S)
            log.info("%s", self.status_line())
            if self.flightlog is not None:
                try:
                    self.flightlog.sync()
                except OSError as exc:  # a full disk must not stop the flight
                    log.error("flight log: %s", exc)
            self.notifier.status(self.short_status())


async def serve(config: RunConfig, ready_out=sys.stdout, *,
                reload: Callable[[], RunConfig] | None = None,
                notifier: Notifier | None = None) -> int:
    """Run the daemon until SIGINT/SIGTERM. ``reload`` re-reads the configuration file on
    SIGHUP (raising ScenarioError if it is invalid); ``notifier`` talks to systemd (default: as
    $NOTIFY_SOCKET says, a no-op without it)."""
    notifier = notifier if notifier is not None else Notifier.from_env()
    daemon = Daemon(config, notifier)
    await daemon.open()
    settle_heap()
    if not ipaddress.ip_address(config.bind).is_loopback:
        log.warning("the vehicles' ports are open to the network on %s%s", config.bind,
                    "" if config.signing_key is not None else
                    " without MAVLink signing: anyone who can reach them can fly the vehicles "
                    "(--signing-key)")
        if config.gcs is None:
            log_first_peer(config.bind, config.remote_host, 14550 + config.port_offset)
    metrics = None
    if config.metrics_port is not None:
        metrics = MetricsServer(Exporter(daemon, clock=daemon.pacer.wall), config.bind,
                                config.metrics_port)
        try:
            await metrics.start()
        except OSError as exc:
            daemon.close()
            raise MetricsPortError(f"--metrics-port {config.metrics_port}: {exc.strerror}") \
                from exc
        log.info("metrics: http://%s:%d/metrics", config.bind, metrics.port)
    web = None
    if config.web is not None and daemon.publisher is not None:
        try:
            web = await start_web(config.web, daemon.publisher)
        except OSError:
            if metrics is not None:
                metrics.close()
            daemon.close()
            raise
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    handled = (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1, signal.SIGHUP)
    tasks: list[asyncio.Task] = []
    t0 = time.monotonic()
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        loop.add_signal_handler(signal.SIGUSR1, daemon.log_link_stats)

        def on_sighup() -> None:
            notifier.reloading(status="reloading the network")
            try:
                daemon.reload(reload)
            finally:  # systemd waits for READY=1 to leave the "reloading" state
                notifier.ready(status=daemon.short_status())

        loop.add_signal_handler(signal.SIGHUP, on_sighup)
        # The vehicles talk first, as PX4 SITL does: their first telemetry leaves now, before
        # anyone is told the daemon is ready.
        daemon.pacer.sync()
        cfg = config
        speed = speed_text(cfg.speed, cfg.environment)
        print(f"cornet ready: {cfg.vehicles} vehicle(s), network={cfg.network.summary}, "
              f"speed {speed}, {ports_summary(cfg)}{home_text(cfg.home, cfg.environment)}",
              file=ready_out, flush=True)
        notifier.ready(status=f"serving {cfg.vehicles} vehicle(s) on {cfg.bind}, network "
                              f"{cfg.network.summary}, speed {speed}")
        interval = notifier.watchdog_interval_s
        watchdog = None
        if interval is not None:
            watchdog = Watchdog(notifier, daemon.sim, interval, daemon.pacer.wall)
            log.info("systemd watchdog: pinging every %.3f s while simulated time advances",
                     interval)
        tasks = [asyncio.create_task(daemon.pacer.run(watchdog.poll if watchdog else None),
                                     name="pacer"),
                 asyncio.create_task(daemon._report(), name="status"),
                 asyncio.create_task(stop.wait(), name="stop")]
        if cfg.speed > 1.0 and sys.stderr.isatty():
            tasks.append(asyncio.create_task(daemon._live_line(ProgressLine(sys.stderr)),
                                             name="live"))
        done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        for task in done:
            failure = task.exception() if task.get_name() != "stop" else None
            if failure is not None:
                raise failure  # a crashed pacer must not look like a clean stop
    finally:
        notifier.stopping(status="stopping")
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        for sig in handled:
            loop.remove_signal_handler(sig)
        daemon.log_link_stats()
        log.info("stopping after %.1f s: %s", time.monotonic() - t0, daemon.status_line())
        if metrics is not None:
            metrics.close()
        if web is not None:
            await web.close()
        daemon.close()
        notifier.close()
    return 0
