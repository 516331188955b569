"""Control allocation and ESC outputs from PX4's parameters, as control_allocator and the gz
bridge take them: CA_ROTOR_COUNT and CA_ROTORn_* make the allocation (ActuatorEffectivenessRotors,
then the normalized pseudo-inverse), SIM_GZ_EC_FUNCn/MINn/MAXn/DISn and SIM_GZ_EC_REV map the
motors onto the x500's ESC outputs; both follow a parameter change at once."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as M

from gateway.testing import Sim
from vehicles.airframe import X500
from vehicles.control.mixer import (
    clip_into,
    desaturate_into,
    geometry_effectiveness,
    mixer_rows_with_effectiveness,
    pseudo_inverse_into,
)

TEST = M.MAV_CMD_ACTUATOR_TEST


def test_px4_effectiveness_of_its_wide_quad_all_zero_case():
    """ActuatorEffectivenessRotorsTest.cpp AllZeroCase: its geometry and expected matrix."""
    geometry = [(1.0, 1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.05), (-1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.05),
                (1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, -0.05), (-1.0, 1.0, 0.0, 0.0, 0.0, -1.0, 1.0, -0.05)]
    expected = [[-1.0, 1.0, 1.0, -1.0], [1.0, -1.0, 1.0, -1.0], [0.05, 0.05, -0.05, -0.05],
                [0.0] * 4, [0.0] * 4, [-1.0] * 4]
    assert np.allclose(geometry_effectiveness(geometry), expected, atol=1e-7)


def test_an_axis_of_zero_length_or_a_zero_thrust_coefficient_leaves_the_rotor_out():
    """computeEffectivenessMatrix skips such a rotor (its column stays zero); a non-finite value
    leaves it out too rather than poisoning the pseudo-inverse."""
    base = (0.1, 0.1, 0.0, 0.0, 0.0, -1.0, 6.5, 0.05)
    effectiveness = geometry_effectiveness([base, (0.1, 0.1, 0.0, 0.0, 0.0, 0.0, 6.5, 0.05),
                                            (0.1, 0.1, 0.0, 0.0, 0.0, -1.0, 0.0, 0.05),
                                            (math.nan, 0.1, 0.0, 0.0, 0.0, -1.0, 6.5, 0.05),
                                            (0.1, 0.1, 0.0, 0.0, 0.0, -2.0, 6.5, 0.05)])
    assert effectiveness[:, 1:4].tolist() == [[0.0] * 3] * 6
    assert np.allclose(effectiveness[:, 4], effectiveness[:, 0])  # the axis is normalized


def outputs_of(vehicle) -> tuple[float, ...]:
    return tuple(vehicle.targets.outputs[:4])


def test_the_default_allocation_is_the_x500s_and_a_vehicle_flies_on_it():
    with Sim() as sim:
        sim.advance(1.0)
        inner = sim.simulation.world.inner
        assert inner.alloc[0, 0, :2].tolist() == [4.0, 2.0]  # CA_ROTOR_COUNT, CA_METHOD
        rows = inner.alloc[0, 1:5]
        assert np.allclose(rows[:, :7], mixer_rows_with_effectiveness(*X500.mixer_rows()),
                           atol=1e-12)
        assert rows[:, 7].tolist() == [0.0] * 4  # CA_Rn_SLEW
        assert inner.outputs[0].tolist() == [[101 + i, 150.0, 1000.0, 0.0, 0.0] for i in range(4)]


def test_output_functions_route_the_actuator_test_and_the_disarmed_value_holds():
    """Motor 1 on ESC 3 (SIM_GZ_EC_FUNC3 101): its test spins the third rotor; ESC 1 with no
    function stays at its disarmed value, which also holds disarmed (SIM_GZ_EC_DIS, the rotor
    turning at it, as the gz model would)."""
    with Sim(params={"SIM_GZ_EC_FUNC1": 0, "SIM_GZ_EC_FUNC3": 101, "SIM_GZ_EC_DIS2": 100,
                     "SIM_GZ_EC_MAX3": 800}) as sim:
        sim.advance(1.0)
        vehicle = sim.vehicles[0]
        assert outputs_of(vehicle) == (0.0, 100.0, 0.0, 0.0)
        assert abs(vehicle.status.extra["rotor_speed_radps"][1] - 100.0) < 1.0
        assert sim.api(0).command_long(TEST, 0.5, 1.0, 0, 0, 1101) == 0
        sim.advance(0.3)
        assert outputs_of(vehicle) == (0.0, 100.0, 475.0, 0.0)  # 150 + (800 - 150) * 0.5
        speeds = vehicle.status.extra["rotor_speed_radps"]
        assert speeds[2] > 400.0 and speeds[0] == 0.0


def test_a_parameter_change_reaches_the_outputs_at_once_reversed_and_limited():
    with Sim() as sim:
        sim.advance(6.0)
        vehicle = sim.vehicles[0]
        assert sim.api(0).arm() == 0
        sim.advance(0.2)
        assert outputs_of(vehicle) == (150.0,) * 4  # armed, on the ground: idle at the minimum
        assert vehicle.params.set("SIM_GZ_EC_REV", 0b0001)
        assert vehicle.params.set("SIM_GZ_EC_MIN4", 200)
        sim.advance(0.1)
        assert outputs_of(vehicle) == (1000.0, 150.0, 150.0, 200.0)


def test_output_parameters_are_kept_as_mixing_output_keeps_them():
    """MixingOutput::updateParams holds them in uint16_t (70000 wraps to 4464) and swaps a
    minimum above the maximum."""
    with Sim(params={"SIM_GZ_EC_MIN1": 1000, "SIM_GZ_EC_MAX1": 150,
                     "SIM_GZ_EC_DIS2": 65536 + 50, "SIM_GZ_EC_MAX3": 70000}) as sim:
        sim.advance(1.0)
        outputs = sim.simulation.world.inner.outputs[0]
        assert outputs[0, 1:3].tolist() == [150.0, 1000.0]
        assert outputs[1, 3] == 50.0 and outputs[2, 2] == 4464.0
        assert outputs_of(sim.vehicles[0])[1] == 50.0


def test_ca_method_0_clips_where_the_sequential_desaturation_gives_up_thrust():
    """CA_METHOD 0 (ControlAllocationPseudoInverse: the matrix times the setpoint, clipped) at
    thrust 0.9 with a roll torque clips the high motors and leaves roll unallocated; the
    sequential desaturation (1, and 2 on a multicopter) lowers the thrust and meets it."""
    rows = mixer_rows_with_effectiveness(*X500.mixer_rows())
    clipped, desaturated = np.zeros(4), np.zeros(4)
    pseudo_inverse_into(0.9, 0.3, 0.0, 0.0, rows, clipped)
    assert np.allclose(clipped, 0.9 + 0.3 * rows[:, 0])
    flags = clip_into(0.3, 0.0, 0.0, rows, 0.0, clipped)
    assert max(clipped) == 1.0 and flags[0]  # roll+ saturated
    desaturate_into(0.9, 0.3, 0.0, 0.0, rows, desaturated)
    assert not any(clip_into(0.3, 0.0, 0.0, rows, 0.0, desaturated))
    assert desaturated.mean() < clipped.mean()


def test_ca_method_0_flies_and_a_slew_rate_limit_slows_every_motor():
    """CA_Rn_SLEW 2 s: a motor's setpoint moves at most half its range a second
    (applySlewRateLimit), so its output at most 850/2 per second over the ESC range (without
    the limit the take-off moves one by up to 29 in 20 ms)."""
    slews = {f"CA_R{i}_SLEW": 2.0 for i in range(4)}
    with Sim(params={"CA_METHOD": 0, **slews}) as sim:
        sim.advance(6.0)
        vehicle = sim.vehicles[0]
        assert sim.api(0).arm() == 0
        assert sim.api(0).takeoff() == 0
        seen: list[tuple[float, ...]] = []
        sim.every(0.02, lambda now: seen.append(outputs_of(vehicle)))
        sim.advance(12.0)
        steps = [abs(b[i] - a[i]) for a, b in zip(seen, seen[1:]) for i in range(4)
                 if a[i] > 0.0]  # not the step from the disarmed 0 to the idle 150
        # samples 20 ms apart give or take a physics step (4 ms), plus lroundf's rounding
        assert 0.0 < max(steps) <= 850.0 / 2.0 * 0.028 + 1.0
        assert -sim.state(0).position_ned_m[2] > 1.0  # it still climbs


def test_a_rotor_count_below_the_motors_leaves_the_last_motor_at_its_disarmed_value():
    """CA_ROTOR_COUNT 3: Motor 4 has no command (NaN), so its ESC gets SIM_GZ_EC_DIS4."""
    with Sim(params={"CA_ROTOR_COUNT": 3}) as sim:
        sim.advance(6.0)
        vehicle = sim.vehicles[0]
        assert sim.api(0).arm() == 0
        sim.advance(0.2)
        assert outputs_of(vehicle) == (150.0, 150.0, 150.0, 0.0)


def test_swapped_outputs_make_the_vehicle_lose_control_as_it_would_on_px4():
    """Motors 1 and 3 crossed over (SIM_GZ_EC_FUNC1 103, FUNC3 101): roll and yaw act the
    wrong way round, so the take-off ends upside down or far off level."""
    with Sim(params={"SIM_GZ_EC_FUNC1": 103, "SIM_GZ_EC_FUNC3": 101}) as sim:
        sim.advance(6.0)
        assert sim.api(0).arm() == 0
        assert sim.api(0).takeoff() == 0
        tilts = []
        sim.every(0.1, lambda now: tilts.append(_tilt_deg(sim.simulation.vehicles[0])))
        sim.advance(6.0)
        assert max(tilts) > 60.0


def test_flipped_spin_directions_in_the_geometry_make_the_heading_run_away():
    """CA_ROTORn_KM negated on every rotor: the allocation yaws the other way, as the model's
    propellers do not, so the yaw loop runs away (as PX4's would), while roll and pitch, which
    do not depend on KM, hold the vehicle level in its climb."""
    params = {f"CA_ROTOR{i}_KM": -km for i, (_, _, km) in enumerate(X500.allocation_rotors)}
    with Sim(params=params) as sim:
        sim.advance(6.0)
        assert sim.api(0).arm() == 0
        assert sim.api(0).takeoff() == 0
        tilts, yaws = [], []
        sim.every(0.1, lambda now: (tilts.append(_tilt_deg(sim.simulation.vehicles[0])),
                                    yaws.append(math.degrees(sim.state(0).euler_rad()[2]))))
        sim.advance(8.0)
        assert max(tilts) < 20.0 and -sim.state(0).position_ned_m[2] > 1.0
        assert max(abs(y) for y in yaws) > 90.0


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, 3e38, -3e38])
def test_hostile_geometry_and_output_values_keep_the_physics_finite(value):
    with Sim() as sim:
        sim.advance(6.0)
        vehicle = sim.vehicles[0]
        for name in ("CA_ROTOR0_PX", "CA_ROTOR1_AZ", "CA_ROTOR2_CT", "CA_ROTOR3_KM"):
            vehicle.params.set(name, value)
        extreme = -2**31 if value < 0 else 2**31 - 1  # INT32s: the ends of their range
        for name in ("SIM_GZ_EC_MIN1", "SIM_GZ_EC_MAX2", "SIM_GZ_EC_DIS3", "SIM_GZ_EC_FUNC4"):
            assert vehicle.params.set(name, extreme)
        assert sim.api(0).arm() in (0, 1, 4)
        sim.api(0).takeoff()
        sim.advance(2.0)
        state = sim.state(0)
        assert all(math.isfinite(x) for x in (*state.position_ned_m, *state.velocity_ned_mps))
        assert all(math.isfinite(x) for x in vehicle.status.extra["rotor_speed_radps"])


def _tilt_deg(vehicle) -> float:
    """The angle between the body's z axis and the vertical (the truth)."""
    _, x, y, _ = vehicle.state.attitude_q
    return math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y)))))
