import asyncio
import socket
import urllib.error
import urllib.request
from types import SimpleNamespace

import pytest
from prometheus_client import CollectorRegistry, generate_latest
from prometheus_client.parser import text_string_to_metric_families

from gateway.daemon.metrics import Exporter, MetricsServer
from gateway.daemon.pacer import Pacer
from gateway.sim.scenario import NetworkConfig
from gateway.sim.simulation import Simulation


@pytest.fixture
def daemon():
    sim = Simulation(2, NetworkConfig.from_flags(latency_ms=20, jitter_ms=0, loss=0.3, seed=1))
    wall = [0.0]
    d = SimpleNamespace(sim=sim, pacer=Pacer(sim.kernel, clock=lambda: wall[0]), endpoints={},
                        wall=wall)
    yield d
    sim.close()


def families(text: str) -> dict:
    return {f.name: f for f in text_string_to_metric_families(text)}


def render(exporter: Exporter) -> str:
    """The exposition text of one snapshot, as prometheus_client writes it."""
    snapshot = exporter.snapshot()

    class Once:
        def collect(self):
            return snapshot

    registry = CollectorRegistry(auto_describe=False)
    registry.register(Once())
    return generate_latest(registry).decode()


def test_exposition_parses_and_counts_what_the_daemon_counts(daemon):
    sim = daemon.sim
    sim.inject(0, next(iter(sim.links))[1], b"\xfd\x09garbage", ("x", 1))
    sim.run(until=3.0)
    clock = [10.0]
    exp = Exporter(daemon, clock=lambda: clock[0])
    fams = families(render(exp))
    assert fams["cornet_vehicles"].samples[0].value == 2
    assert fams["cornet_sim_seconds"].samples[0].value == pytest.approx(3.0)
    malformed = {(s.labels["vehicle"], s.labels["link"]): s.value
                 for s in fams["cornet_mavlink_rx_malformed"].samples}
    assert malformed[("1", "gcs")] == 1 and malformed[("2", "api")] == 0
    tx = [s for s in fams["cornet_mavlink_tx_frames"].samples if s.labels["vehicle"] == "1"]
    assert all(s.value > 100 for s in tx)  # telemetry went out on both links
    dropped = {(s.labels["net_link"], s.labels["reason"]): s.value
               for s in fams["cornet_net_dropped"].samples}
    assert dropped[("v1/api/down", "loss")] > 0
    lat = {(s.labels["net_link"], s.labels["quantile"]): s.value
           for s in fams["cornet_net_latency_seconds"].samples}
    assert lat[("v1/api/down", "0.5")] == pytest.approx(0.02, rel=0.3)
    # the RTF gauge is over the interval since the previous scrape
    sim.run(until=5.0)
    clock[0] = 12.0
    rtf = families(render(exp))["cornet_real_time_factor"].samples[0].value
    assert rtf == pytest.approx(1.0)


def test_http_server_serves_the_snapshot_and_a_silent_client_starves_nobody(daemon):
    def get(port: int, path: str) -> tuple[int, str, str]:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=5) as r:
                return r.status, r.headers["Content-Type"], r.read().decode()
        except urllib.error.HTTPError as exc:
            return exc.code, "", ""

    async def main():
        server = MetricsServer(Exporter(daemon), port=0)
        await server.start()
        silent = []
        try:
            for _ in range(20):  # connections that never send a request
                c = socket.create_connection(("127.0.0.1", server.port))
                silent.append(c)
            status, ctype, text = await asyncio.to_thread(get, server.port, "/metrics")
            assert status == 200 and ctype.startswith("text/plain; version=0.0.4")
            assert families(text)["cornet_vehicles"].samples[0].value == 2
            junk = socket.create_connection(("127.0.0.1", server.port))
            junk.sendall(b"\x00" * 100 + b"\r\n\r\n")  # junk request: answered, not fatal
            junk.settimeout(5)
            assert b"Error" in junk.recv(200)  # an error page, as http.server answers junk
            junk.close()
            assert (await asyncio.to_thread(get, server.port, "/metrics"))[0] == 200
        finally:
            for c in silent:
                c.close()
            server.close()

    asyncio.run(main())
