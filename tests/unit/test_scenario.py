"""Scenario files: every shipped one loads; every mistake names its key and the file."""

import math
import pathlib
import re

import pytest

from gateway.sim.scenario import DaemonSettings, ScenarioError, describe, load, parse
from gateway.sim.simulation import Simulation
from netsim.ns3.bridge import BINARY, build_missing_message

ROOT = pathlib.Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "scenarios").glob("*.toml"))


def test_the_five_scenarios_are_shipped():
    assert {p.stem for p in SHIPPED} >= {"ideal", "lossy-wifi", "far-ap", "congested", "blackout"}


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_scenarios_load_and_run(path):
    s = load(path)
    assert "ok" in describe(s)
    if s.network.backend == "ns3" and not BINARY.is_file():
        pytest.skip(build_missing_message())
    sim = Simulation(s.vehicles, s.network, home=s.home, spawn_ned_m=s.spawn_ned_m)
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
    ({"vehicles": {"spawn_ned_m": [[0, 0], [0, 9]]}}, "vehicles.spawn_ned_m: 2 points for 1"),
    ({"vehicles": {"spawn_ned_m": [[0, 0, 0]]}}, "vehicles.spawn_ned_m[0]: expected [north"),
    ({"vehicles": {"spawn_ned_m": [[0, math.nan]]}}, "vehicles.spawn_ned_m[0]: expected a num"),
    ({"vehicles": {"spawn_ned_m": [[2e5, 0]]}}, "vehicles.spawn_ned_m[0]: must be within"),
    ({"vehicles": {"count": 2, "spawn_ned_m": [[0, 4.5]]}}, "spawn_ned_m[0]: vehicle 1 would"),
    ({"network": {"backend": "ns3", "ns3": {"routing": "babel"}}}, "network.ns3.routing"),
    ({"network": {"backend": "ns3", "ns3": {"routing": "olsr", "topology": "ap"}}},
     "network.ns3.routing: 'olsr' needs"),
])
def test_errors_name_the_key(doc, key):
    with pytest.raises(ScenarioError, match=re.escape(key)):
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


# --- the daemon's configuration file: a scenario plus [daemon] -----------------------------------

@pytest.mark.parametrize("doc, key", [
    ({"daemon": {"bnd": "127.0.0.1"}}, "daemon.bnd: unknown key"),
    ({"daemon": {"bind": "localhost"}}, "daemon.bind"),
    ({"daemon": {"bind": "::1"}}, "daemon.bind"),
    ({"daemon": {"bind": 2130706433}}, "daemon.bind"),  # 127.0.0.1 as an integer
    ({"daemon": {"port_offset": -1}}, "daemon.port_offset"),
    ({"daemon": {"port_offset": 1.5}}, "daemon.port_offset"),
    ({"daemon": {"port_offset": 60000}}, "daemon.port_offset"),  # 18570 + 60000 > 65535
    ({"vehicles": {"count": 254}, "daemon": {"port_offset": 46800}}, "daemon.port_offset"),
    ({"vehicles": {"count": 255}}, "vehicles.count: at most 254"),
    ({"daemon": {"speed": "fast"}}, "daemon.speed"),
    ({"daemon": {"speed": 0}}, "daemon.speed"),
    ({"daemon": {"speed": 5000}}, "daemon.speed"),
    ({"daemon": {"speed": True}}, "daemon.speed"),
    ({"daemon": {"state_dir": 3}}, "daemon.state_dir"),
    ({"daemon": {"log_dir": ""}}, "daemon.log_dir"),
    ({"daemon": {"packet_trace": []}}, "daemon.packet_trace"),
    ({"daemon": {"zmq_pub": "5556"}}, "daemon.zmq_pub"),
    ({"daemon": {"log_level": "loud"}}, "daemon.log_level"),
    ({"daemon": {"log_level": "info"}, "logging": {"level": "info"}}, "daemon.log_level"),
    ({"daemon": "127.0.0.1"}, "daemon: expected a table"),
])
def test_daemon_table_errors_name_the_key(doc, key):
    with pytest.raises(ScenarioError, match=key.replace(".", r"\.")):
        parse(doc)


