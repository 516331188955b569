"""Topologies: paths for each kind, shared channels, outages, mobility, config errors."""

import pytest

from netsim.backend import EmbeddedBackend
from netsim.kernel import Kernel
from netsim.topology import link_names, make_router


def _hops(route, src, dst):
    return [(h.model, h.src, h.dst, h.shared_key) for h in route(src, dst)]


def test_direct_is_one_hop_ideal_by_default():
    route, positions = make_router({})
    assert positions == {}
    assert _hops(route, "v1", "gcs") == [("ideal", "v1", "gcs", None)]
    route, _ = make_router({"topology": "direct", "link": {"latency_s": 0.05}})
    (hop,) = route("gcs", "v3")
    assert (hop.model, hop.params) == ("fixed", {"latency_s": 0.05})


def test_star_paths_ground_api_clients():
    route, positions = make_router({"topology": "star",
                                    "ap": {"position_ned_m": [50, -20, -10]}})
    assert positions == {"ap": (50.0, -20.0, -10.0)}
    assert _hops(route, "v1", "gcs") == [("wireless", "v1", "ap", None),
                                         ("fixed", "ap", "gcs", None)]
    assert _hops(route, "gcs", "v1") == [("fixed", "gcs", "ap", None),
                                         ("wireless", "ap", "v1", None)]
    assert _hops(route, "v2", "api2") == [("wireless", "v2", "ap", None),
                                          ("fixed", "ap", "api2", None)]
    assert route("gcs", "v1")[0].params == {"latency_s": 0.001}


def test_star_with_channel_onboard_api_and_relay():
    route, _ = make_router({
        "topology": "star", "ap": {"name": "tower"}, "api_clients": "onboard",
        "channel": {"rate_bps": 1e6, "queue_packets": 20},
        "wired": {"jitter_s": 0.0002},
    })
    assert _hops(route, "v1", "gcs") == [
        ("queue", "v1", "tower", "tower/channel/rx"), ("wireless", "v1", "tower", None),
        ("fixed", "tower", "gcs", None)]
    assert _hops(route, "gcs", "v1") == [
        ("fixed", "gcs", "tower", None), ("queue", "tower", "v1", "tower/channel/tx"),
        ("wireless", "tower", "v1", None)]
    assert route("gcs", "v1")[0].params == {"latency_s": 0.001, "jitter_s": 0.0002}
    assert route("v1", "gcs")[0].params == {"rate_bps": 1e6, "queue_packets": 20}
    assert _hops(route, "api1", "v1") == [("ideal", "api1", "v1", None)]
    assert _hops(route, "v1", "api1") == [("ideal", "v1", "api1", None)]
    assert [h[0] for h in _hops(route, "v1", "v2")] == ["queue", "wireless", "queue",
                                                        "wireless"]
    half, _ = make_router({"topology": "star", "channel": {"rate_bps": 1e6,
                                                           "half_duplex": True}})
    assert route("v1", "gcs")[0].shared_key != route("gcs", "v1")[1].shared_key
    assert half("v1", "gcs")[0].shared_key == half("gcs", "v1")[1].shared_key == "ap/channel"
    assert "half_duplex" not in half("v1", "gcs")[0].params


def test_adhoc_paths():
    route, positions = make_router({"topology": "adhoc",
                                    "gcs": {"position_ned_m": [0, 0, -3]}})
    assert positions == {"gcs": (0.0, 0.0, -3.0)}
    assert _hops(route, "v1", "gcs") == [("wireless", "v1", "gcs", None)]
    assert _hops(route, "gcs", "v2") == [("wireless", "gcs", "v2", None)]
    assert _hops(route, "api1", "v1") == [("fixed", "api1", "gcs", None),
                                          ("wireless", "gcs", "v1", None)]
    assert _hops(route, "v1", "v2") == [("wireless", "v1", "v2", None)]  # no relaying


def test_unknown_nodes_and_self_links_are_errors():
    route, _ = make_router({"topology": "star"})
    with pytest.raises(ValueError, match="unknown node 'router7'"):
        route("v1", "router7")
    with pytest.raises(ValueError, match="itself"):
        route("v1", "v1")


