"""PX4's own unit tests of SlewRateYaw, run against ours.

Source (PX4 v1.15): ``src/lib/slew_rate/SlewRateYawTest.cpp``, the test of
``SlewRateYaw<float>`` (``src/lib/slew_rate/SlewRateYaw.hpp``): a yaw in [-pi, pi] that moves
towards a target the short way round, at most ``slew rate × dt`` per update.

CORNET has no SlewRateYaw class; PX4 v1.15 uses one in FlightTaskOrbit (``_slew_rate_yaw``), and
ours is that task's ``Orbit._slew(target, step)`` (vehicles/orbit.py), ``step`` being the slew
rate times dt as Orbit computes it (MPC_YAWRAUTO_MAX × dt), the value ``Orbit.yaw_setpoint``:

- ``setForcedValue(v)``: ``Orbit.activate(..., yaw=v)`` (FlightTaskOrbit::activate's
  ``_slew_rate_yaw.setForcedValue(_yaw)``);
- ``setSlewRate(r)`` then ``update(target, dt)``: ``_slew(target, r × dt)``, then the value.

PX4's SlewRateYaw keeps its state unwrapped and returns it wrapped; ours keeps it wrapped. Both
take the wrapped difference to the target first, so the returned values agree (mod 2 pi, then
wrapped).

SlewRateTest.cpp (the plain ``SlewRate<float>``) is not reproduced: CORNET has no SlewRate of
its own; the slew rates PX4 uses one for (mc_pos_control's tilt limit, StickAccelerationXY's jerk
limit) are written inline in vehicles/position_stage.py and vehicles/manual_control.py, with
their rate fixed by their caller.

Comparisons as gtest makes them: ``EXPECT_FLOAT_EQ`` within 4 float32 ULPs (``float_eq``),
``EXPECT_NEAR`` within its bound. Inputs are PX4's float literals as float32 (``f32``), its
expected ``a + i * b`` computed in float32 as PX4 does;
``matrix::wrap_pi`` (into [-pi, pi)) is ``wrap_pi`` below.
"""

from __future__ import annotations

import math

import numpy as np

from tests.unit.test_px4_position_control_tests import f32, float_eq
from vehicles.orbit import Orbit
from vehicles.params import ParamStore

ZERO3 = (0.0, 0.0, 0.0)
F = np.float32


def expected(a: float, i: int, b: float) -> float:
    """PX4's expected ``a + i * b`` (``1.1f + i * .15f``) in float32 arithmetic."""
    return float(F(a) + F(i) * F(b))


def wrap_pi(x: float) -> float:
    """matrix::wrap_pi: into [-pi, pi)."""
    if -math.pi <= x < math.pi:
        return x
    return x - math.tau * math.floor((x + math.pi) / math.tau)


class SlewRateYaw:
    """PX4's SlewRateYaw<float> interface on our Orbit's heading slew."""

    def __init__(self) -> None:
        self.orbit = Orbit(ParamStore())
        self.slew_rate = 0.0

    def set_slew_rate(self, slew_rate: float) -> None:
        self.slew_rate = slew_rate

    def set_forced_value(self, value: float) -> None:
        self.orbit.activate(ZERO3, ZERO3, value)

    def update(self, new_value: float, deltatime: float) -> float:
        self.orbit._slew(new_value, self.slew_rate * deltatime)
        return self.orbit.yaw_setpoint


def _slew(rate: float, forced: float) -> SlewRateYaw:
    slew = SlewRateYaw()
    slew.set_slew_rate(f32(rate))
    slew.set_forced_value(f32(forced))
    return slew


def test_SlewRateYawTest_SlewUpLimited():
    """SlewRateYawTest.cpp, TEST(SlewRateYawTest, SlewUpLimited): rate 0.15 from 1.1 towards 3:
    1.1 + 0.15 i after i updates of 1 s."""
    slew = _slew(0.15, 1.1)
    for i in range(1, 11):
        assert float_eq(slew.update(3.0, 1.0), expected(1.1, i, 0.15))


def test_SlewRateYawTest_SlewDownLimited():
    """SlewRateYawTest.cpp, TEST(SlewRateYawTest, SlewDownLimited): rate 0.1 from 0.5 towards
    -2: 0.5 - 0.1 i (within 1e-7)."""
    slew = _slew(0.1, 0.5)
    for i in range(1, 11):
        assert abs(slew.update(-2.0, 1.0) - expected(0.5, i, -0.1)) <= f32(1e-7)


def test_SlewRateYawTest_ReachValueSlewed():
    """SlewRateYawTest.cpp, TEST(SlewRateYawTest, ReachValueSlewed): rate 0.2 from 1 towards 3:
    1 + 0.2 i for ten updates, then 3."""
    slew = _slew(0.2, 1.0)
    for i in range(1, 11):
        assert float_eq(slew.update(3.0, 1.0), expected(1.0, i, 0.2))
    for _ in range(10):
        assert float_eq(slew.update(3.0, 1.0), 3.0)


def test_SlewRateYawTest_SlewUpWrappedOutput():
    """SlewRateYawTest.cpp, TEST(SlewRateYawTest, SlewUpWrappedOutput): rate 0.2 from 0 towards
    a target always ahead (0.25 i): the output wraps past pi, wrap_pi(0.2 i) within 1e-5."""
    slew = _slew(0.2, 0.0)
    for i in range(1, 31):
        assert abs(slew.update(i * f32(0.25), 1.0) - wrap_pi(i * f32(0.2))) <= f32(1e-5)


def test_SlewRateYawTest_SlewDownWrappedOutput():
    """SlewRateYawTest.cpp, TEST(SlewRateYawTest, SlewDownWrappedOutput): rate 0.2 from 0
    towards a target always behind (-0.25 i): wrap_pi(-0.2 i) within 1e-5."""
    slew = _slew(0.2, 0.0)
    for i in range(1, 51):
        assert abs(slew.update(i * -f32(0.25), 1.0) - wrap_pi(i * -f32(0.2))) <= f32(1e-5)


def test_SlewRateYawTest_SlewUpWrappedInput():
    """SlewRateYawTest.cpp, TEST(SlewRateYawTest, SlewUpWrappedInput): as SlewUpWrappedOutput
    with the target wrapped too (wrap_pi(0.25 i)): wrap_pi(0.2 i) within 1e-5."""
    slew = _slew(0.2, 0.0)
    for i in range(1, 51):
        assert abs(slew.update(wrap_pi(i * f32(0.25)), 1.0) - wrap_pi(i * f32(0.2))) <= f32(1e-5)


def test_SlewRateYawTest_SlewShortWayInput():
    """SlewRateYawTest.cpp, TEST(SlewRateYawTest, SlewShortWayInput): rate 1 from 0; targets
    3, 5, 5, 4, 3, 5 give 1, 0, -1, -2, -3, -2 (5 from 1 is the short way down)."""
    slew = _slew(1.0, 0.0)
    assert float_eq(slew.update(3.0, 1.0), 1.0)
    assert float_eq(slew.update(5.0, 1.0), 0.0)
    assert float_eq(slew.update(5.0, 1.0), -1.0)
    assert float_eq(slew.update(4.0, 1.0), -2.0)
    assert float_eq(slew.update(3.0, 1.0), -3.0)
    assert float_eq(slew.update(5.0, 1.0), -2.0)
