"""PX4's own unit tests of its manual-flight stick utilities, run against ours.

Sources (PX4 v1.15, PX4/PX4-Autopilot):

- ``src/modules/flight_mode_manager/tasks/Utility/StickTiltXYTest.cpp`` (added with the fix for
  PX4 issue #22714, PR #22769, February 2024, so part of v1.15): the tilt that Altitude mode's
  roll/pitch sticks ask for, as a horizontal acceleration. Ours lives in
  ``ManualAltitude.update`` (vehicles/manual_control.py), the port of FlightTaskManualAltitude
  with its StickTiltXY; the acceleration is the setpoint's ``acceleration_ned_mps2``. PX4's test
  calls ``generateAccelerationSetpoints(stick_xy, dt, yaw=0, yaw_setpoint=0)``; here the task is
  activated at heading 0 with a centred yaw stick, so it rotates by the same yaw setpoint 0.
  MC_MAN_TILT_TAU is PX4's default, 0 (no filter), as in PX4's test.
- ``src/lib/mathlib/math/FunctionsTest.cpp``: the stick shaping functions (``expo``,
  ``superexpo``, ``deadzone``, ``expo_deadzone``) and the two helpers our manual modes use:
  ``interpolate`` (ours ``gradual``: the slow-down near the ground in Altitude and Position
  modes) and ``sqrt_linear`` (the drag of StickAccelerationXY in Position mode).

Comparisons as gtest and PX4's matrix library make them: ``EXPECT_FLOAT_EQ`` within 4 float32
ULPs (``float_eq``), ``EXPECT_NEAR`` within its bound, ``EXPECT_EQ`` of two ``Vector2f`` every
element within 1e-4 (matrix's ``operator==``). Inputs are PX4's float literals as float32.

Not reproduced (no counterpart in CORNET's manual flight):

- ``FunctionsTest.signNoZero``, ``signFromBool``, ``interpolateNXY``, ``lerp``,
  ``countSetBits``, ``countTrailingZeros``, ``isFiniteVector3f``, ``negate``: general mathlib
  helpers that none of CORNET's stick handling uses (Sticks.cpp, StickYaw, StickTiltXY and
  StickAccelerationXY use only the functions tested here).
- Sticks.cpp, StickYaw.cpp and StickAccelerationXY.cpp have no unit test in PX4; nor have the
  ManualAcceleration, ManualAltitude and ManualPosition flight tasks in v1.15. (The index holds
  a ``ManualAltitude/AccSpExternalTest.cpp`` for an external acceleration setpoint topic,
  ``acc_sp_external``, that PX4 v1.15 does not have; its tests check a helper defined in the
  test file itself, not the flight task.)
"""

from __future__ import annotations

import math

import numpy as np

from tests.unit.test_px4_position_control_tests import f32, float_eq, matrix_eq
from vehicles.manual_control import (
    ManualAltitude,
    Sticks,
    _sqrt_linear,
    deadzone,
    expo,
    expo_deadzone,
    gradual,
    superexpo,
)
from vehicles.params import ParamStore

ONE_G = float(np.float32(9.80665))  # CONSTANTS_ONE_G
SQRT2 = math.sqrt(2.0)  # M_SQRT2_F
ZERO3 = (0.0, 0.0, 0.0)


# --- StickTiltXYTest.cpp -------------------------------------------------------------------------
def _tilt(task: ManualAltitude, stick_xy: tuple[float, float], dt: float) -> tuple[float, float]:
    """generateAccelerationSetpoints(stick_xy, dt, yaw 0, yaw setpoint 0): stick x is pitch
    (forward +), y roll (right +)."""
    sp = task.update(dt, Sticks(pitch=stick_xy[0], roll=stick_xy[1]), ZERO3, ZERO3, 0.0, ZERO3)
    return sp.acceleration_ned_mps2[0], sp.acceleration_ned_mps2[1]


def _task(overrides: dict[str, float] | None = None) -> ManualAltitude:
    task = ManualAltitude(ParamStore(overrides))
    task.activate(ZERO3, ZERO3, 0.0)
    return task


