"""The command line as a user meets it: bad flags, busy ports, clean stop."""

import socket
import subprocess

import pytest

from gateway.ci.launcher import cornet_command, free_port_offset, start_daemon

pytestmark = [pytest.mark.e2e]


@pytest.mark.parametrize("flags, words", [
    (["--vehicles", "0"], "--vehicles"),
    (["--loss", "1.5"], "loss"),
    (["--latency-ms", "-3"], "--latency-ms"),
    (["--latency-ms", "abc"], "--latency-ms"),
    (["--log-level", "loud"], "--log-level"),
    (["--frobnicate"], "--frobnicate"),
    (["--param", "NOT_A_PX4_PARAM=1"], "NOT_A_PX4_PARAM"),
    (["--param", "MAV_TYPE=1.5"], "INT32"),
    (["--param", "MIS_TAKEOFF_ALT"], "NAME=VALUE"),
    (["--state-dir", "/proc/cornet-cannot-be-here"], "--state-dir"),
    (["--vehicles", "300"], "between 1 and 254"),
])
def test_bad_flags_exit_2_with_a_message(flags, words):
    out = subprocess.run(cornet_command() + ["run", *flags], capture_output=True, text=True,
                         timeout=30)
    assert out.returncode == 2
    assert words in out.stderr


def test_port_in_use_is_named():
    k = free_port_offset(1)
    blocker = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    blocker.bind(("127.0.0.1", 14580 + k))
    try:
        out = subprocess.run(cornet_command() + ["run", "--port-offset", str(k)],
                             capture_output=True, text=True, timeout=60)
    finally:
        blocker.close()
    assert out.returncode == 2
    assert str(14580 + k) in out.stderr


def test_ready_then_sigterm_exits_0_quickly():
    d = start_daemon(vehicles=2)
    assert "ready" in d.ready_line
    code = d.stop()
    took = d.stop_took_s
    assert code == 0, d.log_tail()
    assert took < 2.0


def test_check_accepts_shipped_scenarios_and_names_bad_keys(tmp_path):
    ok = subprocess.run(cornet_command() + ["check", "lossy-wifi"],
                        capture_output=True, text=True, timeout=30)
    assert ok.returncode == 0 and "topology star" in ok.stdout, ok.stderr
    bad = tmp_path / "bad.toml"
    bad.write_text("[network]\ntopology = 'star'\nradio = {model = 'wireless', mcs = 9}\n")
    out = subprocess.run(cornet_command() + ["check", str(bad)], capture_output=True, text=True,
                         timeout=30)
    assert out.returncode == 2 and "network.radio" in out.stderr and "mcs" in out.stderr
    out = subprocess.run(cornet_command() + ["run", "--scenario", str(bad)], capture_output=True,
                         text=True, timeout=30)
    assert out.returncode == 2 and "network.radio" in out.stderr
    out = subprocess.run(cornet_command() + ["run", "--scenario", "ideal",
                                             "--loss", "0.1"], capture_output=True, text=True,
                         timeout=30)
    assert out.returncode == 2 and "--loss" in out.stderr


@pytest.mark.parametrize("speed", ["0", "-2", "fast", "5000"])
def test_bad_speed_exits_2(speed):
    out = subprocess.run(cornet_command() + ["run", "--speed", speed], capture_output=True,
                         text=True, timeout=30)
    assert out.returncode == 2 and "--speed" in out.stderr


def test_any_positive_speed_starts():
    d = start_daemon("--speed", "1.25")
    assert "speed 1.25" in d.ready_line or "1.25" in d.ready_line, d.ready_line
    assert d.stop() == 0, d.log_tail()


def test_unreadable_state_file_stops_the_start_with_one_line_and_is_kept(tmp_path):
    path = tmp_path / "vehicle-1" / "params.json"
    path.parent.mkdir()
    path.write_text('{"version": 1, "params": {"MIS_TAK')  # cut short by a crash
    out = subprocess.run(cornet_command() + ["run", "--port-offset", str(free_port_offset(1)),
                                             "--state-dir", str(tmp_path)],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2
    lines = [ln for ln in out.stderr.splitlines() if ln.startswith("cornet:")]
    assert len(lines) == 1 and str(path) in lines[0] and "--ignore-bad-state" in lines[0], \
        out.stderr
    assert "Traceback" not in out.stderr
    assert path.read_text() == '{"version": 1, "params": {"MIS_TAK'
