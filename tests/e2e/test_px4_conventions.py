"""PX4 SITL's conventions a user brings along: PX4_SIM_SPEED_FACTOR and PX4_HOME_* in the
environment, a ground station on another address (--gcs, PX4's partner address) and
MAV_BROADCAST."""

import os
import subprocess
import time

import pytest
from pymavlink import mavutil

from gateway.ci.launcher import VEHICLE_GCS_PORT, cornet_command, free_port_offset, start_daemon
from gateway.daemon.endpoint import broadcast_address
from tests.e2e.gcs import heartbeats_by_sysid

pytestmark = [pytest.mark.e2e]

GCS_PORT = 14550


def environment(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PX4_SIM_", "PX4_HOME_"))}
    return {**env, **extra}


def listen(host: str, port: int):
    return mavutil.mavlink_connection(f"udpin:{host}:{port}", source_system=255,
                                      source_component=190, dialect="common")


def test_speed_factor_from_the_environment_is_in_the_ready_line():
    d = start_daemon(env=environment(PX4_SIM_SPEED_FACTOR="4"))
    try:
        assert "speed 4x (PX4_SIM_SPEED_FACTOR)" in d.ready_line, d.ready_line
    finally:
        assert d.stop() == 0, d.log_tail()


def test_the_speed_flag_wins_over_the_environment():
    d = start_daemon("--speed", "2", env=environment(PX4_SIM_SPEED_FACTOR="4"))
    try:
        assert "speed 2x," in d.ready_line, d.ready_line
        assert "PX4_SIM_SPEED_FACTOR" not in d.ready_line
    finally:
        assert d.stop() == 0, d.log_tail()


def test_a_bad_speed_factor_exits_2_naming_the_variable():
    out = subprocess.run(cornet_command() + ["run"], capture_output=True, text=True, timeout=30,
                         env=environment(PX4_SIM_SPEED_FACTOR="fast"))
    assert out.returncode == 2
    assert "PX4_SIM_SPEED_FACTOR" in out.stderr.splitlines()[-1], out.stderr


def test_home_from_the_environment_moves_global_position_int():
    d = start_daemon(env=environment(PX4_HOME_LAT="-33.8568", PX4_HOME_LON="151.2153",
                                     PX4_HOME_ALT="12"))
    conn = listen("127.0.0.1", d.gcs_port())
    try:
        assert "(PX4_HOME_LAT, PX4_HOME_LON, PX4_HOME_ALT)" in d.ready_line, d.ready_line
        msg = conn.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=15)
        assert msg is not None, d.log_tail()
        assert abs(msg.lat / 1e7 - -33.8568) < 1e-3 and abs(msg.lon / 1e7 - 151.2153) < 1e-3, msg
        assert abs(msg.alt / 1e3 - 12.0) < 2.0, msg
    finally:
        conn.close()
        assert d.stop() == 0, d.log_tail()


def hears_vehicle_1(conn, d) -> None:
    """``conn`` receives vehicle 1's HEARTBEATs from daemon ``d``, which then stops cleanly."""
    try:
        seen = heartbeats_by_sysid(conn, {1})
        assert set(seen) == {1}, d.log_tail()
    finally:
        conn.close()
        assert d.stop() == 0, d.log_tail()


@pytest.mark.parametrize("with_port", [True, False], ids=["host:port", "host"])
def test_gcs_on_another_address_receives_heartbeats(with_port):
    offset = free_port_offset(1)
    port = GCS_PORT + offset + (7 if with_port else 0)
    conn = listen("127.0.0.2", port)  # a ground station on another address
    target = f"127.0.0.2:{port}" if with_port else "127.0.0.2"
    hears_vehicle_1(conn, start_daemon("--gcs", target, port_offset=offset))


def test_mav_broadcast_sends_heartbeats_to_the_broadcast_address():
    bcast = broadcast_address("0.0.0.0")
    if bcast is None:
        pytest.skip("no network interface with a broadcast address here")
    offset = free_port_offset(1)
    conn = listen(bcast, GCS_PORT + offset)  # only what is sent to the broadcast address
    hears_vehicle_1(conn, start_daemon("--bind", "0.0.0.0", "--gcs", "127.0.0.3", "--param",
                                       "MAV_BROADCAST=1", port_offset=offset))


