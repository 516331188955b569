"""PX4's own unit tests of the multicopter position controller, run against ours.

Sources (PX4 v1.15-era, ``src/modules/mc_pos_control/PositionControl/``):
``PositionControlTest.cpp`` (the version whose input is a ``trajectory_setpoint_s``, v1.14 on,
including ``IntegratorWindupWithInvalidSetpoint``) and ``ControlMathTest.cpp``. Each test below
carries PX4's inputs, expected numbers and tolerances:

- ``EXPECT_FLOAT_EQ``: within 4 units in the last place of a float32 (``float_eq``);
- ``EXPECT_EQ`` of two floats: equal as float32;
- ``EXPECT_EQ`` of two matrix vectors or quaternions: matrix's ``operator==``, every element
  within 1e-4 (``matrix_eq``).

PX4's controller keeps its outputs and hands them over through getters; ours returns them from
``PositionControl.update`` (``PositionControlOutput``), and the attitude setpoint is
``thrust_to_attitude_q`` of the thrust at the controller's yaw (the state's yaw, 0 here, since no
test sets a yaw setpoint), as PositionControl::getAttitudeSetpoint does.

Not reproduced (CORNET has no such thing):
- ``PositionControlTest.EmptySetpoint``, its local position setpoint half: a PX4 controller that
  never ran reports zeros through getLocalPositionSetpoint; ours has no stored setpoint before an
  update (the position stage marks "not run yet" with NaN). The attitude half is reproduced on
  the position stage, whose attitude setpoint before the first tick is the one checked.
- ``ControlMathTest.CrossSphereLine``: ControlMath::cross_sphere_line is not part of the position
  controller (PX4's older line-following flight tasks used it); CORNET's auto modes follow PX4's
  PositionSmoothing (control/position_smoothing.py), which does not use it.
"""

from __future__ import annotations

import math

import numpy as np

from vehicles.control.attitude_control import thrust_to_attitude_q
from vehicles.control.position_control import (
    THRUST_XY_MARGIN,
    PositionControl,
    PositionControlGains,
    PositionSetpoint,
    limit_tilt,
)
from vehicles.control.quat import q_dcm_z
from vehicles.types import Vec3, q_euler_rad

NAN = math.nan
NAN3: Vec3 = (NAN, NAN, NAN)
ZERO: Vec3 = (0.0, 0.0, 0.0)
MAXIMUM_THRUST = 0.9
HORIZONTAL_THRUST_MARGIN = 0.3
DEG = math.pi / 180.0


def _ulps(x: float) -> int:
    """gtest's biased integer of a float32: ordered so that neighbours differ by one."""
    bits = int(np.array(x, dtype=np.float32).view(np.uint32))
    return (~bits + 1) & 0xFFFFFFFF if bits & 0x80000000 else bits | 0x80000000


def float_eq(actual: float, expected: float) -> bool:
    """EXPECT_FLOAT_EQ: the two as float32, at most 4 ULPs apart."""
    if math.isnan(actual) or math.isnan(expected):
        return False
    return abs(_ulps(actual) - _ulps(expected)) <= 4


def float32_eq(actual: float, expected: float) -> bool:
    """EXPECT_EQ of two floats: equal as float32."""
    return bool(np.float32(actual) == np.float32(expected))


def matrix_eq(actual, expected) -> bool:
    """matrix's operator== (isEqualF): every element within 1e-4."""
    return all(abs(a - b) <= 1e-4 for a, b in zip(actual, expected, strict=True))


def f32(x: float) -> float:
    """A literal as PX4 writes it (``.1f``): the float32 nearest to it."""
    return float(np.float32(x))


def norm(v) -> float:
    return math.sqrt(sum(c * c for c in v))


