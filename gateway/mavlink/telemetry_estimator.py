"""What the estimator reports on the wire: ESTIMATOR_STATUS with EKF2's solution status flags,
VIBRATION and WIND_COV (telemetry.py has the rules the builders share).

Source: PX4 v1.15 ESTIMATOR_STATUS.hpp (estimator_status: the test ratios, the accuracies and
solution_status_flags), ekf_helper.cpp Ekf::get_ekf_soln_status and gps_control.cpp (when GNSS
fusion runs: started with EKF2_GPS_CTRL's horizontal position or velocity bit, stopped when
both are cleared or the fixes stopped for reset_timeout_max, 7 s), VIBRATION.hpp, WIND_COV.hpp.
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.codec import Encoder, payload_of
from gateway.mavlink.snapshot import Snapshot
from vehicles.aiding import (
    GPS_CTRL_HGT,
    gnss_fusing,
    gps_ctrl_of,
    published_ratios,
)
from vehicles.estimation import (
    BARO_TIMEOUT_S,
    E_ACCURACY,
    E_BARO_AGE,
    E_GPS_AGE,
    E_RATIOS,
    E_WIND,
    E_WIND_VAR,
    S_VIB,
)

# ESTIMATOR_STATUS flags of a healthy EKF2 with GPS: attitude, horizontal and vertical velocity,
# relative and absolute horizontal position, absolute vertical position, and the predicted ones.
ESTIMATOR_FLAGS_OK = (M.ESTIMATOR_ATTITUDE | M.ESTIMATOR_VELOCITY_HORIZ | M.ESTIMATOR_VELOCITY_VERT
                      | M.ESTIMATOR_POS_HORIZ_REL | M.ESTIMATOR_POS_HORIZ_ABS
                      | M.ESTIMATOR_POS_VERT_ABS | M.ESTIMATOR_PRED_POS_HORIZ_REL
                      | M.ESTIMATOR_PRED_POS_HORIZ_ABS)
_HORIZONTAL = (M.ESTIMATOR_VELOCITY_HORIZ | M.ESTIMATOR_POS_HORIZ_REL | M.ESTIMATOR_POS_HORIZ_ABS
               | M.ESTIMATOR_PRED_POS_HORIZ_REL | M.ESTIMATOR_PRED_POS_HORIZ_ABS)
_VERTICAL = M.ESTIMATOR_VELOCITY_VERT | M.ESTIMATOR_POS_VERT_ABS

_ESTIMATOR_STATUS = payload_of(M.MAVLink_estimator_status_message)
_VIBRATION = payload_of(M.MAVLink_vibration_message)
_WIND_COV = payload_of(M.MAVLink_wind_cov_message)


def solution_status(e: list[float], gps_ctrl: int) -> int:
    """Ekf::get_ekf_soln_status from the estimator's state (E_*) and EKF2_GPS_CTRL: with GNSS
    fusion running (the only horizontal aiding here) the horizontal velocity and both position
    flags and their predictions; without, const_pos_mode instead. Vertically the barometer, or
    the GNSS height that replaces it. No terrain estimate (no range finder), no fault: AGL and
    accel_error stay clear. gps_glitch as PX4 has it: a GNSS innovation over its gate while
    the magnetometer's test ratio is not under 1 (PX4's own inverted test: never, with a
    healthy magnetometer)."""
    gnss = gnss_fusing(gps_ctrl, e[E_GPS_AGE])
    flags = M.ESTIMATOR_ATTITUDE
    flags |= _HORIZONTAL if gnss else M.ESTIMATOR_CONST_POS_MODE
    if e[E_BARO_AGE] <= BARO_TIMEOUT_S or (gnss and gps_ctrl & GPS_CTRL_HGT):
        flags |= _VERTICAL
    vel, pos, _, mag = e[E_RATIOS:E_RATIOS + 4]
    if (vel > 1.0 or pos > 1.0) and not mag < 1.0:
        flags |= M.ESTIMATOR_GPS_GLITCH
    return flags


def innovation_test_ratios(e: list[float], gps_ctrl: int) -> tuple[float, float, float, float]:
    """estimator_status's test ratios of an estimator state (vehicles/aiding.py)."""
    return published_ratios(e[E_RATIOS:E_RATIOS + 4], e[E_GPS_AGE], gps_ctrl)


def estimator_status(enc: Encoder, s: Snapshot) -> bytes | None:
    """PX4's ESTIMATOR_STATUS: the solution status flags, innovation test ratios (velocity,
    horizontal position, height, magnetometer; no range finder or airspeed: 0) and the position
    accuracies."""
    e = s.sample.estimator
    if e is None:
        return None
    ctrl = gps_ctrl_of(s.vehicle.params)
    return _ESTIMATOR_STATUS(s.time_usec, solution_status(e, ctrl), *innovation_test_ratios(e, ctrl), 0.0,
                             0.0, e[E_ACCURACY], e[E_ACCURACY + 1])


def vibration(enc: Encoder, s: Snapshot) -> bytes | None:
    """PX4's VIBRATION (its own use of the fields): delta-angle coning, gyro and accelerometer
    high-frequency vibration metrics of the primary IMU; no clipping."""
    sensed = s.sample.sensors
    if sensed is None:
        return None
    coning, gyro, accel = sensed[S_VIB:S_VIB + 3]
    return _VIBRATION(s.time_usec, coning, gyro, accel, 0, 0, 0)


def wind_cov(enc: Encoder, s: Snapshot) -> bytes | None:
    """The estimated wind (NED, horizontal; from the drag while flying) and the variability of
    the raw wind samples behind it. EKF2 publishes wind (and WIND_COV.hpp sends) only while its
    wind states are active (EKF2::PublishWindEstimate, get_wind_status): for a multicopter only
    with drag fusion, EKF2_DRAG_CTRL, which is off by default and which CORNET's parameter set
    does not have, so nothing is sent."""
    e = s.sample.estimator
    if e is None or not s.vehicle.params.get("EKF2_DRAG_CTRL", 0):
        return None
    return _WIND_COV(s.time_usec, e[E_WIND], e[E_WIND + 1], 0.0,
                     e[E_WIND_VAR], 0.0, s.sample.geo.alt_amsl_m, 0.0, 0.0)
