"""Vehicle faults a scenario schedules (its ``[[faults]]`` timeline): what a failure is, by PX4's
failure unit and type names (MAV_CMD_INJECT_FAILURE's FAILURE_UNIT / FAILURE_TYPE).

A scheduled fault is the simulator's doing, like a Gazebo world plugin: it needs no
SYS_FAILURE_EN (that guards the MAVLink command). Units and types the simulation models: the
GPS off and back on.
"""

from __future__ import annotations

from dataclasses import dataclass

UNITS = {"gps": 4}  # FAILURE_UNIT_SENSOR_GPS
TYPES = {"ok": 0, "off": 1}  # FAILURE_TYPE_OK, FAILURE_TYPE_OFF


@dataclass(frozen=True)
class Fault:
    at_s: float  # simulated time
    vehicle: int  # instance number, 1-based (vehicle 1 is MAV_SYS_ID 1)
    unit: str  # a key of UNITS
    type: str  # a key of TYPES

    def describe(self) -> str:
        return f"vehicle {self.vehicle} {self.unit} {self.type}"
