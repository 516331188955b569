"""A scenario's ``[[commands]]`` timeline: what a ground station would command, at simulated times.

Each entry gives one vehicle a command at ``at_s`` seconds of simulated time, as if a client had
sent it (the autopilot answers exactly as to MAVLink; a refusal is logged). With no client on the
wall clock, a run with a fixed seed flies the same flight every time — ``cornet run --duration``
then writes the same logs, in one process or sharded.

    [[commands]]
    at_s = 5.0
    vehicle = 1                      # 1-based (default 1)
    command = "takeoff"              # arm | takeoff | reposition | land
    # ned_m = [40.0, 0.0, -10.0]     # reposition: a point of the vehicle's local NED frame
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from gateway.sim.values import ScenarioError, choice, number, timeline_entry, unknown
from vehicles.types import CommandResult

ACTIONS = ("arm", "takeoff", "reposition", "land")


@dataclass(frozen=True)
class Command:
    at_s: float
    vehicle: int  # 1-based, as MAV_SYS_ID
    command: str
    ned_m: tuple[float, float, float] | None = None  # reposition's target

    def describe(self) -> str:
        where = "" if self.ned_m is None else f" to {list(self.ned_m)} m NED"
        return f"vehicle {self.vehicle}: {self.command}{where}"

    def apply(self, vehicle: Any, now_s: float) -> CommandResult:
        if self.command == "arm":
            return vehicle.arm(now_s)
        if self.command == "takeoff":
            return vehicle.takeoff(now_s)
        if self.command == "land":
            return vehicle.land(now_s)
        assert self.ned_m is not None
        return vehicle.reposition(now_s, self.ned_m)


def parse_commands(entries: Any, vehicles: int) -> tuple[Command, ...]:
    """``[[commands]]``, checked and sorted by time (entries of one time keep their order)."""
    if not isinstance(entries, list):
        raise ScenarioError("commands: expected an array of tables ([[commands]])")
    out = []
    for i, entry in enumerate(entries):
        where = f"commands[{i}]"
        if not isinstance(entry, dict):
            raise ScenarioError(f"{where}: expected a table with at_s, vehicle, command")
        unknown(entry, ("at_s", "vehicle", "command", "ned_m"), where)
        at, vehicle = timeline_entry(entry, where, ("at_s", "command"), vehicles)
        command = choice(entry["command"], ACTIONS, f"{where}.command")
        ned = entry.get("ned_m")
        if (ned is None) != (command != "reposition"):
            raise ScenarioError(f"{where}.ned_m: " + (
                "missing (reposition needs a point [n, e, d] in metres)"
                if ned is None else "only for command = \"reposition\""))
        point = None
        if ned is not None:
            if not isinstance(ned, list) or len(ned) != 3:
                raise ScenarioError(f"{where}.ned_m: expected 3 numbers [n, e, d], got {ned!r}")
            n, e, d = (number(x, f"{where}.ned_m", minimum=-100_000.0) for x in ned)
            point = (float(n), float(e), float(d))
        out.append(Command(float(at), vehicle, command, point))
    return tuple(sorted(out, key=lambda c: c.at_s))