def test_link_names_follow_the_gateway():
    assert link_names("v1", "gcs")[0] == "v1/gcs/down"
    assert link_names("gcs", "v1")[0] == "v1/gcs/up"
    assert link_names("api2", "v2")[0] == "v2/api/up"
    assert link_names("api2", "v1") == ("api2->v1", "api2", "v1")


def test_outages_by_link_name_node_and_glob():
    route, _ = make_router({"topology": "star", "outages": [
        {"link": "v1/gcs/down", "start_s": 10, "duration_s": 5},
        {"link": "v2", "start_s": 1, "duration_s": 1},
        {"link": "v*/api/*", "start_s": 7, "duration_s": 2},
    ]})
    first = route("v1", "gcs")[0]
    assert (first.model, first.params) == ("outage", {"windows_s": [[10.0, 5.0]]})
    assert route("gcs", "v1")[0].model == "fixed"
    assert route("v2", "gcs")[0].params == {"windows_s": [[1.0, 1.0]]}
    assert route("api2", "v2")[0].params == {"windows_s": [[1.0, 1.0], [7.0, 2.0]]}
    assert route("v3", "api3")[0].params == {"windows_s": [[7.0, 2.0]]}


def _backend(config, seed=1, tracer=None):
    route, positions = make_router(config)
    kernel = Kernel()
    return kernel, EmbeddedBackend(kernel, route, seed=seed, fixed_positions=positions,
                                   tracer=tracer)


def test_shared_channel_queues_two_vehicles_behind_each_other():
    # Ideal radios isolate the channel: 80 kbit/s, so a 100-byte packet holds it 10 ms.
    config = {"topology": "star", "radio": {"model": "ideal"}, "wired": {"model": "ideal"},
              "channel": {"rate_bps": 80_000}}
    kernel, backend = _backend(config)
    got = []
    v1 = backend.make_link("v1/gcs/down", "v1", "gcs", lambda p, m: got.append((kernel.now, p)))
    v2 = backend.make_link("v2/gcs/down", "v2", "gcs", lambda p, m: got.append((kernel.now, p)))
    down = backend.make_link("v1/gcs/up", "gcs", "v1", lambda p, m: got.append((kernel.now, p)))
    v1.send(b"1" * 100)
    v2.send(b"2" * 100)
    down.send(b"d" * 100)  # the other direction has its own channel
    kernel.run()
    assert got == [(pytest.approx(0.01), b"1" * 100), (pytest.approx(0.01), b"d" * 100),
                   (pytest.approx(0.02), b"2" * 100)]
    # half duplex: all three share one channel.
    kernel, backend = _backend({**config, "channel": {"rate_bps": 80_000, "half_duplex": True}})
    times = []
    for name, src, dst in (("a", "v1", "gcs"), ("b", "v2", "gcs"), ("c", "gcs", "v1")):
        backend.make_link(name, src, dst, lambda p, m: times.append(kernel.now)).send(b"x" * 100)
    kernel.run()
    assert times == pytest.approx([0.01, 0.02, 0.03])


def test_positions_move_with_mobility_updates():
    kernel, backend = _backend({"topology": "star", "ap": {"position_ned_m": [0, 0, -10]}})
    link = backend.make_link("v1/gcs/down", "v1", "gcs", lambda p, m: None)
    backend.update_mobility(0.0, {"v1": (20.0, 0.0, -10.0)})
    for i in range(100):
        kernel.schedule(i * 0.01, link.send, b"x" * 60)
    kernel.run(until=1.0)
    assert link.stats.delivered == 100
    backend.update_mobility(1.0, {"v1": (900.0, 0.0, -10.0)})  # far beyond the AP's range
    for i in range(100):
        kernel.schedule(1.0 + i * 0.01, link.send, b"x" * 60)
    kernel.run(until=2.0)
    assert link.stats.dropped == {"range": 100}
    assert backend.mobility.distance_m("v1", "ap") == 900.0


