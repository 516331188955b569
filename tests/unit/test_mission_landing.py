"""A mission's landing item as PX4 1.15's MissionBase::handleLanding flies it on a multicopter
(vehicles/mission_landing.py): a move to the landing point first only from farther than
NAV_ACC_RAD, at the current waypoint setpoint's altitude, accepted within NAV_ACC_RAD and
NAV_MC_ALT_RAD; closer, the descent at once."""

import math

import pytest

from tests.unit.test_vehicles_flight import Sim
from tests.unit.test_vehicles_mission import item
from vehicles.plan_types import MavCmd, MissionState, PlanType
from vehicles.types import CommandResult, LandedState


@pytest.fixture
def sim():
    s = Sim()
    s.run(1.2)
    yield s
    s.close()


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
