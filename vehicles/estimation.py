"""Simulated sensors and the estimator every vehicle flies on, compiled over all rows of a World.

Sensors (what PX4 SITL with Gazebo's x500 sees):
- IMU at the physics rate (250 Hz = the ``update_rate`` of ``imu_sensor`` in PX4-gazebo-models
  models/x500_base/model.sdf): gyro white noise σ 0.00018665 rad/s with a dynamic bias of
  σ 3.8785e-5 rad/s and correlation time 1000 s; accelerometer white noise σ 0.00186 m/s² with a
  dynamic bias of σ 0.006 m/s² and correlation time 300 s. The accelerometer measures the
  specific force (acceleration minus gravity) in the body frame.
- Barometer at 50 Hz (``air_pressure_sensor``: pressure noise σ 0.01 Pa, as height
  σ 0.01 Pa / (ρ₀ g) with ISA sea-level density), which PX4 v1.15's gz bridge publishes as
  sensor_baro (barometerCallback; 4001_gz_x500 sets SENS_EN_BAROSIM 0); the telemetry turns the
  height into gz-sensors' pressure (gateway/mavlink/telemetry.py ``baro_sample``).
- Magnetometer at 50 Hz: the Earth's field in the body frame plus white noise σ (0.02, 0.02,
  0.03) gauss (sensor_mag_sim); EKF2 takes vehicle_magnetometer's means (mag_fusion.py).
- GPS at 8 Hz as PX4 v1.15's SITL for gz_x500 has it: the airframe (4001_gz_x500) sets
  SENS_EN_GPSSIM, so sensor_gps comes from src/modules/simulation/sensor_gps_sim (the gz bridge's
  navSatCallback only publishes the ground truth, vehicle_global_position_groundtruth, at the
  ``navsat_sensor``'s 30 Hz). SensorGpsSim::Run, every 125 ms (ScheduleOnInterval), takes the
  latest ground truth (position: the last 30 Hz navsat sample; velocity: the local position
  ground truth, every physics step) and adds white Gaussian noise: σ 0.2 m north and east, 0.5 m
  in altitude, (0.06, 0.077, 0.158) m/s in velocity (noiseGauss3f). It adds no delay: the fix
  describes the vehicle when it was taken (at most one navsat period earlier), while EKF2 fuses
  it as EKF2_GPS_DELAY (110 ms) plus half its 10 ms filter period older than its publication
  (EstimatorInterface::setGpsData on sensor_gps.timestamp): PX4 SITL's mismatch, kept here.
  Its reported accuracies are constants (GPS_EPH_M, GPS_EPV_M, GPS_S_VARIANCE_MPS, the DOPs,
  SIM_GPS_USED satellites) with a 3D fix. It publishes only when both ground truths updated
  since its last run, which at 30 Hz and every physics step they always have here.
- Failure injection (``set_failed``, PX4 SITL's simulator: a sensor that is off publishes
  nothing, one that is stuck repeats its last sample): a GPS that is off gives no fixes, and the
  estimator dead-reckons on the IMU and counts the time since it last fused one (E_AID_AGE),
  which the vehicle compares with EKF2_NOAID_TOUT; gyro, accelerometer, barometer and magnetometer off or
  stuck keep their last sample (the estimator and the controllers fly on it, as PX4's would on
  a frozen IMU), and the estimator fuses only what arrives and passes its gate.
- ``noise`` scales every noise and bias (1 = the models above, 0 = exact sensors); the GPS's
  sampling (8 Hz of the 30 Hz ground truth) and EKF2's delay stay. Every draw comes from the
  vehicle's own seeded stream (``NoiseBlocks``), so the same seed gives the same noise whatever
  else runs, and lockstep runs repeat exactly.

Estimator (a compact stand-in for EKF2 with PX4's sensor fusion choices: IMU prediction, GPS
position and velocity fused EKF2_GPS_DELAY late, barometric height, magnetometer heading):
- Attitude: the gyro (less its estimated bias) integrated every step; tilt corrected towards
  the specific force the GPS velocity implies (so accelerating flight does not tilt it), heading
  towards the magnetometer, bias learned from both (a complementary filter).
- Position and velocity: the IMU's specific force rotated by the estimated attitude, integrated
  every step; GPS innovations are formed against the estimate of EKF2_GPS_DELAY (and half
  EKF2's filter period) before the fix arrived (a ring of past estimates) and the correction
  is applied to the present and the ring; a fix's velocity or position whose test ratio is
  over 1 on any axis is not fused, and after GNSS_RESET_S with neither fused, or twice that
  without the position, the whole innovation is (EKF2's reset to the fix). Height, vertical
  velocity and the accelerometer's z bias: the vertical channel of height_fusion.py (EKF2's:
  the barometer, the GPS height and vertical velocity in a Kalman filter, each height source
  less its bias but the reference's, EKF2_HGT_REF's fallbacks). A magnetometer heading whose
  test ratio is over 1 (EKF2_MAG_GATE) is rejected. The resets EKF2 makes at start-up and once
  per flight are made and counted as it counts them (ekf_resets.py).
- Wind: with the vehicle flying, the horizontal specific force in the body frame is the drag of
  the air, so the air's velocity follows (EKF2's drag fusion principle), low-passed.
- Health: the innovation test ratios as estimator_status has them (√(innovation² / (gate² ·
  innovation variance)) of the worst axis, with EKF2's noise parameters and gates — for the GPS
  the receiver's eph and s_variance where larger, as EKF2 fuses them; horizontally the
  observation's variance stands for the innovation's) and the accuracies that ESTIMATOR_STATUS
  reports; PX4's vibration metrics (vehicle_imu) for VIBRATION.

The estimate (``estimated``) has the columns of the inner loop's ``measured`` (inner_loop.M_*):
the controllers and the telemetry read it; ``measured`` stays the ground truth the physics uses.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from vehicles import ekf_resets as rs
from vehicles import height_fusion as hf
from vehicles import mag_fusion as mf
from vehicles.aiding import (
    AID_BARO,
    AID_DEFAULT,
    AID_HGT_REF_GPS,
    GPS_CTRL_HGT,
    GPS_CTRL_POS,
    GPS_CTRL_VEL,
    aiding_word,
)
from vehicles.control.compiled import njit_cached
from vehicles.control.rotation import dcm
from vehicles.inner_loop import M_ACCEL, M_POS, M_Q, M_RATES, M_VEL
from vehicles.noise_blocks import NoiseBlocks, with_rows
from vehicles.types import GRAVITY_MPS2, SensorConfig

# --- the sensor models (module docstring for the sources) ---------------------------------------
IMU_RATE_HZ = 250.0
GYRO_NOISE_RADPS = 0.00018665
GYRO_BIAS_RADPS = 3.8785e-05
GYRO_BIAS_TIME_S = 1000.0
ACCEL_NOISE_MPS2 = 0.00186
ACCEL_BIAS_MPS2 = 0.006
ACCEL_BIAS_TIME_S = 300.0
BARO_RATE_HZ = 50.0
BARO_NOISE_PA = 0.01
AIR_DENSITY_KGM3 = 1.225
BARO_NOISE_M = BARO_NOISE_PA / (AIR_DENSITY_KGM3 * GRAVITY_MPS2)
MAG_NOISE_GAUSS = (0.02, 0.02, 0.03)
GPS_RATE_HZ = 8.0  # SensorGpsSim: ScheduleOnInterval(125_ms)
NAVSAT_RATE_HZ = 30.0  # the ground truth it reads: navsat_sensor's update_rate
GPS_POS_NOISE_M = (0.2, 0.2, 0.5)  # north, east, down (latitude, longitude, altitude)
GPS_VEL_NOISE_MPS = (0.06, 0.077, 0.158)  # noiseGauss3f on the NED velocity
# What SensorGpsSim reports with a fix (SIM_GPS_USED ≥ 4): sensor_gps eph, epv, s_variance_m_s,
# hdop, vdop, satellites_used (SIM_GPS_USED's default).
GPS_EPH_M, GPS_EPV_M, GPS_S_VARIANCE_MPS = 0.9, 1.78, 0.4
GPS_HDOP, GPS_VDOP, GPS_SATELLITES_USED = 0.7, 1.1, 10
GPS_DELAY_S = 0.11  # EKF2_GPS_DELAY default (ms in the parameter)
EKF2_FILTER_PERIOD_S = 0.01  # setGpsData also takes off half of it (_dt_ekf_avg / 2)
# The Earth's field at PX4's SITL home (Zurich), gauss NED: 48 µT, inclination 63.5°,
# declination 3° east (WMM; sensor_mag_sim uses the same model at the home position).
MAG_NED_GAUSS = (0.2145, 0.0112, 0.4296)
# EKF2's magnetometer noise and gate (the GPS's and the barometer's: height_fusion.PARAMS).
EKF2_MAG_NOISE, EKF2_MAG_GATE = 0.05, 3.0
BARO_TIMEOUT_S = 0.2  # EKF2's BARO_MAX_INTERVAL: no barometer for this long → GNSS height
GNSS_RESET_S = 7.0  # EKF2's reset_timeout_max: unaided this long, a fix resets the estimate

# Failure injection (``failed``, a bit set per row; MAV_CMD_INJECT_FAILURE's units and types).
F_GPS_OFF, F_BARO_OFF, F_BARO_STUCK, F_MAG_OFF, F_MAG_STUCK = 1, 2, 4, 8, 16
F_GYRO_OFF, F_GYRO_STUCK, F_ACC_OFF, F_ACC_STUCK = 32, 64, 128, 256
F_GYRO, F_ACC = F_GYRO_OFF | F_GYRO_STUCK, F_ACC_OFF | F_ACC_STUCK
F_BARO, F_MAG = F_BARO_OFF | F_BARO_STUCK, F_MAG_OFF | F_MAG_STUCK

HISTORY = 64  # steps of past states kept: delays up to 63 physics steps (252 ms at 250 Hz)
# The World's recent-steps ring (physics.py): per row and physics step, what PX4's logger records
# at the sensors' rate while it runs at 50 Hz: the IMU samples (sensor_combined), the estimated
# attitude and rates (vehicle_attitude, vehicle_angular_velocity), the true ones (*_groundtruth),
# and the sensors module's vehicle_acceleration (vehicle_acceleration.py: R_ACC_LP, from its input
# R_ACC_IN, the bias-corrected accelerometer sample, kept for the filter's next steps).
R_GYRO, R_ACC, R_Q, R_RATES, R_TRUE_Q, R_TRUE_RATES, R_ACC_IN, R_ACC_LP, R_SIZE = (
    0, 3, 6, 10, 13, 17, 20, 23, 26)


# Columns of ``sensed`` (the latest sample of each sensor; NED positions from the spawn point).
S_GYRO, S_ACC, S_MAG, S_BARO_DOWN, S_GPS_POS, S_GPS_VEL, S_VIB, S_PREV, S_SIZE = (
    0, 3, 6, 9, 10, 13, 16, 19, 25)
# Columns of the sensors' own state: gyro bias, accel bias.
B_GYRO, B_ACC, B_SIZE = 0, 3, 6
# Columns of the estimator's state.
(E_Q, E_GYRO_BIAS, E_POS, E_VEL, E_ACC_BIAS_Z, E_CORR, E_F_LP, E_A_LP, E_GPS_VEL_PREV, E_WIND,
 E_RATIOS, E_ACCURACY, E_HAVE_GPS, E_GPS_AGE, E_AID_AGE, E_XY_RESET, E_VXY_RESET, E_VZ_RESET,
 E_Z_RESET, E_POS_AGE, E_HGT) = (0, 4, 7, 10, 13, 14, 17, 20, 23, 26, 28, 33, 35, 36, 37, 38, 41, 44,
                                 46, 48, 49)
E_MAG = E_HGT + hf.H_SIZE  # the magnetometer's way in (mag_fusion.py's MAG_* columns)
E_RS = E_MAG + mf.MAG_SIZE  # EKF2's start-up and in-flight resets (ekf_resets.py's columns)
E_SIZE = E_RS + rs.SIZE
E_QUAT_RESET = E_RS + rs.Q_RESET  # the heading's reset count, then its last change
# since the barometer was last fused: the vertical channel's own clock of it
E_BARO_AGE = E_HGT + hf.H_SRC + hf.BARO * hf.SRC_SIZE + hf.SRC_AGE
# E_RATIOS: velocity, horizontal position, height, magnetometer heading, then the raw wind
# samples' variance (m²/s²); E_ACCURACY: horizontal, vertical (running RMS of the innovations);
# E_GPS_AGE: s since the last fix came; E_BARO_AGE: since the barometer was last fused;
# E_AID_AGE: since a fix's horizontal position or velocity was (EKF2_NOAID_TOUT's clock);
# E_XY_RESET, E_VXY_RESET, E_VZ_RESET, E_Z_RESET (RESET_COLUMNS): EKF2's _state_reset_status
# reset_count posNE, velNE, velD, posD, each with its last change (north and east for the first
# two: vehicle_local_position's *_reset_counter and delta_*); E_HGT: height_fusion.py's H_*.
RESET_COLUMNS = (E_XY_RESET, E_VXY_RESET, E_VZ_RESET, E_Z_RESET)

E_WIND_VAR = E_RATIOS + 4

# Gains of the complementary filters (per second; see the module docstring).
K_TILT, K_HEADING, K_GYRO_BIAS = 0.2, 0.2, 0.002
L_POS, L_VEL_FROM_POS, L_VEL = 1.0, 0.5, 0.5
TAU_ACCEL_REF_S, TAU_WIND_S, TAU_ACCURACY_S = 0.3, 5.0, 5.0


def _gm(dt_s: float, tau_s: float, sigma: float) -> tuple[float, float]:
    """Decay and drive of a first-order Gauss-Markov process with stationary σ ``sigma``."""
    decay = math.exp(-dt_s / tau_s)
    return decay, sigma * math.sqrt(1.0 - decay * decay)


@njit_cached
def _apply_height(e, ring, corr, h_then, v_then):  # pragma: no cover - compiled
    """A height observation's corrections (``corr``: height, vertical velocity, z bias; a reset's
    height and vertical velocity, NaN: none, against ``h_then``, ``v_then``) to now and the ring."""
    dh, dv = corr[0], corr[1] + (0.0 if math.isnan(corr[4]) else corr[4] - v_then)
    if not math.isnan(corr[4]):
        e[E_VZ_RESET], e[E_VZ_RESET + 1] = e[E_VZ_RESET] + 1.0, corr[4] - v_then
    if not math.isnan(corr[3]):  # resetVerticalPositionTo, counted
        e[E_Z_RESET], e[E_Z_RESET + 1] = e[E_Z_RESET] + 1.0, corr[3] - h_then
        dh += corr[3] - h_then
    e[E_POS + 2] += dh
    e[E_VEL + 2] += dv
    e[E_ACC_BIAS_Z] += corr[2]
    for k in range(len(ring)):
        ring[k, 2] += dh
        ring[k, 5] += dv


@njit_cached
def estimate(sensed, est, ehist, hist_i, delay, dt_s, t_s, baro_due, gps_due, flying, consts,
             estimated, failed, aiding, hparams):  # pragma: no cover - compiled
    """Every vehicle's estimate after its sensors (module rules). ``ehist``: the ring of past
    estimated positions and velocities; ``flying``: rows whose drag tells the wind; ``consts``:
    the Earth's field (NED), the airframe's mass over its linear drag; ``aiding``: each row's
    aiding word (``aiding_word``: what of a fix it fuses, whether the barometer aids, which is
    the height reference); ``hparams``: each row's height_fusion.PARAMS."""
    g = 9.80665
    mn, me = consts[0], consts[1]  # the heading needs the horizontal field only
    mass_over_drag = consts[3]
    dt_gps = 1.0 / GPS_RATE_HZ
    dt_baro = 1.0 / 50.0
    a_ref = dt_gps / (TAU_ACCEL_REF_S + dt_gps)
    a_f = dt_s / (TAU_ACCEL_REF_S + dt_s)
    a_wind = dt_baro / (TAU_WIND_S + dt_baro)
    a_acc_gps = dt_gps / (TAU_ACCURACY_S + dt_gps)
    corr = np.zeros(5)  # a height observation's corrections (height_fusion.height_source)
    mag = np.zeros(3)  # a vehicle_magnetometer publication
    for v in range(len(sensed)):
        s = sensed[v]
        e = est[v]
        out = estimated[v]
        f = failed[v]
        rs.step(e, E_RS, dt_s, RESET_COLUMNS)
        # --- attitude: integrate the corrected rates --------------------------------------------
        wx = s[S_GYRO] - e[E_GYRO_BIAS] + e[E_CORR]
        wy = s[S_GYRO + 1] - e[E_GYRO_BIAS + 1] + e[E_CORR + 1]
        wz = s[S_GYRO + 2] - e[E_GYRO_BIAS + 2] + e[E_CORR + 2]
        qw, qx, qy, qz = e[E_Q], e[E_Q + 1], e[E_Q + 2], e[E_Q + 3]
        hx, hy, hz = 0.5 * wx * dt_s, 0.5 * wy * dt_s, 0.5 * wz * dt_s
        nw = qw - qx * hx - qy * hy - qz * hz
        nx = qx + qw * hx + qy * hz - qz * hy
        ny = qy + qw * hy + qz * hx - qx * hz
        nz = qz + qw * hz + qx * hy - qy * hx
        norm = math.sqrt(nw * nw + nx * nx + ny * ny + nz * nz)
        if nw < 0.0:
            norm = -norm
        qw, qx, qy, qz = nw / norm, nx / norm, ny / norm, nz / norm
        e[E_Q], e[E_Q + 1], e[E_Q + 2], e[E_Q + 3] = qw, qx, qy, qz
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = dcm(qw, qx, qy, qz)
        # --- velocity and position: the specific force in NED, plus gravity -------------------
        f0, f1, f2 = s[S_ACC], s[S_ACC + 1], s[S_ACC + 2] - e[E_ACC_BIAS_Z]
        an = r00 * f0 + r01 * f1 + r02 * f2
        ae = r10 * f0 + r11 * f1 + r12 * f2
        ad = r20 * f0 + r21 * f1 + r22 * f2 + g
        for i in range(3):
            e[E_F_LP + i] += a_f * ((an, ae, ad - g)[i] - e[E_F_LP + i])
        e[E_VEL] += an * dt_s
        e[E_VEL + 1] += ae * dt_s
        e[E_VEL + 2] += ad * dt_s
        for i in range(3):
            e[E_POS + i] += e[E_VEL + i] * dt_s
        use = aiding[v]
        hgt_ref = hf.REF_GNSS if use & AID_HGT_REF_GPS else hf.REF_BARO
        hp = hparams[v]
        hf.predict(e, E_HGT, dt_s, r22, hp)
        hf.housekeeping(e, E_HGT, hgt_ref)
        ring = ehist[v]
        slot = ring[hist_i]
        for i in range(3):
            slot[i] = e[E_POS + i]
            slot[3 + i] = e[E_VEL + i]
        # --- GPS: delayed innovations, corrections to the present and the ring -----------------
        e[E_GPS_AGE] += dt_s
        e[E_AID_AGE] += dt_s
        e[E_POS_AGE] += dt_s
        use_pos, use_vel = use & GPS_CTRL_POS != 0, use & GPS_CTRL_VEL != 0
        if f & F_GPS_OFF:
            e[E_HAVE_GPS] = 0.0  # no tilt reference until fixes come again
        elif gps_due:
            e[E_GPS_AGE] = 0.0
            old = ring[(hist_i - delay[v]) % len(ring)]
            ep0, ep1 = s[S_GPS_POS] - old[0], s[S_GPS_POS + 1] - old[1]
            ev0, ev1, ev2 = (s[S_GPS_VEL] - old[3], s[S_GPS_VEL + 1] - old[4],
                             s[S_GPS_VEL + 2] - old[5])
            # EKF2's test ratios (innovation² / (gate² · innovation variance); horizontally the
            # observations' variances) per axis: a velocity or position failing on any axis is not
            # fused (updateGnssVel, updateGnssPos, setEstimatorAidStatusTestRatio)
            vnoise, vgate = max(GPS_S_VARIANCE_MPS, hp[hf.P_GPS_V_NOISE]), max(hp[hf.P_GPS_V_GATE], 1.0)
            pnoise, pgate = max(GPS_EPH_M, hp[hf.P_GPS_P_NOISE]), max(hp[hf.P_GPS_P_GATE], 1.0)
            r_vel = max(max(ev0 * ev0, ev1 * ev1) / (vgate * vnoise) ** 2, ev2 * ev2 / (
                vgate * vgate * (e[E_HGT + hf.H_P + 4] + hf.gnss_vz_noise(hp) ** 2)))
            r_pos = max(ep0 * ep0, ep1 * ep1) / (pgate * pnoise) ** 2
            fuse_pos, fuse_vel = use_pos and r_pos <= 1.0, use_vel and r_vel <= 1.0
            dp0 = dp1 = dv0 = dv1 = dv2 = dh = db = 0.0
            if fuse_pos:
                dp0, dp1 = L_POS * dt_gps * ep0, L_POS * dt_gps * ep1
                dv0, dv1 = L_VEL_FROM_POS * dt_gps * ep0, L_VEL_FROM_POS * dt_gps * ep1
            if fuse_vel:  # (0.0 + x is x); vertically the vertical channel's filter
                dv0, dv1 = dv0 + L_VEL * dt_gps * ev0, dv1 + L_VEL * dt_gps * ev1
                hf.fuse(e, E_HGT, 1, ev2, hf.gnss_vz_noise(hp) ** 2, vgate, corr)
                dh, dv2, db = corr[0], corr[1], corr[2]
            fused = fuse_pos or fuse_vel
            # "starting GPS fusion" (ekf_resets.py), or shouldResetGpsFusion (none fused for 7 s,
            # or no position for 14 s): reset to the fix
            starting = (use_pos or use_vel) and rs.gnss_starting(e, E_RS)
            if starting or e[E_AID_AGE] >= GNSS_RESET_S or use_pos and e[E_POS_AGE] >= 2.0 * GNSS_RESET_S:
                fused, fuse_pos = use_pos or use_vel, use_pos
                dp0, dp1 = (ep0, ep1) if use_pos else (0.0, 0.0)
                dv0, dv1, dv2 = (ev0, ev1, ev2) if use_vel else (0.0, 0.0, 0.0)
                dh = db = 0.0
                rs.gnss_reset(e, E_RS, RESET_COLUMNS, use_pos, use_vel, dp0, dp1, dv0, dv1, dv2,
                              starting, use & GPS_CTRL_HGT != 0)
                if use_vel:  # resetVelocityTo: the velocity's variance the observation's
                    hf.uncorrelate(e, E_HGT, 1, hf.gnss_vz_noise(hp) ** 2)
            if fuse_pos:
                e[E_POS_AGE] = 0.0
            if fused:
                e[E_AID_AGE] = 0.0
                e[E_POS] += dp0
                e[E_POS + 1] += dp1
                e[E_VEL] += dv0
                e[E_VEL + 1] += dv1
                e[E_VEL + 2] += dv2
                e[E_POS + 2] += dh
                e[E_ACC_BIAS_Z] += db
                for k in range(len(ring)):
                    ring[k, 0] += dp0
                    ring[k, 1] += dp1
                    ring[k, 2] += dh
                    ring[k, 3] += dv0
                    ring[k, 4] += dv1
                    ring[k, 5] += dv2
            if use_vel:
                # The acceleration the GPS velocity implies: the tilt reference.
                if e[E_HAVE_GPS] > 0.0:
                    for i in range(3):
                        acc = (s[S_GPS_VEL + i] - e[E_GPS_VEL_PREV + i]) / dt_gps
                        e[E_A_LP + i] += a_ref * (acc - e[E_A_LP + i])
                e[E_HAVE_GPS] = 1.0
                for i in range(3):
                    e[E_GPS_VEL_PREV + i] = s[S_GPS_VEL + i]
                e[E_RATIOS] = math.sqrt(r_vel)  # get_innovation_test_status's
            else:
                e[E_HAVE_GPS] = 0.0  # no GPS velocity, no tilt reference
            if use_pos:
                e[E_RATIOS + 1] = math.sqrt(r_pos)
                e[E_ACCURACY] = math.sqrt(e[E_ACCURACY] ** 2 + a_acc_gps * (
                    ep0 * ep0 + ep1 * ep1 - e[E_ACCURACY] ** 2))
            # the GPS height: the vertical channel's (as taken, against the estimate then)
            hf.height_source(e, E_HGT, hf.GNSS, s[S_GPS_POS + 2], old[2], s[S_GPS_VEL + 2]
                             if use_vel else math.nan, use & GPS_CTRL_HGT != 0, hgt_ref, hp, corr)
            _apply_height(e, ring, corr, old[2], old[5])
            e[E_RATIOS + 2] = hf.innovation_ratio(e, E_HGT)
        # --- barometer and magnetometer (50 Hz): height, attitude corrections, wind -----------
        air = hf.air_data(e, E_HGT, s[S_BARO_DOWN], t_s, hp[hf.P_BARO_RATE]) \
            if baro_due and not f & F_BARO_OFF else math.nan
        if not math.isnan(air):
            eh = air - e[E_HGT + hf.H_SRC + hf.SRC_BIAS] - e[E_POS + 2]
            hf.height_source(e, E_HGT, hf.BARO, air, e[E_POS + 2], math.nan, use & AID_BARO != 0,
                             hgt_ref, hp, corr)
            e[E_RATIOS + 2] = hf.innovation_ratio(e, E_HGT)
            if e[E_BARO_AGE] == 0.0:  # fused
                a_acc_baro = 1.0 / (5.0 * hp[hf.P_BARO_RATE] + 1.0)  # dt / (5 s + dt), as fused
                e[E_ACCURACY + 1] = math.sqrt(
                    e[E_ACCURACY + 1] ** 2 + a_acc_baro * (eh * eh - e[E_ACCURACY + 1] ** 2))
            _apply_height(e, ring, corr, e[E_POS + 2], e[E_VEL + 2])
        if baro_due:
            # Tilt: the measured specific force (NED, low-passed) against the one the GPS
            # velocity implies; heading: the field against the Earth's.
            c0 = c1 = 0.0
            if e[E_HAVE_GPS] > 0.0:
                r0, r1, r2 = e[E_A_LP], e[E_A_LP + 1], e[E_A_LP + 2] - g
                m0, m1, m2 = e[E_F_LP], e[E_F_LP + 1], e[E_F_LP + 2]
                rr = r0 * r0 + r1 * r1 + r2 * r2
                c0 = (r1 * m2 - r2 * m1) / rr
                c1 = (r2 * m0 - r0 * m2) / rr
            # vehicle_magnetometer's mean of n samples: the correction of the n, once (gated)
            n = 0 if f & F_MAG_OFF else mf.publish(e, E_MAG, s[S_MAG], s[S_MAG + 1], s[S_MAG + 2],
                                                   t_s, hp[hf.P_MAG_RATE], mag)
            yaw_err = 0.0
            if n:
                yaw_err, field_err = mf.heading_error(mag, r00, r01, r02, r10, r11, r12, mn, me)
                e[E_RATIOS + 3] = abs(field_err) / (EKF2_MAG_GATE * EKF2_MAG_NOISE)  # √ratio
                yaw_err = n * yaw_err if e[E_RATIOS + 3] <= 1.0 else 0.0
            w0, w1, w2 = -K_TILT * c0, -K_TILT * c1, -K_HEADING * yaw_err
            # Into the body frame: Rᵀ ω.
            bx = r00 * w0 + r10 * w1 + r20 * w2
            by = r01 * w0 + r11 * w1 + r21 * w2
            bz = r02 * w0 + r12 * w1 + r22 * w2
            e[E_CORR], e[E_CORR + 1], e[E_CORR + 2] = bx, by, bz
            e[E_GYRO_BIAS] -= K_GYRO_BIAS * bx * dt_baro
            e[E_GYRO_BIAS + 1] -= K_GYRO_BIAS * by * dt_baro
            e[E_GYRO_BIAS + 2] -= K_GYRO_BIAS * bz * dt_baro
            if flying[v]:
                # The drag's specific force (body x, y) → the air relative to the body.
                ux, uy = -mass_over_drag * s[S_ACC], -mass_over_drag * s[S_ACC + 1]
                vn, ve, vd = e[E_VEL], e[E_VEL + 1], e[E_VEL + 2]
                uz = r02 * vn + r12 * ve + r22 * vd
                wn = vn - (r00 * ux + r01 * uy + r02 * uz)
                we = ve - (r10 * ux + r11 * uy + r12 * uz)
                dn, de = wn - e[E_WIND], we - e[E_WIND + 1]
                e[E_WIND] += a_wind * dn
                e[E_WIND + 1] += a_wind * de
                e[E_WIND_VAR] += a_wind * (dn * dn + de * de - e[E_WIND_VAR])
        rs.in_flight_heading_reset(e, E_RS, flying[v], e[E_POS + 2], not f & F_MAG_OFF)
        # --- the estimate, in the columns of ``measured`` -------------------------------------
        for i in range(3):
            out[M_POS + i] = e[E_POS + i]
            out[M_VEL + i] = e[E_VEL + i]
        out[M_Q], out[M_Q + 1], out[M_Q + 2], out[M_Q + 3] = qw, qx, qy, qz
        out[M_RATES] = s[S_GYRO] - e[E_GYRO_BIAS]
        out[M_RATES + 1] = s[S_GYRO + 1] - e[E_GYRO_BIAS + 1]
        out[M_RATES + 2] = s[S_GYRO + 2] - e[E_GYRO_BIAS + 2]
        out[M_ACCEL], out[M_ACCEL + 1], out[M_ACCEL + 2] = an, ae, ad


