"""cornet under systemd, with the test playing systemd: $NOTIFY_SOCKET (an abstract AF_UNIX
datagram socket bound here), $WATCHDOG_USEC, signals. READY=1 only once the ports are bound and
the vehicle talks; WATCHDOG=1 while it runs; SIGHUP swaps the network and keeps the vehicle;
SIGTERM says STOPPING=1, flushes the flight logs and exits 0. Plus the unit file itself
(systemd-analyze verify) and the configuration file (`--config`, `cornet check`)."""

from __future__ import annotations

import os
import pathlib
import re
import select
import shutil
import signal
import socket
import subprocess
import time
import uuid

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.ci.launcher import cornet_command, free_port_offset, start_daemon
from gateway.ci.ports import udp_free

pytestmark = [pytest.mark.e2e]

ROOT = pathlib.Path(__file__).resolve().parents[2]
UNIT = ROOT / "systemd" / "cornet.service"
READY_TIMEOUT_S = 30.0


class SystemdPeer:
    """systemd's end of $NOTIFY_SOCKET: an abstract-namespace AF_UNIX datagram socket."""

    def __init__(self) -> None:
        self.name = f"@cornet-e2e-{uuid.uuid4().hex}"
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind("\0" + self.name[1:])
        self.messages: list[tuple[float, dict[str, str]]] = []

    def next(self, timeout_s: float) -> dict[str, str] | None:
        ready, _, _ = select.select([self.sock], [], [], timeout_s)
        if not ready:
            return None
        data = self.sock.recv(4096).decode()
        fields = dict(line.split("=", 1) for line in data.split("\n"))
        self.messages.append((time.monotonic(), fields))
        return fields

    def wait_for(self, key: str, timeout_s: float) -> dict[str, str]:
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            fields = self.next(left)
            if fields is not None and key in fields:
                return fields
        raise AssertionError(f"no {key}= within {timeout_s} s; got {self.messages}")

    def close(self) -> None:
        self.sock.close()


class ApiClient:
    """A raw UDP socket on vehicle 1's API client port (where the vehicle talks first) with a
    pymavlink codec: what MAVSDK's `udpin://:14540` is on the wire."""

    def __init__(self, offset: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 14540 + offset))
        self.vehicle = ("127.0.0.1", 14580 + offset)
        self.mav = M.MAVLink(None, srcSystem=245, srcComponent=190)
        self.mav.robust_parsing = True
        self._ts1 = int(time.time() * 1e9)

    def readable_now(self) -> bool:
        return bool(select.select([self.sock], [], [], 0)[0])

    def recv(self, match, timeout_s: float):
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            if not select.select([self.sock], [], [], left)[0]:
                break
            for msg in self.mav.parse_buffer(self.sock.recv(65535)) or []:
                if match(msg):
                    return msg
        return None

    def send(self, msg) -> None:
        self.sock.sendto(msg.pack(self.mav), self.vehicle)

    def timesync(self) -> tuple[float, int]:
        """(wall-clock round trip in s, the vehicle's clock tc1 in ns) of one TIMESYNC."""
        self._ts1 += 1
        ts1 = self._ts1
        t0 = time.monotonic()
        self.send(self.mav.timesync_encode(0, ts1))
        reply = self.recv(lambda m: m.get_type() == "TIMESYNC" and m.tc1 != 0 and m.ts1 == ts1,
                          timeout_s=3.0)
        assert reply is not None, "no TIMESYNC reply"
        return time.monotonic() - t0, reply.tc1

    def param(self, name: str, set_to: float | None = None) -> float | None:
        if set_to is None:
            self.send(self.mav.param_request_read_encode(1, 1, name.encode(), -1))
        else:
            self.send(self.mav.param_set_encode(1, 1, name.encode(), set_to,
                                                M.MAV_PARAM_TYPE_REAL32))
        msg = self.recv(lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == name, 3.0)
        return None if msg is None else msg.param_value

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def launch(tmp_path):
    """Start `cornet run ARGS` with extra environment; stderr goes to a file. Killed at the end
    if a test left it running."""
    procs = []

    def start(*args: str, env: dict[str, str]) -> tuple[subprocess.Popen, pathlib.Path]:
        err = tmp_path / f"stderr-{len(procs)}.log"
        with open(err, "w") as f:
            proc = subprocess.Popen(cornet_command() + ["run", *args], env={**os.environ, **env},
                                    stdout=subprocess.DEVNULL, stderr=f)
        procs.append(proc)
        return proc, err

    yield start
    for proc in procs:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.fixture
