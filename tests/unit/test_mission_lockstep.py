"""Mission behaviour through the wire in lockstep (gateway.testing.Sim, pymavlink client), as a
MAVSDK / QGC / pymavlink user meets it on PX4 1.15."""

import dataclasses
import math

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.testing import mission_item
from tests.unit import lockstep_support
from tests.unit.lockstep_support import geo
from vehicles.plan_types import MavCmd, MissionState, PlanResult
from vehicles.types import NavState

sim = lockstep_support.sim  # the fixture: one vehicle, its position estimate valid

# The mission's state and whether Mission mode flies it, as the vehicle knows them (PX4 v1.15's
# MISSION_CURRENT leaves mission_state and mission_mode 0)
ACTIVE, COMPLETE = MissionState.ACTIVE, MissionState.COMPLETE
MODE_ACTIVE, MODE_SUSPENDED = True, False


def test_finished_mission_reentered_then_set_current_and_the_same_upload(sim):
    """mission_base.cpp: re-entering a mission finished in the air loiters with "No valid
    mission available, loitering" (checkMissionRestart needs a disarm); MISSION_SET_CURRENT
    (mavlink_mission.cpp update_active_mission) makes it fly again from that item; uploading the
    same mission (same CRC32) leaves the current item alone."""
    api = sim.api(0)
    items = [mission_item(MavCmd.NAV_WAYPOINT, *geo(15, 0), 6.0),
             mission_item(MavCmd.NAV_WAYPOINT, *geo(15, 15), 6.0)]
    assert api.upload_mission(items) == PlanResult.ACCEPTED
    assert api.arm() == 0 and api.start_mission() == 0

    def state(st, mode):
        status = sim.vehicles[0].mission_status
        return (status.state, status.in_mission_mode) == (st, mode)

    assert sim.run_until(lambda: state(COMPLETE, MODE_ACTIVE), timeout_s=60)
    sim.advance(1.5)  # loitering at the end ("Mission finished, loitering")
    assert api.set_mode(NavState.AUTO_LOITER) == 0
    assert sim.run_until(lambda: state(COMPLETE, MODE_SUSPENDED), timeout_s=3)
    sim.advance(0.5)  # holding
    mark = len(api.frames)
    assert api.set_mode(NavState.AUTO_MISSION) == 0
    sim.advance(3.0)
    texts = [m.text for m in api.messages("STATUSTEXT", since=mark)]
    assert "No valid mission available, loitering\t" in texts
    assert state(COMPLETE, MODE_ACTIVE) and api.last("MISSION_CURRENT").seq == 1
    mark = len(api.frames)
    api.send(api.mav.mission_set_current_encode(api.target, 1, 0))
    assert sim.run_until(lambda: 0 in [m.seq for m in api.messages("MISSION_ITEM_REACHED",
                                                                   since=mark)], timeout_s=30)
    assert state(ACTIVE, MODE_ACTIVE) and api.last("MISSION_CURRENT").seq == 1
    assert api.upload_mission(items) == PlanResult.ACCEPTED  # the same again: nothing changes
    sim.advance(1.5)
    m = api.last("MISSION_CURRENT")
    assert (m.seq, m.mission_state, m.mission_mode) == (1, 0, 0) and state(ACTIVE, MODE_ACTIVE)
    assert sim.run_until(lambda: state(COMPLETE, MODE_ACTIVE), timeout_s=30)


def test_float_item_in_int_frame_and_download_frames(sim):
    """parse_mavlink_mission_item: *_INT frames only in int mode; format_mavlink_mission_item:
    a waypoint sent in GLOBAL_RELATIVE_ALT comes back as GLOBAL_RELATIVE_ALT_INT, yaw wrapped."""
    api = sim.api(0)
    lat, lon = geo(10, 0)
    it = mission_item(MavCmd.NAV_WAYPOINT, lat, lon, 5.0, frame=3, params=(0.0, 2.0, 4.0, -90.0))
    assert api.upload_mission([it]) == PlanResult.ACCEPTED
    mark = len(api.frames)
    api.send(api.mav.mission_request_list_encode(api.target, 1, 0))
    sim.advance(0.2)
    api.send(api.mav.mission_request_int_encode(api.target, 1, 0, 0))
    sim.advance(0.2)
    back = api.messages("MISSION_ITEM_INT", since=mark)[-1]
    assert (back.frame, back.param2, back.param3) == (6, 2.0, 0.0)
    assert back.param4 == pytest.approx(270.0)
    api.send(api.mav.mission_ack_encode(api.target, 1, 0, 0))
    mark = len(api.frames)
    api.send(api.mav.mission_count_encode(api.target, 1, 1, 0))
    sim.advance(0.2)
    api.send(api.mav.mission_item_encode(api.target, 1, 0, 6, 16, 1, 1, 0, 2, 0, 0, lat, lon, 5.0, 0))
    sim.advance(0.2)
    acks = api.messages("MISSION_ACK", since=mark)
    assert [a.type for a in acks] == [M.MAV_MISSION_UNSUPPORTED_FRAME]


