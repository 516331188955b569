"""Sharded runs are exact: a shard held right after each sync point's mobility update, given
every other vehicle's position there, has the network of one process; the shards' log parts
merge into the files one process writes; a scripted flight and --duration need no client."""

import io
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from gateway.daemon.app import RunConfig
from gateway.daemon.pacer import Pacer
from gateway.daemon.shard import check
from gateway.sim import logparts
from gateway.sim.command_timeline import Command, parse_commands
from gateway.sim.flightlog import link_vehicle
from gateway.sim.scenario import NetworkConfig, ScenarioError, parse
from gateway.sim.simulation import Simulation
from netsim.kernel import PRIORITY_DEFAULT, PRIORITY_PHYSICS, Kernel
from netsim.link import InstantSortedTrace

ADHOC = NetworkConfig(topology={"topology": "adhoc", "radio": {"model": "wireless"}}, seed=5)
FLY = tuple(c for i in (1, 2, 3, 4) for c in (Command(3.0, i, "arm"), Command(3.5, i, "takeoff")))


def test_a_run_stops_at_a_priority_inside_an_instant():
    kernel, seen = Kernel(), []
    for name, priority in (("net", PRIORITY_DEFAULT), ("physics", PRIORITY_PHYSICS)):
        kernel.schedule(1.0, seen.append, name, priority=priority)
    kernel.run(until=1.0, priority=PRIORITY_PHYSICS)
    assert seen == ["physics"] and kernel.now == 1.0
    kernel.run(until=1.0)
    assert seen == ["physics", "net"]


@pytest.mark.asyncio
async def test_the_pacer_holds_at_the_horizon_barrier_and_ends_at_end_s():
    kernel, seen = Kernel(), []
    for t, priority in ((1.0, PRIORITY_PHYSICS), (1.0, PRIORITY_DEFAULT), (2.0, PRIORITY_DEFAULT)):
        kernel.schedule(t, lambda t=t, p=priority: seen.append((t, p)), priority=priority)
    pacer = Pacer(kernel, speed=float("inf"), end_s=2.0)
    pacer.set_horizon(1.0, PRIORITY_PHYSICS)
    pacer.run_due()
    kernel.run(until=1.0, priority=pacer.horizon_priority)
    pacer.run_due()  # a datagram arriving while held runs nothing past the barrier
    assert seen == [(1.0, PRIORITY_PHYSICS)] and not pacer.finished
    pacer.set_horizon(5.0, PRIORITY_PHYSICS)  # past end_s: the end, all of it
    assert (pacer.horizon, pacer.horizon_priority > PRIORITY_DEFAULT) == (2.0, True)
    await pacer.run()  # returns: every event up to end_s has run
    assert seen[1:] == [(1.0, PRIORITY_DEFAULT), (2.0, PRIORITY_DEFAULT)] and pacer.finished


def test_shards_held_at_each_sync_point_see_the_positions_one_process_sees():
    one = Simulation(4, ADHOC, commands=FLY)
    shards = [Simulation(2, ADHOC, first_index=0, commands=FLY),
              Simulation(2, ADHOC, first_index=2, commands=FLY)]
    reports: dict[int, dict] = {}
    for k, shard in enumerate(shards):
        shard.on_sync = lambda t, pos, k=k: reports.__setitem__(k, pos)
    try:
        t = 0.0
        while t < 9.0:
            one.kernel.run(until=t, priority=PRIORITY_PHYSICS)
            for shard in shards:
                shard.kernel.run(until=t, priority=PRIORITY_PHYSICS)
            everyone = {**reports[0], **reports[1]}
            for k, shard in enumerate(shards):
                shard.set_remote_positions(t, {n: p for n, p in everyone.items()
                                               if n not in reports[k]})
                assert shard.backend.mobility.positions == one.backend.mobility.positions
            t = shards[0].next_sync_s
            assert t == shards[1].next_sync_s == one.next_sync_s
        altitudes = [-p[2] for n, p in one.backend.mobility.positions.items() if n[0] == "v"]
        assert min(altitudes) > 0.5  # they flew: the positions moved
        assert one.link_stats() == {**shards[0].link_stats(), **shards[1].link_stats()}
    finally:
        for sim in (one, *shards):
            sim.close()


