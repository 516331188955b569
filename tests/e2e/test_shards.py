"""`cornet run --shards 2`: the vehicles split across two worker ranks of an MPI job in lockstep;
MAVSDK flies one vehicle of each shard at once; the daemon stops cleanly; a worker's start error
and a missing MPI are exit-2 errors."""

import asyncio
import re
import signal
import socket
import subprocess
import sys

import pytest

from gateway.ci.launcher import VEHICLE_GCS_PORT, cornet_command, free_port_offset
from tests.e2e.flows import takeoff_hover_land

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


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


def test_shards_refuse_what_they_do_not_support():
    r = subprocess.run(cornet_command() + ["run", "--vehicles", "2", "--shards", "2",
                                           "--zmq-pub", "tcp://127.0.0.1:5999"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "--zmq-pub" in r.stderr, r.stderr


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
    d.proc.send_signal(signal.SIGINT)  # the pid is mpiexec's: it forwards SIGINT to the ranks
    assert d.proc.wait(timeout=10) == 0, d.log_tail()
    assert d.stop() == 0
    assert any("stopping after" in ln and "shards=2" in ln for ln in d.stderr_lines), d.log_tail()
