"""Failsafes end to end: the client goes away mid-flight and the vehicle reacts as PX4 does."""

import time

import pytest
from pymavlink import mavutil

from tests.e2e.gcs import gcs, heartbeats_by_sysid
from tests.e2e.persona import connected, first

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

HOLD = 0x03040000
RTL = 0x05040000
MAV_STATE_CRITICAL = 4 + 1


class Watcher:
    """A silent pymavlink listener (sends nothing, so it is no GCS) recording the mode history."""

    def __init__(self, port: int) -> None:
        self.conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=250)
        self.modes: list[tuple[float, int, bool, int]] = []

    def poll(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            msg = self.conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.2)
            if msg is not None and msg.get_srcComponent() == 1:
                armed = bool(msg.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
                self.modes.append((time.monotonic(), msg.custom_mode, armed, msg.system_status))

    def wait(self, predicate, timeout_s: float, what: str):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.poll(0.5)
            if self.modes and predicate(*self.modes[-1][1:]):
                return self.modes[-1]
        raise AssertionError(f"timed out waiting for {what}; last: {self.modes[-3:]}")

    def close(self) -> None:
        self.conn.close()


@pytest.mark.asyncio
async def test_offboard_loss_returns_home(daemon_factory):
    from mavsdk.offboard import PositionNedYaw

    d = daemon_factory()
    watcher = Watcher(d.gcs_port())
    try:
        async with connected(d.api_port()) as drone:
            await drone.action.arm()
            await drone.offboard.set_position_ned(PositionNedYaw(0, 0, -5, 0))
            await drone.offboard.start()
            await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 4.5, 30,
                        "offboard climb")
        # The client is gone (mavsdk_server killed): no more setpoints.
        t_lost = time.monotonic()
        watcher.wait(lambda mode, armed, state: mode == RTL, 20, "Return after offboard loss")
        assert time.monotonic() - t_lost > 1.0  # COM_OF_LOSS_T, then the hold delay
        watcher.wait(lambda mode, armed, state: not armed, 90, "landed and disarmed at home")
    finally:
        watcher.close()


def test_data_link_loss_with_nav_dll_act_return(daemon_factory):
    d = daemon_factory("--param", "NAV_DLL_ACT=2", "--param", "COM_DL_LOSS_T=3")
    ground = gcs(d.gcs_port())
    watcher = Watcher(d.api_port())
    try:
        assert heartbeats_by_sysid(ground, {1})  # a udpin GCS answers once it has heard us
        hb = ground.mav.heartbeat_send
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline:  # be a GCS for a while
            hb(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            watcher.poll(0.5)
        for command, params in [(400, [1, 0, 0, 0, 0, 0, 0]),
                                (22, [-1, 0, 0, float("nan"), float("nan"), float("nan"),
                                      float("nan")])]:
            ack = None
            for _ in range(6):  # a GCS retries an unanswered command, heartbeating meanwhile
                ground.mav.command_long_send(1, 1, command, 0, *params)
                ack = ground.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.5,
                                        condition=f"COMMAND_ACK.command=={command}")
                hb(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                if ack is not None:
                    break
            assert ack is not None and ack.result == 0, (command, ack, d.log_tail())
            hb(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        deadline = time.monotonic() + 8
        while time.monotonic() < deadline:  # climbing and holding, GCS still there
            hb(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            watcher.poll(0.5)
        assert watcher.modes[-1][1] == HOLD and watcher.modes[-1][2], watcher.modes[-3:]
        t_lost = time.monotonic()  # the GCS goes silent
        try:
            mode = watcher.wait(lambda mode, armed, state: mode == RTL, 30, "Return after DLL")
        except AssertionError as exc:
            raise AssertionError(f"{exc}\n{d.log_tail()}") from None
        assert mode[0] - t_lost > 3.0  # COM_DL_LOSS_T
        watcher.wait(lambda mode, armed, state: not armed, 90, "landed and disarmed")
    finally:
        watcher.close()
        ground.close()
