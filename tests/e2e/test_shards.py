"""`cornet run --shards 2`: the vehicles split across two worker ranks of an MPI job in lockstep;
MAVSDK flies one vehicle of each shard at once; the daemon stops cleanly; a worker's start error,
a flag one rank refuses and a missing MPI are exit-2 errors. A scripted flight on two ranks that
talk over TCP (as on two hosts) writes the same logs as one process; --state-dir keeps each
shard's vehicles."""

import asyncio
import contextlib
import json
import os
import re
import select
import signal
import socket
import struct
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest
import zmq
from pymavlink import mavutil

from gateway.ci.launcher import (
    VEHICLE_GCS_PORT,
    cornet_command,
    free_port_offset,
    free_tcp_port,
)
from gateway.sim.flightlog import read_tlog
from tests.e2e.flows import takeoff_hover_land
from tests.e2e.gcs import gcs, heartbeats_by_sysid

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

M = mavutil.mavlink
ROOT = Path(__file__).resolve().parents[2]
# MPICH: no shared memory between the ranks, TCP instead, as if each were on its own host.
NETWORK_PATH = {"MPIR_CVAR_NOLOCAL": "1", "UCX_TLS": "tcp"}


@pytest.mark.asyncio
async def test_two_shards_fly_a_vehicle_each_and_stop_cleanly(daemon_factory):
    d = daemon_factory("--shards", "2", vehicles=4)
    assert "in 2 shards" in d.ready_line
    r1, r4 = await asyncio.gather(takeoff_hover_land(d.api_port(0), hover_s=3.0),
                                  takeoff_hover_land(d.api_port(3), hover_s=3.0))
    for r in (r1, r4):
        assert 2.2 <= r.hover_alt_min_m and r.hover_alt_max_m <= 2.8, r
        assert r.disarmed_after_landing
    code = d.stop()
    assert code == 0, d.log_tail()
    stop_line = next(ln for ln in reversed(d.stderr_lines) if "stopping after" in ln)
    m = re.search(r"sim_t=([\d.]+)s .*shards=2 .*internal_errors=0", stop_line)
    assert m and float(m.group(1)) > 10.0, stop_line


def _udp_bound(port: int) -> bool:
    """Whether some socket of this host is bound to UDP ``port`` (/proc/net/udp, read only)."""
    with open("/proc/net/udp") as f:
        return any(int(line.split()[1].split(":")[1], 16) == port for line in list(f)[1:])


