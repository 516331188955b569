"""The command line as a user meets it: bad flags, busy ports, clean stop."""

import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gateway.ci.launcher import cornet_command, free_port_offset, start_daemon

pytestmark = [pytest.mark.e2e]

ROOT = Path(__file__).resolve().parents[2]


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


def test_ctrl_c_while_starting_exits_130_with_one_line():
    """A Ctrl-C before the daemon serves (here while it imports) ends it as a shell reports
    an interrupted command: 130, one line, no traceback. (Sharded, each rank does the same,
    unless the Ctrl-C comes while a rank's interpreter is still starting, before any of its
    code runs.)"""
    k = free_port_offset(1)
    proc = subprocess.Popen(cornet_command() + ["run", "--port-offset", str(k)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # Interrupted once it imports numpy (its interpreter is up, numba and PyBullet still to
    # load): long before it is ready.
    deadline = time.monotonic() + 20
    while "numpy" not in Path(f"/proc/{proc.pid}/maps").read_text():
        assert time.monotonic() < deadline and proc.poll() is None
        time.sleep(0.002)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert (out, err.strip()) == ("", "cornet: interrupted"), err


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


def test_the_pytest_plugin_says_the_daemon_exited_and_its_code(tmp_path):
    """A user's test whose daemon dies at start: the report names the exit code and the
    daemon's own message, not a time-out."""
    (tmp_path / "test_user.py").write_text(
        "def test_it(cornet_daemon):\n    cornet_daemon('--loss', '7')\n")
    out = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                          str(tmp_path / "test_user.py")],  # the plugin: installed with cornet
                         capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert out.returncode == 1, out.stdout + out.stderr
    assert "cornet run exited with code 2 before it was ready" in out.stdout, out.stdout
    assert "loss must be between 0 and 1" in out.stdout, out.stdout


@pytest.mark.parametrize("argv, usage", [
    (["run", "--loss", "7"], "usage: cornet run"),
    (["run", "--scenario", "no-such-scenario"], "usage: cornet run"),
    (["fly", "square", "--loss", "7"], "usage: cornet fly"),
    (["fly", "no-such-plan", "--scenario", "no-such-scenario"], "usage: cornet fly"),
    (["check"], "usage: cornet check"),
    (["plot"], "usage: cornet plot"),
    (["watch", "--duration", "-1"], "usage: cornet watch"),
])
def test_a_subcommand_error_shows_that_subcommand_usage(argv, usage):
    out = subprocess.run(cornet_command() + argv, capture_output=True, text=True, timeout=60)
    assert out.returncode == 2, out.stderr
    assert out.stderr.startswith(usage), out.stderr
    assert len(out.stderr.strip().splitlines()[-1]) > len("cornet x: error: "), out.stderr


def test_version():
    out = subprocess.run(cornet_command() + ["--version"], capture_output=True, text=True,
                         timeout=30)
    assert out.returncode == 0 and out.stdout.startswith("cornet "), out


def test_no_pybullet_banner_on_stdout():
    """What a program reads from `cornet check` is the summary alone (PyBullet prints a build
    banner from C when it loads)."""
    out = subprocess.run(cornet_command() + ["check", "scenarios/ideal.toml"],
                         capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines()[0] == "scenarios/ideal.toml: ok", out.stdout
    assert "pybullet" not in out.stdout + out.stderr


def test_the_ready_line_is_the_first_line_on_stdout():
    d = start_daemon()
    code = d.stop()
    assert code == 0, d.log_tail()
    assert d.stdout_lines[0].startswith("cornet ready:"), d.stdout_lines
    assert not any("pybullet build time" in line for line in d.stderr_lines)
