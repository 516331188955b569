"""The gcs_examples scripts over a lossy network (the lossy-wifi scenario: ~20 % of the
datagrams lost each way after 802.11 retries): they ask again where MAVLink needs it, as QGC
and a careful script do, and finish; and PX4's log streaming to a pymavlink client."""

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


def test_log_stream_over_lossy_wifi_with_pymavlink(daemon_factory, tmp_path):
    """The ULog streamed through 20 % loss to a plain pymavlink client that does what PX4's
    Tools/mavlink_ulog_streaming.py does (LOGGING_ACK for each LOGGING_DATA_ACKED, commands
    asked again until answered): the acknowledged header is sent again until it arrives, lost
    data packets leave gaps, and the ULog is whole messages that pyulog reads, the takeoff in it.
    (MAVSDK's log_streaming over this link: mavsdk_server 3.x was seen to stop acknowledging
    mid-stream and then never answer LOGGING_STOP, in about one run in three.)"""
    from tests.e2e.gcs import gcs

    d = daemon_factory("--scenario", "lossy-wifi")
    conn = gcs(d.gcs_port())
    try:
        assert conn.wait_heartbeat(timeout=15) is not None
        stream_a_flight(conn, tmp_path)
    finally:
        conn.close()


def stream_a_flight(conn, tmp_path) -> None:
    import time

    import pyulog
    from pymavlink.dialects.v20 import common as M

    from gateway.ci.ulog_receiver import UlogReceiver

    receiver = UlogReceiver()

    def pump(seconds: float, command: int | None = None):
        """Receive for ``seconds`` (acknowledging and keeping the log packets); the first
        COMMAND_ACK for ``command`` ends it early."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            msg = conn.recv_match(blocking=True, timeout=0.05)
            if msg is None or msg.get_srcSystem() != 1:
                continue
            kind = msg.get_type()
            if kind in ("LOGGING_DATA", "LOGGING_DATA_ACKED"):
                if kind == "LOGGING_DATA_ACKED":
                    conn.mav.logging_ack_send(1, 1, msg.sequence)
                receiver.feed(msg.sequence, msg.length, msg.first_message_offset,
                              bytes(msg.data))
            elif kind == "COMMAND_ACK" and msg.command == command \
                    and msg.result != M.MAV_RESULT_IN_PROGRESS:
                return msg.result
        return None

    def command(cmd: int, *params: float, tries: int = 20) -> int | None:
        for _ in range(tries):
            conn.mav.command_long_send(1, 1, cmd, 0, *params, *(0,) * (7 - len(params)))
            result = pump(0.5, cmd)
            if result is not None:
                return result
        return None

    started = None
    for _ in range(20):  # asked again only while nothing streams (the logger is busy meanwhile)
        started = command(M.MAV_CMD_LOGGING_START, 0, tries=1)
        if started is not None or receiver.packets:
            break
    assert started == M.MAV_RESULT_ACCEPTED or receiver.packets, started
    deadline = time.monotonic() + 30  # armed once the position estimate is valid
    while command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1) != M.MAV_RESULT_ACCEPTED:
        assert time.monotonic() < deadline, "never armed"
        pump(0.5)
    assert command(M.MAV_CMD_NAV_TAKEOFF, *(float("nan"),) * 7) == M.MAV_RESULT_ACCEPTED
    pump(8.0)
    assert command(M.MAV_CMD_LOGGING_STOP) == M.MAV_RESULT_ACCEPTED
    pump(0.5)
    path = tmp_path / "streamed.ulg"
    path.write_bytes(receiver.ulog())
    log = pyulog.ULog(str(path))
    assert len(log.initial_parameters) > 600 and log.msg_info_dict["ver_hw"] == "PX4_SITL"
    assert min(log.get_dataset("vehicle_local_position").data["z"]) < -0.5  # it flew
    assert receiver.lost > 0  # the link lost some: the gaps were skipped
