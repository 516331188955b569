"""Follow Me (FOLLOW_TARGET → vehicles/follow_target.py): physics + autopilot on simulated time."""

import math

import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from vehicles.types import CommandResult, NavState


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def report(sim, n, e, vn=0.0, ve=0.0):
    g = sim.v.origin.offset_ned(n, e, 0.0)
    sim.v.set_follow_target(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m, (vn, ve, 0.0))


def test_follow_me_follows_a_walking_target_from_behind(sim):
    take_off(sim)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_FOLLOW_TARGET) is CommandResult.ACCEPTED
    # A target walking east at 2 m/s, reported once a second (as MAVSDK's follow_me sends).
    n0, e0 = 10.0, 0.0
    for k in range(40):
        report(sim, n0, e0 + 2.0 * k, 0.0, 2.0)
        sim.run(1.0)
    tn, te = n0, e0 + 2.0 * 40
    pn, pe, pd = sim.v.state.position_ned_m
    assert -pd == pytest.approx(8.0, abs=0.5)  # FLW_TGT_HT above home
    assert math.hypot(pn - tn, pe - te) == pytest.approx(8.0, abs=1.5)  # FLW_TGT_DST
    assert pe < te - 6.0 and abs(pn - tn) < 2.0  # behind (FLW_TGT_FA 180): west of it
    assert sim.v.state.velocity_ned_mps[1] == pytest.approx(2.0, abs=0.4)
    heading = sim.v.state.euler_rad()[2]
    assert abs(math.remainder(heading - math.pi / 2, math.tau)) < math.radians(15)  # at the target


def test_follow_me_without_target_holds_and_cannot_arm(sim):
    take_off(sim)
    start = sim.v.state.position_ned_m.copy()
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_FOLLOW_TARGET) is CommandResult.ACCEPTED
    sim.run(5.0)  # no target yet: holds where it is
    assert math.dist(start, sim.v.state.position_ned_m) < 0.5
    report(sim, 20.0, 0.0)
    sim.run(1.0)
    sim.run(3.5)  # the report is 3.5 s old: lost, the vehicle brakes and holds
    held = sim.v.state.position_ned_m.copy()
    v0 = math.hypot(*sim.v.state.velocity_ned_mps[:2])
    assert sim.run(10.0, until=lambda: math.hypot(*sim.v.state.velocity_ned_mps[:2]) < 0.05)
    # Within PX4's braking distance (navigator: MPC_ACC_HOR 3, delay 0.6 s), plus the settling.
    assert math.dist(held[:2], sim.v.state.position_ned_m[:2]) < v0 * (v0 / 6.0 + 0.6) + 0.5
    sim.v.land(sim.t)
    assert sim.run(40.0, until=lambda: not sim.v.status.armed)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_FOLLOW_TARGET) is CommandResult.ACCEPTED
    assert sim.v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED
