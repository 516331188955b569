"""Scenario files: vehicles, network (topology, models, seeds), sync period, late policy, logging,
and the daemon's own settings.

A scenario is a TOML file (docs/scenarios.md shows every key); the daemon's configuration file
(``cornet run --config``, e.g. systemd/cornet.toml) is the same format:

    [vehicles]
    count = 3                       # how many
    home = {lat_deg = 47.397742, lon_deg = 8.545594, alt_amsl_m = 488.0}
    airframe = "x500"
    params = {NAV_DLL_ACT = 2}      # PX4 parameters set on every vehicle at start

    [network]
    backend = "embedded"            # or "ns3"
    seed = 1
    sync_period_s = 0.02            # mobility → network, and external backends' cycle
    late_policy = "drop"            # "drop" (the CORNET paper's rule) or "deliver"
    topology = "star"               # the rest of [network] is netsim.topology's
    ...
    extra_radios = [{name = "lte", radio = {model = "fixed", latency_s = 0.04}}]  # radios.py

    [logging]
    level = "info"

    [daemon]                        # what `cornet run` flags set; a flag given wins
    bind = "127.0.0.1"
    port_offset = 0
    speed = 1.0                     # or "max"
    state_dir = "/var/lib/cornet"   # relative paths are relative to the file's directory
    log_dir = "/var/log/cornet"
    zmq_pub = "tcp://127.0.0.1:5556"
    packet_trace = "packets.trace"
    web = "127.0.0.1:8080"          # the live view ([ADDR:]PORT)
    # log_level = "info"            # or [logging] level: set one of them

Every error names the key's path and the file (``lossy.toml: network.radio.mcs: ...``); the CLI
turns it into exit code 2. Nothing here opens a socket: loading a scenario also validates every
model parameter, so ``cornet check`` catches what ``cornet run`` would trip on.
"""

from __future__ import annotations

import ipaddress
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gateway.data import scenario_path
from gateway.sim import param_files
from gateway.sim.command_timeline import Command, parse_commands
from gateway.sim.fault_timeline import parse_faults
from gateway.sim.radios import ExtraRadio, check_radio_ports, radio_ports, split_entries
from gateway.sim.values import ScenarioError, gcs_partner, listen_address, spawn_points
from gateway.sim.values import choice as _choice
from gateway.sim.values import number as _number
from gateway.sim.values import table as _table
from gateway.sim.values import unknown as _unknown
from netsim.topology import make_router
from vehicles.faults import Fault
from vehicles.params import ParamStore
from vehicles.types import PX4_SITL_HOME, GeoPoint, SensorConfig, grid_spawn_ned_m
from vehicles.wind import WindConfig

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

BACKENDS = ("embedded", "ns3", "ns3-reference")
LATE_POLICIES = ("drop", "deliver")
AIRFRAMES = ("x500",)
LOG_LEVELS = ("debug", "info", "warning", "error")
DEFAULT_SYNC_PERIOD_S = 0.02
# One MAVLink network: system ids 1..254 (0 is broadcast, 255 the GCS by convention).
MAX_VEHICLES = 254
# The ns-3 bridge's sync period: under a physics step's fraction it only burns CPU; over a
# second, mobility updates are too coarse for a radio model.
MIN_SYNC_PERIOD_S = 0.001
MAX_SYNC_PERIOD_S = 1.0
MIN_HOME_ALT_M = -500.0  # the Dead Sea shore is -430 m
MAX_HOME_ALT_M = 9000.0
MAX_SPEED = 1000.0  # as `cornet run --speed` (gateway/cli_args.py)
MAX_PORT = 65535
HIGHEST_BASE_PORT = 18570  # vehicle i's GCS port 18570+i is the highest it binds (gateway/sim/simulation.py)
DAEMON_KEYS = ("bind", "port_offset", "speed", "state_dir", "log_dir", "zmq_pub", "packet_trace",
               "log_level", "signing_key", "metrics_port", "web", "gcs")
