"""Extra radios: scenario keys, ports, one session per radio, and an outage on one radio."""

import itertools

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.ci.ports import daemon_ports
from gateway.mavlink.session import LinkKind
from gateway.sim.radios import MAX_EXTRA_RADIOS, ExtraRadio, link_ports, px4_ports, radio_ports
from gateway.sim.scenario import MAX_VEHICLES, ScenarioError, check_ports, parse
from gateway.sim.simulation import Simulation

LTE = {"name": "lte", "radio": {"model": "fixed", "latency_s": 0.04}}


def scenario(*radios, vehicles=1, **network):
    return parse({"vehicles": {"count": vehicles},
                  "network": {"topology": "star", "extra_radios": list(radios), **network}})


class Client:
    """A pymavlink codec on one link of vehicle 1, fed by the simulation."""

    def __init__(self, sim: Simulation, tag, peer) -> None:
        self.sim, self.tag, self.peer = sim, tag, peer
        self.mav = M.MAVLink(None, srcSystem=255, srcComponent=190)
        self.mav.robust_parsing = True
        self.received: list = []

    def send(self, msg) -> None:
        self.sim.inject(0, self.tag, msg.pack(self.mav), self.peer)

    def of_type(self, name: str) -> list:
        return [m for m in self.received if m.get_type() == name]


def wire(sim: Simulation) -> dict:
    clients = {tag: Client(sim, tag, (str(tag), 1)) for tag in sim.link_tags}

    def route(index, tag, data, peer):
        if index == 0:
            assert peer in (None, clients[tag].peer)  # each link answers its own client
            client = clients[tag]
            client.received += [m for m in client.mav.parse_buffer(data) or []
                                 if m.get_type() != "BAD_DATA"]

    sim.on_downlink = route
    return clients


# --- the scenario ---------------------------------------------------------------------------------
def test_scenario_keys():
    sc = scenario(LTE, {"name": "wifi2", "radio": {"model": "ideal"}, "remote_port": 14551,
                        "wired": {"latency_s": 0.002}, "position_ned_m": [10, 0, -5]})
    net = sc.network
    assert net.radios == (ExtraRadio("lte", 1, 14550), ExtraRadio("wifi2", 2, 14551))
    assert net.summary == "embedded/star+lte+wifi2"
    # The topology gets the network's part only.
    assert all("remote_port" not in entry for entry in net.topology["extra_radios"])


@pytest.mark.parametrize("radios, network, where", [
    ([{"name": "lte", "radio": {"model": "fixed", "latency_s": -1}}], {},
     "network.extra_radios[0].radio.latency_s"),
    ([{"name": "lte", "radio": {"model": "warp"}}], {}, "network.extra_radios[0].radio.model"),
    ([{"name": "lte", "radio": "fast"}], {}, "network.extra_radios[0].radio"),
    ([{"name": "lte", "wired": {"loss": 2}}], {}, "network.extra_radios[0].wired.loss"),
    ([LTE, {"name": "x", "antenna": 1}], {}, "network.extra_radios[1].antenna"),
    ([{"radio": {}}], {}, "network.extra_radios[0].name"),
    ([{"name": "gcs"}], {}, "network.extra_radios[0].name"),
    ([{"name": "Wi Fi"}], {}, "network.extra_radios[0].name"),
    ([{"name": "ap"}], {}, "network.extra_radios[0].name"),  # the star's access point
    ([LTE, LTE], {}, "network.extra_radios[1].name"),
    ([{"name": "lte", "position_ned_m": [0, 0]}], {}, "network.extra_radios[0].position_ned_m"),
    ([{"name": "lte", "remote_port": 0}], {}, "network.extra_radios[0].remote_port"),
    ([{"name": "lte", "remote_port": 18570}], {}, "network.extra_radios[0].remote_port"),
    ([{"name": "lte", "remote_port": 19570}], {}, "network.extra_radios[0].remote_port"),
    ([{"name": f"r{k}x"} for k in range(MAX_EXTRA_RADIOS + 1)], {}, "network.extra_radios"),
    ([LTE], {"backend": "ns3"}, "network.extra_radios"),
])
def test_bad_extra_radios_name_the_key(radios, network, where):
    with pytest.raises(ScenarioError) as err:
        scenario(*radios, **network)
    assert str(err.value).startswith(f"{where}:"), err.value


def test_extra_radios_is_a_list_of_tables():
    for value in ({"name": "lte"}, ["lte"]):
        with pytest.raises(ScenarioError, match=r"^network\.extra_radios"):
            parse({"network": {"extra_radios": value}})


def test_port_offset_must_leave_room_for_the_radios():
    radios = scenario(LTE, {"name": "sat"}).network.radios
    check_ports(254, 45000, "--port-offset")  # fine without radios: 18823 + 45000
    with pytest.raises(ScenarioError, match="extra radio 'sat'.*needs port"):
        check_ports(254, 45000, "--port-offset", radios)


