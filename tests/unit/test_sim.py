"""The daemon's whole data path on simulated time: no sockets, no asyncio, no wall clock."""

import hashlib

import pytest
from pymavlink.dialects.v20 import common as mavlink2

from gateway.mavlink.session import LinkKind
from gateway.sim.scenario import NetworkConfig
from gateway.sim.simulation import Simulation, px4_ports

M = mavlink2


class Client:
    """A pymavlink codec playing MAVSDK on one vehicle link, fed by the simulation."""

    def __init__(self, sim: Simulation, index: int, kind: LinkKind) -> None:
        self.sim, self.index, self.kind = sim, index, kind
        self.mav = M.MAVLink(None, srcSystem=245, srcComponent=190)
        self.mav.robust_parsing = True
        self.received: list = []
        self.raw = hashlib.sha256()

    def on_datagram(self, data: bytes) -> None:
        self.raw.update(data)
        for msg in self.mav.parse_buffer(data) or []:
            if msg.get_type() != "BAD_DATA":
                self.received.append((self.sim.now, msg))

    def send(self, msg) -> None:
        self.sim.inject(self.index, self.kind, msg.pack(self.mav), ("client", 1))

    def command(self, command: int, *params: float) -> None:
        p = list(params) + [0.0] * (7 - len(params))
        self.send(self.mav.command_long_encode(1, 1, command, 0, *p))

    def of_type(self, name: str):
        return [m for _, m in self.received if m.get_type() == name]


def make(network: NetworkConfig, vehicles: int = 1):
    sim = Simulation(vehicles, network)
    clients = {}

    def route(index, kind, data, peer):
        clients[(index, kind)].on_datagram(data)

    sim.on_downlink = route
    for i in range(vehicles):
        for kind in (LinkKind.GCS, LinkKind.API):
            clients[(i, kind)] = Client(sim, i, kind)
    return sim, clients


