"""Faults a lab box sees: the daemon SIGKILLed mid-flight and started again; clients killed and
restarted mid-mission. Parameters set before the kill are still set; the flight logs are
readable up to the last flush (one simulated second)."""

import os
import signal
import struct
import subprocess
import sys
import time

import pytest
from pymavlink import mavutil

from gateway.ci.launcher import start_daemon
from tests.e2e.gcs import arm_and_take_off, command_long, gcs, heartbeats_by_sysid

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

M = mavutil.mavlink


def _param(conn, name: str) -> float | None:
    conn.mav.param_request_read_send(1, 1, name.encode(), -1)
    msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=5,
                          condition=f"PARAM_VALUE.param_id=='{name}'")
    return None if msg is None else msg.param_value


def _tlog_stamps(path) -> list[float]:
    """Timestamps (unix s) of every frame, walking the tlog as pymavlink does."""
    conn = mavutil.mavlink_connection(str(path), dialect="common")
    out = []
    while True:
        msg = conn.recv_match()
        if msg is None:
            break
        out.append(msg._timestamp)
    conn.close()
    return out


def test_sigkill_mid_flight_keeps_params_and_logs_up_to_the_last_second(daemon_factory,
                                                                         tmp_path):
    state, logs = tmp_path / "state", tmp_path / "logs"
    killed_at = 0.0
    d = start_daemon("--state-dir", str(state), "--log-dir", str(logs))  # killed below
    conn = gcs(d.api_port(0))
    try:
        conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert heartbeats_by_sysid(conn, {1})
        conn.mav.param_set_send(1, 1, b"MIS_TAKEOFF_ALT", 4.0, M.MAV_PARAM_TYPE_REAL32)
        assert conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=5,
                               condition="PARAM_VALUE.param_id=='MIS_TAKEOFF_ALT'")
        arm_and_take_off(conn, above_m=3.0)
        time.sleep(2.5)
        killed_at = time.time()
        os.kill(d.proc.pid, signal.SIGKILL)
    finally:
        conn.close()
        if d.proc.poll() is None and not killed_at:
            d.proc.terminate()
        d.stop()
    assert d.proc.returncode == -signal.SIGKILL

    (run,) = list(logs.iterdir())
    # The tlog reads to its end (a frame cut by the kill is at most the tail) and covers the
    # flight up to the last flush: one simulated second (= wall second here) before the kill.
    stamps = _tlog_stamps(run / "v1-api.tlog")
    assert len(stamps) > 500 and stamps == sorted(stamps)
    assert stamps[-1] > killed_at - 2.0, (stamps[-1], killed_at)
    dump = os.path.join(os.path.dirname(sys.executable), "mavlogdump.py")
    out = subprocess.run([sys.executable, dump, "--types", "GLOBAL_POSITION_INT",
                          str(run / "v1-api.tlog")], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and "GLOBAL_POSITION_INT" in out.stdout, out.stderr
    rows = (run / "state.csv").read_text().splitlines()
    assert len(rows) > 50
    # the last whole row shows the vehicle flying: armed, above 3 m
    header = rows[0].split(",")
    last = next(r.split(",") for r in reversed(rows) if len(r.split(",")) == len(header))
    rec = dict(zip(header, last))
    assert rec["armed"] in ("1", "True", "true") and float(rec["d_m"]) < -3.0, rec

    # Restart on the same state directory: the parameter set before the kill is there.
    d2 = daemon_factory("--state-dir", str(state), "--log-dir", str(logs))
    conn = gcs(d2.api_port(0))
    try:
        conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert heartbeats_by_sysid(conn, {1})
        assert _param(conn, "MIS_TAKEOFF_ALT") == pytest.approx(4.0)
    finally:
        conn.close()
    assert d2.stop() == 0
    assert len(list(logs.iterdir())) == 2  # a new run directory; the crashed one untouched
    assert struct.unpack(">Q", (run / "v1-api.tlog").read_bytes()[:8])[0] > 0


def test_client_killed_and_restarted_mid_mission_picks_up_and_the_mission_finishes(
        daemon_factory):
    from tests.e2e.gcs import upload_mission
    from vehicles.types import PX4_SITL_HOME

    d = daemon_factory("--speed", "4")

    def geo(n: float, e: float) -> tuple[float, float]:
        g = PX4_SITL_HOME.offset_ned(n, e, 0.0)
        return g.lat_deg, g.lon_deg

    rel = M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    items = [(M.MAV_CMD_NAV_TAKEOFF, rel, *geo(0, 0), 5.0),
             (M.MAV_CMD_NAV_WAYPOINT, rel, *geo(15, 0), 5.0),
             (M.MAV_CMD_NAV_WAYPOINT, rel, *geo(15, 15), 5.0),
             (M.MAV_CMD_NAV_WAYPOINT, rel, *geo(0, 15), 5.0),
             (M.MAV_CMD_NAV_RETURN_TO_LAUNCH, M.MAV_FRAME_MISSION, 0.0, 0.0, 0.0)]
    first = gcs(d.api_port(0))
    try:
        first.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert heartbeats_by_sysid(first, {1})
        assert upload_mission(first, 1, items) == M.MAV_MISSION_ACCEPTED
        deadline = time.monotonic() + 20
        while command_long(first, M.MAV_CMD_COMPONENT_ARM_DISARM, 1) != 0:
            assert time.monotonic() < deadline, "could not arm"
            time.sleep(0.5)
        assert command_long(first, M.MAV_CMD_MISSION_START, 0, 0) == 0
        cur = first.recv_match(type="MISSION_CURRENT", blocking=True, timeout=10,
                               condition="MISSION_CURRENT.seq>=2")
        assert cur is not None, "mission did not progress"
    finally:
        first.close()  # the client dies: no goodbye, its socket simply goes away

    time.sleep(1.0)
    second = gcs(d.api_port(0))  # a new client process on the same port
    try:
        second.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert heartbeats_by_sysid(second, {1})
        second.mav.mission_request_list_send(1, 1, 0)
        count = second.recv_match(type="MISSION_COUNT", blocking=True, timeout=5)
        assert count is not None and count.count == len(items)
        second.mav.mission_ack_send(1, 1, M.MAV_MISSION_ACCEPTED, 0)  # we only wanted the count
        cur = second.recv_match(type="MISSION_CURRENT", blocking=True, timeout=5)
        assert cur is not None and cur.seq >= 2  # it carried on while nobody listened
        deadline = time.monotonic() + 60
        landed = None
        while time.monotonic() < deadline:
            hb = second.recv_match(type="HEARTBEAT", blocking=True, timeout=1)
            if hb is not None and hb.get_srcSystem() == 1 and \
                    not hb.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED:
                landed = hb
                break
            second.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert landed is not None, "the mission did not finish with a landing"
    finally:
        second.close()


def _children(pid: int) -> list[int]:
    out = []
    for task in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{task}/children") as f:
            out += [int(x) for x in f.read().split()]
    return out


def test_ns3_engine_killed_mid_run_the_daemon_keeps_its_clock_and_stops_cleanly(daemon_factory):
    from netsim.ns3 import BINARY, build_missing_message

    if not BINARY.is_file():
        pytest.skip(build_missing_message())
    d = daemon_factory("--scenario", "ns3-wifi")
    conn = gcs(d.api_port(0))
    try:
        conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert heartbeats_by_sysid(conn, {1}, timeout_s=20)  # through ns-3
        engines = [p for p in _children(d.proc.pid)
                   if os.path.basename(os.readlink(f"/proc/{p}/exe")) == BINARY.name]
        assert len(engines) == 1
        os.kill(engines[0], signal.SIGKILL)
        time.sleep(3.0)
        assert d.proc.poll() is None, d.log_tail()
        while conn.recv_match(blocking=False) is not None:
            pass
        conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        # its network is gone: nothing crosses it any more
        assert conn.recv_match(type="HEARTBEAT", blocking=True, timeout=2.0) is None
    finally:
        conn.close()
    code = d.stop()
    d_lines = "\n".join(d.stderr_lines)
    assert "lost" in d_lines and "ns-3" in d_lines
    stop_line = next(ln for ln in reversed(d.stderr_lines) if "stopping after" in ln)
    sim_t = float(stop_line.split("sim_t=")[1].split("s")[0])
    assert sim_t > 4.0  # the physics clock kept going after the engine died
    assert code == 0
