"""PX4's own unit tests of the multicopter attitude controller, the rate controller and the
control allocation, run against CORNET's controllers (vehicles/control).

Each test is one PX4 ``TEST()`` (or ``TEST_F``), named after it, with PX4's inputs, expected
numbers and tolerances (gtest's EXPECT_EQ on PX4 matrix types compares within 1e-4; EXPECT_NEAR
within the tolerance it names). The PX4 version is v1.15's (the one CORNET follows); where the
stored PX4 source is newer, its tests for later features are listed below, not reproduced.

PX4 files:
- src/modules/mc_att_control/AttitudeControl/AttitudeControlTest.cpp (AttitudeControl.cpp)
- src/lib/rate_control/rate_control_test.cpp (rate_control.cpp)
- src/modules/control_allocator/ControlAllocation/ControlAllocationSequentialDesaturationTest.cpp
  (ControlAllocationSequentialDesaturation.cpp, MC_AIRMODE 0), ControlAllocationPseudoInverseTest.cpp
  (ControlAllocationPseudoInverse.cpp)
- src/modules/control_allocator/ActuatorEffectiveness/ActuatorEffectivenessRotorsTest.cpp

How PX4's allocation tests map onto CORNET's mixer: PX4 allocates a 6-axis control setpoint
(roll, pitch, yaw, thrust x, y, z) through its allocation matrix; CORNET's ``mix_into`` takes
the roll, pitch and yaw columns as rows and the collective thrust as one number per motor. The
tests build PX4's matrix with CORNET's ``pseudo_inverse_mix`` (not normalized, as the tests'
``UPDATE_NORMALIZATION_SCALE`` false) and pass ``thrust z · thrust column`` as that number: the
quad-x thrust column is the same for every motor (-0.25), and desaturating along a uniform
column is the same whatever its length. PX4's tests also check that actuators 5..16 stay 0;
CORNET's mixer has only the vehicle's four.

Not reproduced (PX4 tests of features v1.15 and CORNET do not have, or other airframes):
- AttitudeControlTest.cpp, fixture AttitudeControlFeedforwardTest (ConstantSetpointGivesNo-
  Feedforward, RollRampProducesRollFeedforward, PitchRampProducesPitchFeedforward,
  HighRateRampStillExact, YawRampOnlyAnalyticalFeedforwardContributes, TiltedYawDoesNotDouble-
  Count, FeedForwardDisabledSuppressesContribution, UnlockedYawDoesNotFeedBackSlavedHeading,
  LockedYawRampStillFeedsForward, TiltedUnlockedYawUsesCommandedRateOnly, CommandedYawRateFed-
  ForwardWhenFFDisabled, FractionalGainDoesNotWeakenCommandedYaw, FractionalGainScales-
  Anticipation and the rest of that fixture): the attitude reference model and its rate
  feed-forward (setRefModelFrequency, MC_REF_FF) came after v1.15; v1.15's controller feeds
  forward only the yaw-rate setpoint, as CORNET's does.
- rate_control_test.cpp: NothingRefusedKeepsFullIntegratorLimit, RefusedPositiveFraction-
  LowersIntegratorCeiling, RefusedNegativeFractionRaisesIntegratorFloor, RefusalLeaves-
  OppositeSignTrimUntouched, RefusalExceedingTheRequestDoesNotFlipIntegratorSign,
  IntegratorRecoversWhenRefusalClears, ReportsIntegratorLimits, ResetIntegralClearsRefused-
  Fraction: the refused-torque-fraction integrator limit (setRefusedTorqueFraction) came after
  v1.15, whose integrator stops on the allocator's saturation flags, as CORNET's does.
  gain_compression_test.cpp: gain compression came after v1.15 too.
- ActuatorEffectivenessRotorsTest.cpp Tilt: tilted rotor axes (tiltrotors); CORNET's rotors
  all push along body -z.
- ControlAllocationSimpleTest.cpp, ControlAllocationMultirotorTest.cpp, ActuatorEffectiveness-
  HelicopterTest.cpp, ActuatorEffectivenessMultirotorTest.cpp: other allocation methods (the
  multicopter one after v1.15) and airframes; CORNET has the sequential desaturation of a
  multicopter with MC_AIRMODE 0 only.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehicles.control.attitude_control import AttitudeControl, AttitudeControlGains
from vehicles.control.mixer import (
    mix_into,
    mixer_rows_with_effectiveness,
    pseudo_inverse_mix,
    rotor_effectiveness,
)
from vehicles.control.quat import Quat, Vec3, q_canonical, q_mul, q_normalized
from vehicles.control.rate_control import RateControl, RateControlGains

IDENTITY: Quat = (1.0, 0.0, 0.0, 0.0)
MATRIX_EQ_TOL = 1e-4  # PX4 matrix's operator==: every element within 1e-4


def attitude_control(p: Vec3, yaw_weight: float, rate_limit: Vec3) -> AttitudeControl:
    """AttitudeControl after setProportionalGain(p, yaw_weight) and setRateLimit(rate_limit)."""
    return AttitudeControl(AttitudeControlGains(
        p_roll=p[0], p_pitch=p[1], p_yaw=p[2], yaw_weight=yaw_weight,
        rate_max_frd_radps=rate_limit))


def q_from_axis_angle(v: Vec3) -> Quat:
    """matrix::Quatf(AxisAnglef(v)): rotation by |v| about v (identity for a zero vector)."""
    angle = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if angle < 1e-12:
        return IDENTITY
    s = math.sin(angle / 2.0) / angle
    return (math.cos(angle / 2.0), v[0] * s, v[1] * s, v[2] * s)


def norm3(v: Vec3) -> float:
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


# --- AttitudeControlTest.cpp ---------------------------------------------------------------


def test_AttitudeControlTest_AllZeroCase():
    """PX4 AttitudeControlTest.cpp, TEST(AttitudeControlTest, AllZeroCase): a default controller
    (zero gains and rate limits, identity setpoint) at identity gives a zero rate setpoint."""
    control = attitude_control((0.0, 0.0, 0.0), 0.0, (0.0, 0.0, 0.0))
    assert control.update(IDENTITY, IDENTITY) == pytest.approx((0.0, 0.0, 0.0), abs=MATRIX_EQ_TOL)


ATTITUDES: tuple[Quat, ...] = (
    (1.0, 0.0, 0.0, 0.0),
    (0.0, 1.0, 0.0, 0.0),
    (0.0, 0.0, 1.0, 0.0),
    (0.0, 0.0, 0.0, 1.0),
    (0.698, 0.024, -0.681, -0.220),
    (-0.820, -0.313, 0.225, -0.423),
    (0.599, -0.172, 0.755, -0.204),
    (0.216, -0.662, 0.290, -0.656),
)


@pytest.mark.parametrize("goal", range(len(ATTITUDES)))
@pytest.mark.parametrize("start", range(len(ATTITUDES)))
def test_AttitudeControlConvergenceTest_AttitudeControlConvergence(start, goal):
    """PX4 AttitudeControlTest.cpp, TEST_F(AttitudeControlConvergenceTest,
    AttitudeControlConvergence): gains (0.5, 0.6, 0.3), yaw weight 0.4, rate limit 100; from
    each of eight attitudes to each of them, the state rotated by the rate setpoint (as an
    axis-angle) and negated (antipodal states: no unwinding) every step; the rate setpoint must
    shrink at every step until it no longer does, within 100 steps, and the state must then
    equal the goal."""
    control = attitude_control((0.5, 0.6, 0.3), 0.4, (100.0, 100.0, 100.0))
    state = q_normalized(ATTITUDES[start])
    goal_q = q_normalized(ATTITUDES[goal])
    rate_sp: Vec3 = (1000.0, 1000.0, 1000.0)
    steps_left = 100
    while steps_left > 0:
        rate_sp_new = control.update(state, goal_q)
        state = q_mul(state, q_from_axis_angle(rate_sp_new))
        state = (-state[0], -state[1], -state[2], -state[3])
        if norm3(rate_sp_new) >= norm3(rate_sp):
            break
        rate_sp = rate_sp_new
        steps_left -= 1
    assert q_canonical(state) == pytest.approx(q_canonical(goal_q), abs=MATRIX_EQ_TOL)
    assert steps_left > 0


def test_AttitudeControlTest_YawWeightScaling():
    """PX4 AttitudeControlTest.cpp, TEST(AttitudeControlTest, YawWeightScaling): a pure 0.1 rad
    yaw setpoint with gains (6.5, 6.5, 2.8) and yaw weight 0.4 gives no roll/pitch rate and
    0.1 · 2.8 yaw rate (the yaw weight is compensated in the gain); yaw weight 0 gives no rate
    at all (and no NaN)."""
    yaw_gain, yaw_sp = 2.8, 0.1
    pure_yaw = (math.cos(yaw_sp / 2.0), 0.0, 0.0, math.sin(yaw_sp / 2.0))
    limit = (1000.0, 1000.0, 1000.0)
    rates = attitude_control((6.5, 6.5, yaw_gain), 0.4, limit).update(IDENTITY, pure_yaw)
    assert rates[:2] == pytest.approx((0.0, 0.0), abs=MATRIX_EQ_TOL)
    assert rates[2] == pytest.approx(yaw_sp * yaw_gain, abs=1e-4)
    rates = attitude_control((6.5, 6.5, yaw_gain), 0.0, limit).update(IDENTITY, pure_yaw)
    assert rates == pytest.approx((0.0, 0.0, 0.0), abs=MATRIX_EQ_TOL)


# --- rate_control_test.cpp -------------------------------------------------------------------


def test_RateControlTest_AllZeroCase():
    """PX4 rate_control_test.cpp, TEST(RateControlTest, AllZeroCase): a default rate controller
    (zero gains) with zero rate, setpoint and angular acceleration, dt 0, not landed, gives zero
    torque."""
    zero = (0.0, 0.0, 0.0)
    control = RateControl(RateControlGains(p=zero, i=zero, d=zero, ff=zero, int_lim=zero))
    torque = control.update(0.0, zero, zero, landed=False)
    assert torque == pytest.approx(zero, abs=MATRIX_EQ_TOL)


# --- ActuatorEffectivenessRotorsTest.cpp, ControlAllocationPseudoInverseTest.cpp ------------

# make_quad_x_geometry of PX4's allocation tests: (CA_ROTORn_PX, _PY, _KM), axis -z, CT 1.
QUAD_X = ((1.0, 1.0, 0.05), (-1.0, -1.0, 0.05), (1.0, -1.0, -0.05), (-1.0, 1.0, -0.05))


def test_ActuatorEffectivenessRotors_AllZeroCase():
    """PX4 ActuatorEffectivenessRotorsTest.cpp, TEST(ActuatorEffectivenessRotors, AllZeroCase):
    the effectiveness of the wide quad-x geometry."""
    expected = np.array([
        [-1.0, 1.0, 1.0, -1.0],
        [1.0, -1.0, 1.0, -1.0],
        [0.05, 0.05, -0.05, -0.05],
        [0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0],
        [-1.0, -1.0, -1.0, -1.0],
    ])
    np.testing.assert_allclose(rotor_effectiveness(QUAD_X), expected, rtol=0, atol=MATRIX_EQ_TOL)


@pytest.mark.parametrize("normalize", [False, True])
def test_ControlAllocationTest_AllZeroCase(normalize):
    """PX4 ControlAllocationPseudoInverseTest.cpp, TEST(ControlAllocationTest, AllZeroCase): a
    zero 6 × 16 effectiveness and a zero control setpoint give zero actuator setpoints and zero
    allocated control (with or without the normalization, which must not divide by zero)."""
    effectiveness = np.zeros((6, 16))
    mix = pseudo_inverse_mix(effectiveness, normalize=normalize)
    actuator_sp = mix @ np.zeros(6)
    np.testing.assert_allclose(actuator_sp, np.zeros(16), rtol=0, atol=MATRIX_EQ_TOL)
    np.testing.assert_allclose(effectiveness @ actuator_sp, np.zeros(6), rtol=0,
                               atol=MATRIX_EQ_TOL)


# --- ControlAllocationSequentialDesaturationTest.cpp ----------------------------------------

EXPECT_NEAR_TOL = 1e-4


def allocate(roll: float, pitch: float, yaw: float, thrust_z: float) -> np.ndarray:
    """setup_quad_allocator + allocate() with MC_AIRMODE 0 (module docstring: the mapping)."""
    mix = pseudo_inverse_mix(rotor_effectiveness(QUAD_X), normalize=False)
    assert mix[:, 5] == pytest.approx([mix[0, 5]] * len(mix), abs=1e-9)  # a uniform column
    rows = mixer_rows_with_effectiveness(mix[:, 0], mix[:, 1], mix[:, 2])
    out = np.zeros(len(rows))
    mix_into(float(mix[0, 5]) * thrust_z, roll, pitch, yaw, rows, 0.0, out)
    return out


def test_ControlAllocationSequentialDesaturationTest_AirmodeDisabledOnlyYaw():
    """PX4 ControlAllocationSequentialDesaturationTest.cpp, TEST(..., AirmodeDisabledOnlyYaw):
    yaw 1 at zero thrust allocates nothing."""
    assert allocate(0.0, 0.0, 1.0, 0.0) == pytest.approx((0.0,) * 4, abs=MATRIX_EQ_TOL)


def test_ControlAllocationSequentialDesaturationTest_AirmodeDisabledThrustZ():
    """PX4 ControlAllocationSequentialDesaturationTest.cpp, TEST(..., AirmodeDisabledThrustZ):
    thrust z -0.75 gives each of the four motors 0.75 / 4."""
    thrust_z_total = -0.75
    out = allocate(0.0, 0.0, 0.0, thrust_z_total)
    assert out == pytest.approx((-thrust_z_total / 4,) * 4, abs=EXPECT_NEAR_TOL)


def test_ControlAllocationSequentialDesaturationTest_AirmodeDisabledThrustAndYaw():
    """PX4 ControlAllocationSequentialDesaturationTest.cpp, TEST(..., AirmodeDisabledThrustAnd-
    Yaw): thrust z -0.75 and yaw 0.02 (not saturating): motors 1, 2 get 0.75 / 4 + 0.02 · 5,
    motors 3, 4 0.75 / 4 − 0.02 · 5 (5: the geometry's yaw effectiveness factor)."""
    thrust_z_total, yaw_sp = -0.75, 0.02
    out = allocate(0.0, 0.0, yaw_sp, thrust_z_total)
    high = -thrust_z_total / 4 + yaw_sp * 5.0
    low = -thrust_z_total / 4 - yaw_sp * 5.0
    assert out == pytest.approx((high, high, low, low), abs=EXPECT_NEAR_TOL)


def test_ControlAllocationSequentialDesaturationTest_AirmodeDisabledThrustAndSaturatedYaw():
    """PX4 ControlAllocationSequentialDesaturationTest.cpp, TEST(..., AirmodeDisabledThrustAnd-
    SaturatedYaw): thrust z -0.75 and yaw 0.25 (saturating, thrust not reduced): motors 1, 2
    carry all the thrust, 0.75 / 2 each, motors 3, 4 nothing."""
    thrust_z_total = -0.75
    out = allocate(0.0, 0.0, 0.25, thrust_z_total)
    half = -thrust_z_total / 2
    assert out == pytest.approx((half, half, 0.0, 0.0), abs=EXPECT_NEAR_TOL)


def test_ControlAllocationSequentialDesaturationTest_AirmodeDisabledThrustAndPitch():
    """PX4 ControlAllocationSequentialDesaturationTest.cpp, TEST(..., AirmodeDisabledThrustAnd-
    Pitch): thrust z -0.75 and pitch 0.1 (not saturating): front motors (1, 3) 0.75 / 4 +
    0.1 / 4, rear motors (2, 4) 0.75 / 4 − 0.1 / 4."""
    thrust_z_total, pitch_sp = -0.75, 0.1
    out = allocate(0.0, pitch_sp, 0.0, thrust_z_total)
    high = -thrust_z_total / 4 + pitch_sp / 4
    low = -thrust_z_total / 4 - pitch_sp / 4
    assert out == pytest.approx((high, low, high, low), abs=EXPECT_NEAR_TOL)


def test_ControlAllocationSequentialDesaturationTest_AirmodeDisabledReducedThrustAndYaw():
    """PX4 ControlAllocationSequentialDesaturationTest.cpp, TEST(..., AirmodeDisabledReduced-
    ThrustAndYaw): 0.8 thrust per motor and yaw 1 (saturating): yaw may use 15 % above the top
    (ControlAllocationSequentialDesaturation::MINIMUM_YAW_MARGIN, v1.15) and thrust is then
    reduced by that margin: motors 1, 2 at 0.8 + 0.35 − 0.15, motors 3, 4 at 0.8 − 0.35 − 0.15
    (0.35 = 1 + 0.15 − 0.8)."""
    per_motor, margin = 0.8, 0.15
    out = allocate(0.0, 0.0, 1.0, -per_motor * 4)
    yaw_diff = 1.0 + margin - per_motor
    high = per_motor + yaw_diff - margin
    low = per_motor - yaw_diff - margin
    assert out == pytest.approx((high, high, low, low), abs=EXPECT_NEAR_TOL)


def test_ControlAllocationSequentialDesaturationTest_AirmodeDisabledReducedThrustAndPitch():
    """PX4 ControlAllocationSequentialDesaturationTest.cpp, TEST(..., AirmodeDisabledReduced-
    ThrustAndPitch): thrust z -3 (0.75 per motor) and pitch 2 (saturating): thrust is reduced
    by the front motors' overage 0.75 + 0.5 − 1, the pitch difference kept."""
    thrust_z_total, pitch_sp = -0.75 * 4, 2.0
    out = allocate(0.0, pitch_sp, 0.0, thrust_z_total)
    overage = -thrust_z_total / 4 + pitch_sp / 4 - 1.0
    assert overage > 0.0
    high = -thrust_z_total / 4 + pitch_sp / 4 - overage
    low = -thrust_z_total / 4 - pitch_sp / 4 - overage
    assert out == pytest.approx((high, low, high, low), abs=EXPECT_NEAR_TOL)
