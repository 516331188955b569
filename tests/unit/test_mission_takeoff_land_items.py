"""A mission's takeoff and landing items as PX4 1.15 flies them on a multicopter.

- Landing (MissionBase::handleLanding, vehicles/mission_landing.py): a move to the landing point
  first only from farther than NAV_ACC_RAD, at the current waypoint setpoint's altitude,
  accepted within NAV_ACC_RAD and NAV_MC_ALT_RAD; closer, the descent at once.
- Takeoff (mission.cpp handleTakeoff): a multicopter's takeoff item, in the air, is a waypoint
  to its own position: a SETPOINT_TYPE_POSITION, not a loiter setpoint.
- A waypoint or landing without autocontinue (MissionBase::on_active) is reported reached, and
  the vehicle stays on it: the mission goes on only from a new current item.
- A forced heading not reached within MIS_YAW_TMT fails the mission
  (Navigator::set_mission_failure_heading_timeout), and the failsafe returns (mission_failure:
  RTL)."""

import dataclasses
import math

import pytest

from tests.unit import test_vehicles_mission
from tests.unit.test_vehicles_failsafe import event_name
from tests.unit.test_vehicles_flight import Sim
from tests.unit.test_vehicles_mission import item
from vehicles.plan_types import MavCmd, MissionState, PlanType
from vehicles.types import CommandResult, LandedState, NavState

sim = test_vehicles_mission.sim  # the fixture: one vehicle, settled 1.2 s


def fly(sim, items):
    v = sim.v
    v.set_plan(sim.t, PlanType.MISSION, items)
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    return v


def horizontal(v, n, e):
    p = v.state.position_ned_m
    return math.hypot(p[0] - n, p[1] - e)


def test_the_move_to_the_landing_point_keeps_the_waypoint_setpoints_altitude(sim):
    """The waypoint before the landing is accepted within NAV_MC_ALT_RAD of its altitude; the
    move to the landing point flies at that waypoint's setpoint altitude, not the vehicle's."""
    o = sim.v.origin
    v = fly(sim, [item(0, MavCmd.NAV_WAYPOINT, 0.0, 0.0, 4.0, o),
                  item(1, MavCmd.NAV_WAYPOINT, 25.0, 0.0, 9.0, o),
                  item(2, MavCmd.NAV_LAND, 25.0, 20.0, 0.0, o)])
    assert sim.run(60.0, until=lambda: v.mission_status.current_seq == 1)
    sim.run(0.1)
    waypoint_z = v.targets.global_target_ned_m[2]
    assert sim.run(60.0, until=lambda: v.mission_status.current_seq == 2)
    sim.run(0.1)
    assert v.status.landed_state is LandedState.IN_AIR
    assert v.targets.global_target_ned_m[:2] == pytest.approx((25.0, 20.0), abs=0.01)
    assert v.targets.global_target_ned_m[2] == waypoint_z
    # setActiveMissionItems: the move's previous setpoint is the waypoint's (the line to follow)
    previous = v._autopilot.tasks.auto.setpoint.previous_ned_m
    assert previous == pytest.approx((25.0, 0.0, waypoint_z), abs=0.01)


def test_the_descent_starts_once_within_nav_acc_rad_of_the_landing_point(sim):
    """The move's acceptance radius is NAV_ACC_RAD (2 m): the vehicle decelerating towards the
    landing point starts the descent as it crosses it."""
    o = sim.v.origin
    v = fly(sim, [item(0, MavCmd.NAV_WAYPOINT, 0.0, 0.0, 5.0, o),
                  item(1, MavCmd.NAV_LAND, 20.0, 0.0, 0.0, o)])
    assert sim.run(60.0, until=lambda: v.mission_status.current_seq == 1)
    assert v.status.landed_state is LandedState.IN_AIR
    assert sim.run(40.0, until=lambda: v.status.landed_state is LandedState.LANDING)
    assert 1.5 < horizontal(v, 20.0, 0.0) < 2.0
    assert sim.run(60.0, until=lambda: v.mission_status.state is MissionState.COMPLETE)
    assert horizontal(v, 20.0, 0.0) < 1.0


def test_a_landing_point_within_nav_acc_rad_descends_at_once(sim):
    """do_need_move_to_item: no move to a landing point closer than NAV_ACC_RAD (the waypoint
    before it holds 2 s, so the vehicle stops there)."""
    o = sim.v.origin
    v = fly(sim, [item(0, MavCmd.NAV_WAYPOINT, 10.0, 0.0, 5.0, o, p1=2.0),
                  item(1, MavCmd.NAV_LAND, 11.2, 0.0, 0.0, o)])
    assert sim.run(60.0, until=lambda: v.mission_status.current_seq == 1)
    dist = horizontal(v, 11.2, 0.0)
    assert dist < 2.0
    sim.run(0.1)
    assert v.status.landed_state is LandedState.LANDING
    assert v.targets.global_target_ned_m[:2] == pytest.approx((11.2, 0.0), abs=0.01)
    assert sim.run(60.0, until=lambda: v.mission_status.state is MissionState.COMPLETE)
    assert horizontal(v, 11.2, 0.0) < 0.5



