"""LTE through the real ns-3 (netsim/ns3/lte.cc): the engine's protocol on the kernel (attach,
handover between two eNBs, every packet reported once, bad config refused naming the key), and
an unmodified MAVSDK mission flown through the ns3-lte scenario."""

from __future__ import annotations

import struct

import pytest

from netsim.kernel import PRIORITY_PHYSICS, Kernel, Ticker
from netsim.ns3 import BINARY, Ns3Backend, Ns3Error, build_missing_message
from tests.e2e.flows import fly_square_mission
from tests.e2e.persona import connected

pytestmark = [
    pytest.mark.e2e,
    pytest.mark.skipif(not BINARY.is_file(), reason=build_missing_message()),
]

SYNC_S = 0.02
PACKET = struct.Struct("<dI")  # send time, sequence
TWO_CELLS = {
    "topology": "lte",
    "nodes": {"enb1": {"position": [0.0, 0.0, -30.0]}, "enb2": {"position": [1000.0, 0.0, -30.0]},
              "gcs": {"position": [0.0, 0.0, 0.0]}},
    "propagation": {"exponent": 3.0},
    "lte": {"ideal_rrc": False},
}


def fly_past(config: dict, *, start_m: float, speed_mps: float, sim_s: float,
             rate_hz: float = 50.0, seed: int = 1):
    """v1 flies north at `speed_mps` from `start_m`, 10 m up, with `rate_hz` datagrams each way
    (MAVLink-like: 72 bytes); returns (backend, links, latencies by send time)."""
    kernel = Kernel()
    backend = Ns3Backend(kernel, config, seed=seed, sync_period_s=SYNC_S)
    latencies: list[tuple[float, float]] = []

    def received(packet: bytes, meta) -> None:
        sent_at, _ = PACKET.unpack_from(packet)
        latencies.append((sent_at, kernel.now - sent_at))

    links = [backend.make_link("v1/up", "gcs", "v1", received),
             backend.make_link("v1/down", "v1", "gcs", received)]
    position = lambda t: (start_m + speed_mps * t, 0.0, -10.0)  # noqa: E731
    Ticker(kernel, SYNC_S, lambda now: backend.update_mobility(now, {"v1": position(now)}),
           priority=PRIORITY_PHYSICS)
    count = [0]

    def send(now: float) -> None:
        if now < sim_s - 1.0:  # the last second lets the last ones arrive
            for link in links:
                count[0] += 1
                link.send(PACKET.pack(now, count[0]) + bytes(60))

    Ticker(kernel, 1.0 / rate_hz, send, start_s=0.0013)
    try:
        kernel.run(until=sim_s)
    finally:
        backend.close()
    return backend, links, latencies


def test_attach_then_handover_to_the_second_enb_with_every_packet_reported_once():
    backend, links, latencies = fly_past(TWO_CELLS, start_m=450.0, speed_mps=20.0, sim_s=12.0)
    ready = backend.ready_reply
    assert ready["unassociated"] == [] and ready["serving"] == {"v1": "enb1"}
    assert ready["cells"] == {"enb1": 1, "enb2": 2} and ready["addresses"]["v1"].startswith("7.")
    stats = backend.backend_stats()
    assert stats["serving"] == {"v1": "enb2"} and stats["handovers"] == 1, stats
    start, end = [e for e in stats["cell_events"] if e["event"].startswith("handover")]
    assert (start["event"], start["from"], start["to"]) == ("handover_start", "enb1", "enb2")
    assert (end["event"], end["cell"]) == ("handover_end", "enb2")
    # A3, 3 dB hysteresis at exponent 3: enb2 is 3 dB stronger ~560 m from enb1 (+ filtering
    # and the 256 ms time-to-trigger).
    assert 540.0 < 450.0 + 20.0 * start["time_s"] < 620.0, start
    for link in links:
        s = link.stats
        assert s.sent == s.delivered + s.dropped_total and s.in_flight == 0, s.as_dict()
        assert set(s.dropped) <= {"loss"}
    # Far from the handover: LTE's own latency (scheduling, HARQ), a few to ~20 ms one way.
    quiet = [lat for t, lat in latencies if abs(t - start["time_s"]) > 1.0]
    assert max(quiet) < 0.03 and min(quiet) > 0.002
    # Around it: the interruption shows as loss or as datagrams held back.
    near = [lat for t, lat in latencies if abs(t - start["time_s"]) <= 1.0]
    lost = sum(s.stats.dropped_total for s in links)
    assert lost > 0 or max(near) > 0.03, (lost, max(near))


def test_same_seed_same_handover():
    runs = [fly_past(TWO_CELLS, start_m=500.0, speed_mps=20.0, sim_s=5.0)[0]
            .backend_stats()["cell_events"] for _ in range(2)]
    assert runs[0] == runs[1] and runs[0]


@pytest.mark.parametrize(("lte", "error"), [
    ({"bandwidth_rb": 7}, "lte.bandwidth_rb"),
    ({"rlc_mode": "tm"}, "lte.rlc_mode"),
    ({"handover_algorithm": "ns3::NoOpHandoverAlgorithm", "hysteresis_db": 2.0},
     "lte.hysteresis_db"),
    ({"earfcn": "100"}, "lte.earfcn"),
])
def test_bad_lte_config_is_refused_by_the_engine_naming_the_key(lte, error):
    backend = Ns3Backend(Kernel(), {**TWO_CELLS, "lte": lte}, strict=True)
    try:
        with pytest.raises(Ns3Error, match=error):
            backend.start()
    finally:
        backend.close()


def test_lte_nodes_and_keys_are_checked_before_the_engine_starts():
    with pytest.raises(ValueError, match="lte.hysteresis: unknown key"):
        Ns3Backend(Kernel(), {**TWO_CELLS, "lte": {"hysteresis": 3.0}})
    with pytest.raises(ValueError, match="nodes.enb1.kind"):
        Ns3Backend(Kernel(), {"topology": "ap", "nodes": {"enb1": {"kind": "enb"}}})


@pytest.mark.slow
@pytest.mark.asyncio
async def test_mavsdk_mission_through_lte(daemon_factory):
    d = daemon_factory("--scenario", "ns3-lte", "--speed", "2")
    assert "network=ns3/lte" in d.ready_line and "speed 2x" in d.ready_line, d.ready_line
    async with connected(d.api_port()) as drone:
        await fly_square_mission(drone, 120, 90)


@pytest.mark.parametrize(("lte", "nodes", "error"), [
    ({"ttt_s": 1}, ["enb1", "v1"], r"lte\.ttt_s: unknown key"),
    ({}, ["v1"], "at least one node of kind 'enb'"),
    ({}, ["ap", "v1"], "kind 'ap' in topology 'lte'"),
])
def test_the_engine_itself_refuses_a_bad_lte_init(lte, nodes, error):
    """The bridge checks keys and kinds first; the engine does too, for any other client. (A
    refused init leaves ns-3 half built: each case gets its own engine.)"""
    from netsim.ns3.engine import PROTOCOL_VERSION, EngineProcess, node_kind

    process = EngineProcess("ns3", BINARY)
    try:
        init = {"v": PROTOCOL_VERSION, "op": "init", "topology": "lte", "lte": lte,
                "nodes": [{"name": n, "kind": node_kind(n)} for n in nodes]}
        # A generous wait: on a loaded machine ns-3's libraries take a while to load, and a
        # request that times out returns None, which would pass for an accepted init.
        with pytest.raises(Ns3Error, match=error):
            process.request(init, 60.0)
    finally:
        process.release()
