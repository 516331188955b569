"""Wind (vehicles/wind.py, a scenario's [environment]): the vehicle leans into it, holds its
position and still arrives at its waypoints; gusts come from a seeded, named stream."""

from __future__ import annotations

import math

import pytest

from gateway.sim import scenario as scenario_mod
from gateway.testing import Sim, mission_item
from netsim.rng import named_generator
from vehicles.plan_types import PlanResult
from vehicles.wind import Wind, WindConfig

HOME = (47.397742, 8.545594)


def windy(speed=5.0, from_deg=270.0, gust=1.0):
    return scenario_mod.parse({"environment": {"wind_speed_mps": speed, "wind_from_deg": from_deg,
                                               "gust_mps": gust}})


def test_wind_blows_from_its_direction_and_gusts_repeat_with_the_seed():
    assert WindConfig(5.0, 270.0).mean_ned_mps == pytest.approx((0.0, 5.0, 0.0), abs=1e-12)
    a = Wind(WindConfig(5.0, 0.0, 2.0), named_generator(7, "wind"))
    b = Wind(WindConfig(5.0, 0.0, 2.0), named_generator(7, "wind"))
    first = [a.step(0.004) for _ in range(2000)]
    assert first == [b.step(0.004) for _ in range(2000)]
    north = [v[0] for v in first]
    assert sum(north) / len(north) == pytest.approx(-5.0, abs=1.5)  # blowing towards the south
    assert max(north) - min(north) > 0.5  # gusty
    with pytest.raises(ValueError):
        Wind(WindConfig(gust_mps=1.0))  # gusts need a seeded stream


@pytest.mark.parametrize("doc, key", [({"wind_speed_mps": -1}, "wind_speed_mps"),
                                      ({"wind_from_deg": 400}, "wind_from_deg"),
                                      ({"gust_mps": math.inf}, "gust_mps"),
                                      ({"breeze": 1}, "breeze")])
def test_environment_is_range_checked(doc, key):
    with pytest.raises(scenario_mod.ScenarioError, match=f"environment.{key}"):
        scenario_mod.parse({"environment": doc})


def test_hover_holds_within_half_a_metre_in_5_mps_wind():
    with Sim(scenario=windy()) as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        assert api.arm() == 0 and api.takeoff() == 0
        assert sim.run_until(lambda: sim.status(0).nav_state.name == "AUTO_LOITER", timeout_s=30)
        sim.advance(10.0)
        start = sim.state(0).position_ned_m.copy()
        worst = 0.0
        for _ in range(300):
            sim.advance(0.1)
            worst = max(worst, math.dist(start, sim.state(0).position_ned_m))
        assert worst < 0.5
        roll = sim.state(0).euler_rad()[0]
        assert math.degrees(roll) < -2.0  # leaning west, into a westerly


def test_a_mission_still_arrives_in_wind():
    with Sim(scenario=windy(from_deg=0.0)) as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        items = [mission_item(16, HOME[0] + dn * 1e-5, HOME[1] + de * 1e-5, 10)
                 for dn, de in ((20, 0), (20, 20), (0, 20))]
        assert api.upload_mission(items) == PlanResult.ACCEPTED
        assert api.arm() == 0
        assert api.start_mission() == 0
        assert sim.run_until(lambda: sim.vehicles[0].mission_status.reached_count >= 3,
                             timeout_s=120)