def systemd():
    peer = SystemdPeer()
    yield peer
    peer.close()


def test_ready_after_ports_then_watchdog_then_stopping(launch, systemd, tmp_path):
    offset = free_port_offset(1)
    api = ApiClient(offset)  # bound first: the vehicle's first telemetry comes here
    logs = tmp_path / "logs"
    try:
        proc, stderr = launch("--port-offset", str(offset), "--log-dir", str(logs),
                              env={"NOTIFY_SOCKET": systemd.name, "WATCHDOG_USEC": "1000000"})
        first = systemd.next(READY_TIMEOUT_S)
        assert first is not None, stderr.read_text()[-3000:]
        assert first.get("READY") == "1", systemd.messages  # nothing before READY=1
        # At READY=1 every port is bound and the vehicle has already talked (the heartbeat
        # left before READY did: it is waiting in our socket).
        assert not udp_free(18570 + offset) and not udp_free(14580 + offset)
        assert api.readable_now(), "READY=1 came before the vehicle's first datagram"
        heartbeat = api.recv(lambda m: m.get_type() == "HEARTBEAT", timeout_s=1.0)
        assert heartbeat is not None and heartbeat.get_srcSystem() == 1
        assert "1 vehicle(s)" in first["STATUS"]

        # WATCHDOG=1 every half period (0.5 s) while the simulation runs.
        t0 = time.monotonic()
        while time.monotonic() - t0 < 2.6:
            systemd.next(0.1)
        pings = [t for t, fields in systemd.messages if fields.get("WATCHDOG") == "1"]
        assert len(pings) >= 4, systemd.messages
        gaps = [b - a for a, b in zip(pings, pings[1:])]
        assert max(gaps) < 0.9, gaps  # well inside WatchdogSec

        proc.send_signal(signal.SIGTERM)
        systemd.wait_for("STOPPING", timeout_s=5)
        assert proc.wait(timeout=5) == 0, stderr.read_text()[-3000:]
    finally:
        api.close()
    # The flight logs were flushed at the stop, not only at the last periodic flush.
    final = re.search(r"stopping after [\d.]+ s: sim_t=([\d.]+)s", stderr.read_text())
    assert final is not None, stderr.read_text()[-3000:]
    (run,) = logs.iterdir()
    rows = (run / "state.csv").read_text().strip().splitlines()
    assert float(rows[-1].split(",")[0]) >= float(final.group(1)) - 0.25, rows[-3:]
    assert (run / "v1-api.tlog").stat().st_size > 0


def test_no_ready_when_a_port_is_taken(launch, systemd):
    offset = free_port_offset(1)
    blocker = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    blocker.bind(("127.0.0.1", 14580 + offset))  # the last port the daemon binds
    try:
        proc, stderr = launch("--port-offset", str(offset), env={"NOTIFY_SOCKET": systemd.name})
        assert proc.wait(timeout=60) == 2
    finally:
        blocker.close()
    assert str(14580 + offset) in stderr.read_text()
    while systemd.next(0.1) is not None:
        pass
    assert not any("READY" in fields for _, fields in systemd.messages), systemd.messages


CONFIG = """\
[vehicles]
count = 1
params = {{MIS_TAKEOFF_ALT = 7.0}}

[network]
topology = "direct"
link = {link}

[daemon]
port_offset = {offset}
"""


