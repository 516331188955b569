"""``RunConfig``: everything ``cornet run`` was asked for (flags over the configuration file over
the scenario), as the daemon and its shards take it."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from gateway.mavlink.signing import SigningKey
from gateway.sim.command_timeline import Command
from gateway.sim.scenario import NetworkConfig
from vehicles.faults import Fault
from vehicles.types import PX4_SITL_HOME, GeoPoint, SensorConfig
from vehicles.wind import WindConfig


@dataclass(frozen=True)
class RunConfig:
    vehicles: int = 1
    network: NetworkConfig = field(default_factory=NetworkConfig)
    port_offset: int = 0
    bind: str = "127.0.0.1"
    remote_host: str = "127.0.0.1"
    gcs: tuple[str, int | None] | None = None  # --gcs HOST[:PORT]: where GCS links talk first
    environment: tuple[str, ...] = ()  # the PX4 SITL variables that set something (ready line)
    speed: float = 1.0
    state_dir: Path | None = None  # parameters and plans persist here, per vehicle
    ignore_bad_state: bool = False  # an unreadable state file: start that vehicle with defaults
    zmq_pub: str | None = None  # e.g. tcp://127.0.0.1:5556: states, link stats, packet events
    home: GeoPoint = PX4_SITL_HOME  # the world's home: vehicles spawn around it
    packet_trace: Path | None = None  # the network's log: one line per datagram event
    log_dir: Path | None = None  # flight logs: DIR/run-<date>-<time>/
    params: dict[str, float] = field(default_factory=dict)  # set at every boot (--param)
    vehicle_params: dict[int, dict[str, float]] = field(default_factory=dict)  # by sysid, after
    signing_key: SigningKey | None = None  # MAVLink 2 signing on every link (--signing-key)
    metrics_port: int | None = None  # Prometheus /metrics on bind:port (--metrics-port)
    duration: float | None = None  # stop at this simulated time (--duration); None: on a signal
    shards: int = 1  # worker processes (gateway/daemon/shard/); 1: this process simulates all
    first_vehicle: int = 0  # a shard's first vehicle (instance number)
    wind: WindConfig = field(default_factory=WindConfig)  # the scenario's [environment]
    sensors: SensorConfig = field(default_factory=SensorConfig)  # the scenario's [sensors]
    faults: tuple[Fault, ...] = ()  # the scenario's [[faults]] timeline
    spawn_ned_m: tuple[tuple[float, float], ...] = ()  # the scenario's vehicles.spawn_ned_m
    web: tuple[str, int] | None = None  # the live view's (host, port) (--web; gateway/web/)
    commands: tuple[Command, ...] = ()  # the scenario's [[commands]] timeline