class Basic:
    """PositionControlBasicTest: position gain 1, velocity PID gains 20, velocity limits 1 m/s,
    thrust 0.1..0.9 with a 0.3 horizontal margin, tilt limit 1 rad, hover thrust 0.5; the state
    (position, velocity, acceleration) all zero; ``run`` updates with dt = 0.1 s."""

    def __init__(self) -> None:
        assert THRUST_XY_MARGIN == HORIZONTAL_THRUST_MARGIN  # MPC_THR_XY_MARG's default
        self.control = PositionControl(PositionControlGains(
            pos_p_xy=1.0, pos_p_z=1.0, vel_p_xy=20.0, vel_i_xy=20.0, vel_d_xy=20.0,
            vel_p_z=20.0, vel_i_z=20.0, vel_d_z=20.0, vel_max_xy_mps=1.0, vel_max_up_mps=1.0,
            vel_max_down_mps=1.0, tilt_max_rad=1.0, thrust_min=0.1, thrust_max=MAXIMUM_THRUST,
            hover_thrust=0.5))
        self.position: Vec3 = ZERO
        self.velocity: Vec3 = ZERO
        self.acceleration: Vec3 = ZERO
        self.setpoint = PositionSetpoint()
        self.thrust: Vec3 = NAN3
        self.velocity_sp: Vec3 = NAN3
        self.acceleration_sp: Vec3 = NAN3
        self.q = (1.0, 0.0, 0.0, 0.0)
        self.thrust_body: Vec3 = ZERO

    def set_tilt_limit(self, tilt_rad: float) -> None:
        self.control.set_limits(1.0, 0.1, tilt_rad)

    def run(self) -> bool:
        out = self.control.update(0.1, self.position, self.velocity, self.acceleration,
                                  self.setpoint)
        self.thrust, self.velocity_sp = out.thrust_ned, out.velocity_sp_ned_mps
        self.acceleration_sp = out.acceleration_sp_ned_mps2
        self.q, collective = thrust_to_attitude_q(self.thrust, 0.0)
        self.thrust_body = (0.0, 0.0, -collective)
        return out.valid

    def body_z(self) -> Vec3:
        return q_dcm_z(self.q)

    def euler(self) -> tuple[float, float, float]:
        return q_euler_rad(self.q)


# --- PositionControlTest.cpp ---


def test_empty_setpoint():
    """PositionControlTest.cpp, TEST(PositionControlTest, EmptySetpoint): the attitude setpoint
    before any update is level, identity, without thrust or yaw rate (the position stage's, see
    the module docstring for the local position half)."""
    from vehicles.airframe import X500
    from vehicles.land_detector import LandDetector
    from vehicles.params import ParamStore
    from vehicles.position_stage import PositionStage

    params = ParamStore({})
    stage = PositionStage(LandDetector(params),
                          PositionControlGains.from_params(params, X500.hover_thrust_norm), params)
    att = stage.attitude
    roll, pitch, yaw = q_euler_rad(att.attitude_q)
    assert float_eq(roll, 0.0) and float_eq(pitch, 0.0) and float_eq(yaw, 0.0)
    assert float_eq(att.yawspeed_radps, 0.0)
    assert matrix_eq(att.attitude_q, (1.0, 0.0, 0.0, 0.0))
    assert matrix_eq((0.0, 0.0, -att.thrust_body_norm), ZERO)


def check_direction(t: Basic) -> None:
    """PositionControlBasicDirectionTest::checkDirection."""
    assert t.thrust[0] > 0.0 and t.thrust[1] > 0.0 and t.thrust[2] < 0.0
    bz = t.body_z()
    assert bz[0] < 0.0 and bz[1] < 0.0 and bz[2] > 0.0


def test_position_direction():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicDirectionTest, PositionDirection)."""
    t = Basic()
    t.setpoint = PositionSetpoint(position_ned_m=(f32(.1), f32(.1), f32(-.1)))
    assert t.run()
    check_direction(t)


def test_velocity_direction():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicDirectionTest, VelocityDirection)."""
    t = Basic()
    t.setpoint = PositionSetpoint(velocity_ned_mps=(f32(.1), f32(.1), f32(-.1)))
    assert t.run()
    check_direction(t)


def test_tilt_limit():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest, TiltLimit)."""
    t = Basic()
    t.setpoint = PositionSetpoint(position_ned_m=(10.0, 10.0, 0.0))
    assert t.run()
    angle = math.acos(t.body_z()[2])
    assert 0.0 < angle <= 1.0
    t.set_tilt_limit(0.5)
    assert t.run()
    angle = math.acos(t.body_z()[2])
    assert 0.0 < angle <= f32(.50001)


def test_velocity_limit():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest, VelocityLimit)."""
    t = Basic()
    t.setpoint = PositionSetpoint(position_ned_m=(10.0, 10.0, -10.0))
    assert t.run()
    assert math.hypot(t.velocity_sp[0], t.velocity_sp[1]) <= 1.0
    assert abs(t.velocity_sp[2]) <= 1.0


