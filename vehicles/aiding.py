"""What of its sensors a vehicle's estimator fuses: EKF2_GPS_CTRL, EKF2_BARO_CTRL and
EKF2_HGT_REF as one word per row (estimation.py reads it in its compiled step)."""

from __future__ import annotations

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
