"""The appliance's operator surface: /metrics over HTTP, the warning for an exposed bind, and
what bad settings do (exit 2 naming them)."""

import socket
import subprocess
import time
import urllib.request

import pytest
from prometheus_client.parser import text_string_to_metric_families

from gateway.ci.launcher import cornet_command, free_tcp_port

pytestmark = [pytest.mark.e2e]


def test_metrics_endpoint_serves_the_counters(daemon_factory):
    port = free_tcp_port()
    d = daemon_factory("--metrics-port", str(port), vehicles=2)
    # garbage at vehicle 2's API port shows up in its counters
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        for _ in range(5):
            s.sendto(b"\xfd\x09not mavlink", ("127.0.0.1", d.vehicle_port(1, "api")))
    time.sleep(1.5)
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=5) as r:
        assert r.headers["Content-Type"].startswith("text/plain; version=0.0.4")
        text = r.read().decode()
    fams = {f.name: f for f in text_string_to_metric_families(text)}
    assert fams["cornet_vehicles"].samples[0].value == 2
    assert fams["cornet_sim_seconds"].samples[0].value > 1.0
    bad = {(s.labels["vehicle"], s.labels["link"]): s.value
           for s in fams["cornet_mavlink_rx_bad_datagrams"].samples}
    assert bad[("2", "api")] == 5 and bad[("1", "api")] == 0
    sent = {(s.labels["vehicle"], s.labels["link"]): s.value
            for s in fams["cornet_udp_tx_datagrams"].samples}
    assert all(v > 10 for v in sent.values())
    assert any(ln.startswith("metrics: http://127.0.0.1:") or "metrics: http" in ln
               for ln in d.stderr_lines)


def test_metrics_port_in_use_exits_2(tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        from gateway.ci.ports import free_port_offset

        r = subprocess.run(cornet_command() + ["run", "--port-offset", str(free_port_offset()),
                                               "--metrics-port", str(port)],
                           capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "--metrics-port" in r.stderr, r.stderr


def test_exposed_bind_warns_without_signing(daemon_factory):
    d = daemon_factory("--bind", "0.0.0.0")
    time.sleep(0.5)
    assert any("open to the network" in ln and "without MAVLink signing" in ln
               for ln in d.stderr_lines), d.log_tail()


@pytest.mark.parametrize("args, words", [
    (["--signing-key", "/nonexistent/key"], "--signing-key"),
    (["--metrics-port", "70000"], "--metrics-port"),
])
def test_bad_appliance_flags_exit_2(args, words):
    r = subprocess.run(cornet_command() + ["run", *args], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 2 and words in r.stderr, r.stderr
