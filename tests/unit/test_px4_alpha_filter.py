"""PX4's own unit tests of AlphaFilter, run against ours.

Source (PX4 v1.15): ``src/lib/mathlib/math/test/AlphaFilterTest.cpp``, the test of
``AlphaFilter<T>`` (``src/lib/mathlib/math/filter/AlphaFilter.hpp``): ``state += alpha (sample -
state)``, alpha set directly or as ``dt / (tau + dt)`` (``setParameters(dt, tau)``), state 0
and alpha 0 when constructed.

CORNET's shared AlphaFilter is ``_lowpass(state, sample, dt, tau)`` in vehicles/manual_control.py
(the manual tasks' yaw-rate, tilt and brake-boost filters and the sticks' MovingDiff): one update
with alpha ``dt / max(tau + dt, 1e-3)``; the state is the caller's. PX4's calls map onto it as:

- ``setParameters(dt, tau)`` then ``update(x)``: ``_lowpass(state, x, dt, tau)``;
- ``setAlpha(a)``: the (dt, tau) that give that alpha: ``setAlpha(.1f)`` is dt 1, tau 9 (the
  "default time constant of 9 (alpha = 0.1)" of PX4's comments); the constructed filter's
  alpha 0 is dt 0 (any tau);
- ``getState()``: the state the caller keeps; a constructed filter's is 0.

Not reproduced (ours has no such thing):

- ``initializeToZero``, ``resetToValue`` and the reset half of ``convergenceVector3fTauDt``: ours
  has no filter object, so no state of its own to initialise or reset (``reset`` is the caller
  assigning its variable);
- ``SetFrequencyTest``: ours has no ``setCutoffFreq`` (no caller sets a filter by its cutoff);
- ``runPositiveRot3``, ``runNecgativeRot3``: ours has no AlphaFilter<Quatf> (the filter on the
  unit quaternions).

Comparisons as gtest makes them: ``ASSERT_EQ``/``EXPECT_FLOAT_EQ`` (``float32_eq``,
``float_eq``), ``ASSERT_NEAR``/``EXPECT_NEAR`` within PX4's bound, ``EXPECT_GE``/``LE`` as
written. Inputs are PX4's float literals as float32 (``f32``). Ours runs in double.
"""

from __future__ import annotations

from tests.unit.test_px4_position_control_tests import f32, float32_eq, float_eq
from vehicles.manual_control import _lowpass

ALPHA_01 = (1.0, 9.0)  # setAlpha(.1f): dt 1, tau 9
ALPHA_0 = (0.0, 0.0)  # the constructed filter's alpha 0


def run(state: float, sample: float, dt_tau: tuple[float, float], n: int) -> float:
    """``n`` updates with ``sample``."""
    dt, tau = dt_tau
    for _ in range(n):
        state = _lowpass(state, sample, dt, tau)
    return state


def test_AlphaFilterTest_runZero():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, runZero): a new filter run ten times on 0
    stays at 0."""
    assert float32_eq(run(0.0, 0.0, ALPHA_0, 10), 0.0)


def test_AlphaFilterTest_runPositive():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, runPositive): alpha 0.1, nine updates on 1:
    63 % (within 0.02)."""
    assert abs(run(0.0, 1.0, ALPHA_01, 9) - f32(0.63)) <= 0.02


def test_AlphaFilterTest_runNegative():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, runNegative): alpha 0.1, nine updates on -1:
    -63 % (within 0.02)."""
    assert abs(run(0.0, -1.0, ALPHA_01, 9) - f32(-0.63)) <= 0.02


def test_AlphaFilterTest_riseTime():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, riseTime): alpha 0.1, 27 updates (three time
    constants) on 1: 95 % (within 0.02)."""
    assert abs(run(0.0, 1.0, ALPHA_01, 3 * 9) - f32(0.95)) <= f32(0.02)


def test_AlphaFilterTest_convergence():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, convergence): alpha 0.1, 45 updates (five
    time constants) on 1: the input (within 0.01)."""
    assert abs(run(0.0, 1.0, ALPHA_01, 5 * 9) - 1.0) <= f32(0.01)


def test_AlphaFilterTest_convergenceVector3f():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, convergenceVector3f): (3, 7, -11), alpha 0.1,
    45 updates: the input (1 % allowed), each element filtered on its own."""
    for x in (3.0, 7.0, -11.0):
        assert abs(run(0.0, x, ALPHA_01, 5 * 9) - x) <= abs(f32(0.01) * x)


def test_AlphaFilterTest_convergenceVector3fAlpha():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, convergenceVector3fAlpha): (3, 7, -11),
    setParameters(dt 1, tau 18), 18 updates (one time constant): 63 % (2 % allowed)."""
    for x in (3.0, 7.0, -11.0):
        assert abs(run(0.0, x, (1.0, 18.0), 18) - f32(0.63) * x) <= abs(f32(0.02) * x)


def test_AlphaFilterTest_convergenceVector3fTauDt():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, convergenceVector3fTauDt): (51, 7, -11),
    setParameters(dt 0.1, tau 2), tau / dt = 20 updates: 63 % (2 % allowed). (The reset half
    is not reproduced, see the module docstring.)"""
    tau, dt = 2.0, f32(0.1)
    n = int(f32(tau / dt))  # the loop runs while i < n (20.0f)
    assert n == 20
    for x in (51.0, 7.0, -11.0):
        assert abs(run(0.0, x, (dt, tau), n) - f32(0.63) * x) <= abs(f32(0.02) * x)


def test_AlphaFilterTest_AllZeroTest():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, AllZeroTest): a new filter updated with 0 is
    0."""
    assert float_eq(run(0.0, 0.0, ALPHA_0, 1), 0.0)


def test_AlphaFilterTest_AlphaOneTest():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, AlphaOneTest): setParameters(1e-5, 1e5) (alpha
    about 1e-10): 100 updates on 1 stay at 0 (within 1e-4)."""
    state = 0.0
    for _ in range(100):
        state = _lowpass(state, 1.0, f32(1e-5), f32(1e5))
        assert abs(state - 0.0) <= f32(1e-4)


def test_AlphaFilterTest_AlphaZeroTest():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, AlphaZeroTest): setParameters(0.1, 0) (alpha
    1, no filtering): the state is each sample 0..99."""
    state = 0.0
    for i in range(100):
        state = _lowpass(state, float(i), f32(0.1), 0.0)
        assert float_eq(state, float(i))


def test_AlphaFilterTest_ConvergenceTest():
    """AlphaFilterTest.cpp, TEST(AlphaFilterTest, ConvergenceTest): setParameters(0.1, 1): 100
    updates on 1 rise monotonically to 1 (within 1e-4), then 1000 on -100 fall monotonically
    to -100 (within 1e-4)."""
    dt, tau = f32(0.1), 1.0
    state = last_value = 0.0
    for _ in range(100):
        state = _lowpass(state, 1.0, dt, tau)
        assert state >= last_value
        last_value = state
    assert abs(last_value - 1.0) <= f32(1e-4)
    for _ in range(1000):
        state = _lowpass(state, -100.0, dt, tau)
        assert state <= last_value
        last_value = state
    assert abs(last_value - -100.0) <= f32(1e-4)
