"""The simulation assembly: kernel + world + per-link MAVLink sessions + network links.

No sockets and no wall clock here: this is the whole data path of the daemon on simulated time,
so tests (and lockstep users) drive it with ``sim.run(until=...)``. The asyncio shell adds only
the pacer (wall clock → ``run``) and UDP endpoints (``inject`` in, ``on_downlink`` out).

Path of one datagram (STYLE.md "one message, fewest hops"):
  inject → uplink Link (model: delay/drop) → delivery event → Session.receive_datagram → vehicle
  session timer / reply → Session.datagrams_to_send → downlink Link → delivery → on_downlink.

Invariants:
- One kernel owns time. Physics runs on a fixed 250 Hz grid (priority PHYSICS, so at equal
  times the world is stepped before packets are delivered and telemetry is sampled).
- Each vehicle has at most one pending timer event in the heap (``VehicleWake``, wake.py), for the
  earliest deadline of its links' sessions, re-armed after every call into one of them.
- Every random draw comes from a stream named after its link (and hop), seeded from
  ``NetworkConfig.seed``.
- A vehicle's links are keyed by tag (gateway/sim/radios.py): PX4 SITL's GCS and API links,
  then one per extra radio of the network. All of them drive the same vehicle and share its
  telemetry samples and its plan-upload lock; each has its own session, peer and path.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from functools import partial

from gateway.mavlink.command_table import SeenComponents
from gateway.mavlink.mission import UploadLock
from gateway.mavlink.session import LinkKind, Session
from gateway.mavlink.signing import SigningConfig
from gateway.mavlink.snapshot import SampleCache
from gateway.sim.command_timeline import Command
from gateway.sim.radios import ExtraRadio, LinkTag, Ports, link_ports, px4_ports, tag_name
from gateway.sim.scenario import NetworkConfig
from gateway.sim.wake import VehicleWake
from netsim.backend import EmbeddedBackend, NetworkBackend
from netsim.kernel import PRIORITY_PHYSICS, Kernel, Ticker
from netsim.link import Tracer
from netsim.rng import named_generator
from netsim.topology import make_router
from vehicles.faults import TYPES, UNITS, Fault
from vehicles.params import ParamStore
from vehicles.types import PX4_SENSORS, PX4_SITL_HOME, GeoPoint, SensorConfig
from vehicles.wind import Wind, WindConfig
from vehicles.world import World

log = logging.getLogger(__name__)

PHYSICS_DT_S = 0.004  # 250 Hz, PX4 SITL lockstep rate
__all__ = ["PHYSICS_DT_S", "Ports", "Simulation", "VehicleLink", "px4_ports"]

# (vehicle index, link tag, datagram, peer): peer is the opaque address of the client the
# link last heard a valid MAVLink frame from, or None before that (then: PX4's preset remote).
DownlinkHandler = Callable[[int, LinkTag, bytes, object], None]
# One link's: (datagram, peer).
LinkDownlinkHandler = Callable[[bytes, object], None]


def _nowhere(packet: bytes, peer: object) -> None:
    """The downlink's end while nobody takes its datagrams."""


