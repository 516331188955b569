"""The estimator's vertical channel as EKF2 v1.15 runs it (compiled, one row at a time).

Source: PX4 v1.15.2 src/modules/ekf2/EKF: height_control.cpp (checkHeightSensorRefFallback),
baro_height_control.cpp, gnss_height_control.cpp, bias_estimator.cpp / height_bias_estimator.hpp,
common.h's parameters; ekf2/module.yaml for the noise and gate parameters.

- The barometer's samples reach EKF2 through vehicle_air_data, averaged to at most
  SENS_BARO_RATE (20 Hz; VehicleAirData.cpp).
- A Kalman filter over height (down), vertical velocity and the accelerometer's z bias, predicted
  at the IMU rate with EKF2_ACC_NOISE and EKF2_ACC_B_NOISE (their variances per EKF2_PREDICT_US
  update), corrected by the barometer (EKF2_BARO_NOISE, EKF2_BARO_GATE), the GPS height (the
  receiver's vacc or 1.5 x EKF2_GPS_P_NOISE, EKF2_GPS_P_GATE; fused as taken EKF2_GPS_DELAY
  earlier) and the GPS vertical velocity (1.5 x the receiver's sacc or EKF2_GPS_V_NOISE,
  EKF2_GPS_V_GATE).
- Every height source that is on is fused (EKF2_BARO_CTRL; EKF2_GPS_CTRL's altitude bit), each
  less its bias, which a scalar estimator per source learns (HeightBiasEstimator: process noise
  0.13 m/s/√Hz, gate 3, the noise boosted 1000-fold while its innovations show an offset) except
  for the height reference's (EKF2_HGT_REF), whose bias stays.
- A source whose samples stop (2 sample intervals) stops; one whose every sample fails its gate
  for hgt_fusion_timeout_max (5 s) stops while another source works, and a barometer is then
  faulty until the estimator restarts; with none working it resets the height to its own (the
  other source's bias following the jump) and the vertical velocity to the fix's, or to 0. A
  reference that stops leaves none until checkHeightSensorRefFallback picks the next source that
  runs: the barometer, then the GPS, for a barometer reference; the GPS, then the barometer, for a
  GPS reference; the barometer, then the GPS, for the range sensor and vision this vehicle lacks.
- A source that starts (again) as the reference resets the height to it; otherwise its bias is
  set to its offset from the estimate.

Columns H_* of a row, from ``base`` (estimation.E_HGT): the covariance (3 x 3, row-major), then
per source (baro, GNSS) its bias, bias variance, time since it was last fused, whether it runs,
its offset detection, its last sample's test ratio, and the barometer's fault latch; the
reference in force (REF_*).
"""

from __future__ import annotations

import math

from vehicles.control.compiled import njit_cached

# Each row's parameters (``params_row``; the estimator's, this channel's and the others'), in
# this order: ekf2/module.yaml's noises and gates, vehicle_air_data's SENS_BARO_RATE,
# vehicle_magnetometer's SENS_MAG_RATE (defaults: v1.15's)
PARAMS = (("EKF2_ACC_NOISE", 0.35), ("EKF2_ACC_B_NOISE", 0.003), ("EKF2_BARO_NOISE", 3.5),
          ("EKF2_BARO_GATE", 5.0), ("EKF2_GPS_P_NOISE", 0.5), ("EKF2_GPS_P_GATE", 5.0),
          ("EKF2_GPS_V_NOISE", 0.3), ("EKF2_GPS_V_GATE", 5.0), ("SENS_BARO_RATE", 20.0),
          ("SENS_MAG_RATE", 15.0))
(P_ACC_NOISE, P_ACC_B_NOISE, P_BARO_NOISE, P_BARO_GATE, P_GPS_P_NOISE, P_GPS_P_GATE,
 P_GPS_V_NOISE, P_GPS_V_GATE, P_BARO_RATE, P_MAG_RATE) = range(len(PARAMS))
HGT_BIAS_NSD = 0.13  # baro_bias_nsd, gps_hgt_bias_nsd
BIAS_GATE = 3.0  # BiasEstimator::_gate_size
# BiasEstimator's offset detection: the signed test ratios' average (AlphaFilter, 10 s) over
# 0.2, or innovations of one sign for 10 s, boost its process noise 1000-fold.
OFFSET_TAU_S, OFFSET_RATIO, OFFSET_BOOST = 10.0, 0.2, 1.0e3
HGT_FUSION_TIMEOUT_S = 5.0  # hgt_fusion_timeout_max
BARO_MAX_INTERVAL_S, GNSS_MAX_INTERVAL_S = 0.2, 0.5
EKF_DT_S = 0.01  # EKF2_PREDICT_US