def _scripted_run(out: Path, *extra: str, env: dict[str, str] | None = None
                  ) -> tuple[Path, float]:
    """scenarios/adhoc-fleet.toml for 30 simulated seconds, flat out, logged to ``out``: the
    run directory, and a wall-clock time at which the last vehicle's port was not bound yet
    (the run's clock cannot have started before it)."""
    out.mkdir()
    offset = free_port_offset(4)
    last_port = VEHICLE_GCS_PORT + offset + 3
    proc = subprocess.Popen(cornet_command() + [
        "run", "--scenario", str(ROOT / "scenarios" / "adhoc-fleet.toml"), "--seed", "19",
        "--speed", "max", "--duration", "30", "--log-dir", str(out / "logs"),
        "--packet-trace", str(out / "trace.txt"), "--port-offset", str(offset),
        *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        stdin=subprocess.DEVNULL, env={**os.environ, **(env or {})})
    unbound_at = time.time()
    while proc.poll() is None:
        t = time.time()  # taken before the look: the port was free at t or later
        if _udp_bound(last_port):
            break
        unbound_at = t
        time.sleep(0.002)
    _, stderr = proc.communicate(timeout=240)
    assert proc.returncode == 0, stderr[-3000:]
    assert "stopping after" in stderr and "sim_t=30.0s" in stderr, stderr[-3000:]
    (run,) = (out / "logs").iterdir()
    return run, unbound_at


def _tlog_records(run: Path, name: str) -> list[tuple[int, object]]:
    """(µs since the run's epoch, frame) of every record: the stamps are the run's wall-clock
    epoch (meta.json boot_unix_s) plus the simulated time. A SYSTEM_TIME frame carries the
    vehicle's clock, the same epoch plus the simulated time: it is compared as its sequence
    number, that clock in ms since the epoch, and its time_boot_ms."""
    boot_us = round(json.loads((run / "meta.json").read_text())["boot_unix_s"] * 1e6)
    out: list[tuple[int, object]] = []
    for t, frame in read_tlog(run / name):
        record: object = frame
        if frame[0] == 0xFD and int.from_bytes(frame[7:10], "little") == 2:  # SYSTEM_TIME
            unix_us, boot_ms = struct.unpack("<QI", frame[10:10 + frame[1]].ljust(12, b"\0"))
            record = (frame[4], round((unix_us - boot_us) / 1000), boot_ms)
        out.append((round(t * 1e6) - boot_us, record))
    return out


def test_two_ranks_over_tcp_write_the_logs_of_one_process(tmp_path):
    one, one_unbound = _scripted_run(tmp_path / "one")
    two, two_unbound = _scripted_run(tmp_path / "two", "--shards", "2", env=NETWORK_PATH)
    files = sorted(p.name for p in one.iterdir() if p.is_file())
    assert files == sorted(p.name for p in two.iterdir() if p.is_file()) == [
        "meta.json", "packets.trace", "state.csv", *(f"v{i}-{k}.tlog" for i in range(1, 5)
                                                     for k in ("api", "gcs"))]
    # Byte for byte: the vehicles' states, and every datagram's fate on the distance-dependent
    # radios (both runs' merged in one file, vehicles 1-2 from one rank, 3-4 from the other).
    for name in ("state.csv", "packets.trace"):
        assert (one / name).read_bytes() == (two / name).read_bytes(), name
    assert (tmp_path / "one" / "trace.txt").read_bytes() == \
        (tmp_path / "two" / "trace.txt").read_bytes() == (one / "packets.trace").read_bytes()
    # The wall clock's only marks: the epoch in meta.json, the tlogs' stamps (epoch + simulated
    # time) and the onboard logs' names (vehicle-N/log/<date>/<time>.ulg).
    metas = [json.loads((run / "meta.json").read_text()) for run in (one, two)]
    # The epoch is when simulated time starts, after every port is bound (sharded: after every
    # worker built its vehicles), so that SYSTEM_TIME reads the host's clock, not one behind it.
    assert metas[0]["boot_unix_s"] > one_unbound and metas[1]["boot_unix_s"] > two_unbound
    for meta in metas:
        del meta["boot_unix_s"]
    assert metas[0] == metas[1] and [v["sysid"] for v in metas[0]["vehicles"]] == [1, 2, 3, 4]
    for name in files:
        if name.endswith(".tlog"):
            records = _tlog_records(one, name)
            assert len(records) > 5000 and records == _tlog_records(two, name), name
    for sysid in range(1, 5):
        (a,), (b,) = (list((run / f"vehicle-{sysid}").rglob("*.ulg")) for run in (one, two))
        assert a.read_bytes() == b.read_bytes()
    # It flew: every vehicle 70-130 m out, and the radios lost datagrams on the way.
    last = (one / "state.csv").read_text().splitlines()[-4:]
    assert [ln.split(",")[1] for ln in last] == ["1", "2", "3", "4"]
    assert all(60.0 < abs(float(ln.split(",")[2])) + abs(float(ln.split(",")[3])) for ln in last)
    assert " drop " in (one / "packets.trace").read_text()
    plot = subprocess.run(cornet_command() + ["plot", str(two.parent)], capture_output=True,
                          text=True, timeout=300)
    assert plot.returncode == 0, plot.stderr
    assert (two / "track.png").read_bytes()[:4] == b"\x89PNG"


def test_state_dir_keeps_every_shards_vehicles(daemon_factory, tmp_path):
    d = daemon_factory("--shards", "2", "--state-dir", str(tmp_path), vehicles=2)
    conn = gcs(d.gcs_port())
    try:
        conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert set(heartbeats_by_sysid(conn, {1, 2})) == {1, 2}
        for sysid, alt in ((1, 4.0), (2, 6.0)):  # vehicle 1 on shard 0, vehicle 2 on shard 1
            conn.mav.param_set_send(sysid, 1, b"MIS_TAKEOFF_ALT", alt, M.MAV_PARAM_TYPE_REAL32)
            assert conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=10,
                                   condition=f"PARAM_VALUE.param_id=='MIS_TAKEOFF_ALT' and "
                                             f"PARAM_VALUE.param_value=={alt}")
    finally:
        conn.close()
    assert d.stop() == 0, d.log_tail()
    for sysid, alt in ((1, 4.0), (2, 6.0)):
        saved = (tmp_path / f"vehicle-{sysid}" / "params.json").read_text()
        assert '"MIS_TAKEOFF_ALT"' in saved and str(alt) in saved, saved


