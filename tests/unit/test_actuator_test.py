"""MAV_CMD_ACTUATOR_TEST (QGC's Actuators page, motor sliders) as PX4's commander and mixer:
a disarmed motor spins at the test value over the gz ESC range for at most 3 s, then stops;
armed, or COM_MOT_TEST_EN 0: DENIED."""

from __future__ import annotations

from pymavlink.dialects.v20 import common as M

from gateway.testing import Sim

TEST = M.MAV_CMD_ACTUATOR_TEST


def speeds_of(vehicle) -> tuple[float, ...]:
    """The rotors' speeds (rad/s) after the motors' lag."""
    return tuple(vehicle.status.extra["rotor_speed_radps"])


def test_a_motor_spins_at_its_test_value_until_the_timeout():
    with Sim() as sim:
        sim.advance(1.0)
        api = sim.api(0)
        vehicle = sim.vehicles[0]
        # param1 value, param2 timeout (s), param5 function (1 = motor 1).
        assert api.command_long(TEST, 0.5, 1.0, 0, 0, 1) == 0
        sim.advance(0.5)
        speeds = speeds_of(vehicle)
        assert abs(speeds[0] - 575.0) < 5.0 and speeds[1:] == (0.0, 0.0, 0.0), speeds
        assert vehicle.targets.outputs[:4] == (575.0, 0.0, 0.0, 0.0)  # SERVO_OUTPUT_RAW
        assert not vehicle.status.armed
        sim.advance(1.0)  # past the 1 s timeout: stopped
        assert speeds_of(vehicle)[0] < 100.0
        # Two motors at once; a timeout of 0 releases one; at most 3 s.
        assert api.command_long(TEST, 0.2, 10.0, 0, 0, 2) == 0
        assert api.command_long(TEST, 0.2, 10.0, 0, 0, 3) == 0
        sim.advance(0.5)
        speeds = speeds_of(vehicle)
        assert speeds[1] > 300 and speeds[2] > 300 and speeds[0] < 1.0
        assert api.command_long(TEST, 0.0, 0.0, 0, 0, 3) == 0
        sim.advance(0.5)
        assert speeds_of(vehicle)[1] > 300 and speeds_of(vehicle)[2] < 100
        sim.advance(2.5)
        assert speeds_of(vehicle)[1] < 100  # 3 s after the test began
        assert api.command_long(TEST, 0.5, 1.0, 0, 0, 40) == 0  # a servo: nothing mapped
        assert api.command_long(TEST, 0.5, 1.0, 0, 0, 500) == 3


def test_actuator_test_is_denied_armed_or_disabled():
    with Sim(params={"COM_MOT_TEST_EN": 0}) as sim:
        sim.advance(1.0)
        api = sim.api(0)
        assert api.command_long(TEST, 0.5, 1.0, 0, 0, 1) == 2
        assert sim.vehicles[0].params.set("COM_MOT_TEST_EN", 1)
        sim.advance(6.0)
        assert api.arm() == 0
        assert api.command_long(TEST, 0.5, 1.0, 0, 0, 1) == 2


def test_do_motor_test_is_unsupported_as_in_px4_1_15():
    """MAV_CMD_DO_MOTOR_TEST (QGC's older Motors page): PX4 1.14 removed Commander's
    handle_command_motor_test with the test_motor topic (ACTUATOR_TEST replaced it), so
    Commander::handle_command answers it UNSUPPORTED (its default case) whatever the arming
    state, COM_MOT_TEST_EN or params; nothing spins."""
    motor_test = M.MAV_CMD_DO_MOTOR_TEST
    with Sim() as sim:
        sim.advance(1.0)
        api, vehicle = sim.api(0), sim.vehicles[0]
        for params in ((1, 0, 50, 2, 0), (1, 0, 50, 2, 1), (1, 1, 1500, 2, 0),
                       (1, 0, 50, 2, 4)):
            assert api.command_long(motor_test, *params) == 3  # UNSUPPORTED
        sim.advance(0.5)
        assert speeds_of(vehicle) == (0.0, 0.0, 0.0, 0.0)
        assert vehicle.params.set("COM_MOT_TEST_EN", 0)
        assert api.command_long(motor_test, 1, 0, 50, 2, 0) == 3
        assert vehicle.params.set("COM_MOT_TEST_EN", 1)
        sim.advance(6.0)
        assert api.arm() == 0
        assert api.command_long(motor_test, 1, 0, 50, 2, 0) == 3