REF_UNKNOWN, REF_BARO, REF_GNSS = -1.0, 0.0, 1.0
BARO, GNSS = 0, 1  # the sources' blocks of columns

H_P = 0  # 9 columns
H_SRC = 9  # per source: bias, bias variance, time since fused, running; the baro's fault latch
SRC_BIAS, SRC_BIAS_VAR, SRC_AGE, SRC_ON, SRC_LPF, SRC_T_POS, SRC_T_NEG, SRC_RATIO, SRC_SIZE = \
    range(9)
H_BARO_FAULTY = H_SRC + 2 * SRC_SIZE
H_REF = H_BARO_FAULTY + 1
H_DATA_AGE = H_REF + 1  # per source: time since its last sample came
# VehicleAirData's averaging of the barometer's samples: their sum, their times' sum, how many,
# the last publication's sample time
H_AIR_SUM, H_AIR_TSUM, H_AIR_N, H_AIR_LAST = H_DATA_AGE + 2, H_DATA_AGE + 3, H_DATA_AGE + 4, \
    H_DATA_AGE + 5
H_SIZE = H_DATA_AGE + 6


def params_row(get) -> list[float]:
    """A row's parameters (PARAMS) from ``get(name)`` (None: the default)."""
    out = []
    for name, default in PARAMS:
        value = get(name)
        out.append(default if value is None or not math.isfinite(float(value))
                   else float(value))
    out[P_BARO_RATE] = max(out[P_BARO_RATE], 1e-3)
    out[P_MAG_RATE] = max(out[P_MAG_RATE], 1e-3)
    return out


def initial_row(ref: float) -> list[float]:
    """A converged estimate's columns: small variances, both sources on, ``ref`` in force."""
    row = [0.0] * H_SIZE
    row[H_AIR_LAST] = -1.0
    row[H_P + 0], row[H_P + 4], row[H_P + 8] = 0.01, 0.01, 1e-4
    for src in (BARO, GNSS):
        row[H_SRC + src * SRC_SIZE + SRC_BIAS_VAR] = 0.01
        row[H_SRC + src * SRC_SIZE + SRC_ON] = 1.0
    row[H_REF] = ref
    return row


@njit_cached
def predict(e, base, dt_s, r22, hp):  # pragma: no cover - compiled
    """P = F P Fᵀ + Q over one IMU step (F: height from velocity, velocity from the z bias
    through the attitude's r22), the bias estimators' variances grown; the ages advanced."""
    p = e[base + H_P:base + H_P + 9]
    f01, f12 = dt_s, -r22 * dt_s
    # F P
    a = [p[0] + f01 * p[3], p[1] + f01 * p[4], p[2] + f01 * p[5],
         p[3] + f12 * p[6], p[4] + f12 * p[7], p[5] + f12 * p[8],
         p[6], p[7], p[8]]
    # (F P) Fᵀ
    p[0] = a[0] + a[1] * f01
    p[1] = a[1] + a[2] * f12
    p[2] = a[2]
    p[3] = a[3] + a[4] * f01
    p[4] = a[4] + a[5] * f12
    p[5] = a[5]
    p[6] = a[6] + a[7] * f01
    p[7] = a[7] + a[8] * f12
    p[8] = a[8]
    # EKF2's variances per filter update (EKF2_PREDICT_US, 10 ms), spread over the IMU steps
    p[4] += hp[P_ACC_NOISE] ** 2 * EKF_DT_S * dt_s
    p[8] += hp[P_ACC_B_NOISE] ** 2 * EKF_DT_S * dt_s
    ref = e[base + H_REF]
    for src in range(2):
        c = base + H_SRC + src * SRC_SIZE
        e[c + SRC_AGE] += dt_s
        e[base + H_DATA_AGE + src] += dt_s
        if e[c + SRC_ON] > 0.0 and ref != float(src):
            max_var = max(1e-4, (hp[P_BARO_NOISE] if src == BARO else gnss_hgt_noise(hp)) ** 2)
            grow = HGT_BIAS_NSD ** 2 * dt_s
            if abs(e[c + SRC_LPF]) > OFFSET_RATIO or e[c + SRC_T_POS] > OFFSET_TAU_S \
                    or e[c + SRC_T_NEG] > OFFSET_TAU_S:
                grow *= OFFSET_BOOST  # isOffsetDetected
            e[c + SRC_BIAS_VAR] = min(max(e[c + SRC_BIAS_VAR] + grow, 1e-8), max_var)


@njit_cached
def gnss_hgt_noise(hp):  # pragma: no cover - compiled
    """gnss_height_control.cpp: the receiver's vacc, at least 1.5 x EKF2_GPS_P_NOISE (SITL's
    receiver reports vacc = epv = 1.78 m)."""
    return max(1.78, 1.5 * hp[P_GPS_P_NOISE])