def test_an_instants_trace_lines_come_vehicle_by_vehicle():
    out = io.StringIO()
    trace = InstantSortedTrace(out, link_vehicle)
    for link in ("v2/gcs/down", "v1/gcs/down", "v2/api/down", "v1/api/down"):
        trace("send", link, 1.0, 10, "0.001")
    trace("recv", "v2/gcs/down", 1.001, 10, "")
    trace.flush()
    assert [ln.split()[2] for ln in out.getvalue().splitlines()] == [
        "v1/gcs/down", "v1/api/down", "v2/gcs/down", "v2/api/down", "v2/gcs/down"]
    assert (link_vehicle("v12/lte/up"), link_vehicle("gcs->ap")) == (12, 0)


def test_parts_merge_by_time_then_shard(tmp_path):
    (tmp_path / "state.csv.shard0").write_text("t_s,sysid\n0.100,1\n0.100,2\n0.200,1\n0.200,2\n")
    (tmp_path / "state.csv.shard1").write_text("t_s,sysid\n0.100,3\n0.200,3\n")
    (tmp_path / "packets.trace.shard0").write_text("0.5 send v1/gcs/down 1 0\n0.7 recv a 1 \n")
    (tmp_path / "packets.trace.shard1").write_text("0.5 send v3/gcs/down 1 0\n0.6 recv b 1 \n")
    (tmp_path / "meta.json.shard0").write_text('{"seed": 1, "vehicles": [{"sysid": 1}]}')
    (tmp_path / "meta.json.shard1").write_text('{"seed": 1, "vehicles": [{"sysid": 3}]}')
    logparts.merge_run_dir(tmp_path, 2)
    assert (tmp_path / "state.csv").read_text() == (
        "t_s,sysid\n0.100,1\n0.100,2\n0.100,3\n0.200,1\n0.200,2\n0.200,3\n")
    assert [ln.split()[2] for ln in (tmp_path / "packets.trace").read_text().splitlines()] == [
        "v1/gcs/down", "v3/gcs/down", "b", "a"]
    assert '"sysid": 3' in (tmp_path / "meta.json").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["meta.json", "packets.trace",
                                                          "state.csv"]


def test_logs_run_sharded_but_a_shared_channel_does_not():
    config = RunConfig(vehicles=2, shards=2, log_dir=Path("logs"), packet_trace=Path("t"),
                       state_dir=Path("state"))
    assert check(config) is None
    channel = replace(config, network=NetworkConfig(topology={
        "topology": "star", "channel": {"model": "queue", "rate_bps": 1e6}}))
    assert "network.channel" in check(channel)


def test_a_command_timeline_flies_without_a_client():
    commands = parse_commands([{"at_s": 3.0, "vehicle": 2, "command": "arm"},
                               {"at_s": 3.5, "vehicle": 2, "command": "takeoff"},
                               {"at_s": 9.0, "vehicle": 2, "command": "reposition",
                                "ned_m": [10.0, 0.0, -5.0]}], vehicles=2)
    sim = Simulation(2, commands=commands)
    try:
        sim.run(until=22.0)
        still, flown = sim.vehicles
        assert not still.status.armed and flown.status.armed
        n, _, d = flown.state.position_ned_m
        assert abs(n - 10.0) < 1.0 and abs(d + 5.0) < 1.0
    finally:
        sim.close()


@pytest.mark.parametrize("entry, words", [
    ({"at_s": 1.0, "command": "flip"}, "commands[0].command: expected one of"),
    ({"at_s": 1.0, "command": "reposition"}, "commands[0].ned_m: missing"),
    ({"at_s": 1.0, "command": "arm", "ned_m": [0, 0, 0]}, "commands[0].ned_m: only for"),
    ({"at_s": 1.0, "vehicle": 3, "command": "arm"}, "commands[0].vehicle: the scenario has 1"),
    ({"command": "arm"}, "commands[0].at_s: missing"),
])
def test_command_timeline_errors_name_the_key(entry, words):
    with pytest.raises(ScenarioError, match=words.replace("[", r"\[").replace("]", r"\]")):
        parse({"commands": [entry]})


