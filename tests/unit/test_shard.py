from dataclasses import replace

import pytest

from gateway.daemon.app import RunConfig
from gateway.daemon.shard import check, split
from gateway.sim.scenario import NetworkConfig
from gateway.sim.simulation import Simulation


def test_split_is_contiguous_and_balanced():
    assert split(5, 2) == [(0, 3), (3, 2)]
    assert split(200, 2) == [(0, 100), (100, 100)]
    assert split(3, 3) == [(0, 1), (1, 1), (2, 1)]
    parts = split(101, 4)
    assert sum(n for _, n in parts) == 101 and max(n for _, n in parts) - min(
        n for _, n in parts) <= 1


@pytest.mark.parametrize("changes, words", [
    ({"shards": 0}, "at least 1"),
    ({"shards": 3, "vehicles": 2}, "more than --vehicles"),
    ({"shards": 2, "vehicles": 2, "zmq_pub": "tcp://127.0.0.1:5556"}, "--zmq-pub"),
    ({"shards": 2, "vehicles": 2, "network": NetworkConfig(backend="ns3")}, "embedded"),
])
def test_what_cannot_run_sharded_is_named(changes, words):
    assert words in check(replace(RunConfig(), **changes))


def test_one_shard_and_plain_sharding_are_fine():
    assert check(RunConfig()) is None
    assert check(RunConfig(vehicles=4, shards=2)) is None


def test_a_shard_simulates_its_block_and_its_network_sees_the_others():
    sim = Simulation(2, first_index=3)
    try:
        assert sim.indices == [3, 4]
        assert [int(v.params["MAV_SYS_ID"]) for v in sim.vehicles] == [4, 5]
        assert set(sim.vehicle_positions_ned_m()) == {"v4", "v5"}
        reported = []
        sim.on_sync = lambda t, pos: reported.append((t, sorted(pos)))
        sim.remote_positions = {"v1": (100.0, 0.0, -10.0)}
        sim.run(until=0.05)
        assert reported[0] == (0.0, ["v4", "v5"]) and len(reported) == 3
        assert sim.backend.mobility.positions["v1"] == (100.0, 0.0, -10.0)
        assert set(sim.backend.mobility.positions) >= {"v1", "v4", "v5"}
        assert {name[:3] for name in sim.link_stats()} == {"v4/", "v5/"}
    finally:
        sim.close()
