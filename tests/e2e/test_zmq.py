"""The ZeroMQ data path, read with plain pyzmq as an external tool would, and `cornet watch`."""

import json
import subprocess
import time

import pytest
import zmq

from gateway.ci.launcher import cornet_command, free_tcp_port

pytestmark = [pytest.mark.e2e]

STATE_KEYS = {"sysid": int, "mode": str, "custom_mode": int, "armed": bool, "landed_state": str,
              "failsafe": bool, "lat_deg": float, "lon_deg": float, "alt_amsl_m": float,
              "world_ned_m": list, "velocity_ned_mps": list, "battery_remaining": float}
LINK_KEYS = {"sent", "delivered", "bytes_sent", "bytes_delivered", "in_flight", "dropped",
             "late_delivered", "latency_mean_ms", "latency_p50_ms", "latency_p99_ms",
             "latency_max_ms"}


def test_schema_of_every_topic(daemon_factory):
    endpoint = f"tcp://127.0.0.1:{free_tcp_port()}"
    daemon_factory("--zmq-pub", endpoint, "--loss", "0.3", "--seed", "2", vehicles=2)
    sub = zmq.Context.instance().socket(zmq.SUB)
    sub.setsockopt(zmq.LINGER, 0)
    sub.setsockopt(zmq.SUBSCRIBE, b"cornet.")
    sub.connect(endpoint)
    seen: dict[bytes, dict] = {}
    drops = 0
    deadline = time.monotonic() + 10
    try:
        while time.monotonic() < deadline and (len(seen) < 3 or drops == 0):
            if sub.poll(500):
                topic, body = sub.recv_multipart()
                msg = json.loads(body)
                assert msg["v"] == 1
                seen[topic] = msg
                drops += topic == b"cornet.packet" and msg["event"] == "drop"
    finally:
        sub.close(0)
    assert set(seen) == {b"cornet.state", b"cornet.links", b"cornet.packet"}
    vehicles = seen[b"cornet.state"]["vehicles"]
    assert [v["sysid"] for v in vehicles] == [1, 2]
    for v in vehicles:
        for key, kind in STATE_KEYS.items():
            assert isinstance(v[key], kind), (key, v[key])
        assert v["mode"] == "Hold" and v["custom_mode"] == 0x03040000
    links = seen[b"cornet.links"]["links"]
    assert set(links) == {f"v{i}/{k}/{d}" for i in (1, 2) for k in ("gcs", "api")
                          for d in ("up", "down")}
    for stats in links.values():
        assert LINK_KEYS <= set(stats)
    assert links["v1/gcs/down"]["dropped"].get("loss", 0) > 0  # 30 % loss shows
    packet = seen[b"cornet.packet"]
    assert set(packet) == {"v", "t", "event", "link", "size", "detail"}
    assert drops > 0


def test_cornet_watch_shows_live_vehicles(daemon_factory):
    endpoint = f"tcp://127.0.0.1:{free_tcp_port()}"
    daemon_factory("--zmq-pub", endpoint, vehicles=3)
    out = subprocess.run(cornet_command() + ["watch", "--zmq", endpoint, "--duration", "3"],
                         capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    rows = [line.split() for line in out.stdout.splitlines()]
    vehicle_rows = {r[0] for r in rows if r and r[0] in {"1", "2", "3"} and "Hold" in r}
    assert vehicle_rows == {"1", "2", "3"}, out.stdout


def test_faults_of_the_timeline_are_published(daemon_factory, tmp_path):
    """A scenario's [[faults]] fire on the daemon's clock and each one is a cornet.fault
    message on the bus."""
    scenario = tmp_path / "faults.toml"
    scenario.write_text('[[faults]]\nat_s = 2.0\nunit = "gps"\ntype = "off"\n\n'
                        '[[faults]]\nat_s = 2.5\nlink = "v1/gcs/*"\nevent = "outage"\n'
                        'duration_s = 1.0\n')
    endpoint = f"tcp://127.0.0.1:{free_tcp_port()}"
    daemon_factory("--zmq-pub", endpoint, "--scenario", str(scenario))
    sub = zmq.Context.instance().socket(zmq.SUB)
    sub.setsockopt(zmq.LINGER, 0)
    sub.setsockopt(zmq.SUBSCRIBE, b"cornet.fault")
    sub.connect(endpoint)
    got = []
    deadline = time.monotonic() + 10
    try:
        while time.monotonic() < deadline and len(got) < 2:
            if sub.poll(500):
                got.append(json.loads(sub.recv_multipart()[1]))
    finally:
        sub.close(0)
    assert [m["fault"] for m in got] == ["vehicle 1 gps off", "link v1/gcs/* outage for 1 s"]
    assert got[0]["unit"] == "gps" and got[1]["duration_s"] == 1.0