@pytest.mark.parametrize("value", ["0", "-3", "soon", "inf"])
def test_a_bad_duration_exits_2_saying_so(value):
    r = subprocess.run([sys.executable, "-m", "gateway.cli", "run", "--duration", value],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "--duration must be" in r.stderr, r.stderr


def test_the_coordinator_publishes_every_shards_vehicles_as_one_daemon():
    from gateway.bus.zmq_pub import TOPIC_PACKET, TOPIC_STATE
    from gateway.daemon.shard.outlets import BusMerger, RelayPublisher

    sent = []

    class Socketless:
        wants_packets = False

        def publish(self, topic, body):
            sent.append((topic, body))

    relays = [RelayPublisher(), RelayPublisher()]
    sims = [Simulation(2, first_index=0), Simulation(1, first_index=2)]
    try:
        merger = BusMerger(Socketless(), 2)  # type: ignore[arg-type]
        relays[1].wants_packets = True
        relays[1].packet_event("send", "v3/gcs/down", 0.1, 10, "0")
        for relay, sim in zip(relays, sims):
            relay.vehicle_states(0.1, sim)
        merger.take(1, relays[1].take())
        assert [t for t, _ in sent] == [TOPIC_PACKET]  # the state waits for shard 0's
        merger.take(0, relays[0].take())
        topic, body = sent[-1]
        assert topic == TOPIC_STATE and [v["sysid"] for v in body["vehicles"]] == [1, 2, 3]
    finally:
        for sim in sims:
            sim.close()


def test_the_coordinators_metrics_are_every_shards():
    from gateway.daemon.metrics import Exporter
    from gateway.daemon.shard.outlets import ShardedExporter

    class Shard:
        def __init__(self, first: int, n: int) -> None:
            self.sim = Simulation(n, first_index=first)
            self.pacer = Pacer(self.sim.kernel)

    shards = [Shard(0, 2), Shard(2, 1)]
    try:
        shards[0].sim.run(until=2.0)
        shards[1].sim.run(until=1.0)
        merged = ShardedExporter()
        for k, shard in enumerate(shards):
            merged.take(k, Exporter(shard).snapshot())
        samples = {(s.name, tuple(sorted(s.labels.items()))): s.value
                   for m in merged.snapshot() for s in m.samples}
        assert samples[("cornet_vehicles", ())] == 3
        assert samples[("cornet_sim_seconds_total", ())] == 1.0  # the slowest shard's
        assert {dict(labels)["vehicle"] for name, labels in samples
                if name == "cornet_mavlink_tx_frames_total"} == {"1", "2", "3"}
    finally:
        for shard in shards:
            shard.sim.close()


def test_a_relayed_sighup_is_told_from_a_sigusr1_by_every_rank(tmp_path):
    from gateway.daemon.shard.reload import ReloadFlag

    path = tmp_path / "reload"
    ranks = [ReloadFlag(str(path)), ReloadFlag(str(path))]
    assert not any(r.requested() for r in ranks)  # SIGUSR1: no SIGHUP yet
    path.write_text("1")  # the launcher got SIGHUP
    assert all(r.requested() for r in ranks)  # each rank sees it, whoever looks first
    assert not any(r.requested() for r in ranks)  # the next SIGUSR1 is a SIGUSR1


def test_a_sharded_reload_keeps_the_network_it_cannot_swap(caplog):
    from gateway.daemon.shard.reload import prepare

    running = RunConfig(vehicles=2, shards=2)
    channel = replace(running, network=NetworkConfig(topology={
        "topology": "star", "channel": {"model": "queue", "rate_bps": 1e6}}))
    slower = replace(running, network=replace(running.network, sync_period_s=0.05))
    lossy = replace(running, network=NetworkConfig.from_flags(10.0, 0.0, 0.2, 0))
    for new, words in ((channel, "network.channel"), (slower, "sync_period_s")):
        assert prepare(running, lambda new=new: new) == (running, None)
        assert words in caplog.text
    config, change = prepare(running, lambda: lossy)
    assert config.network == lossy.network and change == {"network": lossy.network,
                                                          "wind": lossy.wind}
