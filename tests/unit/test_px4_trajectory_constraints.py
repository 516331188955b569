"""PX4's own unit tests of TrajectoryConstraints.hpp, run against ours.

Source (PX4 v1.15): ``src/lib/motion_planning/TrajectoryConstraintsTest.cpp``. PX4's
``math::trajectory`` functions live in ours in ``vehicles/control/position_smoothing.py`` (the
speed planning of PositionSmoothing):

- ``computeXYSpeedFromWaypoints<N>(waypoints, config)``: ``xy_speed_from_waypoints(waypoints,
  cfg)`` with a ``DynamicLimits`` (PX4's ``VehicleDynamicLimits``, the same six fields);
- ``clampToXYNorm(vec, max)`` / ``clampToZNorm(vec, max)``: ``_clamp_to_norm(v0, v1, v2, norm,
  max, z)``, given the xy norm (``hypot(x, y)``) or the z norm (``|z|``) as its caller in
  PositionSmoothing gives them. Ours has PositionSmoothing's ``accuracy`` of 0.5 built in where
  PX4's tests use the default, FLT_EPSILON; in every case below both accuracies pick the same
  branch (where a vector is scaled down, its clamped part's norm is at least 1).

The fixture (TrajectoryConstraintsTest::SetUp): vehicle at (10, 10, 5), target (20, 10, 5),
next target (20, 20, 5); z acceptance radius 1 m, xy acceptance radius 0.99 m,
acceleration 3 m/s², jerk 10 m/s³, speed 10 m/s, radius scale 0.8. Float literals are PX4's,
as float32 (``f32``).

Comparisons: ``EXPECT_FLOAT_EQ`` within 4 float32 ULPs (``float_eq``); ``EXPECT_GT``/``LT`` as
written (the factors are PX4's float literals); ``EXPECT_EQ``/``==`` of two ``Vector3f`` every
element within 1e-4 (matrix's ``operator==``, ``matrix_eq``).
"""

from __future__ import annotations

import math
from dataclasses import replace

from tests.unit.test_px4_position_control_tests import f32, float_eq, matrix_eq
from vehicles.control.position_smoothing import (
    DynamicLimits,
    _clamp_to_norm,
    xy_speed_from_waypoints,
)
from vehicles.types import Vec3

NAN = math.nan
CONFIG = DynamicLimits(z_accept_rad=1.0, xy_accept_rad=f32(0.99), max_acc_xy=3.0,
                       max_jerk=10.0, max_speed_xy=10.0, max_acc_xy_radius_scale=f32(0.8))
VEHICLE: Vec3 = (10.0, 10.0, 5.0)
TARGET: Vec3 = (20.0, 10.0, 5.0)
NEXT_TARGET: Vec3 = (20.0, 20.0, 5.0)


