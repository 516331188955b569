"""Where a vehicle link talks before it hears a client (PX4, mavlink_main.cpp, UDP mode).

PX4 SITL's links talk first to their preset remote, 127.0.0.1:14550 (GCS, normal mode) or
:14540+i (API, onboard mode); ``mavlink start -t HOST`` sets another partner address, here
``cornet run --gcs HOST[:PORT]`` for the normal-mode links (the GCS link and extra radios). With
MAV_BROADCAST = 1 a normal-mode link also sends to the network's broadcast address while no
client is connected (``send_finish``), so a ground station on the LAN finds the vehicle.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from gateway.daemon.endpoint import broadcast_address
from gateway.mavlink.session import LinkKind
from gateway.sim.radios import LinkTag

if TYPE_CHECKING:
    from gateway.sim.simulation import Simulation

log = logging.getLogger(__name__)

Address = tuple[str, int]


def first_peers(sim: Simulation, index: int, tag: LinkTag, remote_port: int, *, bind: str,
                remote_host: str, gcs: tuple[str, int | None] | None
                ) -> tuple[Address, Address | None]:
    """Vehicle ``index``'s link ``tag``: the address it talks to first, and the broadcast
    address it also talks to until it hears a client (None: no broadcast). ``gcs``: --gcs."""
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
