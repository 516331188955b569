"""The GCS link as QGroundControl uses it, with three vehicles on the shared port 14550."""

import math
import time

import pytest
from pymavlink import mavutil

from tests.e2e.gcs import gcs, heartbeats_by_sysid, read_all_params

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

M = mavutil.mavlink


def command(conn, sysid: int, cmd: int, *params: float, timeout_s: float = 5.0):
    p = list(params) + [0.0] * (7 - len(params))
    conn.mav.command_long_send(sysid, 1, cmd, 0, *p)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.5)
        if ack is not None and ack.get_srcSystem() == sysid and ack.command == cmd:
            return ack
    raise AssertionError(f"no COMMAND_ACK for {cmd} from {sysid}")


def request_message(conn, sysid: int, msg_id: int, msg_type: str):
    """REQUEST_MESSAGE: PX4 sends the message, then its ACK (both consumed here)."""
    conn.mav.command_long_send(sysid, 1, M.MAV_CMD_REQUEST_MESSAGE, 0, msg_id, 0, 0, 0, 0, 0, 0)
    msg = conn.recv_match(type=msg_type, blocking=True, timeout=5,
                          condition=f"{msg_type}._header.srcSystem=={sysid}")
    ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=5,
                          condition=f"COMMAND_ACK._header.srcSystem=={sysid}")
    assert ack is not None and ack.command == M.MAV_CMD_REQUEST_MESSAGE and ack.result == 0
    return msg


def test_qgc_connect_sequence_rates_and_guided_flight(daemon_factory):
    d = daemon_factory(vehicles=3)
    conn = gcs(d.gcs_port())
    try:
        assert set(heartbeats_by_sysid(conn, {1, 2, 3})) == {1, 2, 3}
        conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        for sysid in (1, 2, 3):
            version = request_message(conn, sysid, M.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
                                      "AUTOPILOT_VERSION")
            assert version is not None
            assert version.capabilities & M.MAV_PROTOCOL_CAPABILITY_MISSION_INT
            assert version.capabilities & M.MAV_PROTOCOL_CAPABILITY_FTP  # as PX4 SITL
            # What QGC asks next, as PX4 SITL answers it: the component metadata (then fetched
            # over FTP) and AVAILABLE_MODES (param2 0: every mode, then the ACK).
            for msg_id in (397, 395, 435):
                ack = command(conn, sysid, M.MAV_CMD_REQUEST_MESSAGE, msg_id)
                assert ack.result == M.MAV_RESULT_ACCEPTED
            count, got = read_all_params(conn, sysid)
            assert count >= 100 and sorted(got) == list(range(count))
            for mission_type in (0, 1, 2):
                conn.mav.mission_request_list_send(sysid, 1, mission_type)
                msg = conn.recv_match(
                    type="MISSION_COUNT", blocking=True, timeout=5,
                    condition=f"MISSION_COUNT._header.srcSystem=={sysid} and "
                              f"MISSION_COUNT.mission_type=={mission_type}")
                assert msg is not None and msg.count == 0, (sysid, mission_type)

        counts = {(s, t): 0 for s in (1, 2, 3) for t in ("ATTITUDE", "GLOBAL_POSITION_INT")}
        t0 = time.monotonic()
        while time.monotonic() - t0 < 5.0:
            msg = conn.recv_match(type=["ATTITUDE", "GLOBAL_POSITION_INT"], blocking=True,
                                  timeout=0.2)
            if msg is not None and (msg.get_srcSystem(), msg.get_type()) in counts:
                counts[(msg.get_srcSystem(), msg.get_type())] += 1
        for (sysid, kind), n in counts.items():
            minimum = 5 if kind == "ATTITUDE" else 3
            assert n / 5.0 >= minimum, (sysid, kind, n)

        # QGC's guided takeoff: NAV_TAKEOFF with an AMSL altitude, then arm; then land.
        pos = conn.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=5,
                              condition="GLOBAL_POSITION_INT._header.srcSystem==2")
        amsl = pos.alt / 1000.0 + 4.0
        nan = math.nan
        assert command(conn, 2, M.MAV_CMD_NAV_TAKEOFF, -1, 0, 0, nan, nan, nan,
                       amsl).result == M.MAV_RESULT_ACCEPTED
        assert command(conn, 2, M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == \
            M.MAV_RESULT_ACCEPTED
        deadline = time.monotonic() + 30
        rel = 0.0
        while time.monotonic() < deadline and rel < 3.7:
            msg = conn.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=1,
                                  condition="GLOBAL_POSITION_INT._header.srcSystem==2")
            rel = msg.relative_alt / 1000.0 if msg else rel
            conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert rel >= 3.7
        assert command(conn, 2, M.MAV_CMD_NAV_LAND, 0, 0, 0, nan, nan, nan,
                       nan).result == M.MAV_RESULT_ACCEPTED
        deadline = time.monotonic() + 60
        armed = True
        while time.monotonic() < deadline and armed:
            hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=1,
                                 condition="HEARTBEAT._header.srcSystem==2")
            if hb is not None:
                armed = bool(hb.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)
            conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert not armed, "vehicle 2 did not land and disarm"
    finally:
        conn.close()