def test_position_control_max_thrust_limit():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest, PositionControlMaxThrustLimit):
    vertical and horizontal saturation at once."""
    t = Basic()
    t.setpoint = PositionSetpoint(position_ned_m=(10.0, 10.0, -10.0))
    t.run()
    # the thrust vector's length is limited by the maximum
    assert float_eq(norm(t.thrust), MAXIMUM_THRUST)
    # the horizontal thrust by its margin
    margin_axis = HORIZONTAL_THRUST_MARGIN / math.sqrt(2.0)
    assert float_eq(t.thrust[0], margin_axis)
    assert float_eq(t.thrust[1], margin_axis)
    assert float_eq(t.thrust[2], -math.sqrt(MAXIMUM_THRUST ** 2 - HORIZONTAL_THRUST_MARGIN ** 2))
    # the collective thrust by the maximum
    assert float32_eq(t.thrust_body[0], 0.0) and float32_eq(t.thrust_body[1], 0.0)
    assert float_eq(t.thrust_body[2], -MAXIMUM_THRUST)
    # the tilt: horizontal margin / maximum thrust
    assert float_eq(t.euler()[0], math.asin(margin_axis / MAXIMUM_THRUST))


def test_position_control_min_thrust_limit():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest, PositionControlMinThrustLimit)."""
    t = Basic()
    t.setpoint = PositionSetpoint(position_ned_m=(10.0, 0.0, 10.0))
    t.run()
    assert float_eq(norm(t.thrust), f32(0.1))
    assert float_eq(t.thrust_body[2], f32(-0.1))
    roll, pitch, _ = t.euler()
    assert float_eq(roll, 0.0)
    assert float_eq(pitch, -1.0)


def test_failsafe_input():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest, FailsafeInput): no horizontal
    acceleration, a slow descent."""
    t = Basic()
    t.setpoint = PositionSetpoint(velocity_ned_mps=(NAN, NAN, f32(.1)),
                                  acceleration_ned_mps2=(0.0, 0.0, NAN))
    assert t.run()
    assert float_eq(t.thrust_body[0], 0.0) and float_eq(t.thrust_body[1], 0.0)
    assert -.5 < t.thrust[2] < -.1
    assert -.5 < t.thrust_body[2] <= -.1


def test_idle_thrust_input():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest, IdleThrustInput): a high
    downward acceleration gives the minimum thrust."""
    t = Basic()
    t.setpoint = PositionSetpoint(acceleration_ned_mps2=(0.0, 0.0, 100.0))
    assert t.run()
    assert float_eq(t.thrust[0], 0.0) and float_eq(t.thrust[1], 0.0)
    assert float_eq(t.thrust[2], f32(-.1))


def test_input_combinations_position():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest, InputCombinationsPosition).
    (The output position setpoint is PX4's input, handed back: ours does not hand it back.)"""
    t = Basic()
    t.setpoint = PositionSetpoint(position_ned_m=(f32(.1), f32(.2), f32(.3)))
    assert t.run()
    assert not any(math.isnan(v) for v in t.velocity_sp)
    assert not any(math.isnan(v) for v in t.thrust)


def test_input_combinations_position_velocity():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest,
    InputCombinationsPositionVelocity): velocity horizontally, altitude vertically."""
    t = Basic()
    t.setpoint = PositionSetpoint(position_ned_m=(NAN, NAN, f32(.3)),
                                  velocity_ned_mps=(f32(.1), f32(.2), NAN))
    assert t.run()
    assert float_eq(t.velocity_sp[0], f32(.1))
    assert float_eq(t.velocity_sp[1], f32(.2))
    assert not math.isnan(t.velocity_sp[2])
    assert not any(math.isnan(v) for v in t.thrust)


def test_setpoint_validity_simple():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest, SetpointValiditySimple)."""
    t = Basic()
    assert not t.run()
    t.setpoint = PositionSetpoint(position_ned_m=(f32(.1), NAN, NAN))
    assert not t.run()
    t.setpoint = PositionSetpoint(position_ned_m=(f32(.1), f32(.2), NAN))
    assert not t.run()
    t.setpoint = PositionSetpoint(position_ned_m=(f32(.1), f32(.2), NAN),
                                  acceleration_ned_mps2=(NAN, NAN, f32(.3)))
    assert t.run()


