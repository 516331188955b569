"""The lte topology's Python side (netsim/ns3/cells.py): config checks before any engine starts,
and the serving cells and handovers followed from the engine's replies."""

from __future__ import annotations

import pytest

from gateway.sim.scenario import ScenarioError, parse
from netsim.ns3.cells import EVENTS_KEPT, LTE_DEFAULTS, Cells, check_lte_config
from netsim.ns3.engine import node_kind


def test_enb_names_are_enb_nodes_and_api_clients_stay_ground():
    assert [node_kind(n) for n in ("enb", "enb2", "enbx", "api1", "v3")] == \
        ["enb", "enb", "ground", "ground", "vehicle"]


@pytest.mark.parametrize(("config", "error"), [
    ({"topology": "lte", "lte": {"hysteresis": 3.0}}, "lte.hysteresis: unknown key"),
    ({"topology": "lte", "lte": 3}, "lte: must be a table"),
    ({"topology": "ap", "lte": {}}, "lte: only used with topology"),
    ({"topology": "adhoc", "nodes": {"enb1": {"kind": "enb"}}}, "nodes.enb1.kind"),
    ({"topology": "lte", "nodes": {"ap": {"kind": "ap"}}}, "nodes.ap.kind"),
])
def test_bad_lte_config_names_the_key(config, error):
    with pytest.raises(ValueError, match=error):
        check_lte_config(config)


def test_good_lte_config_passes():
    check_lte_config({"topology": "lte", "lte": dict(LTE_DEFAULTS),
                  "nodes": {"enb1": {"position": [0, 0, -30]}, "gcs": {}}})


def test_cornet_check_names_the_bad_lte_key():
    doc = {"network": {"backend": "ns3", "ns3": {"topology": "lte", "lte": {"ttt_s": 0.1}}}}
    with pytest.raises(ScenarioError, match=r"network\.ns3\.lte\.ttt_s: unknown key"):
        parse(doc, "x.toml")


def test_cells_follow_handovers_and_failures():
    cells = Cells()
    cells.ready({"cells": {"enb1": 1, "enb2": 2}, "serving": {"v1": "enb1", "v2": "enb2"}})
    cells.step({"events": [
        {"time_s": 1.0, "node": "v1", "event": "handover_start", "from": "enb1", "to": "enb2"}]})
    assert cells.serving == {"v1": "enb1", "v2": "enb2"}  # not until it is done
    cells.step({"events": [
        {"time_s": 1.01, "node": "v1", "event": "handover_end", "cell": "enb2"},
        {"time_s": 2.0, "node": "v2", "event": "radio_link_failure", "cell": "enb2"}]})
    cells.step({"delivered": []})  # a reply of another topology: nothing changes
    stats = cells.stats()
    assert stats["serving"] == {"v1": "enb2", "v2": None} and stats["handovers"] == 1
    assert [e["event"] for e in stats["cell_events"]] == \
        ["handover_start", "handover_end", "radio_link_failure"]
    cells.step({"events": [{"time_s": 3.0, "node": "v2", "event": "connected", "cell": "enb1"}]})
    assert cells.serving["v2"] == "enb1" and cells.handovers == 1


def test_cells_keep_the_last_events_only():
    cells = Cells()
    cells.step({"events": [{"time_s": float(i), "node": "v1", "event": "handover_end",
                            "cell": "enb1"} for i in range(EVENTS_KEPT + 5)]})
    assert len(cells.events) == EVENTS_KEPT and cells.events[0]["time_s"] == 5.0
    assert cells.handovers == 0  # ends without a start: no handover counted


def test_a_handover_counts_once_even_if_its_end_is_reported_twice():
    cells = Cells()
    start = {"time_s": 1.0, "node": "v1", "event": "handover_start", "from": "enb1", "to": "enb2"}
    end = {"time_s": 1.003, "node": "v1", "event": "handover_end", "cell": "enb2"}
    cells.step({"events": [start, end, end]})
    assert cells.handovers == 1 and len(cells.events) == 3


def test_the_reference_engine_runs_an_lte_config():
    """The pure-Python engine ignores LTE's specifics (it has no cells) but must not break."""
    from netsim.kernel import Kernel
    from netsim.ns3 import Ns3Backend

    kernel = Kernel()
    got: list[bytes] = []
    config = {"engine": "reference", "topology": "lte", "lte": {"ideal_rrc": False},
              "nodes": {"enb2": {"position": [1000.0, 0.0, -30.0]}}}
    backend = Ns3Backend(kernel, config, sync_period_s=0.02)
    try:
        link = backend.make_link("v1/down", "v1", "gcs", lambda p, m: got.append(p))
        assert backend.nodes == {"enb2": "enb", "v1": "vehicle", "gcs": "ground"}
        backend.update_mobility(0.0, {"v1": (0.0, 0.0, -10.0)})
        kernel.schedule(0.01, lambda: link.send(b"x"))
        kernel.run(until=0.1)
        assert got == [b"x"]
        stats = backend.backend_stats()
        assert stats["serving"] == {} and stats["handovers"] == 0
    finally:
        backend.close()
