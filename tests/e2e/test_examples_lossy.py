"""The gcs_examples scripts over a lossy network (the lossy-wifi scenario: ~20 % of the
datagrams lost each way after 802.11 retries): they ask again where MAVLink needs it, as QGC
and a careful script do, and finish."""

import subprocess
import sys
from pathlib import Path

import pytest

from gateway.ci.launcher import free_tcp_port

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

EXAMPLES = Path(__file__).resolve().parents[2] / "gcs_examples"


def run(script: str, *args, d, timeout_s: float = 300) -> str:
    try:
        out = subprocess.run([sys.executable, str(EXAMPLES / script), *map(str, args)],
                             capture_output=True, text=True, timeout=timeout_s,
                             stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired as exc:  # where it stopped, and what the daemon said
        pytest.fail(f"{script} still running after {timeout_s} s:\n{exc.stdout}\n{exc.stderr}\n"
                    f"{d.log_tail()}")
    assert out.returncode == 0, f"{out.stdout}\n{out.stderr}\n{d.log_tail()}"
    assert "Traceback" not in out.stderr, out.stderr
    return out.stdout


def test_params_lists_and_sets_over_lossy_wifi(daemon_factory):
    d = daemon_factory("--scenario", "lossy-wifi", vehicles=2)
    stdout = run("params.py", "--port", d.gcs_port(), "--sysid", "2", "--set", "MIS_TAKEOFF_ALT",
                 "5", d=d)
    assert "vehicle 2: " in stdout and "MAV_SYS_ID=2" in stdout, stdout
    assert "vehicle 2: MIS_TAKEOFF_ALT is now 5.0" in stdout, stdout


def test_takeoff_and_land_over_lossy_wifi(daemon_factory):
    d = daemon_factory("--scenario", "lossy-wifi")
    stdout = run("takeoff_and_land.py", "--port", d.api_port(0), "--grpc-port", free_tcp_port(),
                 d=d)
    assert "-- Disarmed" in stdout, stdout


def test_stream_log_over_lossy_wifi(daemon_factory, tmp_path):
    """MAVSDK's log_streaming through 20 % loss: the acknowledged header is sent again until it
    arrives, lost data packets leave gaps, and the ULog is whole messages that pyulog reads."""
    import pyulog

    d = daemon_factory("--scenario", "lossy-wifi")
    out = tmp_path / "streamed.ulg"
    stdout = run("stream_log.py", "--port", d.api_port(0), "--grpc-port", free_tcp_port(),
                 "--out", out, "--hover", 8, d=d)
    assert "-- saved" in stdout, stdout
    log = pyulog.ULog(str(out))
    assert len(log.initial_parameters) > 600 and log.msg_info_dict["ver_hw"] == "PX4_SITL"
    assert min(log.get_dataset("vehicle_local_position").data["z"]) < -0.5  # it flew
