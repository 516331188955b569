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
