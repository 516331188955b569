"""Precision Land, after PX4 v1.15.2 navigator/precland.cpp (Required mode, as
NAVIGATION_STATE_AUTO_PRECLAND runs it) and mavlink_receiver's LANDING_TARGET."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as M

from gateway.ci.lockstep import Sim as LockstepSim
from tests.unit.test_vehicles_flight import Sim, take_off
from vehicles.nav_precland import PrecLandState
from vehicles.types import CommandResult, NavState


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def _precland(sim):
    return sim.v._autopilot.navigator.precland


def _run(sim, seconds, target=None, until=None):
    """Run, a companion computer reporting ``target`` (local NED) at 10 Hz."""
    end = sim.t + seconds
    while sim.t < end - 1e-9:
        if target is not None:
            sim.v.landing_target(sim.t, True, M.MAV_FRAME_LOCAL_NED, target)
        if sim.run(0.1, until=until):
            return True
    return False


def test_without_a_target_it_searches_then_lands_where_it_is(sim):
    take_off(sim)
    start = sim.v.state.position_ned_m.copy()
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_PRECLAND) is CommandResult.ACCEPTED
    pl = _precland(sim)
    _run(sim, 1.0)
    assert pl.state is PrecLandState.START
    # 2 s at the start point, then the climb to PLD_SRCH_ALT (10 m) above the origin
    assert _run(sim, 3.0, until=lambda: pl.state is PrecLandState.SEARCH)
    top = []
    _run(sim, 9.0, until=lambda: top.append(-sim.v.state.position_ned_m[2]) and False)
    assert max(top) == pytest.approx(10.0, abs=0.3)
    # PLD_SRCH_TOUT (10 s) without a target: the fallback lands where the vehicle is
    assert _run(sim, 2.0, until=lambda: pl.state is PrecLandState.FALLBACK)
    assert sim.v.status.nav_state is NavState.AUTO_PRECLAND
    assert _run(sim, 40.0, until=lambda: not sim.v.status.armed)
    end = sim.v.state.position_ned_m
    assert np.hypot(*(end[:2] - start[:2])) < 0.5
    assert abs(end[2]) < 0.1
    assert "Disarmed by landing\t" in sim.texts()


def test_a_reported_target_is_approached_and_landed_on(sim):
    take_off(sim)
    target = (6.0, -4.0, 0.0)
    _run(sim, 0.5, target)  # reported before the mode: a new subscriber reads the last one
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_PRECLAND) is CommandResult.ACCEPTED
    pl = _precland(sim)
    _run(sim, 0.2, target)
    assert pl.state is PrecLandState.HORIZONTAL_APPROACH
    z0 = sim.v.state.position_ned_m[2]
    assert _run(sim, 20.0, target, until=lambda: pl.state is PrecLandState.DESCEND_ABOVE_TARGET)
    # the approach keeps the altitude it began at, and ends within PLD_HACC_RAD (0.2 m)
    assert sim.v.state.position_ned_m[2] == pytest.approx(z0, abs=0.3)
    assert _run(sim, 40.0, target, until=lambda: not sim.v.status.armed)
    end = sim.v.state.position_ned_m
    assert math.hypot(end[0] - target[0], end[1] - target[1]) < 0.3
    assert pl.state is PrecLandState.DONE


def test_a_target_lost_after_the_last_search_falls_back(sim):
    sim.v.params.set("PLD_MAX_SRCH", 0)
    take_off(sim)
    target = (8.0, 0.0, 0.0)
    _run(sim, 0.2, target)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_PRECLAND) is CommandResult.ACCEPTED
    pl = _precland(sim)
    _run(sim, 0.2, target)
    assert pl.state is PrecLandState.HORIZONTAL_APPROACH
    # no more reports: it flies on to where it last saw the target, then (PLD_BTOUT 5 s
    # later the target is invalid) it cannot start again (one search allowed, one used)
    assert _run(sim, 20.0, until=lambda: pl.state is PrecLandState.FALLBACK)
    assert math.hypot(*(np.array(sim.v.state.position_ned_m[:2]) - target[:2])) < 1.0


def test_landing_target_on_the_wire():
    with LockstepSim(1) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
        lt = sim.vehicles[0]._autopilot.navigator.landing_target
        api.send(api.mav.landing_target_encode(0, 0, M.MAV_FRAME_LOCAL_NED, 0, 0, 0, 0, 0,
                                               3.0, -2.0, 0.5, (1, 0, 0, 0), 0, 1))
        sim.run_until(lambda: False, timeout_s=0.1)
        assert lt.seq == 1 and lt.position_ned_m == (3.0, -2.0, 0.5)
        # another frame: PX4's critical message, nothing published
        api.send(api.mav.landing_target_encode(0, 0, M.MAV_FRAME_GLOBAL, 0, 0, 0, 0, 0,
                                               3.0, -2.0, 0.5, (1, 0, 0, 0), 0, 1))
        # no position (IR-LOCK angles): for the landing target estimator, not started
        api.send(api.mav.landing_target_encode(0, 0, M.MAV_FRAME_LOCAL_NED, 0.1, 0.1, 0, 0, 0,
                                               0, 0, 0, (1, 0, 0, 0), 0, 0))
        assert sim.run_until(lambda: any(
            m.text == "Landing target: coordinate frame 0 unsupported\t"
            for m in api.messages("STATUSTEXT")), timeout_s=1)
        assert lt.seq == 1
        # hostile values: NaN and huge positions are published; Precision Land holds its
        # setpoint where a coordinate is not finite
        api.send(api.mav.landing_target_encode(0, 0, M.MAV_FRAME_LOCAL_NED, 0, 0, 0, 0, 0,
                                               math.nan, 3e38, math.inf, (1, 0, 0, 0), 0, 1))
        sim.run_until(lambda: False, timeout_s=0.1)
        assert lt.seq == 2
        assert sim.simulation.internal_errors == 0


def _mission_landing(sim, precision, target=None):
    from tests.unit.test_vehicles_mission import item
    from vehicles.plan_types import MavCmd, MissionState, PlanType

    v = sim.v
    o = v.origin
    items = [item(0, MavCmd.NAV_WAYPOINT, 10.0, 5.0, 6.0, o),
             item(1, MavCmd.NAV_LAND, 15.0, 10.0, 0.0, o, p2=precision)]
    sim.run(1.2)  # a position estimate
    v.set_plan(sim.t, PlanType.MISSION, items)
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert _run(sim, 90.0, target, until=lambda: not v.status.armed)
    assert v.mission_status.state is MissionState.COMPLETE
    return v.state.position_ned_m


def test_a_mission_land_item_asking_for_precision_lands_on_the_target(sim):
    # param2 2 (required): the pad 3 m from the item's position is where it lands
    end = _mission_landing(sim, 2.0, (18.0, 10.0, 0.0))
    assert math.hypot(end[0] - 18.0, end[1] - 10.0) < 0.3


def test_an_opportunistic_mission_landing_without_a_target_lands_at_the_item(sim):
    # param2 1 (opportunistic), nothing seen when the landing starts (the move to the landing
    # point ended within NAV_ACC_RAD, 2 m): the fallback lands where the vehicle is, as PX4's
    end = _mission_landing(sim, 1.0)
    assert math.hypot(end[0] - 15.0, end[1] - 10.0) < 2.2
    assert _precland(sim).state is PrecLandState.FALLBACK


def test_return_with_rtl_pld_md_lands_on_the_target(sim):
    sim.v.params.set("RTL_PLD_MD", 2)
    take_off(sim)
    v = sim.v
    g = v.origin.offset_ned(30.0, 0.0, -10.0)
    assert v.goto(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m) is CommandResult.ACCEPTED
    sim.run(12.0)
    assert v.return_to_launch(sim.t) is CommandResult.ACCEPTED
    pad = (2.0, 1.5, 0.0)  # next to home
    assert _run(sim, 120.0, pad, until=lambda: not v.status.armed)
    end = v.state.position_ned_m
    assert math.hypot(end[0] - pad[0], end[1] - pad[1]) < 0.3