# --- ports ----------------------------------------------------------------------------------------
def test_radio_ports_collide_with_nothing_for_254_vehicles():
    radios = [ExtraRadio(f"r{k}", k) for k in range(1, MAX_EXTRA_RADIOS + 1)]
    for offset in (0, 1000):
        bound = [p.local for i in range(MAX_VEHICLES) for p in
                 [px4_ports(i, LinkKind.GCS, offset), px4_ports(i, LinkKind.API, offset),
                  *(radio_ports(i, r, offset) for r in radios)]]
        assert len(set(bound)) == len(bound)
        clients = {14550 + offset, *range(14540 + offset, 14550 + offset)}
        assert not clients & set(bound)
        assert max(bound) <= 65535
    assert radio_ports(0, radios[0]) == (19570, 14550)
    assert radio_ports(3, ExtraRadio("lte", 2, 14551), offset=10) == (20583, 14561)
    assert link_ports(3, "r1", radios, 10) == (19583, 14560)
    assert link_ports(3, LinkKind.API, radios, 10) == (14593, 14553)


def test_the_ci_port_list_checks_the_radios_ports():
    radios = [ExtraRadio("a", 1), ExtraRadio("b", 2)]
    expected = {p for i, r in itertools.product(range(3), radios)
                for p in [radio_ports(i, r, 200).local]}
    assert expected <= set(daemon_ports(200, 3, radios=2))
    assert not expected & set(daemon_ports(200, 3))


# --- the simulation -------------------------------------------------------------------------------
def test_every_radio_is_a_session_of_the_same_vehicle():
    sc = scenario(LTE, vehicles=2)
    sim = Simulation(sc.vehicles, sc.network)
    try:
        assert sim.link_tags == (LinkKind.GCS, LinkKind.API, "lte")
        for i in range(2):
            gcs, lte = sim.links[(i, LinkKind.GCS)], sim.links[(i, "lte")]
            assert lte.session is not gcs.session
            assert lte.session.vehicle is gcs.session.vehicle is sim.vehicles[i]
            assert lte.session.kind is LinkKind.GCS  # PX4's Normal mode streams
            assert lte.session.sysid == i + 1
            assert lte.session.samples is gcs.session.samples
            assert lte.session.mission.uploads is gcs.session.mission.uploads
            assert (lte.uplink.name, lte.downlink.name) == (f"v{i + 1}/lte/up",
                                                            f"v{i + 1}/lte/down")
        assert "v2/lte/down" in sim.link_stats()
        # Lockstep runs leave them out unless asked.
        assert (0, "lte") not in Simulation(1, sc.network, extra_radios=False).links
    finally:
        sim.close()


def test_an_outage_of_one_radio_leaves_the_other_alone():
    sc = scenario(LTE, outages=[{"link": "v1/lte/*", "start_s": 2.0, "duration_s": 3.0}],
                  radio={"model": "fixed", "latency_s": 0.002})
    sim = Simulation(1, sc.network)
    clients = wire(sim)
    gcs, lte = clients[LinkKind.GCS], clients["lte"]
    try:
        sim.run(until=6.0)
        stats = sim.link_stats()
        assert stats["v1/lte/down"]["dropped"].get("outage", 0) > 0
        assert not stats["v1/gcs/down"]["dropped"]
        beats = {name: [m._header.seq for m in c.of_type("HEARTBEAT")]
                 for name, c in (("gcs", gcs), ("lte", lte))}
        assert len(beats["gcs"]) == 6 and len(beats["lte"]) == 3  # t = 0, 1, 5 (5 is after)
        # Each instance has its own message sequence: the radio's gap shows as lost frames.
        assert beats["gcs"] != beats["lte"]
        # The radio's node is where its vehicle is.
        mobility = sim.backend.mobility  # type: ignore[attr-defined]
        assert mobility.positions["v1.lte"] == mobility.positions["v1"]

        # Commands on the surviving radio act on the vehicle; the ACK comes back on it alone.
        sc2 = scenario(LTE, outages=[{"link": "v1/gcs/*", "start_s": 6.0, "duration_s": 60.0}])
        sim.reload_network(sc2.network)
        sim.run(until=6.1)  # what was in flight before the outage has arrived
        gcs.received.clear()
        lte.received.clear()
        lte.send(lte.mav.command_long_encode(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0,
                                             M.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
                                             0, 0, 0, 0, 0, 0))
        gcs.send(gcs.mav.command_long_encode(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0,
                                             300,  # PROTOCOL_VERSION
                                             0, 0, 0, 0, 0, 0))
        sim.run(until=8.0)
        assert [a.result for a in lte.of_type("COMMAND_ACK")] == [M.MAV_RESULT_ACCEPTED]
        assert lte.of_type("AUTOPILOT_VERSION")
        assert not gcs.of_type("COMMAND_ACK") and not gcs.of_type("HEARTBEAT")
        assert sim.link_stats()["v1/gcs/up"]["dropped"] == {"outage": 1}
    finally:
        sim.close()