def test_the_gcs_link_carries_what_the_controllers_aim_for_as_px4_sitl_sends_it(daemon_factory):
    """px4-rc.mavlink raises ATTITUDE_TARGET, POSITION_TARGET_LOCAL_NED and SERVO_OUTPUT_RAW to
    50 Hz on the GCS link; QGC's MAVLink Inspector, actuator view and setpoint facts read them.
    Once airborne: thrust, motor outputs and a position setpoint near the vehicle."""
    d = daemon_factory(vehicles=1)
    conn = gcs(d.gcs_port())
    try:
        assert set(heartbeats_by_sysid(conn, {1})) == {1}
        conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        pos = conn.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=5)
        nan = math.nan
        assert command(conn, 1, M.MAV_CMD_NAV_TAKEOFF, -1, 0, 0, nan, nan, nan,
                       pos.alt / 1000.0 + 5.0).result == M.MAV_RESULT_ACCEPTED
        assert command(conn, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == \
            M.MAV_RESULT_ACCEPTED
        kinds = ("ATTITUDE_TARGET", "POSITION_TARGET_LOCAL_NED", "SERVO_OUTPUT_RAW",
                 "LOCAL_POSITION_NED")
        conn.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=20,
                        condition="LOCAL_POSITION_NED.z < -3.0")
        last, counts = {}, dict.fromkeys(kinds, 0)
        t0 = time.monotonic()
        while time.monotonic() - t0 < 4.0:
            msg = conn.recv_match(type=list(kinds), blocking=True, timeout=0.2)
            if msg is not None:
                counts[msg.get_type()] += 1
                last[msg.get_type()] = msg
        # 50 Hz each at real time (a loaded machine may run the daemon a little slower).
        for kind in kinds:
            assert counts[kind] / 4.0 >= 35, (kind, counts)
        assert abs(counts["ATTITUDE_TARGET"] - counts["LOCAL_POSITION_NED"]) <= 10, counts
        att, sp, out = last["ATTITUDE_TARGET"], last["POSITION_TARGET_LOCAL_NED"], \
            last["SERVO_OUTPUT_RAW"]
        lpos = last["LOCAL_POSITION_NED"]
        assert 0.3 < att.thrust < 0.9
        assert all(300 < getattr(out, f"servo{i}_raw") < 1000 for i in range(1, 5))
        assert out.servo5_raw == 0
        assert sp.type_mask & 7 == 0 and math.dist((sp.x, sp.y, sp.z), (lpos.x, lpos.y, lpos.z)) < 3
        assert command(conn, 1, M.MAV_CMD_NAV_LAND).result == M.MAV_RESULT_ACCEPTED
    finally:
        conn.close()
