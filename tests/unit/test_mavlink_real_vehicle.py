"""The session against the real vehicles.World (skipped until vehicles/vehicle.py lands).

MAVSDK takeoff_and_land in miniature: wait for health via SYS_STATUS/HOME_POSITION, arm and take
off with COMMAND_LONG exactly as MAVSDK sends them, watch LOCAL_POSITION_NED climb, land.
"""

import dataclasses
import math

import pytest
from pymavlink.dialects.v20 import common as M

pytest.importorskip("vehicles.vehicle")

from test_mavlink_support import Client, acks, of_type  # noqa: E402

from gateway.mavlink.session import LinkKind, Session  # noqa: E402
from vehicles.params import ParamStore  # noqa: E402
from vehicles.plan_types import MissionState, PlanType  # noqa: E402
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


def _real_world_with_plans():
    world = World(dt_s=0.004)
    vehicle = world.add_vehicle(index=0, params=ParamStore({"MAV_SYS_ID": 1}))
    client = Client(Session(vehicle, LinkKind.API, now_s=0.0))
    client.heartbeat()
    _fly(world, client, 8.0)
    return world, vehicle, client


@pytest.mark.slow
def test_mavsdk_mission_over_mavlink():
    """MAVSDK mission.upload_mission + start_mission (DO_SET_MODE 4/4) on the real autopilot."""
    from test_mavlink_mission import upload, wp

    world, vehicle, client = _real_world_with_plans()
    try:
        home = vehicle.origin
        a, b = home.offset_ned(15.0, 0.0, 0.0), home.offset_ned(15.0, 15.0, 0.0)
        items = [wp(0, round(a.lat_deg * 1e7), round(a.lon_deg * 1e7), 5.0, current=1),
                 wp(1, round(b.lat_deg * 1e7), round(b.lon_deg * 1e7), 5.0)]
        got = upload(client, items)
        assert [(m.type, m.mission_type) for m in of_type(got, "MISSION_ACK")] == [(0, 0)]
        assert len(vehicle.plan(0)) == 2
        assert [a.result for a in acks(client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1))] \
            == [0]
        assert [a.result for a in acks(client.command_long(M.MAV_CMD_DO_SET_MODE, 129, 4, 4))] \
            == [0]
        msgs = _fly(world, client, 60.0)
        assert [m.seq for m in of_type(msgs, "MISSION_ITEM_REACHED")][:1] == [0]
        assert 1 in {m.seq for m in of_type(msgs, "MISSION_ITEM_REACHED")}
        assert vehicle.mission_status.state is MissionState.COMPLETE
    finally:
        world.close()


@pytest.mark.slow
def test_mavsdk_offboard_position_over_mavlink():
    """MAVSDK offboard: set_position_ned streamed at 20 Hz, start = DO_SET_MODE 6/0."""
    world, vehicle, client = _real_world_with_plans()
    try:
        def stream(until_s):
            msgs = []
            while client.now_s < until_s:
                client.send(M.MAVLink_set_position_target_local_ned_message(
                    0, 1, 1, 1, 2552, 5.0, 0.0, -4.0, 0, 0, 0, 0, 0, 0, 0.0, 0))
                msgs += _fly(world, client, client.now_s + 0.05)
            return msgs

        assert [a.result for a in acks(client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1))] \
            == [0]
        stream(client.now_s + 0.3)
        assert [a.result for a in acks(client.command_long(M.MAV_CMD_DO_SET_MODE, 129, 6, 0))] \
            == [0]
        msgs = stream(client.now_s + 15.0)
        lpn = of_type(msgs, "LOCAL_POSITION_NED")[-1]
        assert abs(lpn.x - 5.0) < 0.5 and abs(lpn.z + 4.0) < 0.5
    finally:
        world.close()


@pytest.mark.slow
def test_plans_round_trip_and_goto_on_real_vehicle():
    """QGC-style fence/rally round trip through the real validator, then MAVSDK goto_location."""
    from test_mavlink_mission import download, fence_items, int_frames, rally_items, same, upload

    world, vehicle, client = _real_world_with_plans()
    try:
        for mission_type, items in ((1, fence_items()), (2, rally_items())):
            got = upload(client, items, mission_type)
            assert [m.type for m in of_type(got, "MISSION_ACK")] == [0]
            back = download(client, mission_type)
            expected = int_frames(items, PlanType(mission_type))
            assert len(back) == len(items) and all(same(a, b) for a, b in zip(back, expected))
        bad = [dataclasses.replace(it, param1=2.0) for it in fence_items()[:2]]  # 2 vertices
        got = upload(client, bad, 1)
        assert [m.type for m in of_type(got, "MISSION_ACK")] == [1]  # MAV_MISSION_ERROR
        assert len(download(client, 1)) == len(fence_items())  # old fence kept
        got = client.send(M.MAVLink_mission_clear_all_message(1, 1, 1))  # the goto is inside
        assert [m.type for m in of_type(got, "MISSION_ACK")] == [0]  # its exclusion circle
        assert [a.result for a in acks(client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1))] \
            == [0]
        client.command_long(M.MAV_CMD_NAV_TAKEOFF, *([math.nan] * 7))
        _fly(world, client, client.now_s + 6.0)
        target = vehicle.origin.offset_ned(10.0, 0.0, -3.0)
        assert [a.result for a in acks(client.command_long(M.MAV_CMD_DO_SET_MODE, 129, 4, 3))] \
            == [0]
        got = client.send(M.MAVLink_command_int_message(
            1, 1, 5, M.MAV_CMD_DO_REPOSITION, 0, 0, math.nan, 1, 0, 0.0,
            round(target.lat_deg * 1e7), round(target.lon_deg * 1e7), target.alt_amsl_m))
        assert [a.result for a in acks(got)] == [0]
        msgs = _fly(world, client, client.now_s + 12.0)
        lpn = of_type(msgs, "LOCAL_POSITION_NED")[-1]
        assert abs(lpn.x - 10.0) < 1.0 and abs(lpn.z + 3.0) < 1.0
    finally:
        world.close()
