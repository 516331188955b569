"""`cornet run --shards 2`: the vehicles split across two worker processes in lockstep; MAVSDK
flies one vehicle of each shard at once; the daemon stops cleanly."""

import asyncio
import re
import subprocess

import pytest

from gateway.ci.launcher import cornet_command
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
