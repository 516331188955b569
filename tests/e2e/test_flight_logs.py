"""Flight logs as a user records them: `cornet run --log-dir`, then mavlogdump and `cornet plot`;
`cornet fly` on the shipped plans."""

import asyncio
import os
import subprocess
import sys

import pytest

from gateway.ci.launcher import cornet_command
from tests.e2e.flows import takeoff_hover_land

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


@pytest.mark.asyncio
async def test_log_dir_tlog_readable_by_mavlogdump_and_plotted(daemon_factory, tmp_path):
    d = daemon_factory("--log-dir", str(tmp_path), "--speed", "4")
    await takeoff_hover_land(d.api_port(0), hover_s=1.0)
    await asyncio.sleep(1.0)
    assert d.stop() == 0  # SIGTERM flushes and closes the logs
    (run,) = list(tmp_path.iterdir())
    assert {p.name for p in run.iterdir()} >= {"v1-api.tlog", "v1-gcs.tlog", "state.csv",
                                               "packets.trace", "meta.json"}
    dump = os.path.join(os.path.dirname(sys.executable), "mavlogdump.py")
    out = subprocess.run([sys.executable, dump, "--types", "HEARTBEAT,COMMAND_LONG",
                          str(run / "v1-api.tlog")], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "HEARTBEAT" in out.stdout and "COMMAND_LONG" in out.stdout  # both directions
    plot = subprocess.run(cornet_command() + ["plot", str(tmp_path)], capture_output=True,
                          text=True, timeout=120)
    assert plot.returncode == 0, plot.stderr
    for name in ("track.png", "altitude_speed.png", "link.png"):
        data = (run / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


@pytest.mark.parametrize("plan, code, words", [("square", 0, "PASS"),
                                              ("breach", 1, "geofence: breached")])
def test_cornet_fly_judges_plans(plan, code, words, tmp_path):
    """The shipped plans by name; the flight recorded in ./logs, where `cornet plot logs/`
    (README) looks."""
    out = subprocess.run(cornet_command() + ["fly", plan], capture_output=True, text=True,
                         timeout=300, cwd=tmp_path)
    assert out.returncode == code, out.stdout + out.stderr
    assert words in out.stdout
    assert (tmp_path / "logs" / "state.csv").is_file()
