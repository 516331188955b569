"""A pymavlink GCS on the shared GCS port: discovery, the full parameter protocol, a PARAM_SET."""

import struct
import time

import pytest
from pymavlink import mavutil

from tests.e2e.gcs import command_long, gcs, heartbeats_by_sysid, read_all_params

pytestmark = [pytest.mark.e2e]


def test_gcs_sees_all_vehicles_reads_every_param_and_sets_one(daemon_factory):
    d = daemon_factory(vehicles=3)
    conn = gcs(d.gcs_port())
    try:
        # The GCS answers so that the vehicles latch onto it, as QGC does.
        conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID,
                                0, 0, 0)
        seen = heartbeats_by_sysid(conn, {1, 2, 3})
        assert set(seen) == {1, 2, 3}
        for hb in seen.values():
            assert hb.autopilot == mavutil.mavlink.MAV_AUTOPILOT_PX4
            assert hb.type == mavutil.mavlink.MAV_TYPE_QUADROTOR
            assert hb.custom_mode == 0x03040000  # AUTO.LOITER (Hold) at boot
        for sysid in (1, 2, 3):
            count, got = read_all_params(conn, sysid)
            assert count and count >= 100
            assert sorted(got) == list(range(count))
            names = {m.param_id: m for m in got.values()}
            sys_id = names["MAV_SYS_ID"]
            assert sys_id.param_type == mavutil.mavlink.MAV_PARAM_TYPE_INT32
            assert struct.unpack("<i", struct.pack("<f", sys_id.param_value))[0] == sysid
            assert names["MIS_TAKEOFF_ALT"].param_value == pytest.approx(2.5)

        conn.mav.param_set_send(2, 1, b"MIS_TAKEOFF_ALT", 6.0,
                                mavutil.mavlink.MAV_PARAM_TYPE_REAL32)
        deadline = time.monotonic() + 10
        echo = None
        while time.monotonic() < deadline:
            msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
            if msg is not None and msg.get_srcSystem() == 2 and msg.param_id == "MIS_TAKEOFF_ALT":
                echo = msg
                break
        assert echo is not None and echo.param_value == pytest.approx(6.0)
        # PX4 sends a changed parameter again on every link once it is set (the copy of the
        # unsaved value, after the echo): vehicle 2's may come before vehicle 1's answer.
        conn.mav.param_request_read_send(1, 1, b"MIS_TAKEOFF_ALT", -1)
        deadline = time.monotonic() + 5
        msg = None
        while msg is None and time.monotonic() < deadline:
            got = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
            if got is not None and got.get_srcSystem() == 1 and got.param_id == "MIS_TAKEOFF_ALT":
                msg = got
        assert msg is not None and msg.param_value == pytest.approx(2.5)  # vehicle 1 unchanged
    finally:
        conn.close()


def test_parameters_survive_a_restart_with_state_dir(daemon_factory, tmp_path):
    d = daemon_factory("--state-dir", str(tmp_path), "--param", "MPC_XY_CRUISE=7")
    conn = gcs(d.gcs_port())
    try:
        conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                                mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert heartbeats_by_sysid(conn, {1})
        conn.mav.param_set_send(1, 1, b"MIS_TAKEOFF_ALT", 6.5,
                                mavutil.mavlink.MAV_PARAM_TYPE_REAL32)
        assert conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=5,
                               condition="PARAM_VALUE.param_id=='MIS_TAKEOFF_ALT'")
    finally:
        conn.close()
    assert d.stop() == 0

    d2 = daemon_factory("--state-dir", str(tmp_path))
    conn = gcs(d2.gcs_port())
    try:
        conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                                mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert heartbeats_by_sysid(conn, {1})
        values = {}
        for name in ("MIS_TAKEOFF_ALT", "MPC_XY_CRUISE"):
            conn.mav.param_request_read_send(1, 1, name.encode(), -1)
            msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=5,
                                  condition=f"PARAM_VALUE.param_id=='{name}'")
            values[name] = msg.param_value
        assert values["MIS_TAKEOFF_ALT"] == pytest.approx(6.5)
        assert values["MPC_XY_CRUISE"] == pytest.approx(5.0)  # --param is set at boot, never saved
    finally:
        conn.close()


