"""Simulation.reload_network (the daemon's SIGHUP): new link models from the present simulated
time on; vehicles, sessions, peers and counters kept; ns-3 and invalid networks refused."""

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.mavlink.session import LinkKind
from gateway.sim.scenario import NetworkConfig
from gateway.sim.simulation import Simulation

API = (0, LinkKind.API)


def fixed(latency_s: float, **extra) -> NetworkConfig:
    return NetworkConfig(topology={"topology": "direct",
                                   "link": {"model": "fixed", "latency_s": latency_s}}, **extra)


class Api:
    """A pymavlink codec on vehicle 1's API link; records TIMESYNC replies with their time."""

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.mav = M.MAVLink(None, srcSystem=245, srcComponent=190)
        self.replies: dict[int, float] = {}  # ts1 -> simulated time the reply arrived
        sim.on_downlink = self.on_datagram

    def on_datagram(self, index, kind, data, peer) -> None:
        if (index, kind) != API:
            return
        for msg in self.mav.parse_buffer(data) or []:
            if msg.get_type() == "TIMESYNC" and msg.tc1 != 0:
                self.replies[msg.ts1] = self.sim.now

    def timesync(self, ts1: int) -> None:
        self.sim.inject(0, LinkKind.API, self.mav.timesync_encode(0, ts1).pack(self.mav),
                        ("client", 1))


def round_trip_s(sim: Simulation, api: Api, ts1: int, at_s: float) -> float:
    sim.run(until=at_s)
    api.timesync(ts1)
    sim.run(until=at_s + 2.0)
    return api.replies[ts1] - at_s


def test_new_latency_applies_and_everything_else_stays():
    events = []
    sim = Simulation(1, NetworkConfig(), tracer=lambda *e: events.append(e))
    api = Api(sim)
    assert round_trip_s(sim, api, 1, at_s=1.0) == pytest.approx(0.0, abs=1e-9)
    vehicle, link = sim.vehicles[0], sim.links[API]
    session, peer = link.session, link.peer
    sent_before = link.downlink.stats.sent

    sim.reload_network(fixed(0.1))

    assert sim.network == fixed(0.1)
    assert round_trip_s(sim, api, 2, at_s=4.0) == pytest.approx(0.2, abs=1e-6)
    assert sim.vehicles[0] is vehicle and sim.links[API] is link
    assert link.session is session and link.peer == peer == ("client", 1)
    assert link.downlink.stats.sent > sent_before  # counters carry on, not reset
    assert any(e[2] > 4.0 for e in events)  # the packet trace follows the new links
    sim.close()


def test_packets_in_flight_keep_their_delay():
    sim = Simulation(1, fixed(0.5))
    api = Api(sim)
    sim.run(until=1.0)
    api.timesync(7)  # reaches the vehicle at 1.5 s, as the old network decided
    sim.run(until=1.1)
    sim.reload_network(NetworkConfig())
    sim.run(until=3.0)
    assert api.replies[7] == pytest.approx(1.5, abs=1e-9)  # the reply crossed the new network
    for stats in sim.link_stats().values():
        assert stats["sent"] == stats["delivered"] + sum(stats["dropped"].values()) \
            + stats["in_flight"]
    sim.close()


def test_sync_period_follows_the_new_network():
    sim = Simulation(1, NetworkConfig())
    sim.run(until=0.5)
    sim.reload_network(NetworkConfig(sync_period_s=0.1))
    assert sim.backend.sync_period_s == 0.1
    sim.run(until=1.0)
    assert sim.backend.mobility.updated_at_s == pytest.approx(1.0)  # ticks on the new period
    sim.close()


@pytest.mark.parametrize("network, words", [
    (NetworkConfig(backend="ns3"), "ns3 backend"),
    (NetworkConfig(topology={"topology": "mesh"}), "network.topology"),
])
def test_refused_reload_changes_nothing(network, words):
    sim = Simulation(1, fixed(0.05))
    uplink, backend = sim.links[API].uplink, sim.backend
    with pytest.raises(ValueError, match=words):
        sim.reload_network(network)
    assert sim.links[API].uplink is uplink and sim.backend is backend
    assert sim.network == fixed(0.05)
    sim.close()


def test_set_wind_changes_the_air_and_calm_stops_it():
    from vehicles.wind import WindConfig

    sim = Simulation(1, NetworkConfig())
    try:
        sim.set_wind(WindConfig(5.0, 270.0))
        sim.run(until=0.1)
        assert tuple(sim.world.inner.wind) == pytest.approx((0.0, 5.0, 0.0))
        sim.set_wind(WindConfig())
        sim.run(until=0.2)
        assert tuple(sim.world.inner.wind) == (0.0, 0.0, 0.0) and sim.world.wind is None
    finally:
        sim.close()