NETWORK_OWN_KEYS = ("backend", "seed", "sync_period_s", "late_policy", "ns3")


@dataclass(frozen=True)
class NetworkConfig:
    """What the simulation needs to build its network backend."""

    backend: str = "embedded"
    topology: dict = field(default_factory=dict)  # netsim.topology config ([network] minus ours)
    seed: int = 0
    sync_period_s: float = DEFAULT_SYNC_PERIOD_S
    late_policy: str = "drop"
    ns3: dict = field(default_factory=dict)  # options of the ns-3 backend
    # Every vehicle's extra radios (gateway/sim/radios.py); their hops are in ``topology``.
    radios: tuple[ExtraRadio, ...] = ()

    @property
    def summary(self) -> str:
        topo = self.topology.get("topology", "direct")
        if self.backend != "embedded":
            return f"{self.backend}/{self.ns3.get('topology', 'adhoc')}"
        extra = "".join(f"+{r.name}" for r in self.radios)
        if topo == "direct":
            link = self.topology.get("link")
            model = "ideal" if link is None else link.get("model", "fixed")
            return f"{self.backend}/{model}{extra}"
        return f"{self.backend}/{topo}{extra}"

    @staticmethod
    def from_flags(latency_ms: float, jitter_ms: float, loss: float, seed: int) -> NetworkConfig:
        """The CLI's --latency-ms/--jitter-ms/--loss: one `fixed` hop on every link direction."""
        if latency_ms == 0 and jitter_ms == 0 and loss == 0:
            return NetworkConfig(seed=seed)
        link = {"model": "fixed", "latency_s": latency_ms / 1e3, "jitter_s": jitter_ms / 1e3,
                "loss": loss}
        return NetworkConfig(topology={"topology": "direct", "link": link}, seed=seed)


@dataclass(frozen=True)
class DaemonSettings:
    """The ``[daemon]`` table: what `cornet run` flags set. None: not set in the file (the flag,
    or the built-in default, applies). The log level is ``Scenario.log_level``."""

    bind: str | None = None  # an IPv4 address
    port_offset: int | None = None
    speed: float | None = None  # math.inf for "max"
    state_dir: Path | None = None
    log_dir: Path | None = None
    zmq_pub: str | None = None
    packet_trace: Path | None = None
    signing_key: Path | None = None  # MAVLink 2 signing key file (gateway/mavlink/signing.py)
    metrics_port: int | None = None  # Prometheus /metrics on bind:port; None: off
    web: tuple[str, int] | None = None  # the live view's (host, port); None: off
    gcs: tuple[str, int | None] | None = None  # where the GCS links talk first (--gcs)


@dataclass(frozen=True)
class Scenario:
    source: str
    vehicles: int = 1
    home: GeoPoint = PX4_SITL_HOME
    airframe: str = "x500"
    params: dict[str, float] = field(default_factory=dict)
    network: NetworkConfig = field(default_factory=NetworkConfig)
    log_level: str | None = None
    daemon: DaemonSettings = field(default_factory=DaemonSettings)
    wind: WindConfig = field(default_factory=WindConfig)  # [environment]
    sensors: SensorConfig = field(default_factory=SensorConfig)  # [sensors]
    faults: tuple[Fault, ...] = ()  # [[faults]], in time order
    spawn_ned_m: tuple[tuple[float, float], ...] = ()  # vehicles.spawn_ned_m, by instance
    commands: tuple[Command, ...] = ()  # [[commands]], in time order
    # vehicles.param_files (gateway/sim/param_files.py): values by system id, after `params`
    vehicle_params: dict[int, dict[str, float]] = field(default_factory=dict)


