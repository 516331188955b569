"""MAVSDK 4.x native binding flies the daemon, from its own venv (it can't share one with 3.x)."""

import os
import re
import subprocess
from pathlib import Path

import pytest

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

CLIENT = Path(__file__).parent / "clients" / "mavsdk4_takeoff_land.py"


def mavsdk4_python() -> str:
    python = os.environ.get("CORNET_MAVSDK4_PYTHON")
    if not python or not Path(python).exists():
        pytest.skip("MAVSDK 4.x venv missing: CORNET_MAVSDK4_PYTHON must point at a python with "
                    "'mavsdk>=4' installed (`make test` creates .venv-mavsdk4)")
    return python


def test_mavsdk4_takeoff_hover_land(daemon_factory, tmp_path):
    """...with the flight's ULog streamed by MAVSDK 4's log_streaming: pyulog reads it."""
    import pyulog

    python = mavsdk4_python()
    d = daemon_factory()
    ulog_file = tmp_path / "streamed.ulg"
    out = subprocess.run([python, str(CLIENT), str(d.api_port(0)), str(ulog_file)],
                         capture_output=True, text=True, timeout=180)
    assert out.returncode == 0, f"{out.stdout}\n{out.stderr}\n{d.log_tail()}"
    m = re.search(r"RESULT ok hover_min=([\d.]+) hover_max=([\d.]+)", out.stdout)
    assert m, out.stdout
    assert 2.2 <= float(m.group(1)) and float(m.group(2)) <= 2.8, out.stdout
    log = pyulog.ULog(str(ulog_file))
    assert min(log.get_dataset("vehicle_local_position").data["z"]) < -2.0
    assert 2 in set(log.get_dataset("vehicle_status").data["arming_state"])
