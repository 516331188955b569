"""What the mission flies while an item waits: a NAV_DELAY or a DO_JUMP loaded as it is has no
setpoint of its own (PX4 v1.15.2 mission.cpp setActiveMissionItems sets none for an item without a
position), a waypoint's hold time keeps the waypoint's own triplet, and a reset triplet
(navigator_main.cpp on a mode change, Mission::set_current_mission_index) leaves FlightTaskAuto
holding at the vehicle's position (_evaluateTriplets without a valid current setpoint)."""

import math

import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from tests.unit.test_vehicles_mission import item
from vehicles.plan_types import MavCmd, MavFrame, PlanResult, PlanType
from vehicles.types import CommandResult, NavState


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def setpoint(v):
    """The navigator's setpoint of the last tick (PX4's position setpoint triplet)."""
    return v.autopilot.navigator._last


def test_delay_after_a_waypoint_keeps_the_waypoints_triplet(sim):
    """A NAV_DELAY after a waypoint: the waypoint's setpoint stays (target, previous, acceptance
    radius), not a stopping point of the trajectory; the next waypoint has the first one as its
    previous (setActiveMissionItems: the triplet's current before it changed)."""
    v = sim.v
    sim.run(1.2)
    o = v.origin
    items = [item(0, MavCmd.NAV_WAYPOINT, 20.0, 0.0, 6.0, o),
             item(1, MavCmd.NAV_DELAY, frame=MavFrame.MISSION, p1=4.0),
             item(2, MavCmd.NAV_WAYPOINT, 20.0, 20.0, 6.0, o)]
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: v.mission_status.current_seq == 1)
    wp0 = setpoint(v)
    assert wp0.target_ned_m[:2] == pytest.approx((20.0, 0.0), abs=0.05)
    for _ in range(3):
        sim.run(1.0)
        assert setpoint(v) is wp0  # unchanged through the delay
    assert sim.run(2.0, until=lambda: v.mission_status.current_seq == 2)
    sim.run(0.1)
    assert setpoint(v).previous_ned_m == wp0.target_ned_m


def test_hold_time_keeps_the_waypoints_own_triplet(sim):
    """A waypoint's hold time (param1): its triplet, previous and acceptance radius included,
    stays while the time runs."""
    v = sim.v
    sim.run(1.2)
    o = v.origin
    items = [item(0, MavCmd.NAV_WAYPOINT, 10.0, 0.0, 6.0, o),
             item(1, MavCmd.NAV_WAYPOINT, 10.0, 10.0, 6.0, o, p1=3.0, p2=1.5),
             item(2, MavCmd.NAV_WAYPOINT, 0.0, 10.0, 6.0, o)]
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: v.mission_status.current_seq == 1)
    flying = setpoint(v)
    assert sim.run(20.0, until=lambda: v.mission_status.reached_seq == 1
                   or math.hypot(v.state.position_ned_m[0] - 10.0,
                                 v.state.position_ned_m[1] - 10.0) < 1.0)
    sim.run(1.0)
    assert v.mission_status.current_seq == 1  # holding
    held = setpoint(v)
    assert held.target_ned_m == flying.target_ned_m
    assert held.previous_ned_m == flying.previous_ned_m is not None
    assert held.acceptance_radius_m == 1.5 and held.next_ned_m is None


def test_delay_first_after_activation_holds_at_the_vehicles_position(sim):
    """Mission entered in the air on a NAV_DELAY: the triplet was reset, so FlightTaskAuto's
    waypoints are the vehicle's position (and its heading the vehicle's) at every update."""
    v = sim.v
    take_off(sim)
    o = v.origin
    items = [item(0, MavCmd.NAV_DELAY, frame=MavFrame.MISSION, p1=5.0),
             item(1, MavCmd.NAV_WAYPOINT, 10.0, 0.0, 6.0, o)]
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.set_nav_state(sim.t, NavState.AUTO_MISSION) is CommandResult.ACCEPTED
    targets = []
    for _ in range(3):
        sim.run(1.0)
        sp = setpoint(v)
        assert v.mission_status.current_seq == 0 and sp.previous_ned_m is None
        assert not sp.loiter  # not a valid loiter setpoint Hold would keep
        targets.append(sp.target_ned_m)
        # the vehicle's estimate at that tick: within what the vehicle drifts in one tick
        assert math.dist(sp.target_ned_m, v.state.position_ned_m) < 0.05
    assert len(set(targets)) == 3  # follows the vehicle, not a point fixed at the start


def test_condition_delay_is_never_reached_and_keeps_the_triplet(sim, monkeypatch):
    """CONDITION_DELAY (112): the feasibility check rejects it; flown anyway (the check made to
    pass here), it is no delay: get_time_inside counts only NAV_DELAY, and
    is_mission_item_reached_or_completed measures it as a waypoint at its unset position, so it
    is never reached. Without a position it keeps the triplet set last."""
    from vehicles import mission_feasibility

    monkeypatch.setattr(mission_feasibility, "SUPPORTED", mission_feasibility.SUPPORTED | {112})
    v = sim.v
    sim.run(1.2)
    o = v.origin
    items = [item(0, MavCmd.NAV_WAYPOINT, 20.0, 0.0, 6.0, o),
             item(1, MavCmd.CONDITION_DELAY, frame=MavFrame.MISSION, p1=2.0),
             item(2, MavCmd.NAV_WAYPOINT, 20.0, 20.0, 6.0, o)]
    assert v.set_plan(sim.t, PlanType.MISSION, items) is PlanResult.ACCEPTED
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: v.mission_status.current_seq == 1)
    wp0 = setpoint(v)
    assert not sim.run(8.0, until=lambda: v.mission_status.current_seq != 1)
    assert setpoint(v) is wp0 and v.mission_status.reached_seq == 0