def bind_address(value: Any, path: str) -> str:
    """An IPv4 address to bind the vehicles' ports to (they talk first to 127.0.0.1)."""
    try:
        if not isinstance(value, str):
            raise TypeError(value)  # IPv4Address also takes ints and bytes; a TOML value must not
        ipaddress.IPv4Address(value)
    except (ValueError, TypeError):
        raise ScenarioError(f"{path}: expected an IPv4 address such as 127.0.0.1 or 0.0.0.0, "
                            f"got {value!r}") from None
    return value


def _speed(value: Any, path: str) -> float:
    if value == "max":
        return math.inf
    if isinstance(value, str):
        raise ScenarioError(f"{path}: expected a factor like 10, or \"max\"; got {value!r}")
    speed = _number(value, path, positive=True)
    if speed > MAX_SPEED:
        raise ScenarioError(f"{path}: must be <= {MAX_SPEED:g} (or \"max\"), got {value!r}")
    return float(speed)


def _path(value: Any, path: str, base_dir: Path | None) -> Path:
    if not isinstance(value, str) or not value:
        raise ScenarioError(f"{path}: expected a path (a non-empty string), got {value!r}")
    p = Path(value)
    return base_dir / p if base_dir is not None and not p.is_absolute() else p


def check_ports(vehicles: int, port_offset: int, path: str,
                radios: tuple[ExtraRadio, ...] = ()) -> None:
    highest = HIGHEST_BASE_PORT + vehicles - 1 + port_offset
    if highest > MAX_PORT:
        raise ScenarioError(f"{path}: {port_offset} with {vehicles} vehicles needs port "
                            f"{highest} > {MAX_PORT}; use a smaller offset")
    check_radio_ports(radios, vehicles, port_offset, path)


def _daemon(table: dict, base_dir: Path | None) -> tuple[DaemonSettings, str | None]:
    _unknown(table, DAEMON_KEYS, "daemon")
    out: dict[str, Any] = {}
    if "bind" in table:
        out["bind"] = bind_address(table["bind"], "daemon.bind")
    if "gcs" in table:
        out["gcs"] = gcs_partner(table["gcs"], "daemon.gcs")
    if "port_offset" in table:
        out["port_offset"] = int(_number(table["port_offset"], "daemon.port_offset",
                                         integer=True, minimum=0))
    if "speed" in table:
        out["speed"] = _speed(table["speed"], "daemon.speed")
    if "metrics_port" in table:
        port = int(_number(table["metrics_port"], "daemon.metrics_port", integer=True,
                           minimum=1))
        if port > MAX_PORT:
            raise ScenarioError(f"daemon.metrics_port: at most {MAX_PORT}, got {port}")
        out["metrics_port"] = port
    for key in ("state_dir", "log_dir", "packet_trace", "signing_key"):
        if key in table:
            out[key] = _path(table[key], f"daemon.{key}", base_dir)
    if "zmq_pub" in table:
        value = table["zmq_pub"]
        if not isinstance(value, str) or "://" not in value:
            raise ScenarioError(f"daemon.zmq_pub: expected a ZeroMQ endpoint such as "
                                f"tcp://127.0.0.1:5556, got {value!r}")
        out["zmq_pub"] = value
    if "web" in table:
        out["web"] = listen_address(table["web"], "daemon.web", 'web = "127.0.0.1:8080"')
    level = table.get("log_level")
    if level is not None:
        _choice(level, LOG_LEVELS, "daemon.log_level")
    return DaemonSettings(**out), level