def test_a_mission_uploaded_on_one_radio_is_the_vehicles():
    sc = scenario(LTE)
    sim = Simulation(1, sc.network)
    clients = wire(sim)
    gcs, lte = clients[LinkKind.GCS], clients["lte"]
    try:
        sim.run(until=1.0)
        lte.send(lte.mav.mission_count_encode(1, 1, 2, 0))
        sim.run(until=1.1)
        # While the radio uploads, the other link is refused (PX4: one transfer per vehicle:
        # MAV_MISSION_ERROR) and keeps its telemetry.
        gcs.send(gcs.mav.mission_count_encode(1, 1, 1, 0))
        sim.run(until=1.2)
        assert [a.type for a in gcs.of_type("MISSION_ACK")] == [M.MAV_MISSION_ERROR]
        for _ in range(2):
            request = lte.of_type("MISSION_REQUEST_INT")[-1]
            lte.send(lte.mav.mission_item_int_encode(
                1, 1, request.seq, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_WAYPOINT,
                0, 1, 0, 0, 0, float("nan"), int(47.3977e7) + request.seq * 1000,
                int(8.5456e7), 10.0, 0))
            sim.run(until=sim.now + 0.1)
        assert [a.type for a in lte.of_type("MISSION_ACK")] == [M.MAV_MISSION_ACCEPTED]
        gcs.send(gcs.mav.mission_request_list_encode(1, 1, 0))
        sim.run(until=sim.now + 0.1)
        assert [c.count for c in gcs.of_type("MISSION_COUNT")] == [2]
        assert len(gcs.of_type("HEARTBEAT")) == 2
    finally:
        sim.close()


def test_each_radio_signs_as_an_instance_of_its_own():
    from gateway.mavlink.signing import SigningConfig, SigningKey
    from gateway.sim.flightlog import split_frames

    sc = scenario(LTE, {"name": "sat"})
    sim = Simulation(1, sc.network, signing=SigningConfig(SigningKey.from_passphrase("x"),
                                                                 1.8e9))
    link_ids: dict = {}

    def route(index, tag, data, peer):
        for frame in split_frames(data):
            assert frame[2] & 1, "unsigned frame"
            link_ids.setdefault(tag, set()).add(frame[-13])  # link_id opens the signature

    sim.on_downlink = route
    try:
        sim.run(until=1.0)
        # PX4 numbers its MAVLink instances in start order: GCS 0, onboard 1, then the radios.
        assert link_ids == {LinkKind.GCS: {0}, LinkKind.API: {1}, "lte": {2}, "sat": {3}}
    finally:
        sim.close()


def test_a_reload_may_change_the_radios_hops_but_not_the_radios():
    sim = Simulation(1, scenario(LTE).network)
    try:
        sim.run(until=0.5)
        slower = scenario({"name": "lte", "radio": {"model": "fixed", "latency_s": 0.3}})
        sim.reload_network(slower.network)
        sim.run(until=2.0)
        assert sim.link_stats()["v1/lte/down"]["latency_max_ms"] == pytest.approx(300.0)
        for other in (scenario({"name": "sat"}), scenario(LTE, {"name": "sat"}),
                      scenario({**LTE, "remote_port": 14551}), scenario()):
            with pytest.raises(ValueError, match="extra radios"):
                sim.reload_network(other.network)
        assert sim.network == slower.network
    finally:
        sim.close()


def test_flight_logs_and_metrics_name_the_radio(tmp_path):
    import json
    from types import SimpleNamespace

    from gateway.daemon.metrics import Exporter
    from gateway.daemon.pacer import Pacer
    from gateway.sim.flightlog import FlightLog

    log = FlightLog(tmp_path, boot_unix_s=1000.0)
    sim = Simulation(1, scenario(LTE).network, tracer=log.tracer)
    try:
        log.attach(sim)
        sim.on_downlink = lambda i, tag, data, peer: log.record_datagram("down", i, tag, data,
                                                                         sim.now)
        sim.run(until=1.5)
        log.close()
        meta = json.loads((tmp_path / "meta.json").read_text())
        assert meta["vehicles"][0]["tlogs"] == ["v1-gcs.tlog", "v1-api.tlog", "v1-lte.tlog"]
        assert (tmp_path / "v1-lte.tlog").stat().st_size > 0
        assert "v1/lte/down" in (tmp_path / "packets.trace").read_text()
        d = SimpleNamespace(sim=sim, pacer=Pacer(sim.kernel, clock=lambda: 0.0), endpoints={})
        labels = {(m.name, tuple(sorted(s.labels.items()))) for m in
                  Exporter(d, clock=lambda: 1.0).snapshot() for s in m.samples}
        assert ("cornet_mavlink_tx_frames", (("link", "lte"), ("vehicle", "1"))) in labels
    finally:
        sim.close()