class VehicleLink:
    """One MAVLink link of one vehicle: a session between an uplink and a downlink.
    ``tag``: which link (a LinkKind, or an extra radio's name); ``kind``: its session's."""

    def __init__(self, sim: Simulation, index: int, tag: LinkTag, session: Session,
                 wake: VehicleWake) -> None:
        """``wake``: the vehicle's timer, shared by its links (this one joins it)."""
        self.sim = sim
        self.index = index
        self.tag = tag
        self.kind = session.kind
        self.session = session
        self.name = f"v{index + 1}/{tag_name(tag)}"
        # An extra radio is a node of its own that moves with its vehicle (push_mobility).
        vehicle_node = f"v{index + 1}" if isinstance(tag, LinkKind) else f"v{index + 1}.{tag}"
        client_node = f"api{index + 1}" if tag is LinkKind.API else "gcs"
        self._nodes = (client_node, vehicle_node)  # the uplink's (src, dst)
        self.uplink = sim.backend.make_link(f"{self.name}/up", client_node, vehicle_node,
                                            self._on_uplink_delivered)
        self._on_downlink: LinkDownlinkHandler | None = None
        self.downlink = sim.backend.make_link(f"{self.name}/down", vehicle_node, client_node,
                                              _nowhere)
        self.deadline_s = math.inf  # when the session wants ``handle_timer`` next
        self.wake = wake
        wake.links.append(self)

    def rewire(self, backend: NetworkBackend) -> None:
        """Take both directions from ``backend`` (a reloaded network), keeping their counters:
        packets already in flight on the old links arrive as the old links decided, and are
        counted in the same statistics."""
        client, vehicle = self._nodes
        uplink = backend.make_link(self.uplink.name, client, vehicle, self._on_uplink_delivered)
        downlink = backend.make_link(self.downlink.name, vehicle, client,
                                     self.downlink.deliver)
        uplink.stats, downlink.stats = self.uplink.stats, self.downlink.stats
        self.uplink, self.downlink = uplink, downlink

    @property
    def peer(self) -> object:
        """The client the session answers: where it last heard a valid frame for this vehicle
        from (Session.peer), None before that."""
        return self.session.peer

    # --- uplink: client → vehicle ---------------------------------------------------------------
    def _on_uplink_delivered(self, packet: bytes, peer: object) -> None:
        try:
            self.session.receive_datagram(packet, self.sim.kernel.now, peer)
        except Exception:
            # A bug in handling one message must not take down every vehicle of the daemon.
            self.sim.session_failed(self.name, "handling a datagram")
        self.service()

    # --- downlink: vehicle → client -------------------------------------------------------------
    @property
    def on_downlink(self) -> LinkDownlinkHandler | None:
        """Where this link's downlink delivers ``(datagram, peer)`` (None: nowhere): the
        simulation's ``on_downlink`` bound to this link, or a client's own handler. It is the
        downlink's ``deliver`` itself, so a delivery costs no call in between (every datagram
        of every vehicle goes this way)."""
        return self._on_downlink

    @on_downlink.setter
    def on_downlink(self, handler: LinkDownlinkHandler | None) -> None:
        self._on_downlink = handler
        self.downlink.deliver = _nowhere if handler is None else handler

    def timer_failed(self) -> None:
        self.sim.session_failed(self.name, "in a session timer")

    def flush(self, now: float) -> None:
        """Push what the session wants to send into the downlink; note its next deadline."""
        session = self.session
        for datagram in session.datagrams_to_send(now):
            self.downlink.send(datagram, session.peer)
        deadline = session.get_timer()
        self.deadline_s = math.inf if deadline is None else deadline

    def service(self) -> None:
        """``flush``, then re-arm the vehicle's timer for the new deadline."""
        self.flush(self.sim.kernel.now)
        self.wake.arm()


def make_backend(kernel: Kernel, network: NetworkConfig, tracer: Tracer | None = None, *,
                 realtime: bool = False) -> NetworkBackend:
    """The network backend a scenario names (see gateway/sim/scenario.py). ``realtime``: the
    daemon's pacer runs the kernel against the wall clock, so an external backend must never
    make it wait (late packets then follow the late policy); otherwise it runs in lockstep."""
    if network.backend == "embedded":
        router, positions = make_router(network.topology)
        return EmbeddedBackend(kernel, router, seed=network.seed,
                               sync_period_s=network.sync_period_s, fixed_positions=positions,
                               tracer=tracer)
    from netsim.ns3.bridge import Ns3Backend  # imported on demand: it spawns a process

    config = dict(network.ns3)
    strict = bool(config.pop("strict", False))
    config.setdefault("engine", "reference" if network.backend == "ns3-reference" else "ns3")
    return Ns3Backend(kernel, config, seed=network.seed, sync_period_s=network.sync_period_s,
                      late_policy=network.late_policy, realtime=realtime, strict=strict,
                      tracer=tracer)