def test_set_servo_item_is_refused_at_upload(sim):
    """PX4 1.15 parse_mavlink_mission_item has no MAV_CMD_DO_SET_SERVO (183) in its
    MAV_FRAME_MISSION branch: the upload ends with MAV_MISSION_UNSUPPORTED and the stored
    mission is kept."""
    api = sim.api(0)
    wp = mission_item(MavCmd.NAV_WAYPOINT, *geo(10, 0), 6.0)
    assert api.upload_mission([wp]) == PlanResult.ACCEPTED
    servo = mission_item(183, params=(5.0, 1500.0, 0.0, 0.0), frame=2)
    assert api.upload_mission([wp, servo]) == M.MAV_MISSION_UNSUPPORTED
    assert len(sim.vehicles[0].plan(0)) == 1


def test_takeoff_item_in_the_air_is_flown_as_a_waypoint(sim):
    """Mission::handleTakeoff (multicopter): started in the air below the takeoff item, the
    mission first climbs in place (checkClimbRequired: "Climb to 10.0 meters above home"),
    then the takeoff item is flown as a waypoint to its own position; started above it, no
    climb: straight to the takeoff item's position and altitude, reached only there."""
    api = sim.api(0)
    assert api.arm() == 0 and api.takeoff() == 0  # MIS_TAKEOFF_ALT 2.5 m, then Hold
    assert sim.run_until(lambda: -sim.state(0).position_ned_m[2] > 2.3, timeout_s=20)
    sim.advance(3.0)
    takeoff = mission_item(MavCmd.NAV_TAKEOFF, *geo(15, 0), 10.0)
    items = [takeoff, mission_item(MavCmd.NAV_WAYPOINT, *geo(15, 10), 10.0)]
    assert api.upload_mission(items) == PlanResult.ACCEPTED
    mark = len(api.frames)
    assert api.start_mission() == 0

    def reached(seq, since):
        return seq in [m.seq for m in api.messages("MISSION_ITEM_REACHED", since=since)]

    assert sim.run_until(lambda: reached(0, mark), timeout_s=40)
    n, e, d = sim.state(0).position_ned_m
    assert math.hypot(n - 15, e) < 2.5 and abs(-d - 10) < 1.0
    texts = [m.text for m in api.messages("STATUSTEXT", since=mark)]
    assert "Climb to 10.0 meters above home\t" in texts
    assert sim.run_until(lambda: reached(1, mark), timeout_s=40)
    # above the takeoff item: a new mission starts with it, flown down to it as a waypoint
    low = [mission_item(MavCmd.NAV_TAKEOFF, *geo(0, 10), 5.0),
           mission_item(MavCmd.NAV_WAYPOINT, *geo(0, 0), 5.0)]
    low[0] = dataclasses.replace(low[0], current=1)
    assert api.upload_mission(low) == PlanResult.ACCEPTED
    mark = len(api.frames)
    assert sim.run_until(lambda: reached(0, mark), timeout_s=40)
    n, e, d = sim.state(0).position_ned_m
    assert math.hypot(n, e - 10) < 2.5 and abs(-d - 5) < 1.0
    texts = [m.text for m in api.messages("STATUSTEXT", since=mark)]
    assert not any(t.startswith("Climb to") for t in texts)


def test_rally_points_and_fences_as_px4_takes_them(sim):
    """A MISSION_ITEM_INT client's rally point in frame 6 (mavlink_mission.cpp stores the frame
    as sent) is accepted, and RTL (rtl.cpp setSafepointAsDestination, frames 0 and 3 only)
    answers "RTL: unsupported MAV_FRAME" every 2 s; QGC's frame 3 does not. A fence PX4 takes
    (a NaN inclusion circle) is dropped at load with its text."""
    api = sim.api(0)
    mark = len(api.frames)
    rally6 = [mission_item(MavCmd.NAV_RALLY_POINT, *geo(30, 0), 10.0, params=(0, 0, 0, 0),
                           mission_type=2)]
    assert rally6[0].frame == 6 and api.upload_rally(rally6) == PlanResult.ACCEPTED
    sim.advance(4.5)
    texts = [m.text for m in api.messages("STATUSTEXT", since=mark)]
    assert texts.count("RTL: unsupported MAV_FRAME\t") == 2
    rally3 = [dataclasses.replace(rally6[0], frame=3)]
    assert api.upload_rally(rally3) == PlanResult.ACCEPTED
    mark = len(api.frames)
    circle = [mission_item(MavCmd.NAV_FENCE_CIRCLE_INCLUSION, *geo(0, 0), 0.0,
                           params=(math.nan, 0, 0, 0), frame=0, mission_type=1)]
    assert api.upload_fence(circle) == PlanResult.ACCEPTED
    sim.advance(4.5)
    texts = [m.text for m in api.messages("STATUSTEXT", since=mark)]
    assert texts == ["Geofence invalid, doesn't contain Home position\t"]
