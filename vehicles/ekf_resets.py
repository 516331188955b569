"""The state resets EKF2 makes in every start-up and every flight, counted as it counts them
(_state_reset_status.reset_count posNE, velNE, velD, posD, quat), compiled into estimation.py.

PX4 v1.15.2 facts (src/modules/ekf2/EKF, SITL defaults: EKF2_HGT_REF 1 (GNSS), EKF2_GPS_CTRL 7,
EKF2_MAG_TYPE 0, EKF2_REQ_GPS_H 0.5 from rcS), as its own EKF library with the test harness's
sensor simulator runs them:
- At the filter's first step nothing aids it yet, so the fake height starts
  (fake_height_control.cpp: resetVerticalVelocityToZero, resetHeightToLastKnown: velD and posD
  counted) and, the vehicle at rest, the fake position (fake_pos_control.cpp:
  resetHorizontalPositionToLastKnown, resetHorizontalVelocityToZero: posNE and velNE). Their
  changes are zero: nothing moved yet.
- About a second later the GPS checks pass (EKF2_REQ_GPS_H) and the origin is set; the GNSS
  height, the reference, starts with resetVerticalPositionTo (gnss_height_control.cpp: posD,
  a change of millimetres, the origin's altitude coming from the same sample); the magnetometer
  aligns the heading (mag_3d_control.cpp → resetMagHeading → resetQuatStateYaw: quat); then
  "starting GPS fusion" resets the velocity (resetVelocityTo: velNE and velD) and the
  horizontal position (posNE) to the fix. So before take-off posNE, velNE, velD and posD are 2,
  quat 1, and vehicle_odometry's reset_counter (their sum) 9.
- In the air, once 1.5 m above the terrain estimate (checkHaglYawResetReq; the terrain is set
  EKF2_MIN_RNG 0.1 m below the vehicle at take-off: 1.4 m of climb) the heading is reset to the
  magnetometer's once per flight (mag_aligned_in_flight): quat again, a change of hundredths of
  a radian. Landing resets nothing.
Here: the first step counts the fake starts; the GNSS start is the first fix fused once the
estimate is POSITION_VALID_DELAY_S old (the commander's stand-in for the checks passing:
vehicles/commander.py), with the heading alignment counted at the same step, and the velocity
and position reset by estimation.py's reset to the fix; the in-flight reset is counted with
the magnetometer working. This estimator's heading follows the magnetometer all along (its
complementary filter), so both heading resets change it by 0. The counters are floats here and
published as uint8 (they wrap, as PX4's do).
"""

from __future__ import annotations

import math

from numba.extending import register_jitable

# Columns from the estimator row's offset (estimation.E_RS): the quaternion's reset count and
# the last reset's heading change (rad), the estimate's age (s), the start-up stage, the height
# (down, m) the vehicle took off at (NaN on the ground), 1.0 once the heading was reset in flight.
Q_RESET, UPTIME, STAGE, TAKEOFF_DOWN, ALIGNED_IN_FLIGHT, SIZE = 0, 2, 3, 4, 5, 6
STAGE_INIT, STAGE_WAITING_FOR_GNSS, STAGE_GNSS = 0.0, 1.0, 2.0
GNSS_START_S = 1.0  # vehicles/commander.py POSITION_VALID_DELAY_S
IN_FLIGHT_YAW_RESET_M = 1.5 - 0.1  # checkHaglYawResetReq's HAGL less EKF2_MIN_RNG's terrain


def initial_row() -> list[float]:
    row = [0.0] * SIZE
    row[TAKEOFF_DOWN] = math.nan
    return row


@register_jitable
def step(e, r: int, dt_s: float, columns) -> None:
    """Every step: the estimate's age; at its first, the fake height and position starts
    (``columns``: the estimator's posNE, velNE, velD and posD reset columns, each a count then
    the last change)."""
    e[r + UPTIME] += dt_s
    if e[r + STAGE] == STAGE_INIT:
        e[r + STAGE] = STAGE_WAITING_FOR_GNSS
        xy, vxy, vz, z = columns
        _count(e, z, 0.0, 0.0, 1)
        _count(e, vz, 0.0, 0.0, 1)
        _count(e, xy, 0.0, 0.0, 2)
        _count(e, vxy, 0.0, 0.0, 2)


@register_jitable
def _count(e, col: int, d0: float, d1: float, n: int) -> None:
    e[col] += 1.0
    e[col + 1] = d0
    if n == 2:
        e[col + 2] = d1


@register_jitable
def gnss_starting(e, r: int) -> bool:
    """Whether a fix fused now starts the GNSS fusion (its checks passed)."""
    return e[r + STAGE] == STAGE_WAITING_FOR_GNSS and e[r + UPTIME] >= GNSS_START_S - 1e-9


@register_jitable
def gnss_reset(e, r: int, columns, use_pos: bool, use_vel: bool, dp0: float, dp1: float,
               dv0: float, dv1: float, dv2: float, starting: bool, gnss_height: bool) -> None:
    """The estimate reset to a fix (resetHorizontalPositionToGnss, resetVelocityToGnss), counted
    with its changes; ``starting`` the GNSS fusion: also the GNSS height's start as the
    reference (posD, change ≈ 0, when the fix's height is used) and the heading's alignment
    (quat; this estimator's heading follows the magnetometer from the start: change 0)."""
    xy, vxy, vz, z = columns
    if use_pos:
        _count(e, xy, dp0, dp1, 2)
    if use_vel:
        _count(e, vxy, dv0, dv1, 2)
        _count(e, vz, dv2, 0.0, 1)
    if starting:
        if gnss_height:
            _count(e, z, 0.0, 0.0, 1)
        _count(e, r + Q_RESET, 0.0, 0.0, 1)
        e[r + STAGE] = STAGE_GNSS


@register_jitable
def in_flight_heading_reset(e, r: int, flying: bool, down_m: float, mag_ok: bool) -> None:
    """Once per flight, 1.4 m above the take-off height, the heading's reset to the
    magnetometer's (with a magnetometer: ``mag_ok``), counted; this estimator's heading follows
    the magnetometer all along, so the change is 0."""
    if not flying:
        e[r + TAKEOFF_DOWN] = math.nan
    elif math.isnan(e[r + TAKEOFF_DOWN]):
        e[r + TAKEOFF_DOWN] = down_m
        e[r + ALIGNED_IN_FLIGHT] = 0.0
    elif mag_ok and e[r + ALIGNED_IN_FLIGHT] == 0.0 \
            and e[r + TAKEOFF_DOWN] - down_m > IN_FLIGHT_YAW_RESET_M:
        e[r + ALIGNED_IN_FLIGHT] = 1.0
        _count(e, r + Q_RESET, 0.0, 0.0, 1)
