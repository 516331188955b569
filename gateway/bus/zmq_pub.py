"""The outside data path: vehicle states, link statistics and packet events on a ZeroMQ PUB socket.

For external tools (plots, dashboards, `cornet watch`). Publishing never blocks the simulation:
the socket sends with NOBLOCK and a bounded high-water mark, and a message that does not fit is
counted as dropped. The schema is documented in docs/zmq.md; every message carries ``"v"``.

Messages are two frames: the topic (ASCII) and a JSON object.
  cornet.state   10 Hz simulated: every vehicle's mode, arming, position, velocity, battery
  cornet.links   1 Hz simulated: every link direction's counters and latency percentiles
  cornet.packet  each datagram event on a link: send / drop (with reason) / recv
  cornet.fault   each fault of the scenario's timeline as it fires

The socket is an XPUB, so the publisher knows what subscribers asked for: packet events (one
per datagram per event, the costly topic) are only built while someone subscribes to them.

In-process listeners get every message (packet events only while a ZeroMQ subscriber asks) as
the object itself, before it is encoded; with no endpoint there is no socket, only listeners.
A listener must return at once: it runs on the simulation's clock.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from typing import Any

import zmq

from gateway.mavlink.modes import custom_mode_of
from vehicles.geodesy import reproject
from vehicles.types import NavState

log = logging.getLogger(__name__)

SCHEMA_VERSION = 1
STATE_PERIOD_S = 0.1
LINKS_PERIOD_S = 1.0
SEND_HWM = 10_000

TOPIC_STATE = b"cornet.state"
TOPIC_LINKS = b"cornet.links"
TOPIC_PACKET = b"cornet.packet"
TOPIC_FAULT = b"cornet.fault"

# QGC's names for PX4 modes (px4_custom_mode.h; QGC's PX4FirmwarePlugin), for humans reading the stream.
MODE_NAMES = {
    NavState.MANUAL: "Manual", NavState.ALTCTL: "Altitude", NavState.POSCTL: "Position",
    NavState.AUTO_MISSION: "Mission", NavState.AUTO_LOITER: "Hold", NavState.AUTO_RTL: "Return",
    NavState.ACRO: "Acro", NavState.DESCEND: "Land", NavState.TERMINATION: "Termination",
    NavState.OFFBOARD: "Offboard", NavState.STAB: "Stabilized", NavState.AUTO_TAKEOFF: "Takeoff",
    NavState.AUTO_LAND: "Land", NavState.AUTO_FOLLOW_TARGET: "Follow Me",
    NavState.AUTO_PRECLAND: "Precision Land", NavState.ORBIT: "Orbit",
    NavState.POSITION_SLOW: "Position Slow",
}


def _r(x: float, digits: int = 3) -> float:
    return round(float(x), digits)


Listener = Callable[[bytes, dict], None]  # (topic, message): must not block


class Publisher:
    def __init__(self, endpoint: str | None, context: zmq.Context | None = None) -> None:
        self.socket: zmq.Socket | None = None
        if endpoint is not None:
            self.socket = (context or zmq.Context.instance()).socket(zmq.XPUB)
            self.socket.setsockopt(zmq.SNDHWM, SEND_HWM)
            self.socket.setsockopt(zmq.LINGER, 0)
            self.socket.bind(endpoint)
        self.endpoint = endpoint
        self.listeners: list[Listener] = []
        self.sent = 0
        self.dropped = 0
        self._subscriptions: set[bytes] = set()
        self.wants_packets = False  # someone subscribes to a prefix of cornet.packet

    def poll_subscriptions(self) -> None:
        """Read subscribe / unsubscribe notices (XPUB: first subscribe, last unsubscribe)."""
        while self.socket is not None:
            try:
                msg = self.socket.recv(zmq.NOBLOCK)
            except zmq.Again:
                break
            if msg[:1] == b"\x01":
                self._subscriptions.add(msg[1:])
            elif msg[:1] == b"\x00":
                self._subscriptions.discard(msg[1:])
        self.wants_packets = any(TOPIC_PACKET.startswith(p) for p in self._subscriptions)

    def publish(self, topic: bytes, body: dict) -> None:
        body["v"] = SCHEMA_VERSION
        for listener in self.listeners:
            listener(topic, body)
        if self.socket is None:
            return
        try:
            self.socket.send_multipart([topic, json.dumps(body, separators=(",", ":")).encode()],
                                       flags=zmq.NOBLOCK)
            self.sent += 1
        except zmq.Again:
            self.dropped += 1

    # --- what the simulation hands over -----------------------------------------------------
    def vehicle_states(self, now_s: float, sim) -> None:
        self.poll_subscriptions()
        world = sim.vehicle_positions_ned_m()
        out = []
        for i, v in enumerate(sim.vehicles):
            status = v.status
            geo = v.global_position
            home = status.home
            n, e, d = world[f"v{i + 1}"]
            vel = v.kinematics.velocity_ned_mps
            out.append({
                "sysid": i + 1,
                "mode": MODE_NAMES.get(status.nav_state, status.nav_state.name),
                "custom_mode": custom_mode_of(status.nav_state),
                "armed": status.armed,
                "landed_state": status.landed_state.name,
                "failsafe": status.failsafe,
                "lat_deg": _r(geo.lat_deg, 7), "lon_deg": _r(geo.lon_deg, 7),
                "alt_amsl_m": _r(geo.alt_amsl_m),
                "rel_alt_m": _r(geo.alt_amsl_m - home.geo.alt_amsl_m) if home else None,
                "world_ned_m": [_r(n), _r(e), _r(d)],
                "velocity_ned_mps": [_r(vel[0]), _r(vel[1]), _r(vel[2])],
                "battery_remaining": _r(status.battery.remaining),
            })
        home = sim.world.home
        nodes = []
        for node in sim.ground_nodes():
            n, e, d = node["world_ned_m"]
            lat, lon = reproject(home.lat_deg, home.lon_deg, n, e)
            nodes.append({**node, "world_ned_m": [_r(n), _r(e), _r(d)], "lat_deg": _r(lat, 7),
                          "lon_deg": _r(lon, 7), "alt_amsl_m": _r(home.alt_amsl_m - d)})
        self.publish(TOPIC_STATE, {"t": _r(now_s, 4), "vehicles": out, "nodes": nodes,
                                   "home": {"lat_deg": home.lat_deg, "lon_deg": home.lon_deg,
                                            "alt_amsl_m": home.alt_amsl_m}})

    def link_stats(self, now_s: float, sim) -> None:
        body = {"t": _r(now_s, 4), "links": sim.link_stats()}
        # An external backend's own counters (ns-3: cycles, exchanges; LTE: cells, handovers).
        backend_stats = getattr(sim.backend, "backend_stats", None)
        if backend_stats is not None:
            body["network"] = backend_stats()
        self.publish(TOPIC_LINKS, body)

    def packet_event(self, event: str, link: str, time_s: float, size: int, detail: str) -> None:
        if not self.wants_packets:
            return
        self.publish(TOPIC_PACKET, {"t": _r(time_s, 6), "event": event, "link": link,
                                    "size": size, "detail": detail})

    def fault(self, now_s: float, fault: Any) -> None:
        """A fault of the scenario's timeline fired (vehicles/faults.py)."""
        body: dict[str, Any] = {"t": _r(now_s, 4), "fault": fault.describe()}
        if fault.on_network:
            body.update(link=fault.link, event=fault.event, duration_s=fault.duration_s)
        else:
            body.update(sysid=fault.vehicle, unit=fault.unit, type=fault.type,
                        instance=fault.instance)
        self.publish(TOPIC_FAULT, body)

    def close(self) -> None:
        if self.socket is not None:
            self.socket.close(0)
