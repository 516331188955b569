"""A scenario's ``[[faults]]`` timeline, checked: vehicle failures by PX4's unit and type names and
network events on links (vehicles/faults.py says what each does)."""

from __future__ import annotations

from typing import Any

from gateway.sim.values import ScenarioError, choice, number, timeline_entry, unknown
from vehicles.faults import EVENTS, SUPPORTED, TYPES, UNITS, Fault


def parse_faults(entries: Any, vehicles: int) -> tuple[Fault, ...]:
    """``[[faults]]``: at ``at_s`` seconds of simulated time, vehicle ``vehicle`` (1-based,
    default 1) gets a failure of ``unit`` and ``type`` (vehicles/faults.py SUPPORTED), or link
    ``link`` has an ``event`` (outage, loss with ``loss``, latency with ``latency_ms``) for
    ``duration_s``. Sorted by time."""
    if not isinstance(entries, list):
        raise ScenarioError("faults: expected an array of tables ([[faults]])")
    out = []
    for i, entry in enumerate(entries):
        where = f"faults[{i}]"
        if not isinstance(entry, dict):
            raise ScenarioError(f"{where}: expected a table with at_s, vehicle, unit, type")
        unknown(entry, ("at_s", "vehicle", "unit", "type", "instance", "link", "event",
                        "duration_s", "loss", "latency_ms"), where)
        if "link" in entry:
            for key in ("at_s", "event", "duration_s"):
                if key not in entry:
                    raise ScenarioError(f"{where}.{key}: missing")
            link = entry["link"]
            if not isinstance(link, str) or not link:
                raise ScenarioError(f"{where}.link: expected a link name or pattern (v1, "
                                    f"v1/gcs/down, v*), got {link!r}")
            at = number(entry["at_s"], f"{where}.at_s", minimum=0.0)
            event = choice(entry["event"], EVENTS, f"{where}.event")
            duration = number(entry["duration_s"], f"{where}.duration_s", positive=True)
            loss, latency = 1.0, 0.0
            needs = {"loss": "loss", "latency": "latency_ms"}.get(event)
            for key in ("loss", "latency_ms"):
                if key in entry and key != needs:
                    raise ScenarioError(f"{where}.{key}: only for event = "
                                        f"{'loss' if key == 'loss' else 'latency'}")
            if needs is not None and needs not in entry:
                raise ScenarioError(f"{where}.{needs}: missing (event = {event!r})")
            if event == "loss":
                loss = number(entry["loss"], f"{where}.loss")
                if not 0.0 < loss <= 1.0:
                    raise ScenarioError(f"{where}.loss: must be a probability in (0, 1], "
                                        f"got {loss!r}")
            if event == "latency":
                latency = number(entry["latency_ms"], f"{where}.latency_ms")
                if not 0.0 < latency <= 60_000.0:
                    raise ScenarioError(f"{where}.latency_ms: must be in (0, 60000] ms, "
                                        f"got {latency!r}")
            out.append(Fault(float(at), link=link, event=event, duration_s=float(duration),
                             loss=float(loss), latency_ms=float(latency)))
            continue
        at, vehicle = timeline_entry(entry, where, ("at_s", "unit", "type"), vehicles)
        unit = choice(entry["unit"], tuple(UNITS), f"{where}.unit")
        kind = choice(entry["type"], tuple(TYPES), f"{where}.type")
        if kind not in SUPPORTED[unit]:
            raise ScenarioError(f"{where}.type: {unit} can be {', '.join(SUPPORTED[unit])} "
                                f"(as PX4 SITL), got {kind!r}")
        instance = int(number(entry.get("instance", 0), f"{where}.instance", integer=True,
                               minimum=0))
        if unit == "motor" and instance > 4:  # the x500's four
            raise ScenarioError(f"{where}.instance: motors are 1..4 (0: all), got {instance}")
        out.append(Fault(float(at), vehicle, instance=instance, unit=unit, type=kind))
    return tuple(sorted(out, key=lambda f: f.at_s))
