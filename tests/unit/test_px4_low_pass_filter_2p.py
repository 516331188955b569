"""PX4's own unit test of LowPassFilter2p, run against ours.

Source (PX4 v1.15): ``src/lib/mathlib/math/test/LowPassFilter2pVector3fTest.cpp``, the test of
``math::LowPassFilter2p<Vector3f>`` (``src/lib/mathlib/math/filter/LowPassFilter2p.hpp``, a
second-order Butterworth low-pass in direct form II).

CORNET's one LowPassFilter2p is vehicle_acceleration's IMU_ACCEL_CUTOFF filter
(vehicles/vehicle_acceleration.py), split as PX4's class is used:

- ``set_cutoff_frequency(fs, fc)``: ``lowpass2p(fs, fc)``, the coefficients (b0, b1, b2, a1,
  a2), with delay elements reset to zero (a new, zeroed ring below);
- ``get_cutoff_freq()`` after it: ``filter_cutoff_hz(fs, fc)``;
- ``apply(sample)``: ``lowpass_accel``, the compiled filter of every vehicle's accelerometer
  sample (direct form I over the ring's last two inputs and outputs, the same filter), run here on
  one vehicle whose bias estimate is zero, so that its input is the sample itself.

Not reproduced: the ``get_sample_freq()`` half of ``setGet``: ours keeps no sample rate (the
physics step's rate is passed to ``lowpass2p`` by its caller).

Comparisons as gtest makes them: ``EXPECT_EQ`` of two floats equal as float32
(``float32_eq``), ``EXPECT_NEAR`` within its bound (PX4's ``_epsilon_near``, 0.08). The test's
own signal and expected output are computed in double here (PX4: float); against the 0.08 bound
that is immaterial. Our filter runs in double.
"""

from __future__ import annotations

import math

import numpy as np

from tests.unit.test_px4_position_control_tests import f32, float32_eq
from vehicles.estimation import E_SIZE, HISTORY, R_ACC_LP, R_SIZE, S_ACC, S_SIZE
from vehicles.vehicle_acceleration import filter_cutoff_hz, lowpass2p, lowpass_accel

EPSILON_NEAR = f32(0.08)


class LowPassFilter2pVector3f:
    """math::LowPassFilter2p<Vector3f> on our vehicle_acceleration filter (one vehicle)."""

    def __init__(self, sample_freq: float, cutoff_freq: float) -> None:
        self.set_cutoff_frequency(sample_freq, cutoff_freq)

    def set_cutoff_frequency(self, sample_freq: float, cutoff_freq: float) -> None:
        self.coeffs = np.array([lowpass2p(sample_freq, cutoff_freq)])
        self.cutoff_freq = filter_cutoff_hz(sample_freq, cutoff_freq)
        self.recent = np.zeros((1, HISTORY, R_SIZE))  # the delay elements, zero
        self.hist_i = 0
        self.sensed = np.zeros((1, S_SIZE))
        self.est = np.zeros((1, E_SIZE))
        self.reset = np.zeros(1, np.int64)

    def apply(self, sample: tuple[float, float, float]) -> tuple[float, float, float]:
        self.hist_i = (self.hist_i + 1) % HISTORY
        self.sensed[0, S_ACC:S_ACC + 3] = sample
        lowpass_accel(self.recent, self.hist_i, self.sensed, self.est, self.coeffs, self.reset)
        out = self.recent[0, self.hist_i, R_ACC_LP:R_ACC_LP + 3]
        return float(out[0]), float(out[1]), float(out[2])


def run_simulated_filter(lpf: LowPassFilter2pVector3f, sample_freq: float,
                         signal_freq_hz: tuple[float, float, float],
                         phase_delay_deg: tuple[float, float, float],
                         gain_db: tuple[float, float, float]) -> int:
    """LowPassFilter2pVector3fTest::runSimulatedFilter: one second of sines (x zero, y at the
    second frequency, z the negated sine at the third) through the filter; after 0.3 s the
    output is the sine delayed and scaled by PX4's simulated phase and gain. As in PX4, ``t``
    advances after the sample is filtered (the first two samples are both at t = 0). Returns
    the number of samples checked."""
    phase_delay = [d * math.pi / 180.0 for d in phase_delay_deg]
    omega = [2.0 * math.pi * f for f in signal_freq_hz]
    gain = [10.0 ** (g / 20.0) for g in gain_db]
    dt = f32(1.0 / sample_freq)
    n_steps = round(1.0 / dt)
    t = 0.0
    checked = 0
    for i in range(n_steps):
        sample = (0.0, math.sin(omega[1] * t), -math.sin(omega[2] * t))
        expected = (0.0, gain[1] * math.sin(omega[1] * t - phase_delay[1]),
                    -gain[2] * math.sin(omega[2] * t - phase_delay[2]))
        out = lpf.apply(sample)
        t = i * dt
        if t > f32(0.3):
            assert float32_eq(out[0], 0.0)
            assert abs(out[1] - expected[1]) <= EPSILON_NEAR, (sample_freq, i, out, expected)
            assert abs(out[2] - expected[2]) <= EPSILON_NEAR, (sample_freq, i, out, expected)
            checked += 1
    return checked


def test_LowPassFilter2pVector3fTest_setGet():
    """LowPassFilter2pVector3fTest.cpp, TEST_F(LowPassFilter2pVector3fTest, setGet): the
    filter (800 Hz, 30 Hz) set to 1000 Hz, 80 Hz reports an 80 Hz cutoff (its sample-rate half
    is not reproduced, see the module docstring)."""
    lpf = LowPassFilter2pVector3f(800.0, 30.0)
    lpf.set_cutoff_frequency(1000.0, 80.0)
    assert float32_eq(lpf.cutoff_freq, 80.0)


def test_LowPassFilter2pVector3fTest_simulate80HzCutoff():
    """LowPassFilter2pVector3fTest.cpp, TEST_F(LowPassFilter2pVector3fTest,
    simulate80HzCutoff): an 80 Hz cutoff at 400, 1000, 8000 and 16000 Hz sampling passes 10 Hz
    with 0 dB and 10.4° delay, 100 Hz with -5.66 dB and 108.5° delay (PX4's simulated values),
    within 0.08."""
    lpf = LowPassFilter2pVector3f(800.0, 30.0)
    signal_freq_hz = (0.0, 10.0, 100.0)
    phase_delay_deg = (0.0, f32(10.4), f32(108.5))
    gain_db = (0.0, 0.0, f32(-5.66))
    for sample_freq in (400.0, 1000.0, 8000.0, 16000.0):
        lpf.set_cutoff_frequency(sample_freq, 80.0)
        checked = run_simulated_filter(lpf, sample_freq, signal_freq_hz, phase_delay_deg,
                                       gain_db)
        assert checked > 0.6 * sample_freq  # the 0.7 s after settling were compared