@njit_cached
def gnss_vz_noise(hp):  # pragma: no cover - compiled
    """The vertical velocity's: 1.5 x max(sacc 0.4 m/s, EKF2_GPS_V_NOISE)."""
    return 1.5 * max(0.4, hp[P_GPS_V_NOISE])


@njit_cached
def fuse(e, base, col, innov, var, gate, out):  # pragma: no cover - compiled
    """A scalar observation of state ``col`` (0 height, 1 vertical velocity): its test ratio;
    passing the gate, the corrections to height, velocity and z bias go to ``out`` and the
    covariance is updated (else ``out`` is zeros)."""
    p = e[base + H_P:base + H_P + 9]
    s = p[col * 3 + col] + var
    ratio = innov * innov / (gate * gate * s)
    out[0] = out[1] = out[2] = 0.0
    if ratio > 1.0:
        return ratio
    k0, k1, k2 = p[col] / s, p[3 + col] / s, p[6 + col] / s
    out[0], out[1], out[2] = k0 * innov, k1 * innov, k2 * innov
    r0, r1, r2 = p[col * 3], p[col * 3 + 1], p[col * 3 + 2]
    p[0] -= k0 * r0
    p[1] -= k0 * r1
    p[2] -= k0 * r2
    p[3] -= k1 * r0
    p[4] -= k1 * r1
    p[5] -= k1 * r2
    p[6] -= k2 * r0
    p[7] -= k2 * r1
    p[8] -= k2 * r2
    return ratio


@njit_cached
def uncorrelate(e, base, col, var):  # pragma: no cover - compiled
    """P.uncorrelateCovarianceSetVariance: state ``col``'s row and column zeroed, its variance
    ``var`` (at least 0.01²)."""
    p = e[base + H_P:base + H_P + 9]
    for k in range(3):
        p[col * 3 + k] = p[k * 3 + col] = 0.0
    p[col * 3 + col] = max(var, 1e-4)


@njit_cached
def fuse_bias(e, base, src, offset, var):  # pragma: no cover - compiled
    """BiasEstimator::fuseBias with the source's offset from the estimate (not for the
    reference's, nor a source that is off)."""
    c = base + H_SRC + src * SRC_SIZE
    if e[c + SRC_ON] <= 0.0 or e[base + H_REF] == float(src):
        return
    bvar = e[c + SRC_BIAS_VAR]
    s = bvar + max(1e-4, var)
    innov = offset - e[c + SRC_BIAS]
    ratio = innov * innov / (BIAS_GATE * BIAS_GATE * s)
    if ratio < 1.0:
        k = bvar / s
        e[c + SRC_BIAS] += k * innov
        e[c + SRC_BIAS_VAR] = max(bvar - k * bvar, 1e-8)
    # updateOffsetDetection: the filter and the clocks step by the filter's period per sample
    signed = min(max(ratio if innov > 0.0 else -ratio, -1.0), 1.0)
    e[c + SRC_LPF] += EKF_DT_S / (OFFSET_TAU_S + EKF_DT_S) * (signed - e[c + SRC_LPF])
    if innov > 0.0:
        e[c + SRC_T_POS] = 0.0
        e[c + SRC_T_NEG] += EKF_DT_S
    else:
        e[c + SRC_T_NEG] = 0.0
        e[c + SRC_T_POS] += EKF_DT_S


