"""Faults a scenario schedules (its ``[[faults]]`` timeline): a vehicle failure, by PX4's failure
unit and type names (MAV_CMD_INJECT_FAILURE's FAILURE_UNIT / FAILURE_TYPE), or a network event
on a link for ``duration_s`` (the network's outage windows, netsim/topology.py): ``outage`` (the
link carries nothing), ``loss`` (a loss burst: each packet lost with probability ``loss``) or
``latency`` (a latency step: ``latency_ms`` more on every packet).

A scheduled fault is the simulator's doing, like a Gazebo world plugin: it needs no
SYS_FAILURE_EN (that guards the MAVLink command). Units and types the simulation models, as
PX4 SITL's simulator and battery simulator do (``SUPPORTED``): gyro, accel, mag and baro off,
stuck or ok; the GPS off or ok; the battery off (its voltage at BAT1_V_EMPTY) or ok; the motors
(``instance``: motor number from 1, 0 = all) off or ok.
"""

from __future__ import annotations

from dataclasses import dataclass

# FAILURE_UNIT and FAILURE_TYPE (MAVLink) of what the simulation models.
UNITS = {"gyro": 0, "accel": 1, "mag": 2, "baro": 3, "gps": 4, "battery": 100, "motor": 101}
TYPES = {"ok": 0, "off": 1, "stuck": 2}
SUPPORTED = {"gyro": ("ok", "off", "stuck"), "accel": ("ok", "off", "stuck"),
             "mag": ("ok", "off", "stuck"), "baro": ("ok", "off", "stuck"), "gps": ("ok", "off"),
             "battery": ("ok", "off"), "motor": ("ok", "off")}


EVENTS = ("outage", "loss", "latency")


@dataclass(frozen=True)
class Fault:
    at_s: float  # simulated time
    vehicle: int = 1  # instance number, 1-based (vehicle 1 is MAV_SYS_ID 1)
    instance: int = 0  # which one of the unit (a motor's number from 1); 0 = all
    unit: str = ""  # a key of UNITS (a vehicle failure)
    type: str = ""  # a key of TYPES
    link: str = ""  # a link name or pattern (a network event): "v2", "v1/gcs/down", "v*"
    event: str = ""  # one of EVENTS
    duration_s: float = 0.0
    loss: float = 1.0  # a loss event's probability
    latency_ms: float = 0.0  # a latency event's added delay

    @property
    def on_network(self) -> bool:
        return bool(self.link)

    def describe(self) -> str:
        if self.on_network:
            what = {"loss": f"loss {self.loss:g}",
                    "latency": f"latency +{self.latency_ms:g} ms"}.get(self.event, self.event)
            return f"link {self.link} {what} for {self.duration_s:g} s"
        which = f" {self.instance}" if self.instance else ""
        return f"vehicle {self.vehicle} {self.unit}{which} {self.type}"