def test_StickTiltXYTest_AllZeroCase():
    """StickTiltXYTest.cpp, TEST(StickTiltXYTest, AllZeroCase): no stick, dt 0 → no
    acceleration."""
    assert matrix_eq(_tilt(_task(), (0.0, 0.0), 0.0), (0.0, 0.0))


def test_StickTiltXYTest_NormalRollPitchCases():
    """StickTiltXYTest.cpp, TEST(StickTiltXYTest, NormalRollPitchCases): MPC_MAN_TILT_MAX 45°,
    so full stick is 1 g; half stick half of it; full diagonal stick is limited to unit length
    (g/√2 on each axis)."""
    task = _task({"MPC_MAN_TILT_MAX": 45.0})
    cases = [
        # pitch
        ((1.0, 0.0), (ONE_G, 0.0)),
        ((0.5, 0.0), (ONE_G / 2.0, 0.0)),
        ((-0.5, 0.0), (-ONE_G / 2.0, 0.0)),
        ((-1.0, 0.0), (-ONE_G, 0.0)),
        # roll
        ((0.0, 1.0), (0.0, ONE_G)),
        ((0.0, 0.5), (0.0, ONE_G / 2.0)),
        ((0.0, -0.5), (0.0, -ONE_G / 2.0)),
        ((0.0, -1.0), (0.0, -ONE_G)),
        # roll & pitch
        ((1.0, 1.0), (ONE_G / SQRT2, ONE_G / SQRT2)),
        ((1.0, -1.0), (ONE_G / SQRT2, -ONE_G / SQRT2)),
        ((-1.0, 1.0), (-ONE_G / SQRT2, ONE_G / SQRT2)),
        ((-1.0, -1.0), (-ONE_G / SQRT2, -ONE_G / SQRT2)),
    ]
    for stick, expected in cases:
        acc = _tilt(task, stick, 1.0)
        assert matrix_eq(acc, expected), (stick, acc, expected)


def test_StickTiltXYTest_90degreeCase():
    """StickTiltXYTest.cpp, TEST(StickTiltXYTest, 90degreeCase): MPC_MAN_TILT_MAX 90° → zero
    stick still gives zero, full stick at most 3 g sideways (not tan 90°)."""
    task = _task({"MPC_MAN_TILT_MAX": 90.0})
    assert matrix_eq(_tilt(task, (0.0, 0.0), 1.0), (0.0, 0.0))
    acc = _tilt(task, (1.0, 0.0), 1.0)
    assert matrix_eq(acc, (3.0 * ONE_G, 0.0)), acc


# --- FunctionsTest.cpp ---------------------------------------------------------------------------
def _check(fn, cases) -> None:
    for args, expected in cases:
        got = fn(*(f32(a) for a in args))
        assert float_eq(got, f32(expected)), (fn.__name__, args, got, expected)


def test_FunctionsTest_expo():
    """FunctionsTest.cpp, TEST(FunctionsTest, expo)."""
    _check(expo, [
        # input value limits
        ((-12.0, 0.5), -1.0), ((-1.0, 0.5), -1.0), ((0.0, 0.5), 0.0), ((1.0, 0.5), 1.0),
        ((45.0, 0.5), 1.0),
        # expo parameter limits
        ((0.1, 0.0), 0.1), ((0.1, -12.0), 0.1), ((0.1, 1.0), 0.001), ((0.1, 12.0), 0.001),
        # in range
        ((0.1, 0.5), 0.0505), ((-0.2, 0.5), -0.104), ((0.3, 0.7), 0.1089), ((-0.4, 0.9), -0.0976),
    ])


def test_FunctionsTest_superexpo():
    """FunctionsTest.cpp, TEST(FunctionsTest, superexpo)."""
    _check(superexpo, [
        # input value limits
        ((-12.0, 0.5, 0.5), -1.0), ((-1.0, 0.5, 0.5), -1.0), ((0.0, 0.5, 0.5), 0.0),
        ((1.0, 0.5, 0.5), 1.0), ((45.0, 0.5, 0.5), 1.0),
        # superexpo parameter limits
        ((0.1, 0.0, 0.0), 0.1), ((0.1, 0.0, -12.0), 0.1),
        # in range
        ((0.5, 0.0, 0.5), 0.33333333333), ((-0.2, 0.5, 0.5), -0.057777781),
        ((0.3, 0.7, 0.5), 0.064058825), ((-0.4, 0.9, 0.5), -0.061000008),
    ])
    # EXPECT_NEAR(..., 1e-8): g at and beyond its 0.99 limit
    for g in (0.99, 12.0):
        assert abs(superexpo(f32(0.1), 0.0, f32(g)) - 0.0011098779134295227) <= 1e-8


