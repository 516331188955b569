"""Scenario files: every shipped one loads; every mistake names its key and the file."""

import pathlib

import pytest

from gateway.scenario import ScenarioError, describe, load, parse
from gateway.sim import Simulation

ROOT = pathlib.Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "scenarios").glob("*.toml"))


def test_the_five_scenarios_are_shipped():
    assert {p.stem for p in SHIPPED} >= {"ideal", "lossy-wifi", "far-ap", "congested", "blackout"}


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_scenarios_load_and_run(path):
    s = load(path)
    assert "ok" in describe(s)
    sim = Simulation(s.vehicles, s.network, home=s.home)
    try:
        sim.run(until=2.0)
        assert all(stats["sent"] > 0 for name, stats in sim.link_stats().items()
                   if name.endswith("/down"))
    finally:
        sim.close()


@pytest.mark.parametrize("doc, key", [
    ({"vehicle": {}}, "vehicle: unknown table"),
    ({"vehicles": {"count": 0}}, "vehicles.count"),
    ({"vehicles": {"count": 2.5}}, "vehicles.count"),
    ({"vehicles": {"cout": 2}}, "vehicles.cout: unknown key"),
    ({"vehicles": {"home": {"lat_deg": 123.0}}}, "vehicles.home"),
    ({"vehicles": {"params": {"NOPE": 1}}}, "vehicles.params.NOPE"),
    ({"vehicles": {"params": {"MAV_TYPE": 1.5}}}, "vehicles.params.MAV_TYPE"),
    ({"vehicles": {"airframe": "f450"}}, "vehicles.airframe"),
    ({"network": {"backend": "omnet"}}, "network.backend"),
    ({"network": {"late_policy": "maybe"}}, "network.late_policy"),
    ({"network": {"sync_period_s": -0.02}}, "network.sync_period_s"),
    ({"network": {"topology": "mesh"}}, "network.topology"),
    ({"network": {"link": {"model": "warp"}}}, "network.link"),
    ({"network": {"link": {"model": "fixed", "latency_s": -1}}}, "network.link"),
    ({"network": {"link": {"model": "fixed", "latency_ms": 80}}}, "network.link"),
    ({"network": {"topology": "star", "ap": {"position_ned_m": [1, 2]}}}, "network.ap"),
    ({"logging": {"level": "loud"}}, "logging.level"),
])
def test_errors_name_the_key(doc, key):
    with pytest.raises(ScenarioError, match=key.replace(".", r"\.")):
        parse(doc)


def test_file_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[network\n")
    with pytest.raises(ScenarioError, match="bad.toml: not valid TOML"):
        load(bad)
    with pytest.raises(ScenarioError, match="cannot read"):
        load(tmp_path / "missing.toml")
    bad.write_text("[network]\nlate_policy = 'maybe'\n")
    with pytest.raises(ScenarioError, match=r"bad\.toml: network\.late_policy"):
        load(bad)
