"""ESTIMATOR_STATUS's solution status flags as Ekf::get_ekf_soln_status sets them (PX4 v1.15
ekf_helper.cpp; gps_control.cpp for when GNSS fusion runs), from CORNET's estimator state."""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.telemetry_estimator import ESTIMATOR_FLAGS_OK, solution_status
from gateway.testing import Sim
from tests.unit.test_failure_injection import GPS, OFF, OK, hover
from vehicles.estimation import E_BARO_AGE, E_GPS_AGE, E_RATIOS, E_SIZE


def state(gps_age_s: float = 0.0, baro_age_s: float = 0.0, ratios=(0.1, 0.1, 0.1, 0.1)):
    e = [0.0] * E_SIZE
    e[E_GPS_AGE], e[E_BARO_AGE] = gps_age_s, baro_age_s
    e[E_RATIOS:E_RATIOS + 4] = ratios
    return e


def test_a_gps_aided_solution_is_px4_sitl_s_831():
    assert solution_status(state(), 7) == ESTIMATOR_FLAGS_OK == 831


def test_without_gnss_fusion_the_horizontal_flags_give_way_to_const_pos_mode():
    unaided = M.ESTIMATOR_ATTITUDE | M.ESTIMATOR_VELOCITY_VERT | M.ESTIMATOR_POS_VERT_ABS | \
        M.ESTIMATOR_CONST_POS_MODE
    assert solution_status(state(), 0) == unaided  # EKF2_GPS_CTRL 0: stopped at once
    assert solution_status(state(), 2) == unaided  # the altitude alone starts nothing
    assert solution_status(state(), 4) == 831  # velocity alone: GNSS fusion runs
    assert solution_status(state(), 1) == 831
    # fixes missing: fusion stops after reset_timeout_max (7 s), not before
    assert solution_status(state(gps_age_s=6.9), 7) == 831
    assert solution_status(state(gps_age_s=7.0), 7) == unaided


def test_vertical_flags_follow_the_barometer_or_the_gnss_height():
    no_vertical = 831 & ~(M.ESTIMATOR_VELOCITY_VERT | M.ESTIMATOR_POS_VERT_ABS)
    assert solution_status(state(baro_age_s=1.0), 7) == 831  # the GNSS height instead
    assert solution_status(state(baro_age_s=1.0), 5) == no_vertical


def test_gps_glitch_only_with_the_magnetometer_s_test_ratio_not_under_1():
    """PX4's mag_innov_good is cleared when the magnetometer's ratios are good: a GNSS
    innovation over its gate flags a glitch only while the magnetometer's is at 1 or more."""
    assert solution_status(state(ratios=(1.5, 0.1, 0.1, 0.2)), 7) == 831
    assert solution_status(state(ratios=(1.5, 0.1, 0.1, 1.0)), 7) == 831 | M.ESTIMATOR_GPS_GLITCH
    assert solution_status(state(ratios=(0.5, 2.0, 0.1, 3.0)), 7) == 831 | M.ESTIMATOR_GPS_GLITCH


def test_the_flags_on_the_wire_when_the_gps_fails_and_when_its_fusion_is_turned_off():
    with Sim() as sim:
        hover(sim)
        api = sim.api(0)
        assert api.last("ESTIMATOR_STATUS").flags == 831
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OFF, 0) == 0
        sim.advance(6.0)
        assert api.last("ESTIMATOR_STATUS").flags == 831
        sim.advance(2.0)
        assert api.last("ESTIMATOR_STATUS").flags & M.ESTIMATOR_CONST_POS_MODE
        assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OK, 0) == 0
        sim.advance(1.5)
        assert api.last("ESTIMATOR_STATUS").flags == 831
        assert sim.vehicles[0].params.set("EKF2_GPS_CTRL", 0)
        sim.advance(1.5)
        assert not api.last("ESTIMATOR_STATUS").flags & M.ESTIMATOR_POS_HORIZ_ABS


def test_the_test_ratios_are_ekf2s_published_ones():
    """Ekf::get_innovation_test_status: velocity and position NaN without GNSS fusion (EKF2_GPS_CTRL
    without its position and velocity bits, or no fix for 7 s), the height NaN with no height
    source running; what is published is never under FLT_MIN."""
    from gateway.mavlink.telemetry_estimator import innovation_test_ratios
    from vehicles.aiding import FLT_MIN

    e = state(ratios=(0.25, 0.0, 0.5, 0.75))
    assert innovation_test_ratios(e, 7) == (0.25, FLT_MIN, 0.5, 0.75)
    vel, pos, hgt, mag = innovation_test_ratios(e, 2)  # the GPS's height only
    assert math.isnan(vel) and math.isnan(pos) and (hgt, mag) == (0.5, 0.75)
    vel, pos, _, _ = innovation_test_ratios(state(gps_age_s=7.5), 7)
    assert math.isnan(vel) and math.isnan(pos)
    assert math.isnan(innovation_test_ratios(state(ratios=(0.1, 0.1, math.nan, 0.1)), 7)[2])
