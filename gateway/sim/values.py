"""The checks every scenario value goes through: each failure is a ScenarioError whose message
names the key path (``network.sync_period_s: ...``), as `cornet run`, `cornet check` and SIGHUP
print it."""

from __future__ import annotations

import ipaddress
import math
from collections.abc import Callable
from typing import Any


class ScenarioError(ValueError):
    """A scenario problem; the message names the key path."""


def table(doc: dict, key: str, path: str) -> dict:
    value = doc.get(key, {})
    if not isinstance(value, dict):
        raise ScenarioError(f"{path}: expected a table, got {type(value).__name__}")
    return value


def unknown(table: dict, known: tuple[str, ...], path: str) -> None:
    for key in table:
        if key not in known:
            raise ScenarioError(f"{path}.{key}: unknown key (known: {', '.join(known)})"
                                if path else f"{key}: unknown table (known: {', '.join(known)})")


def number(value: Any, path: str, *, minimum: float | None = None, integer: bool = False,
            positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            (integer and not isinstance(value, int)) or not math.isfinite(value):
        raise ScenarioError(f"{path}: expected {'an integer' if integer else 'a number'}, "
                            f"got {value!r}")
    if minimum is not None and value < minimum:
        raise ScenarioError(f"{path}: must be >= {minimum}, got {value!r}")
    if positive and value <= 0:
        raise ScenarioError(f"{path}: must be > 0, got {value!r}")
    return value


def choice(value: Any, choices: tuple[str, ...], path: str) -> str:
    if value not in choices:
        raise ScenarioError(f"{path}: expected one of {', '.join(choices)}, got {value!r}")
    return value


MAX_SPAWN_M = 100_000.0  # spawn points within 100 km of home (the local frame is flat)
MIN_SPAWN_SEPARATION_M = 1.0  # closer bodies would start inside each other


def timeline_entry(entry: dict, where: str, required: tuple[str, ...],
                   vehicles: int) -> tuple[float, int]:
    """A timeline entry's ``at_s`` (>= 0) and ``vehicle`` (1 .. ``vehicles``, default 1), after
    checking that every key of ``required`` is there."""
    for key in required:
        if key not in entry:
            raise ScenarioError(f"{where}.{key}: missing")
    at = number(entry["at_s"], f"{where}.at_s", minimum=0.0)
    vehicle = int(number(entry.get("vehicle", 1), f"{where}.vehicle", integer=True, minimum=1))
    if vehicle > vehicles:
        raise ScenarioError(f"{where}.vehicle: the scenario has {vehicles} vehicle(s), "
                            f"got {vehicle}")
    return at, vehicle


def spawn_points(value: Any, count: int,
                 grid: Callable[[int], tuple[float, float]]) -> tuple[tuple[float, float], ...]:
    """``vehicles.spawn_ned_m``: a list of ``[north, east]`` metres from home, one per vehicle
    from vehicle 1 (at most ``count``); vehicles past its end spawn on ``grid``."""
    path = "vehicles.spawn_ned_m"
    if not isinstance(value, list):
        raise ScenarioError(f"{path}: expected a list of [north, east] points, got {value!r}")
    if len(value) > count:
        raise ScenarioError(f"{path}: {len(value)} points for {count} vehicle(s)")
    points = []
    for k, p in enumerate(value):
        where = f"{path}[{k}]"
        if not isinstance(p, list) or len(p) != 2:
            raise ScenarioError(f"{where}: expected [north, east] in metres, got {p!r}")
        n, e = (number(x, where) for x in p)
        if abs(n) > MAX_SPAWN_M or abs(e) > MAX_SPAWN_M:
            raise ScenarioError(f"{where}: must be within {MAX_SPAWN_M:g} m of home, got {p!r}")
        points.append((float(n), float(e)))
    every = points + [grid(i) for i in range(len(points), count)]
    for i in range(len(points)):
        for j in range(count):
            if j != i and math.dist(every[i], every[j]) < MIN_SPAWN_SEPARATION_M:
                raise ScenarioError(f"{path}[{i}]: vehicle {i + 1} would spawn within "
                                    f"{MIN_SPAWN_SEPARATION_M:g} m of vehicle {j + 1}")
    return tuple(points)


def gcs_partner(value: Any, path: str) -> tuple[str, int | None]:
    """``HOST`` or ``HOST:PORT`` (an IPv4 address): where the GCS links talk first (``--gcs``,
    ``daemon.gcs``); the port None keeps each link's own."""
    host, sep, port_text = value.partition(":") if isinstance(value, str) else ("", "", "")
    try:
        ipaddress.IPv4Address(host)
        port = int(port_text) if sep else None
    except ValueError:
        raise ScenarioError(f"{path} must be HOST or HOST:PORT with an IPv4 address, e.g. "
                            f"192.168.1.20 or 192.168.1.20:14550; got {value!r}") from None
    if port is not None and not 1 <= port <= 65535:
        raise ScenarioError(f"{path}: the port must be between 1 and 65535, got {port}")
    return host, port


DEFAULT_LISTEN_HOST = "127.0.0.1"


def listen_address(value: Any, path: str, example: str) -> tuple[str, int]:
    """(host, port) from ``[ADDR:]PORT``: ``8080``, ``0.0.0.0:8080``, ``localhost:8080``,
    ``[::1]:8080`` (the live view's ``--web``, ``daemon.web``)."""
    text = str(value) if isinstance(value, int) and not isinstance(value, bool) else value
    if not isinstance(text, str):
        raise ScenarioError(f"{path}: expected [ADDR:]PORT, e.g. {example}; got {value!r}")
    host, sep, port_text = text.rpartition(":")
    if not sep:
        host = DEFAULT_LISTEN_HOST
    elif host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    try:
        port = int(port_text)
    except ValueError:
        raise ScenarioError(f"{path}: expected [ADDR:]PORT, e.g. {example}; got {value!r}") \
            from None
    if not 1 <= port <= 65535:
        raise ScenarioError(f"{path}: the port must be between 1 and 65535, got {value!r}")
    if host != "localhost":
        try:
            ipaddress.ip_address(host)
        except ValueError:
            raise ScenarioError(f"{path}: {host!r} is not an IP address (or localhost); e.g. "
                                f"{example}") from None
    return host, port
