"""The session against the real vehicles.World (skipped until vehicles/vehicle.py lands).

MAVSDK takeoff_and_land in miniature: wait for health via SYS_STATUS/HOME_POSITION, arm and take
off with COMMAND_LONG exactly as MAVSDK sends them, watch LOCAL_POSITION_NED climb, land.
"""

import math

import pytest
from pymavlink.dialects.v20 import common as M

pytest.importorskip("vehicles.vehicle")

from gateway.mavlink.session import LinkKind, Session  # noqa: E402
from test_mavlink_support import Client, acks, of_type  # noqa: E402
from vehicles.params import ParamStore  # noqa: E402
from vehicles.world import World  # noqa: E402


def _fly(world, client, until_s):
    msgs = []
    while client.now_s < until_s:
        t = client.now_s + world.dt_s if hasattr(world, "dt_s") else client.now_s + 0.004
        world.step(t)
        msgs += client.run_until(t)
    return msgs


@pytest.mark.slow
def test_arm_takeoff_land_over_mavlink():
    world = World(dt_s=0.004)
    try:
        vehicle = world.add_vehicle(index=0, params=ParamStore({"MAV_SYS_ID": 1}))
        session = Session(vehicle, LinkKind.API, now_s=0.0)
        client = Client(session)
        client.heartbeat()
        msgs = _fly(world, client, 8.0)
        ss = of_type(msgs, "SYS_STATUS")[-1]
        assert ss.onboard_control_sensors_health & 32, "global position never became ok"
        assert ss.onboard_control_sensors_health & 0x10000000, "never armable"
        assert of_type(msgs, "HOME_POSITION")
        assert [a.result for a in acks(client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1))] \
            == [0]
        got = client.command_long(M.MAV_CMD_NAV_TAKEOFF, *([math.nan] * 7))
        assert [a.result for a in acks(got)] == [0]
        msgs = _fly(world, client, 20.0)
        z = [m.z for m in of_type(msgs, "LOCAL_POSITION_NED")]
        assert min(z) < -2.0
        assert of_type(msgs, "HEARTBEAT")[-1].base_mode & 128
        got = client.command_long(M.MAV_CMD_NAV_LAND, *([math.nan] * 7))
        assert [a.result for a in acks(got)] == [0]
        msgs = _fly(world, client, 35.0)
        assert of_type(msgs, "EXTENDED_SYS_STATE")[-1].landed_state == 1
    finally:
        world.close()