def test_broadcast_stops_while_a_ground_station_is_connected_and_resumes_when_it_goes():
    """PX4 (send_finish): broadcast until a client is heard and whenever no ground station's
    HEARTBEAT came lately, so a restarted QGC on the LAN finds the vehicle again."""
    bcast = broadcast_address("0.0.0.0")
    if bcast is None:
        pytest.skip("no network interface with a broadcast address here")
    offset = free_port_offset(1)
    conn = listen(bcast, GCS_PORT + offset)
    d = start_daemon("--bind", "0.0.0.0", "--gcs", "127.0.0.3", "--param", "MAV_BROADCAST=1",
                     port_offset=offset)
    station = mavutil.mavlink_connection(f"udpout:127.0.0.1:{VEHICLE_GCS_PORT + offset}",
                                         source_system=255, source_component=190,
                                         dialect="common")

    def heartbeats_on_broadcast(seconds: float, beat: bool) -> int:
        n, end, next_beat = 0, time.monotonic() + seconds, 0.0
        while time.monotonic() < end:
            if beat and time.monotonic() >= next_beat:  # a ground station's 1 Hz, doubled
                station.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                                           mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                next_beat = time.monotonic() + 0.5
            msg = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.1)
            n += msg is not None and msg.get_srcSystem() == 1
        return n

    try:
        assert set(heartbeats_by_sysid(conn, {1})) == {1}, d.log_tail()  # no client yet
        heartbeats_on_broadcast(1.5, beat=True)  # the station is heard; copies in flight drain
        assert heartbeats_on_broadcast(3.0, beat=True) == 0, d.log_tail()
        assert station.recv_match(type="HEARTBEAT", blocking=True, timeout=5) is not None
        assert heartbeats_on_broadcast(6.0, beat=False) >= 2, d.log_tail()  # 2.5 s after
    finally:
        conn.close()
        station.close()
        assert d.stop() == 0, d.log_tail()


def test_no_broadcast_by_default():
    """MAV_BROADCAST is 0 by default (PX4's default): the GCS link talks to its partner only."""
    bcast = broadcast_address("0.0.0.0")
    if bcast is None:
        pytest.skip("no network interface with a broadcast address here")
    offset = free_port_offset(1)
    conn = listen(bcast, GCS_PORT + offset)
    partner = listen("127.0.0.3", GCS_PORT + offset)
    d = start_daemon("--bind", "0.0.0.0", "--gcs", "127.0.0.3", port_offset=offset)
    try:
        for _ in range(3):  # a broadcast copy would be in conn's buffer before each of these
            assert set(heartbeats_by_sysid(partner, {1})) == {1}, d.log_tail()
        assert conn.recv_match(blocking=False) is None
    finally:
        conn.close()
        partner.close()
        assert d.stop() == 0, d.log_tail()


def param_value(conn, sysid: int, name: str) -> float:
    """PARAM_REQUEST_READ by name, as QGC refreshes one parameter (re-asked until answered)."""
    for _ in range(30):
        conn.mav.param_request_read_send(sysid, 1, name.encode(), -1)
        msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=1)
        if msg is not None and msg.get_srcSystem() == sysid and msg.param_id == name:
            return msg.param_value
    raise AssertionError(f"vehicle {sysid} never answered PARAM_REQUEST_READ {name}")


def test_a_param_file_sets_one_vehicle_only(tmp_path):
    saved = tmp_path / "vehicle.params"  # as QGC's "Save to file" writes it
    saved.write_text("# Onboard parameters for Vehicle 1\n#\n# Vehicle-Id Component-Id Name "
                     "Value Type\n1\t1\tMAV_SYS_ID\t1\t6\n1\t1\tMIS_TAKEOFF_ALT\t7.5\t9\n")
    d = start_daemon("--param-file", f"2:{saved}", "--param", "RTL_RETURN_ALT=42", vehicles=2)
    conn = listen("127.0.0.1", d.gcs_port())
    try:
        assert set(heartbeats_by_sysid(conn, {1, 2})) == {1, 2}, d.log_tail()
        assert param_value(conn, 2, "MIS_TAKEOFF_ALT") == 7.5
        assert param_value(conn, 1, "MIS_TAKEOFF_ALT") == 2.5  # PX4's default
        assert param_value(conn, 2, "RTL_RETURN_ALT") == 42  # --param: every vehicle
    finally:
        conn.close()
        assert d.stop() == 0, d.log_tail()


def test_a_bad_param_file_exits_2_naming_the_line(tmp_path):
    bad = tmp_path / "bad.params"
    bad.write_text("1\t1\tNOT_A_PX4_PARAM\t1\t9\n")
    out = subprocess.run(cornet_command() + ["run", "--param-file", str(bad)],
                         capture_output=True, text=True, timeout=30)
    assert out.returncode == 2
    assert f"{bad}:1: no PX4 parameter named 'NOT_A_PX4_PARAM'" in out.stderr, out.stderr


def test_the_configuration_file_sets_the_gcs_address(tmp_path):
    """`[daemon] gcs` in `cornet run --config FILE` (the service's way) does what --gcs does."""
    offset = free_port_offset(1)
    port = GCS_PORT + offset
    config = tmp_path / "cornet.toml"
    config.write_text('[daemon]\ngcs = "127.0.0.2"\n')
    conn = listen("127.0.0.2", port)
    try:
        d = start_daemon("--config", str(config), port_offset=offset)
    except BaseException:
        conn.close()  # not left to the garbage collector, in another test's time
        raise
    try:
        assert set(heartbeats_by_sysid(conn, {1})) == {1}, d.log_tail()
    finally:
        conn.close()
        assert d.stop() == 0, d.log_tail()