def test_zmq_and_metrics_of_every_shard_come_from_one_daemon(daemon_factory):
    endpoint, port = f"tcp://127.0.0.1:{free_tcp_port()}", free_tcp_port()
    daemon_factory("--shards", "2", "--zmq-pub", endpoint, "--metrics-port", str(port),
                   "--loss", "0.3", "--seed", "2", vehicles=3)
    sub = zmq.Context.instance().socket(zmq.SUB)
    sub.setsockopt(zmq.LINGER, 0)
    sub.setsockopt(zmq.SUBSCRIBE, b"cornet.")
    sub.connect(endpoint)
    states, links, packets = set(), set(), set()
    deadline = time.monotonic() + 20
    try:  # shard 0 has vehicles 1-2, shard 1 vehicle 3
        while time.monotonic() < deadline and (len(states) < 3 or len(links) < 3
                                                or len(packets) < 3):
            if sub.poll(500):
                topic, body = sub.recv_multipart()
                msg = json.loads(body)
                assert msg["v"] == 1
                if topic == b"cornet.state":  # one message: every shard's vehicles
                    assert [v["sysid"] for v in msg["vehicles"]] == [1, 2, 3]
                    states = {v["sysid"] for v in msg["vehicles"]}
                elif topic == b"cornet.links":
                    links = {name.split("/")[0] for name in msg["links"]}
                elif topic == b"cornet.packet":
                    packets.add(msg["link"].split("/")[0])
    finally:
        sub.close()
    assert (states, links, packets) == ({1, 2, 3}, {"v1", "v2", "v3"}, {"v1", "v2", "v3"})
    stats = subprocess.run(cornet_command() + ["stats", "--zmq", endpoint], capture_output=True,
                           text=True, timeout=60)
    assert stats.returncode == 0 and "v1/gcs/down" in stats.stdout and \
        "v3/gcs/down" in stats.stdout, stats.stdout + stats.stderr
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=5) as r:
        text = r.read().decode()
    assert "cornet_vehicles 3.0" in text
    for sysid in (1, 2, 3):
        assert f'cornet_mavlink_tx_frames_total{{link="gcs",vehicle="{sysid}"}}' in text


def test_the_live_view_shows_every_shards_vehicles(daemon_factory):
    pytest.importorskip("aiohttp", reason="aiohttp missing: pip install 'cornet[web]'")
    port = free_tcp_port()
    daemon_factory("--shards", "2", "--web", f"127.0.0.1:{port}", vehicles=3)
    snapshot: dict = {}
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:  # until every vehicle and a link interval arrived
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/state.json", timeout=5) as r:
            snapshot = json.loads(r.read())
        if len(snapshot["vehicles"]) == 3 and len(snapshot["links"]) == 6:
            break
        time.sleep(0.2)
    assert [v["sysid"] for v in snapshot["vehicles"]] == [1, 2, 3]
    assert {link["link"] for link in snapshot["links"]} == {
        f"v{i}/{kind}" for i in (1, 2, 3) for kind in ("gcs", "api")}
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=5) as r:
        assert r.status == 200 and b"<canvas" in r.read()