def test_a_joysticks_stick_gestures_arm_and_disarm(daemon_factory):
    """A joystick through the GCS (MANUAL_CONTROL at 20 Hz): in Position mode the left stick held
    to the lower right for COM_RC_ARM_HYST arms ("Armed by RC"), to the lower left disarms, as
    PX4's manual_control module and Commander do."""
    d = daemon_factory()
    conn = gcs(d.gcs_port())
    try:
        conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID,
                                0, 0, 0)
        assert heartbeats_by_sysid(conn, {1})
        texts: list[str] = []
        beat = [0.0]  # when the next GCS HEARTBEAT is due

        def joystick(z: int, r: int, seconds: float, until) -> bool:
            """MANUAL_CONTROL (x, y centred) every 50 ms, a GCS HEARTBEAT every second (PX4 sends
            STATUSTEXT while one is heard), for ``seconds`` or until ``until(msg)``."""
            deadline = time.monotonic() + seconds
            next_s = 0.0
            while time.monotonic() < deadline:
                if time.monotonic() >= next_s:
                    conn.mav.manual_control_send(1, 0, 0, z, r, 0)
                    next_s = time.monotonic() + 0.05
                    if next_s >= beat[0]:
                        conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                                                mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                        beat[0] = next_s + 1.0
                msg = conn.recv_match(blocking=True, timeout=0.01)
                if msg is None or msg.get_srcSystem() != 1:
                    continue
                if msg.get_type() == "STATUSTEXT":
                    texts.append(msg.text)
                if until(msg):
                    return True
            return False

        def armed(want: bool):
            return lambda m: (m.get_type() == "HEARTBEAT" and bool(
                m.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED) is want)

        custom = mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        pos_ctl = lambda m: m.get_type() == "HEARTBEAT" and m.custom_mode == 0x00030000  # noqa: E731
        for _ in range(10):  # Position needs fresh stick input: send it while asking
            conn.mav.command_long_send(1, 1, mavutil.mavlink.MAV_CMD_DO_SET_MODE, 0, custom, 3,
                                       0, 0, 0, 0, 0)
            if joystick(500, 0, 1.0, pos_ctl):
                break
        else:
            raise AssertionError("no Position mode")
        def said(text: str):
            return lambda m: m.get_type() == "STATUSTEXT" and m.text.startswith(text)

        assert joystick(0, 1000, 8.0, said("Armed by RC")), texts
        assert joystick(0, 1000, 3.0, armed(True)), texts
        assert joystick(0, -1000, 8.0, said("Disarmed by RC")), texts
        assert joystick(0, -1000, 3.0, armed(False)), texts
    finally:
        conn.close()


def test_disarmed_the_gcs_may_pick_any_mode_and_arming_says_what_it_lacks(daemon_factory):
    """Commander's UserModeIntention: disarmed, DO_SET_MODE to Mission with no mission is
    ACCEPTED and the HEARTBEAT shows it; arming there is TEMPORARILY_REJECTED."""
    d = daemon_factory()
    conn = gcs(d.gcs_port())
    try:
        assert heartbeats_by_sysid(conn, {1})
        custom = mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        assert command_long(conn, mavutil.mavlink.MAV_CMD_DO_SET_MODE, custom, 4, 4) == 0
        deadline = time.monotonic() + 5
        while True:
            hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=1)
            if hb is not None and hb.get_srcSystem() == 1 and hb.custom_mode == 0x04040000:
                break
            assert time.monotonic() < deadline, "no Mission in the HEARTBEAT"
        assert command_long(conn, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == \
            mavutil.mavlink.MAV_RESULT_TEMPORARILY_REJECTED
    finally:
        conn.close()