def _add(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _scale(k: float, a: Vec3) -> Vec3:
    return (k * a[0], k * a[1], k * a[2])


def _dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _straight(fraction: float) -> tuple[Vec3, Vec3]:
    """The straight-line tests' GIVEN: ``next_target = target + 2 (target - vehicle)``, then
    ``target = vehicle + fraction (next_target - vehicle)``."""
    next_target = _add(TARGET, _scale(2.0, _sub(TARGET, VEHICLE)))
    target = _add(VEHICLE, _scale(fraction, _sub(next_target, VEHICLE)))
    return target, next_target


def clamp_to_xy_norm(vec: Vec3, max_xy_norm: float) -> Vec3:
    return _clamp_to_norm(*vec, math.hypot(vec[0], vec[1]), max_xy_norm, False)


def clamp_to_z_norm(vec: Vec3, max_z_norm: float) -> Vec3:
    return _clamp_to_norm(*vec, abs(vec[2]), max_z_norm, True)


# --- TrajectoryConstraintsTest ---------------------------------------------------------------
def test_TrajectoryConstraintsTest_testStraight():
    """TrajectoryConstraintsTest.cpp, TEST_F(TrajectoryConstraintsTest, testStraight): through a
    waypoint halfway on a straight line, the speed is the speed straight to the end."""
    target, next_target = _straight(0.5)
    through = xy_speed_from_waypoints([VEHICLE, target, next_target], CONFIG)
    direct = xy_speed_from_waypoints([VEHICLE, next_target], CONFIG)
    assert float_eq(through, direct)


def test_TrajectoryConstraintsTest_testStraightNaN():
    """TrajectoryConstraintsTest.cpp, TEST_F(TrajectoryConstraintsTest, testStraightNaN): with
    the next waypoint's x and y NaN, the speed is the speed to (a stop at) the target."""
    target, next_target = _straight(0.5)
    next_target = (NAN, NAN, next_target[2])
    through = xy_speed_from_waypoints([VEHICLE, target, next_target], CONFIG)
    direct = xy_speed_from_waypoints([VEHICLE, target], CONFIG)
    assert float_eq(through, direct)


def test_TrajectoryConstraintsTest_testStraightLowJerkClose():
    """TrajectoryConstraintsTest.cpp, TEST_F(TrajectoryConstraintsTest,
    testStraightLowJerkClose): the waypoint at 5 % of the line, jerk 8: the speed straight to
    the end."""
    target, next_target = _straight(f32(0.05))
    config = replace(CONFIG, max_jerk=8.0)
    through = xy_speed_from_waypoints([VEHICLE, target, next_target], config)
    direct = xy_speed_from_waypoints([VEHICLE, next_target], config)
    assert float_eq(through, direct)


def test_TrajectoryConstraintsTest_testStraightMidClose():
    """TrajectoryConstraintsTest.cpp, TEST_F(TrajectoryConstraintsTest, testStraightMidClose):
    the waypoint at 5 % of the line: the speed straight to the end."""
    target, next_target = _straight(f32(0.05))
    through = xy_speed_from_waypoints([VEHICLE, target, next_target], CONFIG)
    direct = xy_speed_from_waypoints([VEHICLE, next_target], CONFIG)
    assert float_eq(through, direct)


def test_TrajectoryConstraintsTest_testStraightMidFar():
    """TrajectoryConstraintsTest.cpp, TEST_F(TrajectoryConstraintsTest, testStraightMidFar):
    the waypoint at 95 % of the line: the speed straight to the end."""
    target, next_target = _straight(f32(0.95))
    through = xy_speed_from_waypoints([VEHICLE, target, next_target], CONFIG)
    direct = xy_speed_from_waypoints([VEHICLE, next_target], CONFIG)
    assert float_eq(through, direct)


def test_TrajectoryConstraintsTest_test90Angle():
    """TrajectoryConstraintsTest.cpp, TEST_F(TrajectoryConstraintsTest, test90Angle): a 90°
    corner is passed slightly faster than a stop at it (less than 3 % faster)."""
    assert float_eq(0.0, _dot(_sub(VEHICLE, TARGET), _sub(TARGET, NEXT_TARGET)))
    through = xy_speed_from_waypoints([VEHICLE, TARGET, NEXT_TARGET], CONFIG)
    stop = xy_speed_from_waypoints([VEHICLE, TARGET], CONFIG)
    assert through > stop
    assert through < stop * f32(1.03)


def test_TrajectoryConstraintsTest_test45Angle():
    """TrajectoryConstraintsTest.cpp, TEST_F(TrajectoryConstraintsTest, test45Angle): a 45°
    corner (next target (25, 15, 5)): 3 % to 6 % faster than a stop."""
    through = xy_speed_from_waypoints([VEHICLE, TARGET, (25.0, 15.0, 5.0)], CONFIG)
    stop = xy_speed_from_waypoints([VEHICLE, TARGET], CONFIG)
    assert through > stop * f32(1.03)
    assert through < stop * f32(1.06)


def test_TrajectoryConstraintsTest_test10Angle():
    """TrajectoryConstraintsTest.cpp, TEST_F(TrajectoryConstraintsTest, test10Angle): a 10°
    corner (next target (30, 11.7, 5)): 25 % to 30 % faster than a stop."""
    through = xy_speed_from_waypoints([VEHICLE, TARGET, (30.0, f32(11.7), 5.0)], CONFIG)
    stop = xy_speed_from_waypoints([VEHICLE, TARGET], CONFIG)
    assert through > stop * f32(1.25)
    assert through < stop * f32(1.3)


def test_TrajectoryConstraintsTest_test10AngleFarNext():
    """TrajectoryConstraintsTest.cpp, TEST_F(TrajectoryConstraintsTest, test10AngleFarNext):
    the 10° corner with the next waypoint twice as far: the same speed (the turn is the
    bottleneck)."""
    near: Vec3 = (30.0, f32(11.7), 5.0)
    far = _add(_scale(2.0, _sub(near, TARGET)), TARGET)
    far_speed = xy_speed_from_waypoints([VEHICLE, TARGET, far], CONFIG)
    close_speed = xy_speed_from_waypoints([VEHICLE, TARGET, near], CONFIG)
    assert float_eq(far_speed, close_speed)


def test_TrajectoryConstraintsTest_test10AngleCloseNext():
    """TrajectoryConstraintsTest.cpp, TEST_F(TrajectoryConstraintsTest, test10AngleCloseNext):
    the 10° corner with the next waypoint at a fifth of the distance: slower (the distance is
    the bottleneck)."""
    normal: Vec3 = (30.0, f32(11.7), 5.0)
    close = _add(_scale(f32(0.2), _sub(normal, TARGET)), TARGET)
    close_speed = xy_speed_from_waypoints([VEHICLE, TARGET, close], CONFIG)
    normal_speed = xy_speed_from_waypoints([VEHICLE, TARGET, normal], CONFIG)
    assert close_speed < normal_speed


# --- TrajectoryConstraintsClamp --------------------------------------------------------------
def test_TrajectoryConstraintsClamp_clampToXYNormNoEffectLarge():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp,
    clampToXYNormNoEffectLarge): (1, 2, 3) clamped on xy to 1000 is unchanged."""
    assert matrix_eq(clamp_to_xy_norm((1.0, 2.0, 3.0), 1000.0), (1.0, 2.0, 3.0))


def test_TrajectoryConstraintsClamp_clampToZNormNoEffect():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp, clampToZNormNoEffect):
    (1, 2, 3) clamped on z to 1000 is unchanged."""
    assert matrix_eq(clamp_to_z_norm((1.0, 2.0, 3.0), 1000.0), (1.0, 2.0, 3.0))


