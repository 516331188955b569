"""The ``lte`` topology's Python side: its config keys and the cells the engine reports.

Rules:
- ``check_lte_config`` validates the ``lte`` section's keys and the node kinds of an ns-3 config
  before any engine starts (the bridge's ``check_config`` calls it, for ``cornet check`` and
  ``Ns3Backend``), naming the bad key; values are checked again by the engine, which knows ns-3's ranges.
- ``Cells`` follows the engine's replies: the ready reply's ``cells`` (eNB name -> cell id) and
  ``serving`` (UE -> eNB name or None), then each step reply's ``events`` (handover start/end,
  radio link failure, connection), in protocol time. A finished handover (``handover_end``) or a
  new connection changes the serving cell; a radio link failure clears it. ``handovers`` counts
  the ends that follow a start: once, in a real-time daemon run, ns-3 traced HandoverEndOk twice
  (same instant) for one handover; every event is still kept as ns-3 reported it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

# The `lte` section (README.md, "The lte topology"): key -> default, as the engine applies it.
LTE_DEFAULTS: dict[str, Any] = {
    "enb_tx_power_dbm": 46.0, "ue_tx_power_dbm": 23.0, "bandwidth_rb": 25, "earfcn": 100,
    "rlc_mode": "um", "handover_algorithm": "ns3::A3RsrpHandoverAlgorithm",
    "hysteresis_db": 3.0, "time_to_trigger_s": 0.256, "serving_cell_threshold": 30,
    "neighbour_cell_offset": 1, "s1u_delay_s": 0.001, "x2_delay_s": 0.001, "ideal_rrc": True,
}
EVENTS_KEPT = 1000  # the most recent cell events backend_stats() carries


def check_lte_config(config: Mapping[str, Any]) -> None:
    """ValueError naming the key when the topology, a node kind or an ``lte`` key is wrong."""
    topology = config.get("topology", "adhoc")  # the engine checks the name
    lte = config.get("lte")
    if lte is not None:
        if topology != "lte":
            raise ValueError(f"lte: only used with topology = \"lte\" (not {topology!r})")
        if not isinstance(lte, Mapping):
            raise ValueError("lte: must be a table")
        unknown = sorted(set(lte) - set(LTE_DEFAULTS))
        if unknown:
            raise ValueError(f"lte.{unknown[0]}: unknown key (known: {sorted(LTE_DEFAULTS)})")
    for name, spec in (config.get("nodes") or {}).items():
        kind = spec.get("kind") if isinstance(spec, Mapping) else None
        if kind == "enb" and topology != "lte":
            raise ValueError(f"nodes.{name}.kind: 'enb' needs topology = \"lte\"")
        if kind == "ap" and topology == "lte":
            raise ValueError(f"nodes.{name}.kind: 'ap' is not part of the lte topology")


class Cells:
    """Which eNB serves which UE, and the handovers so far (module rules)."""

    def __init__(self) -> None:
        self.cell_ids: dict[str, int] = {}
        self.serving: dict[str, str | None] = {}
        self.events: list[dict[str, Any]] = []
        self.handovers = 0
        self._starting: set[str] = set()  # UEs between handover_start and its end

    def ready(self, reply: Mapping[str, Any]) -> None:
        self.cell_ids = dict(reply.get("cells") or {})
        self.serving = dict(reply.get("serving") or {})

    def step(self, reply: Mapping[str, Any]) -> None:
        for event in reply.get("events") or ():
            kind, node = event["event"], event["node"]
            if kind == "handover_start":
                self._starting.add(node)
            elif kind in ("handover_end", "connected"):
                self.serving[node] = event["cell"]
                if kind == "handover_end" and node in self._starting:
                    self.handovers += 1
                    self._starting.discard(node)
            elif kind in ("radio_link_failure", "handover_error"):
                self._starting.discard(node)
                if kind == "radio_link_failure":
                    self.serving[node] = None
            self.events.append(dict(event))
        del self.events[:-EVENTS_KEPT]

    def stats(self) -> dict[str, Any]:
        return {"cells": dict(self.cell_ids), "serving": dict(self.serving),
                "handovers": self.handovers, "cell_events": list(self.events)}