def test_setpoint_validity_all_combinations():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest, SetpointValidityAllCombinations):
    every combination of set and unset (NaN) position, velocity and acceleration per axis; valid
    when every axis has one and x and y come in pairs."""
    t = Basic()
    wrong = []
    for combination in range(512):
        values = [float(np.float32(combination) / np.float32(j + 1))
                  if combination & (1 << j) else NAN for j in range(9)]
        # PX4's order: x (position, velocity, acceleration), then y, then z
        t.setpoint = PositionSetpoint(position_ned_m=(values[0], values[3], values[6]),
                                      velocity_ned_mps=(values[1], values[4], values[7]),
                                      acceleration_ned_mps2=(values[2], values[5], values[8]))
        has_x = (combination & 7) != 0
        has_y = ((combination >> 3) & 7) != 0
        has_z = ((combination >> 6) & 7) != 0
        xy_pairs = (combination & 7) == ((combination >> 3) & 7)
        if t.run() != (has_x and has_y and has_z and xy_pairs):
            wrong.append(combination)
    assert wrong == []


def test_invalid_state():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest, InvalidState): a controlled
    state that is NaN makes the update fail."""
    t = Basic()
    t.setpoint = PositionSetpoint(position_ned_m=(f32(.1), f32(.2), f32(.3)))
    t.position = (NAN, 0.0, 0.0)
    assert not t.run()
    t.velocity = (NAN, 0.0, 0.0)
    assert not t.run()
    t.position = ZERO
    assert not t.run()
    t.velocity = ZERO
    t.acceleration = (0.0, NAN, 0.0)
    assert not t.run()


def test_update_hover_thrust():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest, UpdateHoverThrust): a new
    hover thrust moves the integrator so that the thrust does not jump."""
    t = Basic()
    hover_thrust = f32(0.6)
    t.control.update_hover_thrust(hover_thrust, NAN)  # PositionControl::setHoverThrust
    t.setpoint = PositionSetpoint(velocity_ned_mps=ZERO)
    assert t.run()
    assert float32_eq(t.thrust[2], -hover_thrust)
    t.control.update_hover_thrust(f32(0.7), t.acceleration_sp[2])
    assert t.run()
    assert float32_eq(t.thrust[2], -hover_thrust)


def test_integrator_windup_with_invalid_setpoint():
    """PositionControlTest.cpp, TEST_F(PositionControlBasicTest,
    IntegratorWindupWithInvalidSetpoint): an invalid setpoint (x and y positions, nothing
    vertical) must leave the integrator alone."""
    t = Basic()
    t.setpoint = PositionSetpoint(position_ned_m=(f32(.1), f32(.2), NAN))
    assert not t.run()
    t.setpoint = PositionSetpoint(velocity_ned_mps=ZERO)
    assert t.run()
    roll, pitch, _ = t.euler()
    assert float_eq(roll, 0.0)
    assert float_eq(pitch, 0.0)


# --- ControlMathTest.cpp ---


def normalized(v: Vec3) -> Vec3:
    n = norm(v)
    return (v[0] / n, v[1] / n, v[2] / n)


def test_limit_tilt_unchanged():
    """ControlMathTest.cpp, TEST(ControlMathTest, LimitTiltUnchanged)."""
    body = normalized((0.0, 0.0, 1.0))
    assert matrix_eq(limit_tilt(body, 45.0 * DEG), body)
    body = normalized((0.0, .1, 1.0))
    assert matrix_eq(limit_tilt(body, 45.0 * DEG), body)


def test_limit_tilt_opposite():
    """ControlMathTest.cpp, TEST(ControlMathTest, LimitTiltOpposite): the corner case of a body
    axis exactly opposite to the world's."""
    body = limit_tilt(normalized((0.0, 0.0, -1.0)), 45.0 * DEG)
    assert abs(math.acos(body[2]) / DEG - 45.0) <= 1e-4
    assert float_eq(norm(body), 1.0)


def test_limit_tilt_almost_opposite():
    """ControlMathTest.cpp, TEST(ControlMathTest, LimitTiltAlmostOpposite)."""
    body = limit_tilt(normalized((.001, 0.0, -1.0)), 45.0 * DEG)
    assert abs(math.acos(body[2]) / DEG - 45.0) <= 1e-4
    assert float_eq(norm(body), 1.0)


