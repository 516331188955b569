"""Takeoff mode's end against PX4 v1.15 navigator takeoff.cpp / mission_block.cpp, flown on the
physics World."""

import pytest

from tests.unit.test_vehicles_flight import Sim
from vehicles.types import CommandResult, NavState


@pytest.mark.parametrize("takeoff_alt, reached_above", [
    (2.5, 2.5 - 0.8),  # the takeoff altitude less NAV_MC_ALT_RAD
    (0.5, 0.25),  # below NAV_MC_ALT_RAD above home: less half the takeoff altitude
])
def test_takeoff_is_reached_above_the_altitude_less_the_acceptance(takeoff_alt, reached_above):
    """is_mission_item_reached_or_completed, multicopter NAV_CMD_TAKEOFF: reached (and the
    switch to Hold, COM_TAKEOFF_ACT 0) once in the air above the takeoff altitude less
    NAV_MC_ALT_RAD, or less half the takeoff altitude when that is below NAV_MC_ALT_RAD."""
    sim = Sim(MIS_TAKEOFF_ALT=takeoff_alt)
    try:
        v = sim.v
        sim.run(1.2)
        assert v.arm(sim.t) is CommandResult.ACCEPTED
        assert v.takeoff(sim.t) is CommandResult.ACCEPTED
        assert sim.run(15.0, until=lambda: v.status.nav_state is NavState.AUTO_LOITER)
        height = -v.state.position_ned_m[2]
        assert reached_above - 0.05 < height < reached_above + 0.1
    finally:
        sim.close()


def test_takeoff_climbs_at_mpc_tko_speed_near_the_ground_and_as_any_climb_above():
    """FlightTaskAuto::_updateTrajConstraints for a takeoff setpoint: closer to the ground than
    MPC_LAND_ALT1 (10 m) the trajectory climbs at most at MPC_TKO_SPEED (1.5 m/s), accelerating
    at most at MPC_TKO_SPEED / MPC_TKO_RAMP_T (0.5 m/s²), its altitude held at the vehicle's;
    above, at MPC_Z_V_AUTO_UP (3 m/s) with MPC_ACC_UP_MAX."""
    sim = Sim(MIS_TAKEOFF_ALT=15.0)
    try:
        v = sim.v
        sim.run(1.2)
        assert v.arm(sim.t) is CommandResult.ACCEPTED
        assert v.takeoff(sim.t) is CommandResult.ACCEPTED
        samples = []  # (t, height, climb rate)

        def record():
            samples.append((sim.t, -v.state.position_ned_m[2], -v.state.velocity_ned_mps[2]))
            return v.status.nav_state is NavState.AUTO_LOITER

        assert sim.run(30.0, until=record)
        low = [(t, vz) for t, h, vz in samples if h < 9.0]
        assert max(vz for _, vz in low) < 1.5 + 0.1
        t_slow = next(t for t, vz in low if vz >= 0.3)
        t_fast = next(t for t, vz in low if vz >= 1.3)
        assert t_fast - t_slow > 1.0 / 0.6  # about MPC_TKO_SPEED / MPC_TKO_RAMP_T
        assert max(vz for t, h, vz in samples if h > 10.0) > 1.8
    finally:
        sim.close()