def test_hold_on_the_way_to_a_takeoff_item_brakes_where_the_vehicle_is(sim):
    """In the air a takeoff item is a waypoint (Mission::handleTakeoff), a SETPOINT_TYPE_POSITION,
    not a loiter setpoint: Hold on the way to it (a paused mission) brakes and holds where the
    vehicle is (Loiter::set_loiter_position) instead of flying on to the item's position."""
    o = sim.v.origin
    v = fly(sim, [item(0, MavCmd.NAV_WAYPOINT, 0.0, 0.0, 5.0, o)])
    assert sim.run(60.0, until=lambda: v.mission_status.state is MissionState.COMPLETE)
    v.set_plan(sim.t, PlanType.MISSION, [item(0, MavCmd.NAV_TAKEOFF, 30.0, 0.0, 5.0, o),
                                         item(1, MavCmd.NAV_WAYPOINT, 30.0, 30.0, 5.0, o)])
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(30.0, until=lambda: v.state.position_ned_m[0] > 8.0)
    assert v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    sim.run(10.0)
    assert v.state.position_ned_m[0] < 16.0
    assert horizontal(v, 30.0, 0.0) > 14.0


def test_a_waypoint_without_autocontinue_is_reached_and_held(sim):
    o = sim.v.origin
    v = fly(sim, [item(0, MavCmd.NAV_WAYPOINT, 0.0, 0.0, 5.0, o),
                  dataclasses.replace(item(1, MavCmd.NAV_WAYPOINT, 15.0, 0.0, 5.0, o),
                                      autocontinue=0),
                  item(2, MavCmd.NAV_WAYPOINT, 15.0, 15.0, 5.0, o)])
    assert sim.run(60.0, until=lambda: v.mission_status.reached_seq == 1)
    count = v.mission_progress[2]
    sim.run(10.0)
    assert v.mission_status.current_seq == 1 and v.mission_status.reached_seq == 1
    assert v.mission_status.state is MissionState.ACTIVE
    assert horizontal(v, 15.0, 0.0) < 1.0
    assert v.mission_progress[2] == count  # reported once
    assert v.set_current_mission_item(sim.t, 2) is True
    assert sim.run(60.0, until=lambda: v.mission_status.state is MissionState.COMPLETE)
    assert horizontal(v, 15.0, 15.0) < 2.0


def test_a_landing_without_autocontinue_is_reached_but_does_not_finish_the_mission(sim):
    o = sim.v.origin
    v = fly(sim, [item(0, MavCmd.NAV_WAYPOINT, 0.0, 0.0, 5.0, o),
                  dataclasses.replace(item(1, MavCmd.NAV_LAND, 10.0, 0.0, 0.0, o),
                                      autocontinue=0)])
    assert sim.run(90.0, until=lambda: v.mission_status.reached_seq == 1)
    count = v.mission_progress[2]
    sim.run(5.0)
    assert v.mission_status.state is MissionState.ACTIVE and v.mission_status.current_seq == 1
    assert v.mission_progress[2] == count
    assert not any(t.startswith("Mission finished") for t in sim.texts())
    assert horizontal(v, 10.0, 0.0) < 1.0


def test_a_forced_heading_not_reached_within_mis_yaw_tmt_fails_the_mission_and_returns():
    """LOITER_TIME with param2 (heading required) and its yaw (param4) south, 5 m from a
    vehicle facing north that turns at MPC_YAWRAUTO_MAX = 10 deg/s: it arrives long before its
    heading, and MIS_YAW_TMT (1 s) runs out."""
    sim = Sim(MIS_YAW_TMT=1.0, MPC_YAWRAUTO_MAX=10.0)
    try:
        sim.run(1.2)
        o = sim.v.origin
        v = fly(sim, [item(0, MavCmd.NAV_WAYPOINT, 0.0, 0.0, 5.0, o, p4=0.0),
                      item(1, MavCmd.NAV_LOITER_TIME, 5.0, 0.0, 5.0, o, p1=5.0, p2=1.0,
                           p4=180.0)])
        assert sim.run(90.0, until=lambda: "unable to reach heading within timeout\t" in sim.texts())
        assert v.mission_status.reached_seq == 0  # item 1 never reached
        # the failsafe framework holds COM_FAIL_ACT_T (5 s) before its action
        assert sim.run(7.0, until=lambda: v.status.nav_state is NavState.AUTO_RTL)
        assert "Failsafe activated: entering Hold for 5 seconds\t" in sim.texts()
        # missionCheck.cpp: an arming check of every mode, with its event and text
        assert "Mission cannot be completed\t" in sim.texts()
        told = [event_name(e.id) for e in v.events.after(v.events.latest - len(v.events))]
        assert "check_mission_failure" in told
        assert not v.status.prearm_ok  # no mode could arm
        assert sim.run(120.0, until=lambda: not v.status.armed)
        assert v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED
        # a mission upload runs the feasibility check again, which clears the failure
        v.set_plan(sim.t, PlanType.MISSION, [item(0, MavCmd.NAV_WAYPOINT, 0.0, 0.0, 5.0, o)])
        sim.run(1.0)
        assert v.status.prearm_ok and v.arm(sim.t) is CommandResult.ACCEPTED
    finally:
        sim.close()