@njit_cached
def height_source(e, base, src, meas, h, vz, enabled, ref_param, hp, out):  # pragma: no cover
    """One sample of source ``src`` (down, m), against the estimate's height ``h`` at its
    time: controlBaroHeightFusion / controlGnssHeightFusion. ``vz``: the fix's vertical velocity
    where EKF2_GPS_CTRL fuses it (NaN: none; the barometer's). ``out``: the corrections to apply
    (height, vertical velocity, z bias), in out[3] a height reset's new height and in out[4] a
    vertical velocity reset's new velocity (NaN: none). Returns the sample's test ratio."""
    c = base + H_SRC + src * SRC_SIZE
    noise = hp[P_BARO_NOISE] if src == BARO else gnss_hgt_noise(hp)
    gate = max(hp[P_BARO_GATE] if src == BARO else hp[P_GPS_P_GATE], 1.0)
    var = noise * noise
    e[base + H_DATA_AGE + src] = 0.0
    innov = meas - e[c + SRC_BIAS] - h
    fuse_bias(e, base, src, meas - h, var + e[base + H_P])
    out[0] = out[1] = out[2] = 0.0
    out[3] = out[4] = math.nan
    faulty = src == BARO and e[base + H_BARO_FAULTY] > 0.0
    go_on = enabled and not faulty
    ratio = innov * innov / (gate * gate * (e[base + H_P] + var + e[c + SRC_BIAS_VAR]))
    other = base + H_SRC + (1 - src) * SRC_SIZE
    e[c + SRC_RATIO] = ratio
    if e[c + SRC_ON] > 0.0:
        if not go_on:
            stop(e, base, src)
            return ratio
        ratio = e[c + SRC_RATIO] = fuse(e, base, 0, innov, var + e[c + SRC_BIAS_VAR], gate, out)
        if ratio <= 1.0:
            e[c + SRC_AGE] = 0.0
        elif e[c + SRC_AGE] > HGT_FUSION_TIMEOUT_S:
            if e[other + SRC_ON] > 0.0 and e[other + SRC_AGE] <= HGT_FUSION_TIMEOUT_S:
                stop(e, base, src)  # another source still works
                if src == BARO:
                    e[base + H_BARO_FAULTY] = 1.0
            else:  # every height source failing: reset to this one, and the vertical velocity
                out[3] = meas - e[c + SRC_BIAS]
                # resetVerticalPositionTo: the other source's bias follows the jump
                e[other + SRC_BIAS] -= out[3] - h
                # resetVerticalVelocityTo: the fix's (EKF2's variance: max(1.5 sacc,
                # EKF2_GPS_V_NOISE)²), else resetVerticalVelocityToZero's 0 with variance 10
                out[4] = vz if not math.isnan(vz) else 0.0
                uncorrelate(e, base, 1, max(1.5 * 0.4, hp[P_GPS_V_NOISE]) ** 2
                            if not math.isnan(vz) else 10.0)
                uncorrelate(e, base, 0, var)
                e[c + SRC_AGE] = 0.0
        return ratio
    if go_on:  # start
        if ref_param == float(src):
            e[base + H_REF] = float(src)
            if src == GNSS:
                e[c + SRC_BIAS] = 0.0
            out[3] = meas - e[c + SRC_BIAS]
            e[base + H_P] = var
        else:
            e[c + SRC_BIAS] = meas - h
        e[c + SRC_AGE] = 0.0
        e[c + SRC_ON] = 1.0
    return ratio


@njit_cached
def innovation_ratio(e, base):  # pragma: no cover - compiled
    """Ekf::get_innovation_test_status's height ratio: the mean of the square roots of the
    running sources' test ratios (NaN: none runs)."""
    total, n = 0.0, 0
    for src in range(2):
        c = base + H_SRC + src * SRC_SIZE
        if e[c + SRC_ON] > 0.0:
            total += math.sqrt(e[c + SRC_RATIO])
            n += 1
    return total / n if n else math.nan


@njit_cached
def air_data(e, base, down_m, t_s, rate_hz):  # pragma: no cover - compiled
    """VehicleAirData: a barometer sample (height down, taken at ``t_s``) into the average it
    publishes once the samples' mean time is SENS_BARO_RATE's interval after the last
    publication's (and what EKF2 fuses). Returns the published height, NaN if none."""
    e[base + H_AIR_SUM] += down_m
    e[base + H_AIR_TSUM] += t_s
    e[base + H_AIR_N] += 1.0
    n = e[base + H_AIR_N]
    t_mean = e[base + H_AIR_TSUM] / n
    if t_mean < e[base + H_AIR_LAST] + 1.0 / rate_hz - 1e-9:
        return math.nan
    out = e[base + H_AIR_SUM] / n
    e[base + H_AIR_LAST] = t_mean
    e[base + H_AIR_SUM] = e[base + H_AIR_TSUM] = e[base + H_AIR_N] = 0.0
    return out


@njit_cached
def stop(e, base, src):  # pragma: no cover - compiled
    e[base + H_SRC + src * SRC_SIZE + SRC_ON] = 0.0
    if e[base + H_REF] == float(src):
        e[base + H_REF] = REF_UNKNOWN


@njit_cached
def housekeeping(e, base, ref_param):  # pragma: no cover - compiled
    """A source without samples for two intervals stops; with no reference in force, the
    first running source of the reference's fallback list becomes it."""
    if e[base + H_DATA_AGE + BARO] > 2.0 * BARO_MAX_INTERVAL_S:
        stop(e, base, BARO)
    if e[base + H_DATA_AGE + GNSS] > 2.0 * GNSS_MAX_INTERVAL_S:
        stop(e, base, GNSS)
    if e[base + H_REF] != REF_UNKNOWN:
        return
    first, second = (GNSS, BARO) if ref_param == REF_GNSS else (BARO, GNSS)
    for src in (first, second):
        if e[base + H_SRC + src * SRC_SIZE + SRC_ON] > 0.0:
            e[base + H_REF] = float(src)
            return
