"""PX4 SITL's conventions in the daemon's shell (PX4, mavlink_main.cpp, UDP mode; rcS).

Where a vehicle link talks before it hears a client: PX4 SITL's links talk first to their
preset remote, 127.0.0.1:14550 (GCS, normal mode) or :14540+i (API, onboard mode); ``mavlink
start -t HOST`` sets another partner address, here ``cornet run --gcs HOST[:PORT]`` for the
normal-mode links (the GCS link and extra radios). With MAV_BROADCAST = 1 a normal-mode link
also sends to the network's broadcast address until it hears a client, and again whenever no
ground station's HEARTBEAT came for 2.5 s (``send_finish``), so a ground station on the LAN
finds the vehicle, and finds it again after a restart.

What PX4 SITL's environment set (PX4_SIM_SPEED_FACTOR, PX4_HOME_*; read by the CLI) is said in
the ready line.
"""

from __future__ import annotations

import logging
import math
from typing import TYPE_CHECKING

from gateway.daemon.endpoint import broadcast_address
from gateway.mavlink.session import LinkKind
from gateway.sim.radios import LinkTag
from vehicles.types import GeoPoint

if TYPE_CHECKING:
    from gateway.sim.simulation import Simulation

log = logging.getLogger(__name__)

Address = tuple[str, int]


def first_peers(sim: Simulation, index: int, tag: LinkTag, remote_port: int, *, bind: str,
                remote_host: str, gcs: tuple[str, int | None] | None
                ) -> tuple[Address, Address | None]:
    """Vehicle ``index``'s link ``tag``: the address it talks to first, and the broadcast
    address it also talks to while no ground station is connected (None: no broadcast).
    ``gcs``: --gcs."""
    if sim.links[(index, tag)].kind is LinkKind.API:
        return (remote_host, remote_port), None
    host, port = gcs or (remote_host, None)
    peer = (host, port if port is not None and tag is LinkKind.GCS else remote_port)
    vehicle = sim.vehicles[sim.indices.index(index)]
    if int(vehicle.params["MAV_BROADCAST"]) != 1:
        return peer, None
    address = broadcast_address(bind)
    if address is None:
        log.warning("MAV_BROADCAST = 1: no broadcast address on %s (bind 0.0.0.0 or an "
                    "interface's address)", bind)
        return peer, None
    return peer, (address, remote_port)


def speed_text(speed: float, environment: tuple[str, ...]) -> str:
    """The ready line's speed: ``4x``, ``max``, ``4x (PX4_SIM_SPEED_FACTOR)``."""
    text = "max" if math.isinf(speed) else f"{speed:g}x"
    return text + (" (PX4_SIM_SPEED_FACTOR)" if "PX4_SIM_SPEED_FACTOR" in environment else "")


def home_text(home: GeoPoint, environment: tuple[str, ...]) -> str:
    """``, home LAT, LON, ALT m (PX4_HOME_LAT, ...)`` when the environment moved it, else ''."""
    names = [name for name in environment if name.startswith("PX4_HOME_")]
    return (f", home {home.lat_deg:.6f}, {home.lon_deg:.6f}, {home.alt_amsl_m:g} m "
            f"({', '.join(names)})" if names else "")


def log_first_peer(bind: str, remote_host: str, gcs_port: int) -> None:
    """Bound beyond loopback without --gcs: say where the GCS links talk and how to change it."""
    log.info("the GCS links talk first to %s:%d; a ground station on another host: --gcs HOST, "
             "or --param MAV_BROADCAST=1", remote_host, gcs_port)
