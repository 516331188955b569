"""MAVSDK-Python on the gRPC wrapper as published today, ``mavsdk-grpc`` 4.x (import
``mavsdk_grpc``, mavsdk_server v4), flies the daemon from its own venv (it cannot share one
with ``mavsdk<4``, which installs the same mavsdk_server binary under another name)."""

import os
import re
import subprocess
from pathlib import Path

import pytest

from gateway.ci.launcher import free_tcp_port

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

CLIENT = Path(__file__).parent / "clients" / "mavsdk_grpc_flight.py"


def mavsdk_grpc_python() -> str:
    python = os.environ.get("CORNET_MAVSDK_GRPC_PYTHON")
    if not python or not Path(python).exists():
        pytest.skip("mavsdk-grpc 4.x venv missing: CORNET_MAVSDK_GRPC_PYTHON must point at a "
                    "python with 'mavsdk-grpc>=4,<5' installed (`make test` creates "
                    ".venv-mavsdk-grpc)")
    return python


def fly(flow: str, port: int, d) -> str:
    out = subprocess.run([mavsdk_grpc_python(), str(CLIENT), flow, str(port),
                          str(free_tcp_port())], capture_output=True, text=True, timeout=400)
    assert out.returncode == 0, f"{out.stdout}\n{out.stderr}\n{d.log_tail()}"
    return out.stdout


def test_mavsdk_grpc_takeoff_hover_land(daemon_factory):
    d = daemon_factory()
    stdout = fly("takeoff_land", d.api_port(0), d)
    m = re.search(r"RESULT ok hover_min=([\d.]+) hover_max=([\d.]+) ulog_bytes=(\d+) "
                  r"ulog_magic=(\w+)", stdout)
    assert m, stdout
    assert 2.2 <= float(m.group(1)) and float(m.group(2)) <= 2.8, stdout
    assert int(m.group(3)) > 200_000 and m.group(4) == "True", stdout  # the flight's ULog


def test_mavsdk_grpc_square_mission_with_return(daemon_factory):
    d = daemon_factory("--speed", "4")
    stdout = fly("mission", d.api_port(0), d)
    assert "RESULT ok items=4 finished=True" in stdout, stdout


def test_mavsdk_grpc_services_and_an_offboard_leg(daemon_factory, tmp_path):
    """The v4 core's info, param, shell (whose send takes the device since v4), geofence, ftp
    and log_files plugins, then Offboard velocity north for 4 s of wall time."""
    d = daemon_factory("--state-dir", str(tmp_path / "state"), "--speed", "2")
    stdout = fly("services", d.api_port(0), d)
    m = re.search(r"RESULT ok cruise=([\d.]+) takeoff_alt=([\d.]+) shell=(\w+) "
                  r"fence_vertices=(\d+) ftp_entries=(\d+) logs=(\d+) "
                  r"offboard_north_m=(-?[\d.]+)", stdout)
    assert m, stdout
    assert float(m.group(1)) == 5.0 and float(m.group(2)) == 4.0, stdout  # MPC_XY_CRUISE, set
    assert m.group(3) == "True" and int(m.group(4)) == 4, stdout
    assert int(m.group(5)) >= 1 and int(m.group(6)) >= 1, stdout  # the root, the boot's log
    assert float(m.group(7)) > 4.0, stdout  # 2 m/s north for 8 simulated seconds
