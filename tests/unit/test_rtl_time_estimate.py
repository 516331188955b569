"""RTL's time estimate (vehicles/nav_rtl.py rtl_time_estimate, navigator.py) and the
TIME_ESTIMATE_TO_TARGET stream, against PX4 v1.15 RtlDirect::calc_rtl_time_estimate and
RtlTimeEstimator (PX4 has no unit test for them: the cases are worked by hand from the source,
with the SITL defaults MPC_Z_V_AUTO_UP 3, MPC_Z_V_AUTO_DN 1.5, MPC_XY_CRUISE 5,
MPC_LAND_SPEED 0.7, RTL_DESCEND_ALT 10, RTL_LAND_DELAY 0, RTL_TIME_FACTOR 1.1,
RTL_TIME_MARGIN 100)."""

import math

import pytest

from gateway.ci.lockstep import Sim
from gateway.mavlink.session import LinkKind
from vehicles.nav_rtl import NO_ESTIMATE, RtlPhase, rtl_time_estimate
from vehicles.params import ParamStore
from vehicles.types import NavState

HOME = (0.0, 0.0, 0.0)


def estimate(start, pos, return_z, dest=HOME, **params):
    return rtl_time_estimate(ParamStore(params), start, pos, dest, return_z)


def test_from_below_the_return_altitude_every_leg_counts():
    """100 m out at 10 m, return at 30 m: climb 20 m at 3 m/s, 100 m at 5 m/s, down 20 m to
    the loiter altitude at 1.5 m/s, no delay, land 10 m at 0.7 m/s."""
    got = estimate(RtlPhase.CLIMB, (100.0, 0.0, -10.0), -30.0)
    t = 20 / 3 + 100 / 5 + 20 / 1.5 + 10 / 0.7
    assert got.valid and got.time_estimate_s == pytest.approx(t, rel=1e-6)
    assert got.safe_time_estimate_s == pytest.approx(1.1 * t + 100, rel=1e-6)


def test_above_the_return_altitude_the_climb_is_skipped():
    got = estimate(RtlPhase.RETURN, (30.0, 40.0, -50.0), -50.0)
    assert got.time_estimate_s == pytest.approx(50 / 5 + 40 / 1.5 + 10 / 0.7, rel=1e-6)


def test_while_descending_and_landing_from_the_present_altitude():
    assert estimate(RtlPhase.DESCEND, (0.0, 0.0, -25.0), -30.0).time_estimate_s == \
        pytest.approx(15 / 1.5 + 10 / 0.7, rel=1e-6)
    assert estimate(RtlPhase.LAND, (0.0, 0.0, -4.0), -30.0).time_estimate_s == \
        pytest.approx(4 / 0.7, rel=1e-6)


def test_land_delay_adds_and_a_negative_one_never_lands():
    base = estimate(RtlPhase.RETURN, (50.0, 0.0, -30.0), -30.0).time_estimate_s
    assert estimate(RtlPhase.RETURN, (50.0, 0.0, -30.0), -30.0,
                    RTL_LAND_DELAY=5.0).time_estimate_s == pytest.approx(base + 5, rel=1e-6)
    assert estimate(RtlPhase.RETURN, (50.0, 0.0, -30.0), -30.0,
                    RTL_LAND_DELAY=-1.0).time_estimate_s == pytest.approx(base - 10 / 0.7,
                                                                          rel=1e-6)


def test_landed_or_a_zero_speed_gives_no_estimate():
    assert estimate(RtlPhase.IDLE, (0.0, 0.0, 0.0), 0.0) == NO_ESTIMATE
    # 100 m at MPC_XY_CRUISE 0: infinite in C, so getEstimate says not valid
    assert estimate(RtlPhase.RETURN, (100.0, 0.0, -30.0), -30.0, MPC_XY_CRUISE=0.0) == NO_ESTIMATE
    assert not estimate(RtlPhase.RETURN, (100.0, 0.0, -30.0), -30.0,
                        MPC_LAND_SPEED=math.nan).valid


def test_the_stream_sends_each_publication_once_on_both_links():
    """0 on the ground (Return would stay idle), then RTL_TIME_FACTOR x the time + the margin,
    as int32; land, mission_next_item, mission_end and commanded_action -1. RTL publishes every
    ~2 s, the 1 Hz stream sends each publication once."""
    with Sim(1, links=(LinkKind.API, LinkKind.GCS)) as sim:
        api, gcs = sim.api(0), sim.gcs(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
        sim.advance(5.0)
        ground = api.messages("TIME_ESTIMATE_TO_TARGET")
        assert ground and all(m.safe_return == 0 for m in ground)
        assert api.arm() == 0 and api.takeoff() == 0
        assert sim.run_until(lambda: sim.status(0).nav_state is NavState.AUTO_LOITER
                             and sim.status(0).armed, timeout_s=20)
        sim.advance(6.0)
        for client in (api, gcs):
            timed = client.timed_messages("TIME_ESTIMATE_TO_TARGET")
            gaps = [b[0] - a[0] for a, b in zip(timed, timed[1:])]
            assert all(g == pytest.approx(2.0, abs=1.01) for g in gaps) and min(gaps) >= 1.0
            last = timed[-1][1]
            assert (last.land, last.mission_next_item, last.mission_end,
                    last.commanded_action) == (-1, -1, -1, -1)
        # over home at the takeoff altitude: only the landing, 2.5 m at MPC_LAND_SPEED 0.7 (the
        # estimated height, which the GPS height reference keeps within cm of the true one)
        height = -sim.state(0).position_ned_m[2]
        assert api.last("TIME_ESTIMATE_TO_TARGET").safe_return == pytest.approx(
            int(1.1 * height / 0.7 + 100), abs=1)