def test_FunctionsTest_deadzone():
    """FunctionsTest.cpp, TEST(FunctionsTest, deadzone)."""
    _check(deadzone, [
        # input value limits
        ((-12.0, 0.5), -1.0), ((-1.0, 0.5), -1.0), ((0.0, 0.5), 0.0), ((1.0, 0.5), 1.0),
        ((45.0, 0.5), 1.0),
        # deadzone parameter limits
        ((0.1, 0.0), 0.1), ((0.1, -12.0), 0.1), ((0.1, 1.0), 0.0), ((0.1, 12.0), 0.0),
        # in range
        ((0.1, 0.0), 0.1), ((0.1, 0.1), 0.0), ((0.2, 0.1), 0.1111111111), ((-0.2, 0.5), 0.0),
        ((0.7, 0.3), 0.57142854), ((-0.9, 0.4), -0.83333325),
    ])


def test_FunctionsTest_expo_deadzone():
    """FunctionsTest.cpp, TEST(FunctionsTest, expo_deadzone)."""
    _check(expo_deadzone, [
        # input value limits
        ((-12.0, 0.5, 0.5), -1.0), ((-1.0, 0.5, 0.5), -1.0), ((0.0, 0.5, 0.5), 0.0),
        ((1.0, 0.5, 0.5), 1.0), ((45.0, 0.5, 0.5), 1.0),
        # in range
        ((0.5, 0.0, 0.5), 0.0), ((-0.5, 0.5, 0.2), -0.21386719), ((0.5, 0.7, 0.3), 0.10204081),
        ((-0.5, 0.9, 0.4), -0.020833336),
    ])


def test_FunctionsTest_interpolate():
    """FunctionsTest.cpp, TEST(FunctionsTest, interpolate): math::interpolate is our
    ``gradual``."""
    _check(gradual, [
        # factor of *2, offset +1
        ((-12.0, 0.0, 1.0, 1.0, 3.0), 1.0), ((0.0, 0.0, 1.0, 1.0, 3.0), 1.0),
        ((0.25, 0.0, 1.0, 1.0, 3.0), 1.5), ((0.5, 0.0, 1.0, 1.0, 3.0), 2.0),
        ((0.75, 0.0, 1.0, 1.0, 3.0), 2.5), ((1.0, 0.0, 1.0, 1.0, 3.0), 3.0),
        ((12.0, 0.0, 1.0, 1.0, 3.0), 3.0),
        # factor of *2, offset +3
        ((-12.0, 1.0, 2.0, 4.0, 6.0), 4.0), ((1.0, 1.0, 2.0, 4.0, 6.0), 4.0),
        ((1.25, 1.0, 2.0, 4.0, 6.0), 4.5), ((1.5, 1.0, 2.0, 4.0, 6.0), 5.0),
        ((1.75, 1.0, 2.0, 4.0, 6.0), 5.5), ((2.0, 1.0, 2.0, 4.0, 6.0), 6.0),
        ((12.0, 1.0, 2.0, 4.0, 6.0), 6.0),
        # corner cases: x_low == x_high == value; x_low > x_high; y_low > y_high; all zero
        ((1.0, 1.0, 1.0, 4.0, 6.0), 4.0), ((1.05, 1.1, 1.0, 4.0, 6.0), 4.0),
        ((1.5, 1.0, 2.0, 6.0, 4.0), 5.0), ((0.0, 0.0, 0.0, 0.0, 0.0), 0.0),
    ])


def test_FunctionsTest_sqrt_linear():
    """FunctionsTest.cpp, TEST(FunctionsTest, sqrt_linear)."""
    _check(_sqrt_linear, [
        ((-12.0,), 0.0), ((-2.0,), 0.0), ((0.0,), 0.0), ((0.5,), 0.70710678), ((1.0,), 1.0),
        ((2.0,), 2.0), ((120.0,), 120.0),
    ])
