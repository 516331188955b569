"""The position setpoint triplet's next item in a mission (PX4 v1.15.2 mission.cpp
setActiveMissionItems with mission_base.cpp getNextPositionItems: the first position item after
the current one, items without a position skipped, DO_JUMPs followed without counting, a takeoff
or landing counted; none without autocontinue or when a multicopter brakes for a hold time)."""

import math
from dataclasses import replace

import pytest

from tests.unit.test_mission_kept_setpoint import setpoint
from tests.unit.test_vehicles_flight import Sim
from tests.unit.test_vehicles_mission import item
from vehicles.mission_jumps import JumpCounts, look_ahead, triplet_next
from vehicles.plan_types import MavCmd, MavFrame, PlanResult, PlanType
from vehicles.status_log import StatusLog
from vehicles.types import CommandResult

WP, DELAY, LAND = MavCmd.NAV_WAYPOINT, MavCmd.NAV_DELAY, MavCmd.NAV_LAND
MISSION = MavFrame.MISSION


def next_of(items, current, jumps=None):
    ahead = look_ahead(StatusLog(), 0.0, items, current + 1, jumps or JumpCounts())
    return triplet_next(items, current, ahead)


def test_items_without_a_position_are_skipped():
    items = [item(0, WP), item(1, DELAY, frame=MISSION, p1=3.0),
             item(2, MavCmd.DO_CHANGE_SPEED, frame=MISSION, p2=3.0),
             item(3, 201, frame=MISSION),  # DO_SET_ROI (MAV_ROI_NONE)
             item(4, WP)]
    assert next_of(items, 0) == 4


@pytest.mark.parametrize("cmd", [LAND, MavCmd.NAV_TAKEOFF, MavCmd.NAV_LOITER_TO_ALT,
                                 MavCmd.NAV_LOITER_TIME])
def test_takeoff_landing_and_loiters_are_position_items(cmd):
    assert next_of([item(0, WP), item(1, cmd), item(2, WP)], 0) == 1


def test_rtl_and_the_end_have_no_next():
    assert next_of([item(0, WP), item(1, MavCmd.NAV_RETURN_TO_LAUNCH, frame=MISSION)], 0) is None
    assert next_of([item(0, WP)], 0) is None


def test_jumps_are_followed_without_counting():
    items = [item(0, WP), item(1, WP),
             item(2, MavCmd.DO_JUMP, frame=MISSION, p1=0.0, p2=1.0), item(3, WP)]
    jumps = JumpCounts()
    assert next_of(items, 1, jumps) == 0
    assert jumps == {} and jumps.reports == 0
    jumps.take(2)  # exhausted: past it
    assert next_of(items, 1, jumps) == 3


def test_no_next_without_autocontinue_or_with_a_hold_time():
    assert next_of([item(0, WP, p1=2.0), item(1, WP)], 0) is None  # brake_for_hold
    assert next_of([item(0, WP, p1=-2.0), item(1, WP)], 0) == 1  # get_time_inside: max(0)
    assert next_of([item(0, MavCmd.NAV_LOITER_TIME, p1=2.0), item(1, WP)], 0) is None
    assert next_of([replace(item(0, WP), autocontinue=0), item(1, WP)], 0) is None


# --- flown ------------------------------------------------------------------------------------
@pytest.fixture
def sim():
    s = Sim()
    s.run(1.2)
    yield s
    s.close()


def test_a_delay_between_two_waypoints_keeps_the_second_as_next(sim):
    """Waypoint A, NAV_DELAY, waypoint B: B is A's next, so the corner at A is planned towards
    it (the vehicle does not stop dead at A); the delay then keeps A's triplet, next included."""
    v = sim.v
    o = v.origin
    items = [item(0, MavCmd.NAV_TAKEOFF, alt=6.0, origin=o),
             item(1, WP, 20.0, 0.0, 6.0, o),
             item(2, DELAY, frame=MISSION, p1=3.0),
             item(3, WP, 20.0, 20.0, 6.0, o)]
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: v.mission_status.current_seq == 1)
    sim.run(0.5)
    b = o.ned_of(o.offset_ned(20.0, 20.0, 0.0))
    sp = setpoint(v)
    assert sp.next_ned_m is not None
    assert sp.next_ned_m[:2] == pytest.approx((b[0], b[1]), abs=0.05)
    assert sim.run(20.0, until=lambda: v.mission_status.current_seq == 2)
    assert setpoint(v).next_ned_m == sp.next_ned_m  # kept through the delay


def test_next_loiter_to_alt_is_at_the_vehicles_altitude(sim):
    """mission_item_to_position_setpoint: a LOITER_TO_ALT setpoint's altitude is the vehicle's."""
    v = sim.v
    o = v.origin
    items = [item(0, MavCmd.NAV_TAKEOFF, alt=6.0, origin=o),
             item(1, WP, 20.0, 0.0, 6.0, o),
             item(2, MavCmd.NAV_LOITER_TO_ALT, 20.0, 20.0, 15.0, o)]
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: v.mission_status.current_seq == 1)
    nxt = setpoint(v).next_ned_m
    assert nxt is not None and math.isclose(nxt[2], v.state.position_ned_m[2], abs_tol=0.5)