def test_star_latency_grows_as_a_vehicle_flies_away():
    kernel, backend = _backend({"topology": "star", "wired": {"model": "ideal"}}, seed=3)
    link = backend.make_link("v1/gcs/down", "v1", "gcs", lambda p, m: None)
    means, losses = [], []
    for leg, distance in enumerate((10.0, 280.0)):
        backend.update_mobility(kernel.now, {"v1": (distance, 0.0, -10.0)})
        before = (link.stats.delivered, link.stats.latency_sum_s, link.stats.dropped_total)
        for i in range(3000):
            kernel.schedule(kernel.now + i * 0.01, link.send, b"x" * 100)
        kernel.run(until=(leg + 1) * 40.0)
        n = link.stats.delivered - before[0]
        means.append((link.stats.latency_sum_s - before[1]) / n)
        losses.append((link.stats.dropped_total - before[2]) / 3000)
    assert means[1] > 1.5 * means[0] and losses[1] > 0.2 > losses[0]


def test_same_seed_same_trace_through_a_star():
    config = {"topology": "star", "channel": {"rate_bps": 500_000, "queue_packets": 3},
              "outages": [{"link": "v2", "start_s": 0.3, "duration_s": 0.2}]}

    def trace(seed):
        events = []
        kernel, backend = _backend(config, seed=seed, tracer=lambda *e: events.append(e))
        links = [backend.make_link(f"v{i}/gcs/down", f"v{i}", "gcs", lambda p, m: None)
                 for i in (1, 2, 3)]
        backend.update_mobility(0.0, {"v1": (150.0, 0, -10), "v2": (220.0, 0, -10),
                                      "v3": (260.0, 0, -10)})
        for i in range(900):
            kernel.schedule(i * 0.001, links[i % 3].send, b"p" * 120)
        kernel.run()
        return events

    first = trace(9)
    assert first == trace(9) and first != trace(10)
    reasons = {e[4] for e in first if e[0] == "drop"}
    assert {"queue", "loss", "outage"} <= reasons


@pytest.mark.parametrize("config, path", [
    ({"topology": "mesh"}, "network.topology"),
    ({"topology": "star", "ap": {"position_ned_m": [1, 2]}}, "network.ap.position_ned_m"),
    ({"topology": "star", "ap": {"position_ned_m": "here"}}, "network.ap.position_ned_m"),
    ({"topology": "star", "ap": {"height_m": 3}}, "network.ap.height_m"),
    ({"topology": "star", "ap": {"name": "v1"}}, "network.ap.name"),
    ({"topology": "adhoc", "gcs": {"position_ned_m": [0, 0, None]}},
     "network.gcs.position_ned_m"),
    ({"topology": "star", "radio": {"path_loss_exponent": 0.1}},
     "network.radio.path_loss_exponent"),
    ({"topology": "star", "radio": {"tx_power_dbmw": 3}}, "network.radio.tx_power_dbmw"),
    ({"topology": "star", "wired": {"latency_s": -1}}, "network.wired.latency_s"),
    ({"topology": "star", "wired": {"model": "nope"}}, "network.wired.model"),
    ({"topology": "star", "channel": {"rate_bps": 1e6, "half_duplex": "yes"}},
     "network.channel.half_duplex"),
    ({"topology": "star", "channel": {"rate_bps": -3}}, "network.channel.rate_bps"),
    ({"topology": "star", "api_clients": "cloud"}, "network.api_clients"),
    ({"topology": "direct", "ap": {}}, "network.ap"),
    ({"link": {"model": "burst", "loss_bad": 3}}, "network.link.loss_bad"),
    ({"outages": [{"link": "v1", "start_s": -1, "duration_s": 1}]},
     r"network.outages\[0\].start_s"),
    ({"outages": [{"link": "v1", "start_s": 1}]}, r"network.outages\[0\].duration_s"),
    ({"outages": [{"link": "", "start_s": 1, "duration_s": 1}]}, r"network.outages\[0\].link"),
    ({"outages": {"link": "v1"}}, "network.outages"),
])
def test_config_errors_name_the_key_path(config, path):
    with pytest.raises(ValueError, match=f"^{path}: "):
        make_router(config)


def test_foreign_keys_are_ignored():
    route, _ = make_router({"topology": "direct", "seed": 3, "backend": "embedded",
                            "sync_period_s": 0.02, "late_policy": "drop"})
    assert route("v1", "gcs")[0].model == "ideal"
    with pytest.raises(ValueError, match="network.seed"):
        make_router({"seed": 3}, ignore=())
