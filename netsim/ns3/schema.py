"""The ns-3 backend's configuration tables, checked before the engine starts (netsim/ns3/README.md
lists every key): a typo or a value of the wrong kind is a ValueError naming its key, never a
default the engine silently takes (its JSON reader falls back to the default for a key it does
not find or cannot read) nor a traceback from the bridge.

Only kinds and finiteness are checked here; ranges (a standard's name, a data rate) are the
engine's, whose error names the key too.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from netsim.ns3.cells import check_lte_config

NUMBER, TEXT, FLAG, POINT = "a number", "a string", "true or false", "[north, east, down] metres"
TABLES: dict[str, dict[str, str]] = {
    "wifi": {"standard": TEXT, "rate_manager": TEXT, "data_mode": TEXT, "control_mode": TEXT,
             "tx_power_dbm": NUMBER, "rx_sensitivity_dbm": NUMBER,
             "cca_ed_threshold_dbm": NUMBER, "preamble_detection_min_rssi_dbm": NUMBER,
             "preamble_detection_snr_db": NUMBER},
    "propagation": {"exponent": NUMBER, "reference_distance_m": NUMBER,
                    "reference_loss_db": NUMBER, "nakagami_m": NUMBER},
    "wired": {"data_rate": TEXT, "delay_s": NUMBER},
    "reference": {"latency_s": NUMBER, "latency_per_m_s": NUMBER, "cycle_delay_s": NUMBER,
                  "hang_at_step": NUMBER, "exit_at_step": NUMBER},
}
NODE_KEYS = {"position": POINT, "kind": TEXT, "passive": FLAG}
# Seconds the bridge waits or simulates: a NaN or infinite one would hang it.
SECONDS = {"warmup_s": 0.0, "drop_after_s": 0.0, "timeout_s": None, "init_timeout_s": None}


def check_tables(config: Mapping[str, Any]) -> None:
    """ValueError naming the key (``wifi.tx_power_dbm: expected a number, got nan``)."""
    for key, minimum in SECONDS.items():
        if key in config:
            value = config[key]
            if not _is(NUMBER, value) or value < (minimum or 0.0) or \
                    (minimum is None and value == 0):
                bound = ">= 0" if minimum is not None else "> 0"
                raise ValueError(f"{key}: expected a number of seconds {bound}, got {value!r}")
    for table, keys in TABLES.items():
        if table in config:
            _check(config[table], keys, table)
    nodes = config.get("nodes", {})
    if not isinstance(nodes, Mapping):
        raise ValueError(f"nodes: expected a table of nodes, got {nodes!r}")
    for name, spec in nodes.items():
        _check(spec, NODE_KEYS, f"nodes.{name}")
    check_lte_config(config)


def _check(table: Any, keys: dict[str, str], path: str) -> None:
    if not isinstance(table, Mapping):
        raise ValueError(f"{path}: expected a table, got {table!r}")
    for key, value in table.items():
        kind = keys.get(key)
        if kind is None:
            raise ValueError(f"{path}.{key}: unknown key (known: {', '.join(keys)})")
        if not _is(kind, value):
            raise ValueError(f"{path}.{key}: expected {kind}, got {value!r}")


def _is(kind: str, value: Any) -> bool:
    if kind == TEXT:
        return isinstance(value, str)
    if kind == FLAG:
        return isinstance(value, bool)
    if kind == POINT:
        return isinstance(value, (list, tuple)) and len(value) == 3 and \
            all(_is(NUMBER, v) for v in value)
    return isinstance(value, (int, float)) and not isinstance(value, bool) and \
        math.isfinite(value)