def test_a_taken_web_port_stops_a_sharded_run_with_exit_2():
    pytest.importorskip("aiohttp", reason="aiohttp missing: pip install 'cornet[web]'")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        r = subprocess.run(cornet_command() + [
            "run", "--vehicles", "2", "--shards", "2", "--port-offset", str(free_port_offset(2)),
            "--web", f"127.0.0.1:{port}"],
            capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    assert r.returncode == 2, r.stderr
    assert f"cornet: --web 127.0.0.1:{port}: Address already in use" in r.stderr, r.stderr
    assert "cornet ready" not in r.stdout


def test_a_metrics_port_in_use_stops_a_sharded_run_with_exit_2():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        r = subprocess.run(cornet_command() + [
            "run", "--vehicles", "2", "--shards", "2", "--port-offset", str(free_port_offset(2)),
            "--metrics-port", str(taken.getsockname()[1])],
            capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    assert r.returncode == 2 and "cornet: --metrics-port" in r.stderr, r.stderr
    assert "cornet ready" not in r.stdout


SHARDED_CONFIG = """\
[vehicles]
count = 2

[network]
topology = "direct"
link = {link}

[daemon]
port_offset = {offset}
"""


def test_sighup_reloads_every_shards_network(tmp_path):
    from tests.e2e.test_systemd import ApiClient, SystemdPeer

    offset = free_port_offset(2)
    config = tmp_path / "cornet.toml"
    config.write_text(SHARDED_CONFIG.format(link='{model = "ideal"}', offset=offset))
    # Vehicle 1 on shard 0, vehicle 2 on shard 1 (ApiClient(offset + 1): vehicle 2's API link).
    apis = [ApiClient(offset), ApiClient(offset + 1)]
    systemd = SystemdPeer()
    err = tmp_path / "stderr.log"
    proc = None
    try:
        with open(err, "w") as f:
            proc = subprocess.Popen(cornet_command() + ["run", "--config", str(config),
                                                        "--shards", "2"],
                                    env={**os.environ, "NOTIFY_SOCKET": systemd.name},
                                    stdout=subprocess.DEVNULL, stderr=f,
                                    stdin=subprocess.DEVNULL)
        systemd.wait_for("READY", 60)
        assert all(min(api.timesync()[0] for _ in range(3)) < 0.1 for api in apis)
        config.write_text(SHARDED_CONFIG.format(link='{model = "fixed", latency_s = 0.15}',
                                                offset=offset))
        proc.send_signal(signal.SIGHUP)  # the launcher's pid: it relays, mpiexec survives
        systemd.wait_for("RELOADING", timeout_s=5)
        systemd.wait_for("READY", timeout_s=5)
        for api in apis:  # 150 ms each way on both shards
            assert 0.29 < api.timesync()[0] < 1.0
        config.write_text(SHARDED_CONFIG.format(link='{model = "warp"}', offset=offset))
        proc.send_signal(signal.SIGHUP)
        systemd.wait_for("RELOADING", timeout_s=5)
        systemd.wait_for("READY", timeout_s=5)
        proc.send_signal(signal.SIGUSR1)  # no flag: each shard logs its links
        assert proc.poll() is None
        assert 0.29 < apis[1].timesync()[0] < 1.0
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0, err.read_text()[-3000:]
        log = err.read_text()
        for shard in (0, 1):
            assert f"shard {shard} gateway.daemon.shard.worker: reload: the network is now " \
                   "embedded/fixed" in log, log[-3000:]
        assert "reload failed" in log and "network.link" in log, log[-3000:]
        # SIGUSR1 itself: each shard's links once (a relayed SIGHUP is not a SIGUSR1), then at
        # the stop.
        assert log.count("link statistics at sim t") == 4, log[-3000:]
    finally:
        if proc is not None and proc.poll() is None:
            proc.terminate()
            proc.wait(timeout=10)
        for api in apis:
            api.close()
        systemd.close()


def test_systemd_hears_every_notification_from_the_main_pid(tmp_path):
    """READY, WATCHDOG and STOPPING come from rank 0 through the launcher, the unit's main pid:
    the shipped NotifyAccess=main holds."""
    peer = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    name = f"cornet-e2e-shards-{os.getpid()}"
    peer.bind("\0" + name)
    peer.setsockopt(socket.SOL_SOCKET, socket.SO_PASSCRED, 1)
    creds = struct.calcsize("3i")
    heard: list[tuple[int, str]] = []

    def listen(until: str, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and not any(until in text for _, text in heard):
            if select.select([peer], [], [], 0.5)[0]:
                data, ancdata, _, _ = peer.recvmsg(4096, socket.CMSG_SPACE(creds))
                pid = next(struct.unpack("3i", d[:creds])[0] for level, kind, d in ancdata
                           if level == socket.SOL_SOCKET and kind == socket.SCM_CREDENTIALS)
                heard.append((pid, data.decode()))

    with open(tmp_path / "stderr.log", "w") as err:
        proc = subprocess.Popen(cornet_command() + ["run", "--vehicles", "2", "--shards", "2",
                                                    "--port-offset", str(free_port_offset(2))],
                                env={**os.environ, "NOTIFY_SOCKET": "@" + name,
                                     "WATCHDOG_USEC": "1000000"},
                                stdout=subprocess.DEVNULL, stderr=err, stdin=subprocess.DEVNULL)
    try:
        listen("READY=1", 90)
        listen("WATCHDOG=1", 10)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == 0, (tmp_path / "stderr.log").read_text()[-3000:]
        listen("STOPPING=1", 5)
    finally:
        if proc.poll() is None:
            proc.terminate()
            proc.wait(timeout=10)
        peer.close()
    said = [text.split("\n")[0] for _, text in heard]
    assert {"READY=1", "WATCHDOG=1", "STOPPING=1"} <= set(said), heard
    assert {pid for pid, _ in heard} == {proc.pid}, heard


def test_shards_refuse_what_they_do_not_support():
    r = subprocess.run(cornet_command() + ["run", "--shards", "2", "--scenario",
                                           str(ROOT / "scenarios" / "congested.toml")],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "network.channel" in r.stderr, r.stderr


def test_a_port_in_use_in_one_shard_is_an_error_of_the_whole_run():
    offset = free_port_offset(2)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        # v2, the first vehicle of shard 1, cannot bind its PX4 GCS port.
        taken.bind(("127.0.0.1", VEHICLE_GCS_PORT + 1 + offset))
        r = subprocess.run(cornet_command() + ["run", "--vehicles", "2", "--shards", "2",
                                               "--port-offset", str(offset)],
                           capture_output=True, text=True, timeout=90)
    assert r.returncode == 2, r.stderr
    assert "cornet: shard 1: UDP port" in r.stderr and "already in use" in r.stderr, r.stderr
    assert "cornet ready" not in r.stdout


def test_a_flag_one_rank_refuses_ends_the_whole_job_with_exit_2(tmp_path):
    """Every rank checks the command line, as ranks on other hosts must: one whose host refuses
    the log directory (here rank 1's, given another one, as mpiexec -hosts a,b would give the
    same path on a machine without it) ends the job with exit 2 and its message, at once,
    rather than leave the other ranks waiting for it; the directory the others share is
    checked by all of them at the same moment, and none of them trips over another's probe."""
    from gateway.daemon.shard.launch import mpiexec_command

    shared = tmp_path / "logs"
    script = ("import os, sys; from gateway.cli import main; "
              "bad = os.environ.get('PMI_RANK') == '1'; "
              f"sys.exit(main(['run', '--vehicles', '2', '--shards', '2', '--port-offset', "
              f"'{free_port_offset(2)}', '--duration', '5', '--speed', 'max', '--log-dir', "
              f"'/proc/no-such-dir' if bad else {str(shared)!r}]))")
    mpiexec = mpiexec_command(2, [])[:3]
    r = subprocess.run([*mpiexec, sys.executable, "-c", script], capture_output=True, text=True,
                       timeout=60, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert r.returncode == 2, r.stderr[-3000:]
    assert "--log-dir /proc/no-such-dir: not a writable directory" in r.stderr, r.stderr[-3000:]
    assert "--log-dir " + str(shared) not in r.stderr


def test_without_mpi4py_sharding_says_how_to_get_it():
    script = ("import sys; sys.modules['mpi4py'] = None; from gateway.cli import main; "
              "sys.exit(main(['run', '--vehicles', '2', '--shards', '2']))")
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2, r.stderr
    said = [ln for ln in r.stderr.splitlines() if not ln.startswith("pybullet build time")]
    assert said == [
        "cornet: --shards needs MPI (mpi4py and an MPI library): pip install 'cornet[mpi]'"]


def test_sigint_stops_every_rank_with_exit_0(daemon_factory):
    d = daemon_factory("--shards", "2", vehicles=2)
    d.proc.send_signal(signal.SIGINT)  # the launcher's pid: relayed to mpiexec, then the ranks
    assert d.proc.wait(timeout=10) == 0, d.log_tail()
    assert d.stop() == 0
    assert any("stopping after" in ln and "shards=2" in ln for ln in d.stderr_lines), d.log_tail()


def _ranks(root: int) -> dict[int, int]:
    """The pids of an MPI job's ranks under process ``root``, by rank (MPICH's PMI_RANK)."""
    parents: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            with contextlib.suppress(OSError):
                stat = Path(f"/proc/{entry}/stat").read_text()
                parents.setdefault(int(stat.rsplit(")", 1)[1].split()[1]), []).append(int(entry))
    found, todo = {}, [root]
    while todo:
        for child in parents.get(todo.pop(), []):
            todo.append(child)
            with contextlib.suppress(OSError):
                for var in Path(f"/proc/{child}/environ").read_bytes().split(b"\0"):
                    if var.startswith(b"PMI_RANK="):
                        found[int(var[9:])] = child
    return found


def test_a_rank_signalled_after_the_job_stopped_still_exits_0(daemon_factory):
    """mpiexec forwards a SIGINT to each rank in its own time: on a loaded machine a worker may
    hear it only after the coordinator has stopped everyone and the worker's event loop has
    closed. Such a late signal must not kill the rank (the job would then end "BAD
    TERMINATION ... Interrupt (signal 2)"). Here the coordinator alone is signalled, and the
    workers get SIGINT again and again until the job has exited."""
    d = daemon_factory("--shards", "2", vehicles=2)
    ranks = _ranks(d.proc.pid)
    assert sorted(ranks) == [0, 1, 2], ranks
    os.kill(ranks[0], signal.SIGINT)
    deadline = time.monotonic() + 10
    while d.proc.poll() is None and time.monotonic() < deadline:
        for rank in (1, 2):
            with contextlib.suppress(ProcessLookupError):
                os.kill(ranks[rank], signal.SIGINT)
        time.sleep(0.002)
    assert d.proc.wait(timeout=5) == 0, d.log_tail()
    assert any("stopping after" in ln and "shards=2" in ln for ln in d.stderr_lines), d.log_tail()


def _started_job(extra: tuple[str, ...] = ()) -> tuple[subprocess.Popen, float]:
    """``cornet run --shards 2`` started as a user starts it, returned as soon as its launcher
    has started mpiexec (the ranks' interpreters are then starting): (process, that moment)."""
    offset = free_port_offset()
    proc = subprocess.Popen(
        [*cornet_command(), "run", "--vehicles", "2", "--shards", "2",
         "--port-offset", str(offset), *extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        with contextlib.suppress(OSError):
            if Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split():
                return proc, time.monotonic()
        time.sleep(0.002)
    proc.kill()
    raise AssertionError("the launcher never started mpiexec")


def _communicate(proc: subprocess.Popen) -> tuple[str, str]:
    try:
        return proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        raise AssertionError(f"the job did not end: {err[-3000:]}") from None


@pytest.mark.parametrize("signals", [("SIGINT",), ("SIGTERM",), ("SIGUSR1", "SIGHUP", "SIGINT")])
@pytest.mark.parametrize("after_s", [0.0, 0.15, 0.4])
def test_a_signal_while_the_ranks_start_is_held_until_they_can_take_it(signals, after_s):
    """Ctrl-C (or systemd's SIGTERM, or a SIGHUP/SIGUSR1) right after `cornet run --shards 2`
    starts, while the ranks' interpreters are still starting: the launcher holds it until every
    rank's handlers are in place, then relays it. The job stops as a running one does, exit 0,
    with no "Fatal Python error", traceback or failed rank (it used to end in those, exit 2 or
    a signal); a SIGUSR1 or SIGHUP held that way does not stop it."""
    proc, started = _started_job()
    with proc:
        time.sleep(max(0.0, started + after_s - time.monotonic()))
        for name in signals[:-1]:
            proc.send_signal(getattr(signal, name))
        if len(signals) > 1:  # the job outlives a SIGUSR1 and a SIGHUP, relayed once armed
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=4)
                raise AssertionError(f"exit {proc.returncode} on {signals[:-1]}: "
                                     f"{proc.stderr.read()[-3000:]}")
        proc.send_signal(getattr(signal, signals[-1]))
        _, err = _communicate(proc)
    assert proc.returncode == 0, err[-3000:]
    for bad in ("Fatal Python error", "Traceback", "BAD TERMINATION", "KeyboardInterrupt"):
        assert bad not in err, err[-3000:]
    assert any("stopping after" in ln and "shards=2" in ln for ln in err.splitlines()), err[-3000:]


def test_a_second_ctrl_c_while_the_ranks_start_is_relayed_at_once():
    """A user who presses Ctrl-C again while the first one is held: both relayed at once (a
    rank that hangs while starting must not keep the job), and the ranks end as a Ctrl-C in
    their start ends them: the job is interrupted (not the clean stop, exit 0, of one)."""
    proc, _ = _started_job()
    with proc:
        proc.send_signal(signal.SIGINT)
        time.sleep(0.01)
        proc.send_signal(signal.SIGINT)
        _, err = _communicate(proc)
    assert proc.returncode != 0, err[-3000:]


CHANNEL_SCRIPT = """
import asyncio, socket, sys, time
from mpi4py import MPI
from gateway.daemon.shard import channel as C
comm = MPI.COMM_WORLD
rank = comm.Get_rank()
if sys.argv[1] == "two-hosts" and rank == 1:
    socket.gethostname = lambda: "another-host"  # as if rank 1 ran elsewhere
ch = C.Channel(comm)
ch.open_doorbells()

async def main():
    for i in range(50):
        if rank == 0:
            ch.send(1, {"grant": i})
            _, msg = await ch.receive(5.0)
            assert msg == {"report": i}, msg
        else:
            _, msg = await ch.receive(5.0)
            assert msg == {"grant": i}, msg
            ch.send(0, {"report": i})
    await ch.flush(1.0)
    print(f"rank {rank}: poll {ch.poll_period_s * 1e3:g} ms, doorbells {sorted(ch._peers)}")

asyncio.run(main())
"""


@pytest.mark.parametrize("hosts", ["one-host", "two-hosts"])
def test_ranks_of_one_host_ring_each_others_doorbell_others_are_probed(hosts):
    """The channel between ranks (gateway/daemon/shard/channel.py): on one host every message
    rings its receiver's doorbell and the periodic probe is only a safety net; a rank on
    another host has no doorbell and is found by the 1 ms probe. Either way every message
    arrives, in order."""
    pytest.importorskip("mpi4py", reason="mpi4py missing: pip install 'cornet[mpi]'")
    from gateway.daemon.shard.launch import mpiexec_command

    command = mpiexec_command(1, [])[:4] + ["-c", CHANNEL_SCRIPT, hosts]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run(command, capture_output=True, text=True, timeout=120, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    # mpiexec forwards both ranks' stdout into one stream, so their lines may run together.
    said = sorted(re.findall(r"rank \d: poll \d+ ms, doorbells \[[\d, ]*\]", r.stdout))
    if hosts == "one-host":
        assert said == ["rank 0: poll 20 ms, doorbells [1]", "rank 1: poll 20 ms, doorbells [0]"]
    else:
        assert said == ["rank 0: poll 1 ms, doorbells []", "rank 1: poll 1 ms, doorbells []"]