def parse(doc: dict, source: str = "<scenario>", base_dir: Path | None = None) -> Scenario:
    """``base_dir``: where relative paths of ``[daemon]`` point from (``load``: the file's
    directory); None keeps them relative to the working directory."""
    _unknown(doc, ("vehicles", "network", "logging", "daemon", "environment", "sensors",
                   "faults", "commands"), "")
    veh = _table(doc, "vehicles", "vehicles")
    _unknown(veh, ("count", "home", "airframe", "params", "param_files", "spawn_ned_m"),
             "vehicles")
    count = int(_number(veh.get("count", 1), "vehicles.count", integer=True, minimum=1))
    if count > MAX_VEHICLES:
        raise ScenarioError(f"vehicles.count: at most {MAX_VEHICLES} vehicles per MAVLink network "
                            f"(system ids 1..{MAX_VEHICLES}), got {count}; run more as another "
                            "daemon on other ports (--port-offset)")
    home = PX4_SITL_HOME
    if "home" in veh:
        h = _table(veh, "home", "vehicles.home")
        _unknown(h, ("lat_deg", "lon_deg", "alt_amsl_m"), "vehicles.home")
        lat = _number(h.get("lat_deg", home.lat_deg), "vehicles.home.lat_deg")
        lon = _number(h.get("lon_deg", home.lon_deg), "vehicles.home.lon_deg")
        if not -90 <= lat <= 90 or not -180 <= lon <= 180:
            raise ScenarioError("vehicles.home: latitude must be within ±90 and longitude ±180")
        alt = _number(h.get("alt_amsl_m", home.alt_amsl_m), "vehicles.home.alt_amsl_m")
        if not MIN_HOME_ALT_M <= alt <= MAX_HOME_ALT_M:
            raise ScenarioError(f"vehicles.home.alt_amsl_m: must be between {MIN_HOME_ALT_M:g} "
                                f"and {MAX_HOME_ALT_M:g} m, got {alt!r}")
        home = GeoPoint(lat, lon, alt)
    airframe = _choice(veh.get("airframe", "x500"), AIRFRAMES, "vehicles.airframe")
    params = _params(_table(veh, "params", "vehicles.params"))
    spawn = spawn_points(veh.get("spawn_ned_m", []), count, grid_spawn_ned_m)
    files = veh.get("param_files", [])
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        raise ScenarioError('vehicles.param_files: expected a list of "FILE" or "N:FILE" '
                            "(QGC .params files; relative to this file)")
    vehicle_params = param_files.merge(files, count, base_dir, "vehicles.param_files:")

    net = _table(doc, "network", "network")
    backend = _choice(net.get("backend", "embedded"), BACKENDS, "network.backend")
    seed = int(_number(net.get("seed", 0), "network.seed", integer=True, minimum=0))
    sync = _number(net.get("sync_period_s", DEFAULT_SYNC_PERIOD_S), "network.sync_period_s")
    if not MIN_SYNC_PERIOD_S <= sync <= MAX_SYNC_PERIOD_S:
        raise ScenarioError(f"network.sync_period_s: must be between {MIN_SYNC_PERIOD_S:g} and "
                            f"{MAX_SYNC_PERIOD_S:g} s, got {sync!r}")
    late = _choice(net.get("late_policy", "drop"), LATE_POLICIES, "network.late_policy")
    ns3 = _table(net, "ns3", "network.ns3")
    if backend != "embedded":
        from netsim.ns3.bridge import CONFIG_KEYS, check_config

        _unknown(ns3, tuple(sorted(CONFIG_KEYS | {"strict"})), "network.ns3")
        try:
            check_config({k: v for k, v in ns3.items() if k != "strict"})
        except ValueError as exc:
            raise ScenarioError(f"network.ns3.{exc}") from None
        if not isinstance(ns3.get("strict", False), bool):
            raise ScenarioError("network.ns3.strict: expected true or false")
    elif ns3:
        raise ScenarioError("network.ns3: only used with backend = \"ns3\"")
    topology = {k: v for k, v in net.items() if k not in NETWORK_OWN_KEYS}
    radios: tuple[ExtraRadio, ...] = ()
    if "extra_radios" in topology:
        if backend != "embedded":
            raise ScenarioError("network.extra_radios: only the embedded backend has extra "
                                "radios so far (the ns-3 engine builds one radio per vehicle)")
        topology["extra_radios"], radios = split_entries(topology["extra_radios"],
                                                         "network.extra_radios")
    try:
        make_router(topology, path="network")  # validates topology and every model parameter
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None
    network = NetworkConfig(backend, topology, seed, sync, late, dict(ns3), radios)

    logging_table = _table(doc, "logging", "logging")
    _unknown(logging_table, ("level",), "logging")
    level = logging_table.get("level")
    if level is not None:
        _choice(level, LOG_LEVELS, "logging.level")

    daemon, daemon_level = _daemon(_table(doc, "daemon", "daemon"), base_dir)
    if daemon_level is not None:
        if level is not None:
            raise ScenarioError("daemon.log_level: logging.level sets it too; keep one of them")
        level = daemon_level
    if daemon.port_offset is not None:
        check_ports(count, daemon.port_offset, "daemon.port_offset", radios)
    else:
        check_radio_ports(radios, count, 0, "network.extra_radios")
    wind = _environment(_table(doc, "environment", "environment"))
    sensors = _sensors(_table(doc, "sensors", "sensors"))
    faults = parse_faults(doc.get("faults", []), count)
    if any(f.on_network for f in faults):
        if backend != "embedded":
            raise ScenarioError("faults: network events need the embedded backend (ns-3 has "
                                "its own link model)")
        outages = [{"link": f.link, "start_s": f.at_s, "duration_s": f.duration_s,
                    "loss": f.loss if f.event != "latency" else 0.0,
                    "latency_s": f.latency_ms / 1000.0}
                   for f in faults if f.on_network]
        topology = {**topology, "outages": [*topology.get("outages", []), *outages]}
        try:
            make_router(topology, path="network")
        except ValueError as exc:
            raise ScenarioError(str(exc)) from None
        network = NetworkConfig(backend, topology, seed, sync, late, dict(ns3), radios)
    return Scenario(source, count, home, airframe, params, network, level, daemon, wind, sensors,
                    faults, spawn, commands=parse_commands(doc.get("commands", []), count),
                    vehicle_params=vehicle_params)