def test_limit_tilt_45degree():
    """ControlMathTest.cpp, TEST(ControlMathTest, LimitTilt45degree)."""
    s = math.sqrt(0.5)
    assert matrix_eq(limit_tilt((1.0, 0.0, 0.0), 45.0 * DEG), (s, 0.0, s))
    assert matrix_eq(limit_tilt((0.0, 1.0, 0.0), 45.0 * DEG), (0.0, s, s))


def test_limit_tilt_10degree():
    """ControlMathTest.cpp, TEST(ControlMathTest, LimitTilt10degree): the second input is not a
    unit vector."""
    body = limit_tilt(normalized((1.0, 1.0, .1)), 10.0 * DEG)
    assert abs(math.acos(body[2]) / DEG - 10.0) <= 1e-4
    assert float_eq(norm(body), 1.0)
    assert float_eq(body[0], body[1])
    body = limit_tilt((1.0, 2.0, .2), 10.0 * DEG)
    assert abs(math.acos(body[2]) / DEG - 10.0) <= 1e-4
    assert float_eq(norm(body), 1.0)
    assert float_eq(2.0 * body[0], body[1])


def test_throttle_attitude_mapping():
    """ControlMathTest.cpp, TEST(ControlMathTest, ThrottleAttitudeMapping): thrustToAttitude."""
    # thrust straight up: level, full thrust
    q, collective = thrust_to_attitude_q((0.0, 0.0, -1.0), 0.0)
    assert float_eq(q[0], 1.0)
    assert float_eq(q[1], 0.0) and float_eq(q[2], 0.0) and float_eq(q[3], 0.0)
    assert float_eq(-collective, -1.0)
    # the same at 90° yaw: only the yaw changes
    yaw = f32(math.pi / 2)
    q, collective = thrust_to_attitude_q((0.0, 0.0, -1.0), yaw)
    roll, pitch, psi = q_euler_rad(q)
    assert float_eq(roll, 0.0) and float_eq(pitch, 0.0) and float_eq(psi, yaw)
    assert float_eq(-collective, -1.0)
    # thrust straight down: upside down (roll 180°, Euler order roll, pitch, yaw)
    q, collective = thrust_to_attitude_q((0.0, 0.0, 1.0), yaw)
    roll, pitch, psi = q_euler_rad(q)
    assert float_eq(abs(roll), math.pi)
    assert float_eq(pitch, 0.0) and float_eq(psi, yaw)
    assert float_eq(-collective, -1.0)


def test_constrain_xy_priorities():
    """ControlMathTest.cpp, TEST(ControlMathTest, ConstrainXYPriorities): v0 has priority over
    v1 when their sum is longer than the maximum."""
    from vehicles.control.position_control import constrain_xy

    limit = 5.0
    # v0 already at the maximum
    v0 = (limit, 0.0)
    v1 = (v0[1], -v0[0])
    r = constrain_xy(v0, v1, limit)
    assert float_eq(r[0], limit) and float_eq(r[1], 0.0)
    # v1 longer than the maximum but v0 zero
    r = constrain_xy((0.0, 0.0), v1, limit)
    assert float_eq(r[1], -limit) and float_eq(r[0], 0.0)
    # within the maximum: the sum
    v0, v1 = (.5, .5), (.5, -.5)
    r = constrain_xy(v0, v1, limit)
    assert float_eq(math.hypot(r[0] - (v0[0] + v1[0]), r[1] - (v0[1] + v1[1])), 0.0)
    # both over the maximum and perpendicular
    v0, v1 = (4.0, 0.0), (0.0, -4.0)
    r = constrain_xy(v0, v1, limit)
    assert float_eq(r[0], v0[0])
    assert r[0] > 0.0
    assert float_eq(r[1], -math.sqrt(limit * limit - v0[0] * v0[0]))


def test_add_if_not_nan():
    """ControlMathTest.cpp, TEST(ControlMathTest, addIfNotNan)."""
    from vehicles.control.position_control import add_if_not_nan

    v = add_if_not_nan(1.0, 2.0)  # regular addition
    assert v == 3.0
    v = add_if_not_nan(v, NAN)  # a NaN addition has no influence
    assert v == 3.0
    v = add_if_not_nan(NAN, NAN)  # both NaN
    assert math.isnan(v)
    v = add_if_not_nan(v, 3.0)  # a value added to NaN replaces it
    assert v == 3.0