def test_sighup_reloads_the_network_and_keeps_the_vehicle(launch, systemd, tmp_path):
    offset = free_port_offset(1)
    config = tmp_path / "cornet.toml"
    config.write_text(CONFIG.format(link='{model = "ideal"}', offset=offset))
    api = ApiClient(offset)
    try:
        # The file's port_offset is the one used: no flag overrides it here.
        proc, stderr = launch("--config", str(config), env={"NOTIFY_SOCKET": systemd.name})
        systemd.wait_for("READY", READY_TIMEOUT_S)
        rtt_ideal = min(api.timesync()[0] for _ in range(3))
        assert rtt_ideal < 0.1
        assert api.param("MPC_XY_CRUISE", set_to=7.5) == pytest.approx(7.5)
        _, clock_before_ns = api.timesync()

        config.write_text(CONFIG.format(link='{model = "fixed", latency_s = 0.15}',
                                        offset=offset))
        proc.send_signal(signal.SIGHUP)
        reloading = systemd.wait_for("RELOADING", timeout_s=5)
        assert int(reloading["MONOTONIC_USEC"]) > 0
        systemd.wait_for("READY", timeout_s=5)
        rtt, clock_after_ns = api.timesync()
        assert 0.29 < rtt < 1.0, rtt  # 150 ms each way
        # The same vehicle: its clock ran on (no reboot), the parameter a GCS set is still set,
        # and so is the file's.
        assert clock_after_ns > clock_before_ns
        assert api.param("MPC_XY_CRUISE") == pytest.approx(7.5)
        assert api.param("MIS_TAKEOFF_ALT") == pytest.approx(7.0)

        # An invalid file: logged, the running network kept, the daemon still serving.
        config.write_text(CONFIG.format(link='{model = "warp"}', offset=offset))
        proc.send_signal(signal.SIGHUP)
        systemd.wait_for("RELOADING", timeout_s=5)
        systemd.wait_for("READY", timeout_s=5)
        assert proc.poll() is None
        assert 0.29 < api.timesync()[0] < 1.0
        log = stderr.read_text()
        assert "reload failed" in log and "network.link" in log, log[-3000:]

        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=5) == 0, stderr.read_text()[-3000:]
    finally:
        api.close()


def test_flags_override_the_config_file(tmp_path):
    config = tmp_path / "cornet.toml"
    config.write_text("[daemon]\nport_offset = 17\nspeed = 2.0\n")
    d = start_daemon("--config", str(config))  # start_daemon passes its own --port-offset
    try:
        assert f"api {14580 + d.offset}->" in d.ready_line, d.ready_line
        assert "speed 2x" in d.ready_line  # from the file: no --speed flag
    finally:
        assert d.stop() == 0, d.log_tail()


@pytest.mark.parametrize("text, flags, words", [
    ('[daemon]\nspeed = "fast"\n', [], "daemon.speed"),
    ('[daemon]\nbnd = "127.0.0.1"\n', [], "daemon.bnd: unknown key"),
    ('[daemon]\nbind = "localhost"\n', [], "daemon.bind"),
    ('[daemon]\nstate_dir = "/proc/cornet-cannot-be-here"\n', [], "daemon.state_dir"),
    ('[deamon]\n', [], "deamon: unknown table"),
    ("[network]\n", ["--latency-ms", "20"], "--latency-ms"),
    ("[network]\n", ["--scenario", "ideal"], "--config and --scenario"),
    ("[network]\n", ["--bind", "::1"], "--bind"),
])
def test_bad_config_exits_2_naming_the_key(tmp_path, text, flags, words):
    config = tmp_path / "cornet.toml"
    config.write_text(text)
    out = subprocess.run(cornet_command() + ["run", "--config", str(config), *flags],
                         capture_output=True, text=True, timeout=30, cwd=ROOT)
    assert out.returncode == 2, out.stderr
    assert words in out.stderr