def test_TrajectoryConstraintsClamp_clampToXYNormNoEffectExact():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp,
    clampToXYNormNoEffectExact): (3, 4, 1) clamped on xy to exactly 5 is unchanged."""
    assert matrix_eq(clamp_to_xy_norm((3.0, 4.0, 1.0), 5.0), (3.0, 4.0, 1.0))


def test_TrajectoryConstraintsClamp_clampToZNormNoEffectExact():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp,
    clampToZNormNoEffectExact): (3, 4, -1) clamped on z to exactly 1 is unchanged."""
    assert matrix_eq(clamp_to_z_norm((3.0, 4.0, -1.0), 1.0), (3.0, 4.0, -1.0))


def test_TrajectoryConstraintsClamp_clampToXYNormHalf():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp, clampToXYNormHalf):
    (3, 4, 1) clamped on xy to 2.5: the whole vector halved."""
    assert matrix_eq(clamp_to_xy_norm((3.0, 4.0, 1.0), 2.5), (1.5, 2.0, 0.5))


def test_TrajectoryConstraintsClamp_clampToZNormHalf():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp, clampToZNormHalf):
    (3, 4, 10) clamped on z to 5: the whole vector halved."""
    assert matrix_eq(clamp_to_z_norm((3.0, 4.0, 10.0), 5.0), (1.5, 2.0, 5.0))


def test_TrajectoryConstraintsClamp_clampToXYNormZero():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp, clampToXYNormZero):
    (3, 4, 1) clamped on xy to 0 is zero."""
    assert matrix_eq(clamp_to_xy_norm((3.0, 4.0, 1.0), 0.0), (0.0, 0.0, 0.0))


def test_TrajectoryConstraintsClamp_clampToZNormZero():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp, clampToZNormZero):
    (3, 4, 1) clamped on z to 0 is zero."""
    assert matrix_eq(clamp_to_z_norm((3.0, 4.0, 1.0), 0.0), (0.0, 0.0, 0.0))


def test_TrajectoryConstraintsClamp_clampToXYNormVecZero():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp, clampToXYNormVecZero):
    the zero vector clamped on xy to 1 stays zero."""
    assert matrix_eq(clamp_to_xy_norm((0.0, 0.0, 0.0), 1.0), (0.0, 0.0, 0.0))


def test_TrajectoryConstraintsClamp_clampToZNormVecZero():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp, clampToZNormVecZero):
    the zero vector clamped on z to 1 stays zero."""
    assert matrix_eq(clamp_to_z_norm((0.0, 0.0, 0.0), 1.0), (0.0, 0.0, 0.0))


def test_TrajectoryConstraintsClamp_clampToXYNormVecZeroToZero():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp,
    clampToXYNormVecZeroToZero): the zero vector clamped on xy to 0 stays zero."""
    assert matrix_eq(clamp_to_xy_norm((0.0, 0.0, 0.0), 0.0), (0.0, 0.0, 0.0))


def test_TrajectoryConstraintsClamp_clampToZNormVecZeroToZero():
    """TrajectoryConstraintsTest.cpp, TEST(TrajectoryConstraintsClamp,
    clampToZNormVecZeroToZero): the zero vector clamped on z to 0 stays zero."""
    assert matrix_eq(clamp_to_z_norm((0.0, 0.0, 0.0), 0.0), (0.0, 0.0, 0.0))