class Estimation:
    """The sensors and estimators of every row of a World (module rules)."""

    def __init__(self, dt_s: float, config: SensorConfig, mass_kg: float, drag_n_per_mps: float,
                 rng_for: Callable[[int], np.random.Generator] | None) -> None:
        if config.noise > 0.0 and rng_for is None:
            raise ValueError("sensor noise needs seeded generators")
        self.dt_s = dt_s
        self.config = config
        self.noise = NoiseBlocks(rng_for)
        g_decay, g_drive = _gm(dt_s, GYRO_BIAS_TIME_S, GYRO_BIAS_RADPS)
        a_decay, a_drive = _gm(dt_s, ACCEL_BIAS_TIME_S, ACCEL_BIAS_MPS2)
        self.sense_consts = np.array([g_decay, g_drive, a_decay, a_drive, GYRO_NOISE_RADPS,
                                      ACCEL_NOISE_MPS2, BARO_NOISE_M, *MAG_NOISE_GAUSS,
                                      *MAG_NED_GAUSS])
        self.est_consts = np.array([*MAG_NED_GAUSS, mass_kg / drag_n_per_mps])
        self.hist_i = 0
        self.sensed = np.zeros((0, S_SIZE))  # the latest sample of each sensor (S_*)
        self.bias = np.zeros((0, B_SIZE))  # the sensors' own state (B_*)
        self.est = np.zeros((0, E_SIZE))  # the estimator's state (E_*)
        self.hist = np.zeros((0, HISTORY, 6))  # true positions and velocities, a ring
        self.ehist = np.zeros((0, HISTORY, 6))  # estimated positions and velocities, a ring
        self.delay = np.zeros(0, np.int64)  # how late EKF2 takes a fix to be, physics steps
        self.failed = np.zeros(0, np.int64)  # failure injection: F_* bits per row
        self.aiding = np.zeros(0, np.int64)  # each row's aiding word (aiding_word)
        self.hparams = np.zeros((0, len(hf.PARAMS)))  # each row's height_fusion.PARAMS
        self.acc_lp = np.zeros((0, 5))  # each row's vehicle_acceleration filter (lowpass2p)
        self.acc_lp_reset = np.zeros(0, np.int64)  # the steps left of its reset

    def set_aiding(self, row: int, gps_ctrl: float | None, baro_ctrl: float | None,
                   hgt_ref: float | None) -> None:
        """The row's EKF2_GPS_CTRL, EKF2_BARO_CTRL and EKF2_HGT_REF (None: the default), from
        its next samples (EKF2 takes them at its parameter update)."""
        self.aiding[row] = aiding_word(gps_ctrl, baro_ctrl, hgt_ref)

    def set_height_params(self, row: int, get: Callable[[str], float | None]) -> None:
        """The row's vertical channel parameters (height_fusion.PARAMS) from ``get(name)``."""
        self.hparams[row] = hf.params_row(get)

    def set_failed(self, row: int, bits: int, on: bool) -> None:
        """Failure injection: the row's sensors of ``bits`` (F_*) fail (``on``) or work again."""
        self.failed[row] = (self.failed[row] | bits) if on else (self.failed[row] & ~bits)

    def _resize(self, n: int) -> None:
        for name in ("sensed", "bias", "est", "hist", "ehist", "delay", "failed", "aiding", "hparams",
                     "acc_lp", "acc_lp_reset"):
            setattr(self, name, with_rows(getattr(self, name), n))

    def add(self, index: int, truth: np.ndarray, estimated: np.ndarray,
            gps_delay_s: float = GPS_DELAY_S,
            accel_lp: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 0.0),
            hgt_ref: float | None = None) -> None:
        """A row for vehicle ``index`` at ``truth`` (a row of ``measured``), its estimate
        converged there (``estimated``: its row of the estimate); ``accel_lp``: its
        vehicle_acceleration filter (lowpass2p); ``hgt_ref``: EKF2_HGT_REF (None: the GPS)."""
        k = len(self.est)
        self._resize(k + 1)
        self.acc_lp[k] = accel_lp
        self.aiding[k] = AID_DEFAULT
        self.hparams[k] = hf.params_row(lambda name: None)
        self.noise.add(index)
        # EKF2 fuses a fix as taken EKF2_GPS_DELAY and half its filter period before it arrived.
        late_s = gps_delay_s + EKF2_FILTER_PERIOD_S / 2.0
        self.delay[k] = max(0, min(HISTORY - 1, int(round(late_s / self.dt_s))))
        e = self.est[k]
        e[E_Q:E_Q + 4] = truth[M_Q:M_Q + 4]
        e[E_POS:E_POS + 3] = truth[M_POS:M_POS + 3]
        e[E_VEL:E_VEL + 3] = truth[M_VEL:M_VEL + 3]
        ref = hf.REF_GNSS if hgt_ref is None or int(hgt_ref) == 1 else hf.REF_BARO
        e[E_HGT:E_HGT + hf.H_SIZE] = hf.initial_row(ref)
        e[E_MAG:E_MAG + mf.MAG_SIZE] = mf.initial_row()
        e[E_RS:E_RS + rs.SIZE] = rs.initial_row()
        self.hist[k, :, :3] = self.ehist[k, :, :3] = truth[M_POS:M_POS + 3]
        self.hist[k, :, 3:] = self.ehist[k, :, 3:] = truth[M_VEL:M_VEL + 3]
        s = self.sensed[k]
        s[S_BARO_DOWN] = truth[M_POS + 2]
        s[S_GPS_POS:S_GPS_POS + 3] = truth[M_POS:M_POS + 3]
        estimated[:] = truth
        estimated[M_ACCEL:M_ACCEL + 3] = 0.0

    def kernel_args(self) -> tuple:
        """What ``sense`` and ``estimate`` read and write, in the order the World's compiled step
        takes it (physics.py): valid until the next ``add``."""
        return (float(self.config.noise), self.noise.block, self.delay, self.hist, self.bias,
                self.sensed, self.sense_consts, self.failed, self.aiding, self.hparams, self.est, self.ehist,
                self.est_consts, self.acc_lp, self.acc_lp_reset)

    def begin_step(self) -> tuple[int, int]:
        """The ring slot that this step's samples go to and the column of this step's draws in
        the noise block; ``end_step`` after the compiled step."""
        self.hist_i = (self.hist_i + 1) % HISTORY
        return self.hist_i, self.noise.j

    def end_step(self) -> None:
        self.noise.advance()
