"""THR_MDL_FAC, the motors' thrust model (PX4 FunctionMotors::updateValues): with a factor f in
(0, 1] a command for relative thrust t goes out as the x with f·x² + (1 − f)·x = t, in flight and
in QGC's motor test; 0 (PX4's default) leaves commands linear."""

from __future__ import annotations

import math

import pytest

from gateway.testing import Sim
from vehicles.inner_loop import thrust_model


@pytest.mark.parametrize("factor", [0.1, 0.3, 0.5, 1.0])
@pytest.mark.parametrize("thrust", [0.0, 0.05, 0.3, 0.73, 1.0])
def test_the_command_gives_the_thrust_asked_for(factor, thrust):
    x = thrust_model(thrust, factor)
    assert factor * x * x + (1 - factor) * x == pytest.approx(thrust, abs=1e-12)
    assert 0.0 <= x <= 1.0


def test_outside_its_range_commands_are_left_alone():
    for factor in (0.0, -0.5, 1.5, math.nan):
        assert thrust_model(0.4, factor) == 0.4
    assert thrust_model(0.25, 1.0) == pytest.approx(0.5)  # pure quadratic: the square root
    assert thrust_model(-0.25, 1.0) == pytest.approx(-0.5)


def test_a_vehicle_flies_with_a_thrust_model_and_its_motor_test_goes_through_it():
    with Sim(params={"THR_MDL_FAC": 0.5}) as sim:
        sim.advance(1.0)
        api = sim.api(0)
        # Motor test at 0.5: the ESC gets 150 + 850·x with 0.5·x² + 0.5·x = 0.5.
        assert api.command_long(310, 0.5, 1.0, 0, 0, 1) == 0  # MAV_CMD_ACTUATOR_TEST
        sim.advance(0.2)
        x = thrust_model(0.5, 0.5)
        assert sim.vehicles[0].targets.outputs[0] == math.floor(150 + 850 * x + 0.5)
        sim.advance(2.0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        assert api.arm() == 0 and api.takeoff() == 0
        assert sim.run_until(lambda: sim.status(0).nav_state.name == "AUTO_LOITER", timeout_s=30)
        sim.advance(5.0)
        z = sim.vehicles[0].state.position_ned_m[2]
        assert -2.8 < z < -2.2  # MIS_TAKEOFF_ALT 2.5 m, held
