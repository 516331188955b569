"""Takeoff altitudes through the wire in lockstep (gateway.testing.Sim), as PX4 1.15's
navigator chooses them: Takeoff mode (takeoff.cpp set_takeoff_position) MAV_CMD_NAV_TAKEOFF
param7 (AMSL) as given, else MIS_TAKEOFF_ALT above the *current* altitude, never down; a
mission started on the ground climbs to its first position item (checkClimbRequired)."""

import pytest

from gateway.testing import mission_item
from tests.unit import lockstep_support
from tests.unit.lockstep_support import height, texts
from vehicles.plan_types import MavCmd, PlanResult
from vehicles.types import PX4_SITL_HOME, NavState

sim = lockstep_support.sim  # the fixture: one vehicle, its position estimate valid

ALREADY_HIGHER = "Already higher than takeoff altitude\t"


def test_default_takeoff_in_the_air_climbs_mis_takeoff_alt_above_the_current_altitude(sim):
    api = sim.api(0)
    origin_amsl = sim.vehicles[0].origin.alt_amsl_m
    assert api.arm() == 0 and api.takeoff(origin_amsl + 8.0) == 0
    assert sim.run_until(lambda: sim.status(0).nav_state is NavState.AUTO_LOITER, timeout_s=20)
    sim.advance(3.0)  # done within NAV_MC_ALT_RAD: Hold closes the rest
    assert height(sim) == pytest.approx(8.0, abs=0.5)
    mark = len(api.frames)
    assert api.takeoff() == 0  # MAVSDK's action.takeoff: param7 NaN
    sim.advance(8.0)
    assert height(sim) == pytest.approx(8.0 + 2.5, abs=0.5)
    said = texts(api, mark)
    assert "Using default takeoff altitude: 2.5 m\t" in said and ALREADY_HIGHER not in said


def test_requested_altitude_is_taken_as_given_and_never_below_the_vehicle(sim):
    api = sim.api(0)
    origin_amsl = sim.vehicles[0].origin.alt_amsl_m
    assert api.arm() == 0 and api.takeoff(origin_amsl + 1.5) == 0  # below MIS_TAKEOFF_ALT
    assert sim.run_until(lambda: sim.status(0).nav_state is NavState.AUTO_LOITER, timeout_s=20)
    sim.advance(3.0)
    assert height(sim) == pytest.approx(1.5, abs=0.3)
    said = texts(api)
    assert not [t for t in said if "takeoff altitude" in t]  # no minimum, no default
    mark = len(api.frames)
    assert api.takeoff(origin_amsl + 0.5) == 0  # below the vehicle: stays where it is
    sim.advance(3.0)
    assert height(sim) == pytest.approx(1.5, abs=0.3)
    assert ALREADY_HIGHER in texts(api, mark)


def test_mission_climb_goes_to_the_first_waypoint_altitude_without_a_floor(sim):
    """mission_base.cpp checkClimbRequired (1.15): started on the ground, a mission climbs to its
    next position item's altitude ("Climb to %.1f meters above home", tab, event), not to at
    least MIS_TAKEOFF_ALT as older PX4 did. The waypoint is the last item: reached within
    NAV_ACC_RAD, the mission ends loitering where the vehicle is then (MissionBase::
    setEndOfMissionItems, setLoiterItemFromCurrentPosition; PX4 v1.16 loiters at the waypoint)."""
    api = sim.api(0)
    g = PX4_SITL_HOME.offset_ned(20.0, 0.0, 0.0)
    items = [mission_item(MavCmd.NAV_WAYPOINT, g.lat_deg, g.lon_deg, 1.6)]
    assert api.upload_mission(items) == PlanResult.ACCEPTED
    assert api.arm() == 0 and api.start_mission() == 0
    top = 0.0

    def arrived():
        nonlocal top
        top = max(top, height(sim))
        return sim.state(0).position_ned_m[0] > 17.5

    assert sim.run_until(arrived, timeout_s=40)
    sim.run_until(lambda: False, timeout_s=8.0)
    assert 17.5 < sim.state(0).position_ned_m[0] < 19.0
    assert top < 1.8, top  # the climb to MIS_TAKEOFF_ALT (2.5) topped out near 2.0
    assert "Climb to 1.6 meters above home\t" in texts(api)