def _sensors(table: dict) -> SensorConfig:
    """``[sensors]``: ``noise`` scales the noise and bias of every simulated sensor (1: PX4's
    Gazebo x500 models, 0: exact sensors for exact regression tests), vehicles/estimation.py."""
    _unknown(table, ("noise",), "sensors")
    if "noise" not in table:
        return SensorConfig()
    value = _number(table["noise"], "sensors.noise")
    if not 0.0 <= value <= 100.0:
        raise ScenarioError(f"sensors.noise: must be between 0 and 100 (1 = PX4's simulated "
                            f"sensors, 0 = exact), got {value!r}")
    return SensorConfig(noise=value)


# [environment]: key -> (lowest, highest) accepted.
ENVIRONMENT_RANGES = {"wind_speed_mps": (0.0, 50.0), "wind_from_deg": (0.0, 360.0),
                      "gust_mps": (0.0, 20.0), "gust_time_s": (0.1, 60.0)}


def _environment(env: dict) -> WindConfig:
    """``[environment]``: a mean wind (speed, the direction it blows from, degrees clockwise from
    north) and gusts (standard deviation, correlation time), vehicles/wind.py."""
    _unknown(env, tuple(ENVIRONMENT_RANGES), "environment")
    values = {}
    for key, (low, high) in ENVIRONMENT_RANGES.items():
        if key in env:
            value = _number(env[key], f"environment.{key}")
            if not low <= value <= high:
                raise ScenarioError(f"environment.{key}: must be between {low:g} and {high:g}, "
                                    f"got {value!r}")
            values[key] = value
    return WindConfig(values.get("wind_speed_mps", 0.0), values.get("wind_from_deg", 0.0),
                      values.get("gust_mps", 0.0), values.get("gust_time_s", 2.0))


def _params(table: dict) -> dict[str, float]:
    store = ParamStore()
    out = {}
    for name, value in table.items():
        path = f"vehicles.params.{name}"
        if name not in store:
            raise ScenarioError(f"{path}: no PX4 parameter of that name")
        value = _number(value, path)
        try:
            store.set(name, value)
        except ValueError:
            raise ScenarioError(f"{path}: {value!r} is not a valid "
                                f"{store.info(name).type.name} value") from None
        out[name] = value
    return out


