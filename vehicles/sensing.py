"""The sensors of every row of a World after a physics step, compiled over the rows: the models,
sources and column layouts are in ``vehicles.estimation``'s docstring and constants (the estimator
reads the same columns)."""

from __future__ import annotations

import math

from vehicles.control.compiled import njit_cached
from vehicles.control.rotation import dcm
from vehicles.estimation import (
    B_ACC,
    B_GYRO,
    F_ACC,
    F_BARO,
    F_GPS_OFF,
    F_GYRO,
    F_MAG,
    GPS_POS_NOISE_M,
    GPS_VEL_NOISE_MPS,
    S_ACC,
    S_BARO_DOWN,
    S_GPS_POS,
    S_GPS_VEL,
    S_GYRO,
    S_MAG,
    S_PREV,
    S_VIB,
)
from vehicles.inner_loop import M_ACCEL, M_POS, M_Q, M_RATES, M_VEL


@njit_cached
def sense(measured, noise, j, dt_s, scale, baro_due, gps_due, navsat_age, hist, hist_i, bias,
          sensed, consts, failed):  # pragma: no cover - compiled
    """Every vehicle's sensors after a physics step (module rules). ``hist``: the ring of true
    positions and velocities (slot ``hist_i`` is written now); ``navsat_age``: the physics steps
    since the last navsat sample (the ground truth a GPS fix takes its position from);
    ``consts``: gyro and accel bias decay and drive, gyro and accel noise, baro and mag noise,
    the Earth's field (NED)."""
    g_decay, g_drive, a_decay, a_drive = consts[0], consts[1], consts[2], consts[3]
    g_noise, a_noise, baro_noise = consts[4], consts[5], consts[6]
    for v in range(len(measured)):
        m = measured[v]
        n = noise[v, j]
        b = bias[v]
        out = sensed[v]
        h = hist[v, hist_i]
        for i in range(3):
            h[i] = m[M_POS + i]
            h[3 + i] = m[M_VEL + i]
        qw, qx, qy, qz = m[M_Q], m[M_Q + 1], m[M_Q + 2], m[M_Q + 3]
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = dcm(qw, qx, qy, qz)
        fn, fe, fd = m[M_ACCEL], m[M_ACCEL + 1], m[M_ACCEL + 2] - 9.80665
        f0 = r00 * fn + r10 * fe + r20 * fd
        f1 = r01 * fn + r11 * fe + r21 * fd
        f2 = r02 * fn + r12 * fe + r22 * fd
        # PX4's vehicle_imu vibration metrics from consecutive delta angles and velocities.
        da0 = da1 = da2 = dv0 = dv1 = dv2 = 0.0
        for i in range(3):
            b[B_GYRO + i] = b[B_GYRO + i] * g_decay + g_drive * scale * n[3 + i]
            b[B_ACC + i] = b[B_ACC + i] * a_decay + a_drive * scale * n[9 + i]
        f = failed[v]
        if not f & F_GYRO:
            out[S_GYRO] = m[M_RATES] + b[B_GYRO] + g_noise * scale * n[0]
            out[S_GYRO + 1] = m[M_RATES + 1] + b[B_GYRO + 1] + g_noise * scale * n[1]
            out[S_GYRO + 2] = m[M_RATES + 2] + b[B_GYRO + 2] + g_noise * scale * n[2]
        if not f & F_ACC:
            out[S_ACC] = f0 + b[B_ACC] + a_noise * scale * n[6]
            out[S_ACC + 1] = f1 + b[B_ACC + 1] + a_noise * scale * n[7]
            out[S_ACC + 2] = f2 + b[B_ACC + 2] + a_noise * scale * n[8]
        da0, da1, da2 = out[S_GYRO] * dt_s, out[S_GYRO + 1] * dt_s, out[S_GYRO + 2] * dt_s
        dv0, dv1, dv2 = out[S_ACC] * dt_s, out[S_ACC + 1] * dt_s, out[S_ACC + 2] * dt_s
        p0, p1, p2 = out[S_PREV], out[S_PREV + 1], out[S_PREV + 2]
        cx, cy, cz = da1 * p2 - da2 * p1, da2 * p0 - da0 * p2, da0 * p1 - da1 * p0
        out[S_VIB] = 0.99 * out[S_VIB] + 0.01 * math.sqrt(cx * cx + cy * cy + cz * cz)
        ex, ey, ez = da0 - p0, da1 - p1, da2 - p2
        out[S_VIB + 1] = 0.99 * out[S_VIB + 1] + 0.01 * math.sqrt(ex * ex + ey * ey + ez * ez)
        ex, ey, ez = dv0 - out[S_PREV + 3], dv1 - out[S_PREV + 4], dv2 - out[S_PREV + 5]
        out[S_VIB + 2] = 0.99 * out[S_VIB + 2] + 0.01 * math.sqrt(ex * ex + ey * ey + ez * ez)
        out[S_PREV], out[S_PREV + 1], out[S_PREV + 2] = da0, da1, da2
        out[S_PREV + 3], out[S_PREV + 4], out[S_PREV + 5] = dv0, dv1, dv2
        if baro_due and not f & F_BARO:
            out[S_BARO_DOWN] = m[M_POS + 2] + baro_noise * scale * n[12]
        if baro_due and not f & F_MAG:
            mn, me, md = consts[10], consts[11], consts[12]
            out[S_MAG] = r00 * mn + r10 * me + r20 * md + consts[7] * scale * n[13]
            out[S_MAG + 1] = r01 * mn + r11 * me + r21 * md + consts[8] * scale * n[14]
            out[S_MAG + 2] = r02 * mn + r12 * me + r22 * md + consts[9] * scale * n[15]
        if gps_due and not f & F_GPS_OFF:
            # SensorGpsSim::Run: the navsat ground truth's position, the current velocity, each
            # with white noise; no delay.
            truth = hist[v, (hist_i - navsat_age) % len(hist[v])]
            for i in range(3):
                out[S_GPS_POS + i] = truth[i] + GPS_POS_NOISE_M[i] * scale * n[16 + i]
                out[S_GPS_VEL + i] = m[M_VEL + i] + GPS_VEL_NOISE_MPS[i] * scale * n[19 + i]
