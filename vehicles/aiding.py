"""What of its sensors a vehicle's estimator fuses: EKF2_GPS_CTRL, EKF2_BARO_CTRL and
EKF2_HGT_REF as one word per row (estimation.py reads it in its compiled step), and the test
ratios estimator_status publishes of it (ESTIMATOR_STATUS, the log, Commander's checks)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

# EKF2_GPS_CTRL's bits: lon/lat, altitude, 3D velocity (dual antenna heading: no such receiver)
GPS_CTRL_POS, GPS_CTRL_HGT, GPS_CTRL_VEL = 1, 2, 4
GPS_CTRL_DEFAULT = GPS_CTRL_POS | GPS_CTRL_HGT | GPS_CTRL_VEL
# Each row's aiding word: EKF2_GPS_CTRL's bits, then EKF2_BARO_CTRL (the barometer fused) and
# EKF2_HGT_REF 1 (the GPS the height reference; 0 the barometer; 2 range sensor and 3 vision,
# which this vehicle lacks, fall back to the barometer as checkHeightSensorRefFallback does).
AID_BARO, AID_HGT_REF_GPS = 16, 32
AID_DEFAULT = GPS_CTRL_DEFAULT | AID_BARO | AID_HGT_REF_GPS  # ekf2/module.yaml's defaults


def aiding_word(gps_ctrl: float | None, baro_ctrl: float | None, hgt_ref: float | None) -> int:
    """The aiding word of EKF2_GPS_CTRL, EKF2_BARO_CTRL and EKF2_HGT_REF (None: the default)."""
    word = GPS_CTRL_DEFAULT if gps_ctrl is None else int(gps_ctrl) & 0xF
    if baro_ctrl is None or int(baro_ctrl) == 1:
        word |= AID_BARO
    if hgt_ref is None or int(hgt_ref) == 1:
        word |= AID_HGT_REF_GPS
    return word


GNSS_STOP_S = 7.0  # EKF2's reset_timeout_max: fixes missing this long stop GNSS fusion
FLT_MIN = 1.1754943508222875e-38


def gps_ctrl_of(params: Any) -> int:
    """EKF2_GPS_CTRL (its default when unset)."""
    ctrl = params.get("EKF2_GPS_CTRL", GPS_CTRL_DEFAULT)
    return GPS_CTRL_DEFAULT if ctrl is None else int(ctrl)


def gnss_fusing(gps_ctrl: int, gps_age_s: float) -> bool:
    """Whether EKF2 runs GNSS fusion (gps_control.cpp): EKF2_GPS_CTRL with its position or
    velocity bit, and a fix within GNSS_STOP_S."""
    return bool(gps_ctrl & (GPS_CTRL_POS | GPS_CTRL_VEL)) and gps_age_s < GNSS_STOP_S


def published_ratios(ratios: Sequence[float], gps_age_s: float, gps_ctrl: int
                     ) -> tuple[float, float, float, float]:
    """estimator_status's velocity, horizontal position, height and magnetometer test ratios
    from the estimator's (estimation.E_RATIOS, the time since the last fix) as
    Ekf::get_innovation_test_status publishes them: at least FLT_MIN, and NaN for what is not
    fused (no GNSS fusion: EKF2_GPS_CTRL without its position and velocity bits, or no fix for
    GNSS_STOP_S; no height source, which the estimator's height ratio already says)."""
    vel, pos, hgt, mag = ratios
    if not gnss_fusing(gps_ctrl, gps_age_s):
        vel = pos = math.nan
    return (max(vel, FLT_MIN) if vel == vel else vel, max(pos, FLT_MIN) if pos == pos else pos,
            max(hgt, FLT_MIN) if hgt == hgt else hgt, mag)
