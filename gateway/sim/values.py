"""The checks every scenario value goes through: each failure is a ScenarioError whose message
names the key path (``network.sync_period_s: ...``), as `cornet run`, `cornet check` and SIGHUP
print it."""

from __future__ import annotations

import math
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
