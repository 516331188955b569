"""The bus publisher without a socket: in-process listeners, and what cornet.state says about
the world (its home, the network's ground nodes) besides the vehicles."""

import pytest

from gateway.bus.zmq_pub import TOPIC_LINKS, TOPIC_STATE, Publisher
from gateway.sim.scenario import load
from gateway.sim.simulation import Simulation
from vehicles.geodesy import reproject

ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]


def published(scenario: str | None, vehicles: int = 2) -> list[tuple[bytes, dict]]:
    network = load(ROOT / "scenarios" / scenario).network if scenario else None
    sim = Simulation(vehicles, network)
    pub = Publisher(None)
    got: list[tuple[bytes, dict]] = []
    pub.listeners.append(lambda topic, body: got.append((topic, body)))
    sim.every(0.1, lambda now: pub.vehicle_states(now, sim))
    sim.every(1.0, lambda now: pub.link_stats(now, sim))
    try:
        sim.run(until=1.05)
    finally:
        sim.close()
        pub.close()
    return got


@pytest.fixture(scope="module")
def star() -> list[tuple[bytes, dict]]:
    return published("far-ap.toml")


def test_listeners_get_every_message_without_a_socket(star):
    topics = [t for t, _ in star]
    assert topics.count(TOPIC_STATE) == 11 and topics.count(TOPIC_LINKS) == 2  # t = 0 too
    assert all(body["v"] == 1 for _, body in star)


def test_state_carries_the_home_and_the_access_point(star):
    state = [b for t, b in star if t == TOPIC_STATE][-1]
    home = state["home"]
    assert (home["lat_deg"], home["lon_deg"]) == (47.397742, 8.545594)
    (ap,) = state["nodes"]
    assert ap["name"] == "ap" and ap["kind"] == "ap" and ap["serves"] == ["gcs", "api"]
    n, e, d = ap["world_ned_m"]
    lat, lon = reproject(home["lat_deg"], home["lon_deg"], n, e)
    assert (ap["lat_deg"], ap["lon_deg"]) == (round(lat, 7), round(lon, 7))
    assert ap["alt_amsl_m"] == pytest.approx(home["alt_amsl_m"] - d)
    assert [v["sysid"] for v in state["vehicles"]] == [1, 2]


def test_direct_links_have_no_ground_node_and_extra_radios_have_theirs():
    direct = [b for t, b in published(None, vehicles=1) if t == TOPIC_STATE][-1]
    assert direct["nodes"] == []
    radios = [b for t, b in published("two-radios.toml", vehicles=1) if t == TOPIC_STATE][-1]
    kinds = {n["name"]: (n["kind"], n["serves"]) for n in radios["nodes"]}
    assert kinds["lte"] == ("radio", ["lte"])


def test_the_ad_hoc_ground_radio_and_onboard_api_clients():
    from gateway.sim.scenario import NetworkConfig

    network = NetworkConfig(topology={"topology": "adhoc", "api_clients": "onboard",
                                      "gcs": {"position_ned_m": [10.0, 20.0, -2.0]}})
    sim = Simulation(1, network)
    want = [{"name": "gcs", "kind": "gcs", "world_ned_m": (10.0, 20.0, -2.0), "serves": ["gcs"]}]
    try:
        assert sim.ground_nodes() == want
        sim.run(until=0.1)  # the vehicles' positions reach the network: they are no ground node
        assert "v1" in sim.backend.mobility.positions and sim.ground_nodes() == want
    finally:
        sim.close()
