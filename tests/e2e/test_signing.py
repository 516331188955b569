"""MAVLink 2 signing on (`cornet run --signing-key FILE`): an unsigned MAVSDK client sees the
vehicle but cannot command it (its frames are refused and counted); a pymavlink client signing
with the same key flies."""

import os
import re
import time

import pytest
from mavsdk import System
from mavsdk.action import ActionError
from pymavlink import mavutil

from gateway.ci.launcher import free_tcp_port
from tests.e2e.gcs import arm_and_take_off, command_long
from tests.e2e.persona import first

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

M = mavutil.mavlink
PASSPHRASE = "cornet lab key 2026"


def key_of(passphrase: str) -> bytes:
    import hashlib

    return hashlib.sha256(passphrase.encode()).digest()


def signed_client(vehicle_port: int):
    """A pymavlink GCS talking to the vehicle's own port from an ephemeral one: its first signed
    frame makes the vehicle reply to it (an unsigned one would not)."""
    # pymavlink speaks MAVLink 1 (which cannot be signed) unless MAVLINK20 is set when the
    # connection picks its dialect.
    os.environ["MAVLINK20"] = "1"
    try:
        conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{vehicle_port}", source_system=255,
                                          source_component=190, dialect="common")
    finally:
        del os.environ["MAVLINK20"]
    conn.setup_signing(key_of(PASSPHRASE), sign_outgoing=True, link_id=7,
                       initial_timestamp=int((time.time() - 1420070400) * 1e5))
    return conn


@pytest.mark.asyncio
async def test_unsigned_mavsdk_is_refused_and_a_signed_pymavlink_client_flies(daemon_factory,
                                                                             tmp_path):
    keyfile = tmp_path / "signing.key"
    keyfile.write_text(PASSPHRASE + "\n")
    d = daemon_factory("--signing-key", str(keyfile))
    assert PASSPHRASE not in "\n".join(d.stderr_lines)  # the key is never logged

    drone = System(port=free_tcp_port())
    await drone.connect(system_address=f"udpin://0.0.0.0:{d.api_port(0)}")
    await first(drone.core.connection_state(), lambda s: s.is_connected, 30, "connection")
    with pytest.raises(ActionError):
        await drone.action.arm()  # its COMMAND_LONGs are unsigned: dropped, never ACKed
    drone._stop_mavsdk_server()

    conn = signed_client(d.vehicle_port(0, "api"))
    try:
        conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=10)
        assert hb is not None and hb.get_srcSystem() == 1
        assert hb.get_header().incompat_flags & 0x01  # the vehicle signs what it sends
        arm_and_take_off(conn, above_m=2.3)
        nan = float("nan")
        assert command_long(conn, M.MAV_CMD_NAV_LAND, nan, nan, nan, nan, nan, nan, nan) == 0
        deadline = time.monotonic() + 30
        while True:
            hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=1)
            if hb is not None and not hb.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED:
                break
            assert time.monotonic() < deadline, "did not land and disarm"
    finally:
        conn.close()
    code = d.stop()
    assert code == 0
    stop_line = next(ln for ln in reversed(d.stderr_lines) if "stopping after" in ln)
    refused = re.search(r"unsigned=(\d+)", stop_line)
    assert refused and int(refused.group(1)) > 0, stop_line