def default_params(index: int, overrides: dict[str, float] | None = None) -> ParamStore:
    """PX4 defaults, MAV_SYS_ID = instance + 1 (as PX4's rcS sets it), then ``overrides``."""
    return ParamStore({"MAV_SYS_ID": index + 1, **(overrides or {})})


class Simulation:
    def __init__(self, vehicles: int, network: NetworkConfig | None = None,
                 param_overrides: dict[str, float] | None = None,
                 physics_dt_s: float = PHYSICS_DT_S,
                 params_for: Callable[[int], ParamStore] | None = None,
                 tracer: Tracer | None = None, home: GeoPoint = PX4_SITL_HOME,
                 realtime: bool = False,
                 link_kinds: Sequence[LinkKind] = (LinkKind.GCS, LinkKind.API),
                 signing: SigningConfig | None = None, first_index: int = 0,
                 wind: WindConfig | None = None,
                 sensors: SensorConfig = PX4_SENSORS, faults: Sequence[Fault] = (),
                 spawn_ned_m: Sequence[tuple[float, float]] = (),
                 extra_radios: bool = True, commands: Sequence[Command] = (),
                 boot_unix_s: float | None = None) -> None:
        """``params_for(index)`` builds each vehicle's parameter store (default:
        ``default_params(index, param_overrides)``); the shell uses it to add persistence.
        ``link_kinds``: the MAVLink links each vehicle has (the daemon: both, as PX4 SITL; an
        in-process lockstep run may leave out a link no client listens to). ``first_index``: the
        instance number of the first vehicle (a shard of a larger daemon simulates vehicles
        first_index … first_index + vehicles − 1; ports, sysids and spawn points follow it).
        ``spawn_ned_m``: the scenario's spawn points, by instance number (World).
        ``extra_radios``: build a link per extra radio of the network (the daemon); False
        leaves them out (a lockstep run whose clients use only ``link_kinds``). ``commands``:
        the scenario's command timeline (gateway/sim/command_timeline.py), each at its time.
        ``boot_unix_s``: the Unix time of simulated t = 0, the vehicles' real-time clock
        (SYSTEM_TIME; None: none, so none is sent); ``set_epoch`` moves it before time starts."""
        if vehicles < 1:
            raise ValueError("need at least one vehicle")
        if not link_kinds:
            raise ValueError("need at least one link kind")
        self.link_kinds = tuple(k for k in LinkKind if k in link_kinds)
        self.kernel = Kernel()
        self.network = network or NetworkConfig()
        self.radios: tuple[ExtraRadio, ...] = self.network.radios if extra_radios else ()
        self._tracer = tracer
        self.backend: NetworkBackend = make_backend(self.kernel, self.network, tracer,
                                                    realtime=realtime)
        self._observers: list[Ticker] = []
        air = self._air(wind)
        # Sensor noise: vehicle N's from the stream "sensors/vN" of the scenario's seed.
        seed = self.network.seed
        self.world = World(dt_s=physics_dt_s, home=home, wind=air, sensors=sensors,
                           rng_for=lambda i: named_generator(seed, f"sensors/v{i + 1}"),
                           spawn_ned_m=spawn_ned_m)
        self._on_downlink: DownlinkHandler | None = None
        self._outer_errors = 0  # failures that escaped a session (its own are in its stats)
        self._next_error_log_s = -math.inf
        self.vehicles = []
        self.links: dict[tuple[int, LinkTag], VehicleLink] = {}
        self.indices = list(range(first_index, first_index + vehicles))
        # Positions of vehicles simulated elsewhere (other shards), by node, pushed with ours.
        self.remote_positions: dict[str, tuple[float, float, float]] = {}
        # Called at every sync point with our vehicles' positions (the shard reports them).
        self.on_sync: Callable[[float, dict[str, tuple[float, float, float]]], None] | None = None
        for i in self.indices:
            if params_for is not None:
                params = params_for(i)
            else:
                params = default_params(i, param_overrides)
            vehicle = self.world.add_vehicle(index=i, params=params)
            self.vehicles.append(vehicle)
            # Both links of a vehicle sample it at the same instants: they share what telemetry
            # derives from one kinematics sample (snapshot.SampleCache).
            samples = SampleCache()
            uploads = UploadLock()  # one plan upload at a time, whichever link it comes on
            seen = SeenComponents()  # what each link heard (a command for it is forwarded)
            wake = VehicleWake(self.kernel)  # and one timer event for all its links
            for kind in self.link_kinds:
                session = Session(vehicle, kind, now_s=0.0, signing=signing, uploads=uploads,
                                  seen=seen, boot_unix_s=boot_unix_s)
                session.samples = samples
                self.links[(i, kind)] = VehicleLink(self, i, kind, session, wake)
            for radio in self.radios:  # PX4's extra instances: Normal mode, GCS streams
                session = Session(vehicle, LinkKind.GCS, now_s=0.0, signing=signing,
                                  uploads=uploads, signing_link_id=1 + radio.number, seen=seen,
                                  boot_unix_s=boot_unix_s)
                session.samples = samples
                self.links[(i, radio.name)] = VehicleLink(self, i, radio.name, session, wake)
        self._physics = Ticker(self.kernel, physics_dt_s, self.world.step,
                               priority=PRIORITY_PHYSICS)
        # The scenario's fault timeline (vehicles/faults.py): each at its time, before the
        # physics step of that instant; ``faults_fired`` records what happened when.
        self.faults = tuple(faults)
        self.faults_fired: list[tuple[float, Fault]] = []
        self.fault_observers: list[Callable[[float, Fault], None]] = []  # the ZeroMQ bus
        for fault in faults:
            k = fault.vehicle - 1 - first_index
            if fault.on_network or 0 <= k < len(self.vehicles):
                self.kernel.schedule(fault.at_s, self._fault, k, fault, priority=PRIORITY_PHYSICS)
        for command in commands:
            k = command.vehicle - 1 - first_index
            if 0 <= k < len(self.vehicles):
                self.kernel.schedule(command.at_s, self._command, k, command)
        # CORNET: the physics clock is the reference; mobility reaches the network once per
        # sync period (scheduled after the physics step of the same instant).
        self._spawn_ned = [self.world.spawn_offset_ned_m(i) for i in self.indices]
        self._nodes = [f"v{i + 1}" for i in self.indices]  # each vehicle's network node
        self._mobility = Ticker(self.kernel, self.backend.sync_period_s, self._push_mobility,
                                priority=PRIORITY_PHYSICS)
        start = getattr(self.backend, "start", None)
        if start is not None:  # an external backend: set its network up before time runs,
            start(self.vehicle_positions_ned_m())  # with the vehicles where they spawned
        for link in self.links.values():
            link.flush(self.kernel.now)
        for link in self.links.values():
            link.wake.arm()

    @property
    def on_downlink(self) -> DownlinkHandler | None:
        """Where every link's delivered datagrams go: ``handler(index, tag, datagram, peer)``
        (None: nowhere). Setting it sets each link's ``VehicleLink.on_downlink``."""
        return self._on_downlink

    @on_downlink.setter
    def on_downlink(self, handler: DownlinkHandler | None) -> None:
        self._on_downlink = handler
        for link in self.links.values():
            link.on_downlink = None if handler is None else partial(handler, link.index, link.tag)

    def _fault(self, k: int, fault: Fault) -> None:
        if not fault.on_network:  # network events are the topology's outage windows
            self.vehicles[k].apply_failure(UNITS[fault.unit], TYPES[fault.type], fault.instance)
        self.faults_fired.append((self.kernel.now, fault))
        log.info("fault at t=%.3f s: %s", self.kernel.now, fault.describe())
        for observer in self.fault_observers:
            observer(self.kernel.now, fault)

    def _command(self, k: int, command: Command) -> None:
        result = command.apply(self.vehicles[k], self.kernel.now)
        log.info("command at t=%.3f s: %s: %s", self.kernel.now, command.describe(), result.name)

    def _air(self, wind: WindConfig | None) -> Wind | None:
        """The air: gusts drawn from the stream "wind" of the scenario's seed."""
        if wind is None or wind.calm:
            return None
        return Wind(wind, named_generator(self.network.seed, "wind"))

    def set_wind(self, wind: WindConfig) -> None:
        """A new mean wind and gusts from now on (SIGHUP); the gusts restart from the seed."""
        self.world.set_wind(self._air(wind))

    @property
    def now(self) -> float:
        return self.kernel.now

    @property
    def link_tags(self) -> tuple[LinkTag, ...]:
        """Every vehicle's links: PX4 SITL's (``link_kinds``), then one per extra radio."""
        return (*self.link_kinds, *(r.name for r in self.radios))

    def ports(self, index: int, tag: LinkTag, offset: int = 0) -> Ports:
        """The UDP ports of vehicle ``index``'s link ``tag`` (bound by the shell)."""
        return link_ports(index, tag, self.radios, offset)

    def vehicle_positions_ned_m(self) -> dict[str, tuple[float, float, float]]:
        """Every vehicle's position in the world frame (NED from the world's home), by node."""
        out = {}
        # where its radio really is; the world's rows are our vehicles, in order
        for node, (n0, e0), (n, e, d) in zip(self._nodes, self._spawn_ned,
                                             self.world.true_positions_ned_m()):
            out[node] = (n0 + n, e0 + e, d)
        return out

    def ground_nodes(self) -> list[dict]:
        """The network's nodes that stay put and have a position — the star's access point, the
        ad hoc topology's ground radio, the extra radios' ground stations, ns-3's positioned
        nodes — each ``{"name", "kind", "world_ned_m", "serves"}``; ``serves``: the link tags
        (gcs, api, an extra radio's name) whose radio hop ends there. Empty for direct links."""
        backend = self.backend
        radios = {r.name for r in self.radios}
        out = []
        if isinstance(backend, EmbeddedBackend):
            topology = self.network.topology
            hub_kind = {"star": "ap", "adhoc": "gcs"}.get(topology.get("topology", "direct"))
            hub_serves = ["gcs"] if topology.get("api_clients") == "onboard" else ["gcs", "api"]
            for name, position in backend.mobility.positions.items():
                if name in radios:
                    out.append({"name": name, "kind": "radio", "world_ned_m": position,
                                "serves": [name]})
                elif hub_kind is not None and not self._is_vehicle_node(name):
                    out.append({"name": name, "kind": hub_kind, "world_ned_m": position,
                                "serves": hub_serves})
            return out
        positions: dict = getattr(backend, "positions", {})
        for name, kind in getattr(backend, "nodes", {}).items():
            if name in positions and kind in ("ap", "enb"):
                out.append({"name": name, "kind": kind, "world_ned_m": positions[name],
                            "serves": ["gcs", "api"]})
        return out

    def _is_vehicle_node(self, name: str) -> bool:
        return name[:1] == "v" and name[1:].partition(".")[0].isdigit()

    @property
    def internal_errors(self) -> int:
        """Bugs met while handling clients' input or building telemetry: every one is counted
        and skipped (the vehicles fly on); the log holds the first traceback."""
        return self._outer_errors + sum(link.session.stats.handler_errors
                                        for link in self.links.values())

    def session_failed(self, link: str, what: str) -> None:
        """Called from an ``except`` block: counted; logged at most once per 10 s."""
        self._outer_errors += 1
        if self.kernel.now >= self._next_error_log_s:
            self._next_error_log_s = self.kernel.now + 10.0
            log.error("%s: error %s (%d so far)", link, what, self._outer_errors,
                      exc_info=self._outer_errors == 1)

    def set_epoch(self, boot_unix_s: float) -> None:
        """Every link's clocks (SYSTEM_TIME, signing) take simulated t = 0 to be the Unix time
        ``boot_unix_s``: the shell stamps it when its pacer starts time."""
        for link in self.links.values():
            link.session.set_epoch(boot_unix_s)

    def every(self, period_s: float, callback: Callable[[float], None]) -> Ticker:
        """Call ``callback(now)`` every ``period_s`` of simulated time (observers: logs, ZMQ)."""
        ticker = Ticker(self.kernel, period_s, callback)
        self._observers.append(ticker)
        return ticker

    def _with_radios(self, positions: dict[str, tuple[float, float, float]]) -> dict:
        if self.radios:  # a vehicle's extra radios (nodes v1.lte …) are where it is
            names = [r.name for r in self.radios]
            positions = {**positions, **{f"{node}.{name}": p for node, p in positions.items()
                                         for name in names}}
        return positions

    def _push_mobility(self, now_s: float) -> None:
        ours = self.vehicle_positions_ned_m()
        positions = {**self.remote_positions, **ours} if self.remote_positions else ours
        self.backend.update_mobility(now_s, self._with_radios(positions))
        if self.on_sync is not None:
            self.on_sync(now_s, ours)

    @property
    def next_sync_s(self) -> float:
        """The next sync point (when the mobility update runs next)."""
        return self._mobility.next_s

    def set_remote_positions(self, sync_s: float,
                             positions: dict[str, tuple[float, float, float]]) -> None:
        """The other shards' vehicles at sync point ``sync_s``, which this shard has just
        passed (nothing but physics since): the network sees them from now on, as one process
        that pushed every vehicle at ``sync_s`` does."""
        self.remote_positions = positions
        self.backend.update_mobility(sync_s, self._with_radios(positions))

    def inject(self, index: int, tag: LinkTag, datagram: bytes, peer: object = None) -> None:
        """A datagram from client ``peer`` arrives at the vehicle's port now: into the uplink."""
        self.links[(index, tag)].uplink.send(datagram, peer)

    def run(self, until: float) -> None:
        self.kernel.run(until=until)

    def reload_network(self, network: NetworkConfig) -> None:
        """Rebuild every link's model from ``network`` at the present simulated time, keeping
        vehicles, sessions, the peers they reply to, and link counters. Packets already in
        flight arrive as the old models decided. Random streams restart from ``network.seed``
        (a reload is an input: the same reload at the same time gives the same run).

        Embedded → embedded only: an external backend (ns-3) owns a process whose network is
        built once, so either side being external raises ValueError and changes nothing; so
        does an invalid topology."""
        for what, config in (("running", self.network), ("new", network)):
            if config.backend != "embedded":
                raise ValueError(f"the {what} network uses the {config.backend} backend; only "
                                 "embedded networks can be reloaded (restart the daemon instead)")
        if network.radios != self.network.radios:
            raise ValueError("the extra radios (names, ports) changed: their links and ports "
                             "are built at start (restart the daemon instead)")
        backend = make_backend(self.kernel, network, self._tracer)
        for link in self.links.values():
            link.rewire(backend)
        old, self.backend, self.network = self.backend, backend, network
        old.close()
        # The new models must know where the vehicles are now, not at the next sync tick.
        self._push_mobility(self.kernel.now)
        if backend.sync_period_s != self._mobility.period_s:
            self._mobility.cancel()
            self._mobility = Ticker(self.kernel, backend.sync_period_s, self._push_mobility,
                                    priority=PRIORITY_PHYSICS)

    def link_stats(self) -> dict[str, dict]:
        out = {}
        for link in self.links.values():
            out[link.uplink.name] = link.uplink.stats.as_dict()
            out[link.downlink.name] = link.downlink.stats.as_dict()
        return out

    def close(self) -> None:
        self._physics.cancel()
        self._mobility.cancel()
        for ticker in self._observers:
            ticker.cancel()
        self.backend.close()
        close = getattr(self.world, "close", None)
        if close is not None:
            close()