def test_check_accepts_the_shipped_config():
    out = subprocess.run(cornet_command() + ["check", str(ROOT / "systemd/cornet.toml")],
                         capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    assert "daemon: bind 127.0.0.1" in out.stdout and "state_dir /var/lib/cornet" in out.stdout


def test_unit_file_has_the_appliance_settings():
    lines = {line.strip() for line in UNIT.read_text().splitlines()}
    for setting in ("Type=notify", "NotifyAccess=main", "WatchdogSec=10", "Restart=on-failure",
                    "ExecStart=/opt/cornet/.venv/bin/cornet run --config /etc/cornet/cornet.toml",
                    "ExecReload=/bin/kill -HUP $MAINPID", "DynamicUser=yes",
                    "StateDirectory=cornet", "LogsDirectory=cornet", "ConfigurationDirectory=cornet",
                    "NoNewPrivileges=yes", "ProtectSystem=strict", "ProtectHome=yes",
                    "PrivateTmp=yes", "RestrictAddressFamilies=AF_INET AF_INET6 AF_UNIX",
                    "MemoryMax=2G", "UMask=0077", "PrivateUsers=yes", "IPAddressDeny=any",
                    "SystemCallFilter=~@privileged @resources", "TasksMax=64",
                    "LoadCredential=signing.key:/etc/cornet/signing.key"):
        assert setting in lines, setting


def test_systemd_analyze_security_exposure_at_most_2():
    """systemd's own score of the unit's sandbox (0 safest, 10 exposed): at most 2.0."""
    analyze = shutil.which("systemd-analyze")
    if analyze is None:
        pytest.skip("systemd-analyze is not installed (Debian: apt-get install systemd)")
    out = subprocess.run([analyze, "security", "--offline=yes", str(UNIT)], capture_output=True,
                         text=True, timeout=60)
    found = re.search(r"Overall exposure level for cornet\.service: ([0-9.]+)", out.stdout)
    assert found, out.stdout + out.stderr
    assert float(found.group(1)) <= 2.0, out.stdout


def test_signing_key_from_the_systemd_credential(tmp_path):
    """LoadCredential=signing.key:…: the daemon signs with $CREDENTIALS_DIRECTORY/signing.key;
    the unit's default "off" (no key file) leaves signing off."""
    creds = tmp_path / "creds"
    creds.mkdir()
    (creds / "signing.key").write_text("a passphrase only the operator knows\n")
    env = {**os.environ, "CREDENTIALS_DIRECTORY": str(creds)}
    d = start_daemon(env=env)
    try:
        assert "signing" in d.ready_line or any("signing on" in ln for ln in d.stderr_lines), \
            d.log_tail()
    finally:
        assert d.stop() == 0, d.log_tail()
    (creds / "signing.key").write_text("off")
    d = start_daemon(env=env)
    try:
        assert not any("signing on" in ln for ln in d.stderr_lines), d.log_tail()
    finally:
        assert d.stop() == 0, d.log_tail()


def test_systemd_analyze_verify(tmp_path):
    """The unit as systemd reads it: every directive known to the installed systemd, the
    command executable. ExecStart points at this venv's `cornet` (/opt/cornet is not here)."""
    analyze = shutil.which("systemd-analyze")
    if analyze is None:
        pytest.skip("systemd-analyze is not installed (Debian: apt-get install systemd)")
    exe = pathlib.Path(cornet_command()[0])
    if exe.name != "cornet":
        pytest.skip("no `cornet` console script in this venv (pip install -e .)")
    unit = tmp_path / "cornet.service"
    unit.write_text(UNIT.read_text().replace("/opt/cornet/.venv/bin/cornet", str(exe)))
    out = subprocess.run([analyze, "verify", str(unit)], capture_output=True, text=True,
                         timeout=60)
    problems = [line for line in (out.stdout + out.stderr).splitlines() if "cornet" in line]
    assert out.returncode == 0 and not problems, out.stdout + out.stderr
