"""A mission item's heading and the wait for it (PX4 v1.15.2 mavlink_mission.cpp
parse_mavlink_mission_item, mission_block.cpp is_mission_item_reached_or_completed: a rotary
wing's position item with a yaw is reached at its position, then within MIS_YAW_ERR of its yaw,
then after its hold time; navigator_main.cpp get_yaw_to_be_accepted)."""

import math

import pytest

from tests.unit.test_vehicles_flight import Sim
from tests.unit.test_vehicles_mission import item
from vehicles.mission_heading import (
    ItemReached,
    forces_heading,
    item_yaw_rad,
    time_inside_s,
    yaw_accepted,
)
from vehicles.params import ParamStore
from vehicles.plan_types import MavCmd, PlanResult, PlanType
from vehicles.types import CommandResult

NAN = math.nan
SOUTH = math.pi
ERR = math.radians(12.0)  # MIS_YAW_ERR's default


def heading(v):
    return v.state.euler_rad()[2]


def off(a, b):
    return abs(math.remainder(a - b, math.tau))


# --- the item's yaw ---------------------------------------------------------------------------
@pytest.mark.parametrize("cmd,p4,expected", [
    (MavCmd.NAV_WAYPOINT, 90.0, math.pi / 2),
    (MavCmd.NAV_WAYPOINT, -90.0, 3 * math.pi / 2),  # wrap_2pi
    (MavCmd.NAV_WAYPOINT, NAN, NAN),  # none: FlightTaskAuto's MPC_YAW_MODE
    (MavCmd.NAV_LOITER_TIME, 45.0, math.pi / 4),
    (MavCmd.NAV_LOITER_UNLIM, 180.0, math.pi),  # parsed from param4 too
    (MavCmd.NAV_LOITER_TO_ALT, NAN, 0.0),  # not parsed: the zeroed mission_item_s
    (MavCmd.NAV_TAKEOFF, 90.0, NAN),  # handleTakeoff: a multicopter's takeoff has none
    (MavCmd.NAV_LAND, 90.0, math.pi / 2),  # its move to the landing point keeps it
])
def test_item_yaw_as_parse_mavlink_mission_item_sets_it(cmd, p4, expected):
    got = item_yaw_rad(item(0, cmd, p4=p4))
    assert got == pytest.approx(expected) if math.isfinite(expected) else math.isnan(got)


def test_force_heading_and_time_inside():
    assert forces_heading(item(0, MavCmd.NAV_LOITER_TIME, p2=1.0))
    assert not forces_heading(item(0, MavCmd.NAV_LOITER_TIME, p2=0.0))
    assert forces_heading(item(0, MavCmd.NAV_LOITER_TO_ALT, p1=1.0))
    assert not forces_heading(item(0, MavCmd.NAV_WAYPOINT, p1=1.0, p2=1.0))
    assert time_inside_s(item(0, MavCmd.NAV_WAYPOINT, p1=3.0)) == 3.0
    assert time_inside_s(item(0, MavCmd.NAV_WAYPOINT, p1=-3.0)) == 0.0  # never negative
    assert time_inside_s(item(0, MavCmd.NAV_LOITER_TIME, p1=2.0)) == 2.0
    assert time_inside_s(item(0, MavCmd.NAV_TAKEOFF, p1=15.0)) == 0.0  # its pitch, not a time


def test_yaw_accepted_within_mis_yaw_err_or_by_the_timeout_if_not_forced():
    p = ParamStore()
    assert yaw_accepted(NAN, 1.0, p, force=True)  # no yaw: no wait
    assert yaw_accepted(SOUTH, SOUTH - ERR + 1e-3, p, force=False)
    assert not yaw_accepted(SOUTH, SOUTH - ERR - 1e-3, p, force=False)
    assert yaw_accepted(math.radians(355.0), math.radians(5.0), p, force=False)  # wrap_pi
    # MIS_YAW_TMT -1 (default): no timeout, the heading must be reached
    p.set("MIS_YAW_TMT", 5.0)
    assert yaw_accepted(SOUTH, 0.0, p, force=False)  # a timeout set: not forced, accepted
    assert not yaw_accepted(SOUTH, 0.0, p, force=True)


def test_item_reached_latches_position_then_yaw_and_counts_the_hold_from_the_position():
    p = ParamStore()
    r = ItemReached()
    assert not r.update(0.0, False, SOUTH, SOUTH, p, hold_s=2.0)
    assert not r.update(1.0, True, SOUTH, 0.0, p, hold_s=2.0)  # position reached at 1 s
    assert not r.update(1.5, False, SOUTH, 0.0, p, hold_s=2.0)  # latched: only the yaw missing
    assert not r.update(2.5, False, SOUTH, SOUTH, p, hold_s=2.0)  # yaw now, hold runs to 3 s
    assert not r.update(2.9, False, SOUTH, 0.0, p, hold_s=2.0)  # the yaw stays accepted
    assert r.update(3.0, False, SOUTH, 0.0, p, hold_s=2.0)
    r.reset()
    assert not r.update(4.0, False, NAN, 0.0, p)
    assert r.update(4.1, True, NAN, 0.0, p)  # no yaw, no hold: reached with the position


# --- flown ------------------------------------------------------------------------------------
@pytest.fixture
def sim():
    # a slow auto yaw rate: the vehicle gets to the waypoint well before it faces the item's yaw
    s = Sim(MPC_YAWRAUTO_MAX=10.0)
    s.run(1.2)
    yield s
    s.close()


