"""PX4's vehicle_acceleration (src/modules/sensors/vehicle_acceleration, VehicleAcceleration):
the accelerometer's samples, less the estimator's bias, through the IMU_ACCEL_CUTOFF low-pass.

Rules: every physics step writes each row's filtered sample into the World's recent-steps ring
(estimation.R_ACC_LP), so that the logger records it per step as PX4 publishes it at the
accelerometer's rate; the filter's state is the ring's last two inputs and outputs. A changed
IMU_ACCEL_CUTOFF takes effect at the next sample, as CheckAndUpdateFilters applies it on a
parameter update: new coefficients when it differs from the filter's cutoff by more than 0.1 Hz,
and the filter reset to the last corrected sample (for RESET_STEPS samples ``lowpass_accel``
reads its history as that sample; the ring keeps what was logged). Pure and compiled: no clock,
no physics.
"""

from __future__ import annotations

import math

from vehicles.control.compiled import njit_cached
from vehicles.estimation import E_ACC_BIAS_Z, HISTORY, R_ACC_IN, R_ACC_LP, S_ACC

IMU_ACCEL_CUTOFF_HZ = 30.0  # IMU_ACCEL_CUTOFF's default
CUTOFF_CHANGE_HZ = 0.1  # CheckAndUpdateFilters: a smaller change is not applied
RESET_STEPS = 2  # the steps whose filter history a reset replaces (lowpass_accel)


def filter_cutoff_hz(sample_hz: float, cutoff_hz: float) -> float:
    """LowPassFilter2p::get_cutoff_freq after set_cutoff_frequency(``sample_hz``,
    ``cutoff_hz``): 0 when that disables the filter, else at least a thousandth of the rate."""
    if not (0.0 < cutoff_hz < sample_hz / 2.0) or not math.isfinite(sample_hz + cutoff_hz):
        return 0.0
    return max(cutoff_hz, sample_hz * 0.001)


def cutoff_update(sample_hz: float, filter_hz: float, param_hz: float) -> float | None:
    """VehicleAcceleration::CheckAndUpdateFilters on a parameter update: the filter's new
    cutoff (``filter_cutoff_hz``) when IMU_ACCEL_CUTOFF (``param_hz``) is more than 0.1 Hz from
    its present one (``filter_hz``), else None (the filter is left alone; a NaN never
    differs)."""
    if not abs(filter_hz - param_hz) > CUTOFF_CHANGE_HZ:
        return None
    return filter_cutoff_hz(sample_hz, param_hz)


def lowpass2p(sample_hz: float, cutoff_hz: float) -> tuple[float, float, float, float, float]:
    """(b0, b1, b2, a1, a2) of PX4's LowPassFilter2p::set_cutoff_frequency (a Butterworth
    biquad); a cutoff of 0 or from half the sample rate on disables it (the input passes)."""
    if not (0.0 < cutoff_hz < sample_hz / 2.0) or not math.isfinite(sample_hz + cutoff_hz):
        return (1.0, 0.0, 0.0, 0.0, 0.0)
    ohm = math.tan(math.pi / (sample_hz / max(cutoff_hz, sample_hz * 0.001)))
    k = 2.0 * math.cos(math.pi / 4.0) * ohm
    c = 1.0 + k + ohm * ohm
    b0 = ohm * ohm / c
    return (b0, 2.0 * b0, b0, 2.0 * (ohm * ohm - 1.0) / c, (1.0 - k + ohm * ohm) / c)


@njit_cached
def lowpass_accel(recent, hist_i, sensed, est, coeffs, reset):  # pragma: no cover - compiled
    """The sensors module's VehicleAcceleration for every row at this step's ring slot: the
    accelerometer sample less the estimated bias (EKF2's estimator_sensor_bias; here only the
    vertical one is estimated), through the IMU_ACCEL_CUTOFF low-pass (LowPassFilter2p; the
    direct form I over the ring's last two inputs and outputs, the same filter as PX4's form
    II). ``coeffs``: each row's (b0, b1, b2, a1, a2). ``reset``: each row's steps left of a
    filter reset (counted down here): RESET_STEPS at the first sample after it, whose past
    inputs and outputs are all the last corrected sample (LowPassFilter2p::reset to
    _acceleration_prev), 1 at the next, whose output two samples back is that sample too."""
    h1, h2 = (hist_i + HISTORY - 1) % HISTORY, (hist_i + HISTORY - 2) % HISTORY
    for v in range(len(sensed)):
        r, r1, r2, s, k = recent[v, hist_i], recent[v, h1], recent[v, h2], sensed[v], coeffs[v]
        left = reset[v]
        for i in range(3):
            x = s[S_ACC + i] - (est[v, E_ACC_BIAS_Z] if i == 2 else 0.0)
            x1, x2 = r1[R_ACC_IN + i], r2[R_ACC_IN + i]
            y1, y2 = r1[R_ACC_LP + i], r2[R_ACC_LP + i]
            if left >= RESET_STEPS:
                x2 = y1 = y2 = x1
            elif left == 1:
                y2 = x2
            r[R_ACC_IN + i] = x
            r[R_ACC_LP + i] = k[0] * x + k[1] * x1 + k[2] * x2 - k[3] * y1 - k[4] * y2
        if left > 0:
            reset[v] = left - 1