def fly(sim, api: Client) -> None:
    """What MAVSDK's takeoff_and_land does, with retries as MAVSDK's command sender."""
    hb = api.mav.heartbeat_encode(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    t = 0.0
    while t < 3.0:
        api.send(hb)
        t += 1.0
        sim.run(until=t)
    for _ in range(10):  # arm, retried until ACKed (MAVSDK: 0.5 s timeout, 3 retries)
        if sim.vehicles[0].status.armed:
            break
        api.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        t += 0.5
        sim.run(until=t)
    for _ in range(10):
        if sim.vehicles[0].status.nav_state.name == "AUTO_TAKEOFF" or \
                sim.vehicles[0].state.position_ned_m[2] < -0.5:
            break
        api.command(M.MAV_CMD_NAV_TAKEOFF, *([float("nan")] * 7))
        t += 0.5
        sim.run(until=t)
    sim.run(until=t + 10.0)


def test_ports_follow_px4_sitl():
    assert px4_ports(0, LinkKind.GCS) == (18570, 14550)
    assert px4_ports(0, LinkKind.API) == (14580, 14540)
    assert px4_ports(3, LinkKind.API, offset=100) == (14683, 14643)
    assert px4_ports(12, LinkKind.API).remote == 14549  # PX4: instances > 9 share 14549


def test_vehicle_talks_first_on_both_links():
    sim, clients = make(NetworkConfig())
    sim.run(until=2.5)
    for kind in (LinkKind.GCS, LinkKind.API):
        hbs = clients[(0, kind)].of_type("HEARTBEAT")  # 1 Hz from t = 0
        assert len(hbs) == 3 and all(h.autopilot == M.MAV_AUTOPILOT_PX4 for h in hbs)
    sim.close()


@pytest.mark.parametrize("seed", [1, 2])
def test_takeoff_over_a_lossy_jittery_network(seed):
    net = NetworkConfig.from_flags(latency_ms=80, jitter_ms=20, loss=0.2, seed=seed)
    sim, clients = make(net)
    api = clients[(0, LinkKind.API)]
    fly(sim, api)
    z = sim.vehicles[0].state.position_ned_m[2]
    assert -2.8 < z < -2.2
    acks = [m for m in api.of_type("COMMAND_ACK") if m.command == M.MAV_CMD_COMPONENT_ARM_DISARM]
    assert sim.vehicles[0].status.armed
    assert all(a.result == M.MAV_RESULT_ACCEPTED for a in acks)  # some ACKs may be lost
    stats = sim.link_stats()
    up = stats["v1/api/up"]
    assert up["dropped"].get("loss", 0) >= 0 and up["sent"] == up["delivered"] + \
        sum(up["dropped"].values()) + up["in_flight"]
    down = stats["v1/api/down"]
    assert 0.15 < down["dropped"]["loss"] / down["sent"] < 0.25
    assert 75 < down["latency_mean_ms"] < 85
    sim.close()


def trace_digest(seed: int) -> str:
    sim, clients = make(NetworkConfig.from_flags(50, 10, 0.1, seed))
    fly(sim, clients[(0, LinkKind.API)])
    digest = clients[(0, LinkKind.API)].raw.hexdigest() + clients[(0, LinkKind.GCS)].raw.hexdigest()
    sim.close()
    return digest


def test_same_seed_same_inputs_same_bytes():
    assert trace_digest(5) == trace_digest(5)
    assert trace_digest(5) != trace_digest(6)


def test_garbage_does_not_move_the_peer():
    sim, clients = make(NetworkConfig())
    api = clients[(0, LinkKind.API)]
    link = sim.links[(0, LinkKind.API)]
    api.send(api.mav.heartbeat_encode(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0))
    sim.run(until=0.5)
    assert link.peer == ("client", 1)
    sim.inject(0, LinkKind.API, b"\xfd\x09garbage", ("attacker", 2))
    other = api.mav.command_long_encode(42, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0).pack(api.mav)
    sim.inject(0, LinkKind.API, other, ("attacker", 2))  # valid, but for another system
    sim.run(until=1.0)
    assert link.peer == ("client", 1)
    assert link.session.stats.rx_malformed >= 1
    sim.close()


def test_the_links_of_a_vehicle_share_its_telemetry_samples():
    sim = Simulation(2)
    try:
        a, b = (sim.links[(0, kind)].session.samples for kind in LinkKind)
        assert a is b
        assert sim.links[(1, LinkKind.GCS)].session.samples is not a
    finally:
        sim.close()


def _downlink_digests(sim: Simulation, until_s: float) -> dict:
    digests: dict = {}

    def record(index, tag, datagram, peer) -> None:
        digests.setdefault((index, tag), hashlib.sha256()).update(f"{sim.now:.6f}".encode()
                                                                  + datagram)
    sim.on_downlink = record
    sim.run(until=until_s)
    sim.close()
    return {key: h.hexdigest() for key, h in digests.items()}


def _wake_times(sim: Simulation, until_s: float) -> dict:
    """When each link's session got ``handle_timer``, and the vehicles' pending timer events."""
    times: dict = {}
    for key, link in sim.links.items():
        def counted(now_s, key=key, inner=link.session.handle_timer):
            times.setdefault(key, []).append(now_s)
            inner(now_s)
        link.session.handle_timer = counted
    wakes = {id(link.wake) for link in sim.links.values()}
    pending = [entry for entry in sim.kernel._heap if not entry[3].cancelled
               and id(getattr(entry[3].callback, "__self__", None)) in wakes]
    sim.run(until=until_s)
    sim.close()
    return {"times": times, "pending": len(pending)}


def test_a_vehicle_has_one_timer_event_and_each_link_wakes_only_when_due():
    both = _wake_times(Simulation(2), 1.999)
    assert both["pending"] == 2  # one per vehicle, not one per link
    for kind in LinkKind:
        alone = _wake_times(Simulation(2, link_kinds=(kind,)), 1.999)
        for index in range(2):
            assert both["times"][(index, kind)] == alone["times"][(index, kind)]


def test_a_links_datagrams_do_not_depend_on_the_vehicles_other_links():
    both = _downlink_digests(Simulation(1), 3.0)
    for kind in LinkKind:
        alone = _downlink_digests(Simulation(1, link_kinds=(kind,)), 3.0)
        assert alone == {(0, kind): both[(0, kind)]}


def test_a_link_that_raises_while_flushing_stops_alone():
    sim = Simulation(1)
    api_times = []

    def handler(index, tag, datagram, peer) -> None:
        if tag is LinkKind.GCS:
            raise RuntimeError("the endpoint broke")
        api_times.append(sim.now)

    sim.on_downlink = handler
    with pytest.raises(RuntimeError):
        sim.run(until=1.0)
    sim.run(until=1.0)  # the API link goes on (no busy loop on the broken one)
    sim.close()
    # The wake-ups of the API link: the 100 Hz, 30 Hz and 8 Hz (GPS_RAW_INT) streams' instants.
    assert len(set(api_times)) == 135 and api_times[-1] == pytest.approx(1.0)


def test_every_downlink_datagram_holds_one_message_as_px4_sends_them():
    """PX4 sends each MAVLink message in a UDP datagram of its own (mavlink_main.cpp:
    ``send_finish`` calls ``sendto`` once per finalised message), telemetry and replies alike:
    a network then loses, delays and queues messages one by one."""
    sim = Simulation(1)
    gcs = M.MAVLink(None, srcSystem=255, srcComponent=190)
    messages: dict = {kind: [] for kind in LinkKind}

    def record(index, tag, datagram, peer) -> None:
        parser = M.MAVLink(None, 0, 0)
        parser.robust_parsing = True
        msgs = parser.parse_buffer(datagram) or []
        assert len(msgs) == 1 and len(msgs[0].get_msgbuf()) == len(datagram), msgs
        messages[tag].append(msgs[0].get_type())

    sim.on_downlink = record
    sim.run(until=0.5)
    # A burst of replies: the whole parameter list.
    sim.inject(0, LinkKind.GCS, gcs.param_request_list_encode(1, 1).pack(gcs), "gcs")
    sim.run(until=3.0)
    sim.close()
    assert messages[LinkKind.GCS].count("PARAM_VALUE") > 100
    assert messages[LinkKind.API].count("ATTITUDE") == 301  # 100 Hz over 3 s, t = 0 included