def fly(sim, items):
    v = sim.v
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    return v


def test_waypoint_with_a_yaw_is_reached_only_once_the_heading_is(sim):
    o = sim.v.origin
    v = fly(sim, [item(0, MavCmd.NAV_TAKEOFF, alt=5.0, origin=o),
                  item(1, MavCmd.NAV_WAYPOINT, 6.0, 0.0, 5.0, o, p4=180.0),
                  item(2, MavCmd.NAV_WAYPOINT, 6.0, 8.0, 5.0, o)])
    assert sim.run(40.0, until=lambda: v.mission_status.current_seq == 1)
    assert sim.run(30.0, until=lambda: math.hypot(v.state.position_ned_m[0] - 6.0,
                                                  v.state.position_ned_m[1]) < 1.0)
    assert off(heading(v), SOUTH) > math.radians(30.0)  # there, still turning
    assert v.mission_status.current_seq == 1
    assert sim.run(30.0, until=lambda: v.mission_status.current_seq == 2)
    assert off(heading(v), SOUTH) < ERR + math.radians(1.0)


def test_yaw_timeout_accepts_a_heading_that_is_not_forced(sim):
    v = sim.v
    v.params.set("MIS_YAW_TMT", 5.0)
    o = v.origin
    fly(sim, [item(0, MavCmd.NAV_TAKEOFF, alt=5.0, origin=o),
              item(1, MavCmd.NAV_WAYPOINT, 6.0, 0.0, 5.0, o, p4=180.0),
              item(2, MavCmd.NAV_WAYPOINT, 6.0, 8.0, 5.0, o)])
    assert sim.run(60.0, until=lambda: v.mission_status.current_seq == 2)
    assert off(heading(v), SOUTH) > math.radians(30.0)  # moved on without it


def test_hold_time_runs_while_the_heading_turns(sim):
    """get_time_inside counts from the position reached: a hold longer than the turn ends when
    the hold does, not the turn plus the hold."""
    o = sim.v.origin
    v = fly(sim, [item(0, MavCmd.NAV_TAKEOFF, alt=5.0, origin=o),
                  item(1, MavCmd.NAV_WAYPOINT, 6.0, 0.0, 5.0, o, p1=25.0, p4=90.0)])
    assert sim.run(40.0, until=lambda: v.mission_status.current_seq == 1)
    assert sim.run(30.0, until=lambda: math.hypot(v.state.position_ned_m[0] - 6.0,
                                                  v.state.position_ned_m[1]) < 2.0)
    t0 = sim.t
    assert sim.run(40.0, until=lambda: v.mission_status.reached_seq == 1)
    assert 24.0 < sim.t - t0 < 26.0


def test_loiter_to_alt_points_north(sim):
    """LOITER_TO_ALT has yaw 0 (its parser sets none): the vehicle turns north there."""
    o = sim.v.origin
    v = fly(sim, [item(0, MavCmd.NAV_TAKEOFF, alt=5.0, origin=o),
                  item(1, MavCmd.NAV_WAYPOINT, 0.0, 30.0, 5.0, o),
                  item(2, MavCmd.NAV_LOITER_TO_ALT, 0.0, 30.0, 7.0, o),
                  item(3, MavCmd.NAV_WAYPOINT, 0.0, 0.0, 7.0, o)])
    assert sim.run(60.0, until=lambda: v.mission_status.current_seq == 2)
    assert off(heading(v), 0.0) > math.radians(45.0)  # turned east on the first leg
    assert sim.run(60.0, until=lambda: v.mission_status.current_seq == 3)
    assert off(heading(v), 0.0) < ERR + math.radians(1.0)


def test_landing_with_a_yaw_turns_to_it_before_the_descent(sim):
    o = sim.v.origin
    v = fly(sim, [item(0, MavCmd.NAV_TAKEOFF, alt=5.0, origin=o),
                  item(1, MavCmd.NAV_LAND, 8.0, 0.0, 0.0, o, p4=90.0)])
    assert sim.run(40.0, until=lambda: v.mission_status.current_seq == 1)
    assert sim.run(40.0, until=lambda: v.status.landed_state.name == "LANDING")
    assert off(heading(v), math.pi / 2) < ERR + math.radians(1.0)



def test_a_roi_heading_is_waited_for_too(sim):
    """heading_sp_update writes the ROI's bearing into the item's yaw, which the reached check
    then waits for like the item's own."""
    o = sim.v.origin
    roi = (-40.0, 0.0)  # south of the leg
    v = fly(sim, [item(0, MavCmd.NAV_TAKEOFF, alt=5.0, origin=o),
                  item(1, 195, *roi, 5.0, o),  # DO_SET_ROI_LOCATION
                  item(2, MavCmd.NAV_WAYPOINT, 12.0, 0.0, 5.0, o),
                  item(3, MavCmd.NAV_WAYPOINT, 12.0, 12.0, 5.0, o)])
    assert sim.run(40.0, until=lambda: v.mission_status.current_seq == 2)
    assert sim.run(30.0, until=lambda: math.hypot(v.state.position_ned_m[0] - 12.0,
                                                  v.state.position_ned_m[1]) < 1.0)
    assert off(heading(v), SOUTH) > math.radians(30.0)
    assert v.mission_status.current_seq == 2
    assert sim.run(30.0, until=lambda: v.mission_status.current_seq == 3)
    p = v.state.position_ned_m
    assert off(heading(v), math.atan2(roi[1] - p[1], roi[0] - p[0])) < ERR + math.radians(1.0)
