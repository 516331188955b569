"""PX4's own unit test of ManualVelocitySmoothingXY, run against ours.

Source (PX4 v1.15): ``src/lib/motion_planning/ManualVelocitySmoothingXYTest.cpp``, the test of
``ManualVelocitySmoothingXY`` (the horizontal jerk-limited smoothing of Position mode with
MPC_POS_MODE 3). Ours: ``vehicles/control/manual_velocity_smoothing_xy.py``.

PX4's getters and setters map onto ours as follows:

- ``setMaxJerk``/``setMaxAccel``/``setMaxVel``: ours sets the three together
  (``set_limits(jerk, accel, vel)``, the same on both axes, as PX4's setters are);
  ``getMaxJerk()``/``getMaxAccel()``/``getMaxVel()`` return ``_trajectory[0]``'s, ours are that
  trajectory's ``max_jerk``/``max_accel``/``max_vel``;
- ``getCurrentJerk``/``Acceleration``/``Velocity`` return ``_state.j``/``a``/``v``: ours ``j``,
  ``a``, ``v``; ``getCurrentPosition`` returns ``_position_setpoint_locked`` (not ``_state.x``):
  ours ``position_locked``.

Comparisons as gtest and PX4's matrix library make them: ``EXPECT_FLOAT_EQ`` within 4 float32
ULPs (``float_eq``), ``EXPECT_EQ`` of two ``Vector3f`` every element within 1e-4 (matrix's
``operator==``, ``matrix_eq``). The test's ``Vector3f`` are the ``Vector2f`` results with a zero
third element.
"""

from __future__ import annotations

from tests.unit.test_px4_position_control_tests import float_eq, matrix_eq
from vehicles.control.manual_velocity_smoothing_xy import ManualVelocitySmoothingXY


def test_ManualVelocitySmoothingXYTest_setGet():
    """ManualVelocitySmoothingXYTest.cpp, TEST_F(ManualVelocitySmoothingXYTest, setGet): the
    limits set (jerk 11, acceleration 7, velocity 5) come back."""
    smoothing = ManualVelocitySmoothingXY()
    smoothing.set_limits(11.0, 7.0, 5.0)
    first = smoothing.trajectories[0]
    assert float_eq(first.max_jerk, 11.0)
    assert float_eq(first.max_accel, 7.0)
    assert float_eq(first.max_vel, 5.0)


def test_ManualVelocitySmoothingXYTest_getCurrentState():
    """ManualVelocitySmoothingXYTest.cpp, TEST_F(ManualVelocitySmoothingXYTest,
    getCurrentState): after setCurrentVelocity((11, 13)) on a new object, jerk and acceleration
    are zero, the velocity is (11, 13) and the (locked) position is zero."""
    smoothing = ManualVelocitySmoothingXY()
    smoothing.set_current_velocity((11.0, 13.0))
    j_end = (*smoothing.j, 0.0)
    a_end = (*smoothing.a, 0.0)
    v_end = (*smoothing.v, 0.0)
    x_end = (*smoothing.position_locked, 0.0)
    assert matrix_eq(j_end, (0.0, 0.0, 0.0))
    assert matrix_eq(a_end, (0.0, 0.0, 0.0))
    assert matrix_eq(v_end, (11.0, 13.0, 0.0))
    assert matrix_eq(x_end, (0.0, 0.0, 0.0))