def test_daemon_table_values_and_relative_paths(tmp_path):
    f = tmp_path / "cornet.toml"
    f.write_text('[daemon]\nbind = "0.0.0.0"\nport_offset = 100\nspeed = "max"\n'
                 'state_dir = "state"\nlog_dir = "/var/log/cornet"\nzmq_pub = "tcp://127.0.0.1:5556"\n'
                 'packet_trace = "trace/packets.trace"\nlog_level = "debug"\n')
    s = load(f)
    d = s.daemon
    assert (d.bind, d.port_offset, d.speed) == ("0.0.0.0", 100, math.inf)
    assert d.state_dir == tmp_path / "state"  # relative to the file, not to the working dir
    assert d.log_dir == pathlib.Path("/var/log/cornet")
    assert d.packet_trace == tmp_path / "trace" / "packets.trace"
    assert d.zmq_pub == "tcp://127.0.0.1:5556" and s.log_level == "debug"
    assert "daemon: bind 0.0.0.0, port_offset 100, speed max" in describe(s)
    assert parse({}).daemon == DaemonSettings()  # nothing set: flags and defaults apply


def test_shipped_service_config_loads():
    s = load(ROOT / "systemd" / "cornet.toml")
    assert s.vehicles == 1 and s.network.backend == "embedded"
    d = s.daemon
    assert (d.bind, d.state_dir, d.log_dir) == ("127.0.0.1", pathlib.Path("/var/lib/cornet"),
                                                pathlib.Path("/var/log/cornet"))


def test_speed_limit_matches_the_cli():
    from gateway import cli_args
    from gateway.sim import scenario

    assert scenario.MAX_SPEED == cli_args.MAX_SPEED


@pytest.mark.parametrize("doc, key", [
    ({"network": {"sync_period_s": 1e-300}}, "network.sync_period_s"),
    ({"network": {"sync_period_s": 1e9}}, "network.sync_period_s"),
    ({"vehicles": {"home": {"alt_amsl_m": 3e38}}}, "vehicles.home.alt_amsl_m"),
    ({"network": {"topology": "star", "ap": {"position_ned_m": [1e308, 0, -10]}}},
     "network.ap.position_ned_m"),
    ({"network": {"link": {"model": "fixed", "latency_s": 1e300}}}, "latency_s"),
    ({"network": {"link": {"model": "fixed", "jitter_s": float("inf")}}}, "jitter_s"),
    ({"network": {"link": {"model": "queue", "rate_bps": 3e38}}}, "rate_bps"),
    ({"network": {"link": {"model": "burst", "latency_s": 1e9}}}, "latency_s"),
])
def test_values_out_of_range_are_refused_naming_the_key(doc, key):
    """What `cornet check` and SIGHUP refuse is what `cornet run` refuses: the same parser."""
    with pytest.raises(ScenarioError, match=key.replace(".", r"\.")):
        parse(doc)


def test_spawn_points_place_vehicles_and_the_rest_stay_on_the_grid():
    s = parse({"vehicles": {"count": 3, "spawn_ned_m": [[140.0, 0.0], [70.0, -3.0]]}})
    assert s.spawn_ned_m == ((140.0, 0.0), (70.0, -3.0))
    assert "spawn points [[140.0, 0.0], [70.0, -3.0]]" in describe(s)
    sim = Simulation(s.vehicles, s.network, home=s.home, spawn_ned_m=s.spawn_ned_m)
    try:
        got = sim.vehicle_positions_ned_m()
        for node, (n, e) in (("v1", (140.0, 0.0)), ("v2", (70.0, -3.0)), ("v3", (0.0, 10.0))):
            assert got[node][:2] == pytest.approx((n, e), abs=1e-6)
        # Each vehicle's EKF origin (its home) is its spawn point.
        v1 = sim.vehicles[0].origin
        assert (v1.lat_deg - s.home.lat_deg) * 111_195.0 == pytest.approx(140.0, abs=0.5)
    finally:
        sim.close()


@pytest.mark.parametrize("value, expected", [("192.168.1.20", ("192.168.1.20", None)),
                                             ("10.0.0.5:14551", ("10.0.0.5", 14551))])
def test_daemon_gcs_is_a_partner_address(value, expected):
    s = parse({"daemon": {"gcs": value}})
    assert s.daemon.gcs == expected
    assert "gcs " + value in describe(s)


@pytest.mark.parametrize("value", ["qgc.local", "10.0.0.5:0", "10.0.0.5:port", 14550])
def test_a_bad_daemon_gcs_names_the_key(value):
    with pytest.raises(ScenarioError, match="daemon.gcs"):
        parse({"daemon": {"gcs": value}})
