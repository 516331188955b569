"""The magnetometer on its way into the estimator: vehicle_magnetometer's averaging, and the
heading error the estimator corrects towards (compiled, one row at a time).

Source: PX4 v1.15.2 src/modules/sensors/vehicle_magnetometer/VehicleMagnetometer.cpp: the
samples are summed until their mean time is SENS_MAG_RATE's interval (15 Hz) after the last
publication's, and the mean is published (and what EKF2 fuses), as vehicle_air_data does for the
barometer (height_fusion.air_data).

Columns MAG_* of a row, from ``base`` (estimation.E_MAG): the field's sum (3), how many samples,
their times' sum, the last publication's sample time.
"""

from __future__ import annotations

import math

from vehicles.control.compiled import njit_cached

MAG_SUM, MAG_N, MAG_TSUM, MAG_LAST, MAG_SIZE = 0, 3, 4, 5, 6


def initial_row() -> list[float]:
    row = [0.0] * MAG_SIZE
    row[MAG_LAST] = -1.0
    return row


@njit_cached
def publish(e, base, b0, b1, b2, t_s, rate_hz, out):  # pragma: no cover - compiled
    """A sample (gauss, body frame, taken at ``t_s``) into the average. When
    vehicle_magnetometer publishes, the mean goes to ``out`` and the number of samples it
    averages is returned (else 0)."""
    e[base + MAG_SUM] += b0
    e[base + MAG_SUM + 1] += b1
    e[base + MAG_SUM + 2] += b2
    e[base + MAG_N] += 1.0
    e[base + MAG_TSUM] += t_s
    n = e[base + MAG_N]
    t_mean = e[base + MAG_TSUM] / n
    if t_mean < e[base + MAG_LAST] + 1.0 / max(rate_hz, 1e-3) - 1e-9:
        return 0
    for i in range(3):
        out[i] = e[base + MAG_SUM + i] / n
        e[base + MAG_SUM + i] = 0.0
    e[base + MAG_LAST] = t_mean
    e[base + MAG_N] = e[base + MAG_TSUM] = 0.0
    return int(n)


@njit_cached
def heading_error(b, r00, r01, r02, r10, r11, r12, mn, me):  # pragma: no cover - compiled
    """The heading error of a field sample ``b`` (body frame) rotated to NED by the estimate's
    attitude, against the Earth's horizontal field (``mn``, ``me``), and the field innovation
    across the horizontal field it makes (gauss)."""
    fn_ = r00 * b[0] + r01 * b[1] + r02 * b[2]
    fe_ = r10 * b[0] + r11 * b[1] + r12 * b[2]
    yaw_err = math.atan2(mn * fe_ - me * fn_, mn * fn_ + me * fe_)
    return yaw_err, yaw_err * math.sqrt(mn * mn + me * me)