def load(path: str | Path) -> Scenario:
    """A scenario file, or a shipped scenario by name (``lossy-wifi``; ``cornet scenarios``)."""
    given, path = path, scenario_path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        hint = ""
        if not Path(given).parent.parts:
            hint = "; nor is it a shipped scenario's name (`cornet scenarios` lists them)"
        raise ScenarioError(f"{path}: cannot read ({exc.strerror}){hint}") from None
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: not UTF-8 text (byte {exc.start}); TOML files are "
                            "UTF-8") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
    try:
        return parse(doc, str(path), base_dir=path.parent.absolute())
    except ScenarioError as exc:
        raise ScenarioError(f"{path}: {exc}") from None


def describe(s: Scenario) -> str:
    """A few lines saying what the scenario sets up (what `cornet check` prints)."""
    net = s.network
    topo = net.topology.get("topology", "direct")
    if net.backend != "embedded":
        topo = f"{net.ns3.get('topology', 'adhoc')} (ns-3)"
    lines = [f"{s.source}: ok",
             f"  vehicles: {s.vehicles} × {s.airframe} around {s.home.lat_deg:.6f}, "
             f"{s.home.lon_deg:.6f}, {s.home.alt_amsl_m:.1f} m AMSL"
             + (f"; params {s.params}" if s.params else "")
             + (f"; spawn points {[list(p) for p in s.spawn_ned_m]}" if s.spawn_ned_m else "")
             + "".join(f"; vehicle {k} params {v}" for k, v in sorted(s.vehicle_params.items())),
             f"  network: backend {net.backend}, topology {topo}, seed {net.seed}, sync period "
             f"{net.sync_period_s * 1e3:.0f} ms, late policy {net.late_policy}"]
    for key in ("link", "ap", "gcs", "radio", "wired", "channel", "api_clients", "outages"):
        if key in net.topology:
            lines.append(f"  {key}: {net.topology[key]}")
    for key, value in net.ns3.items():
        lines.append(f"  ns3.{key}: {value}")
    offset = s.daemon.port_offset or 0
    for radio, entry in zip(net.radios, net.topology.get("extra_radios", [])):
        hops = {k: v for k, v in entry.items() if k != "name"}
        lines.append(f"  extra radio {radio.name}: {hops}; vehicle i binds "
                     f"{radio_ports(0, radio, offset).local}+i, talks to "
                     f"{radio_ports(0, radio, offset).remote}")
    if not s.wind.calm:
        w = s.wind
        lines.append(f"  environment: wind {w.speed_mps:g} m/s from {w.from_deg:g}°, gusts "
                     f"{w.gust_mps:g} m/s over {w.gust_time_s:g} s")
    for f in s.faults:
        lines.append(f"  fault at {f.at_s:g} s: {f.describe()}")
    for c in s.commands:
        lines.append(f"  command at {c.at_s:g} s: {c.describe()}")
    if s.sensors != SensorConfig():
        lines.append(f"  sensors: noise × {s.sensors.noise:g}")
    d = s.daemon
    settings = [f"{key} {_shown(key, value)}"
                for key in DAEMON_KEYS if (value := getattr(d, key, None)) is not None]
    if s.log_level is not None:
        settings.append(f"log_level {s.log_level}")
    if settings:
        lines.append(f"  daemon: {', '.join(settings)}")
    return "\n".join(lines)


def _shown(key: str, value: Any) -> str:
    if key == "speed" and math.isinf(value):
        return "max"
    if key == "web":  # (host, port)
        host, port = value
        return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"
    if key == "gcs":  # (host, port or None)
        return value[0] if value[1] is None else f"{value[0]}:{value[1]}"
    return str(value)
