"""Sensors with PX4's Gazebo x500 noise and the estimator the vehicle flies on
(vehicles/estimation.py): noise levels, the GPS's rate, noise and (absent) delay, convergence,
wind from the drag, seeded repeatability, a scenario's [sensors] noise, and what the telemetry
says of them."""

from __future__ import annotations

import math
import statistics

import numpy as np
import pytest

from gateway.sim import scenario as scenario_mod
from gateway.testing import Sim
from vehicles import estimation as est
from vehicles.estimation import E_RATIOS, E_WIND, S_ACC, S_GPS_POS, S_GYRO
from vehicles.sensing import sense
from vehicles.types import CommandResult, SensorConfig


def specific_force_frd(m) -> tuple[float, float, float]:
    """What an exact accelerometer measures: (acceleration − gravity) in the body frame."""
    w, x, y, z = m.attitude_q
    a, b, c = m.accel_ned_mps2[0], m.accel_ned_mps2[1], m.accel_ned_mps2[2] - 9.80665
    return ((1 - 2 * (y * y + z * z)) * a + 2 * (x * y + w * z) * b + 2 * (x * z - w * y) * c,
            2 * (x * y - w * z) * a + (1 - 2 * (x * x + z * z)) * b + 2 * (y * z + w * x) * c,
            2 * (x * z + w * y) * a + 2 * (y * z - w * x) * b + (1 - 2 * (x * x + y * y)) * c)


def hovering(sim: Sim) -> None:
    assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
    api = sim.api(0)
    assert api.arm() == 0 and api.takeoff() == 0
    assert sim.run_until(lambda: sim.status(0).nav_state.name == "AUTO_LOITER", timeout_s=30)
    sim.advance(5.0)


def series(sim: Sim, seconds: float, read) -> list:
    out = []
    steps = int(round(seconds / sim.simulation.world.dt_s))
    for _ in range(steps):
        sim.advance(sim.simulation.world.dt_s)
        out.append(read(sim.vehicles[0]))
    return out


def test_hover_imu_noise_and_position_estimate_match_the_x500_models():
    with Sim() as sim:
        hovering(sim)
        samples = series(sim, 4.0, lambda v: (v.sensors, v.truth, v.kinematics))
    # Accelerometer and gyro noise (measured less true): the white noise σ of the model (the
    # biases move over minutes, not seconds). The body's horizontal specific force at hover is
    # the drag alone: of the centimetre motions the position controller makes following an
    # estimate that carries some of the GPS's white noise (sensor_gps_sim: σ 0.2 m).
    for axis in range(3):
        acc = [s[S_ACC + axis] - specific_force_frd(t)[axis] for s, t, _ in samples]
        gyro = [s[S_GYRO + axis] - t.rates_frd_radps[axis] for s, t, _ in samples]
        assert statistics.pstdev(acc) == pytest.approx(est.ACCEL_NOISE_MPS2, rel=0.2)
        assert statistics.pstdev(gyro) == pytest.approx(est.GYRO_NOISE_RADPS, rel=0.2)
    for axis in range(2):
        assert statistics.pstdev(s[S_ACC + axis] for s, _, _ in samples) < 0.02
    # The estimate is within centimetres of the truth and varies less than the GPS fixes (its
    # height follows the GPS's, σ 0.5 m, the height reference).
    errors = [math.dist(k.position_ned_m, t.position_ned_m) for _, t, k in samples]
    assert max(errors) < 0.25
    north = [k.position_ned_m[0] for _, _, k in samples]
    fixes = [s[S_GPS_POS] for s, _, _ in samples]
    assert 0.001 < statistics.pstdev(north) < statistics.pstdev(fixes)
    # Attitude estimate within a degree (the heading follows the noisy magnetometer).
    for _, t, k in samples[::50]:
        dot = abs(sum(a * b for a, b in zip(t.attitude_q, k.attitude_q)))
        assert math.degrees(2 * math.acos(min(1.0, dot))) < 1.0


def test_gps_fixes_come_at_8_hz_without_delay_and_exact_without_noise():
    """SensorGpsSim (PX4 v1.15, gz_x500): a fix every 125 ms, its position the latest 30 Hz
    navsat ground truth, its velocity the current one; no EKF2_GPS_DELAY in the sample."""
    exact = scenario_mod.parse({"sensors": {"noise": 0}})
    with Sim(scenario=exact) as sim:
        hovering(sim)
        v = sim.vehicles[0]
        far = v.origin.offset_ned(80.0, 0.0, -2.5)  # moving: a delay would show
        assert v.goto(sim.now, far.lat_deg, far.lon_deg, far.alt_amsl_m) is CommandResult.ACCEPTED
        sim.advance(6.0)
        world = sim.simulation.world
        dt = world.dt_s
        truths = {}  # physics step -> the true position and velocity after it
        fixes = []  # (physics step, the GPS fix after it)
        for _ in range(500):
            sim.advance(dt)  # one step, or none or two where the float clock rounds
            v = sim.vehicles[0]
            truths[world.steps] = (v.truth.position_ned_m, v.truth.velocity_ned_mps)
            fixes.append((world.steps, tuple(v.sensors[S_GPS_POS:S_GPS_POS + 6])))
        new = [step for (step, fix), (before_step, before) in zip(fixes[1:], fixes)
               if fix != before and before_step == step - 1]
        # 2 s: 16 fixes, 125 ms apart (31 or 32 steps of 4 ms).
        assert 15 <= len(new) <= 16
        assert {b - a for a, b in zip(new, new[1:])} <= {31, 32}
        late = int(round(est.GPS_DELAY_S / dt))
        for step in new:
            if any(step - a not in truths for a in range(late + 1)):
                continue  # not recorded long enough
            fix = dict(fixes)[step]
            # The position: the truth of the last navsat sample (30 Hz: at most 8 steps ago).
            ages = [a for a in range(9) if fix[:3] == pytest.approx(truths[step - a][0], abs=1e-9)]
            assert ages, step
            assert fix[:3] != pytest.approx(truths[step - late][0], abs=1e-3)
            assert fix[3:] == pytest.approx(truths[step][1], abs=1e-9)
        # EKF2 still takes each fix as EKF2_GPS_DELAY older than it is: PX4 SITL's mismatch, so
        # in flight the estimate runs ahead of the truth, by ~0.1 s of travel.
        v = sim.vehicles[0]
        pos_est, pos_true = v.kinematics.position_ned_m, v.truth.position_ned_m
        vel = v.truth.velocity_ned_mps
        speed = math.hypot(vel[0], vel[1])
        assert speed > 2.0
        ahead = ((pos_est[0] - pos_true[0]) * vel[0] + (pos_est[1] - pos_true[1]) * vel[1]) / speed
        assert 0.03 * speed < ahead < 0.15 * speed


def _gps_samples(count: int, scale: float = 1.0, failed: int = 0) -> np.ndarray:
    """``count`` fixes of the GPS kernel at rest at the origin: (north, east, down, vn, ve, vd)."""
    from vehicles.inner_loop import M_Q, M_SIZE
    e = est.Estimation(0.004, SensorConfig(noise=scale), 2.0, 1.0,
                       lambda index: np.random.default_rng([7, index]))
    measured = np.zeros((1, M_SIZE))
    measured[0, M_Q] = 1.0
    estimated = np.zeros((1, M_SIZE))
    e.add(0, measured[0], estimated[0])
    e.failed[0] = failed
    out = []
    for _ in range(count):
        hist_i, j = e.begin_step()
        sense(measured, e.noise.block, j, e.dt_s, scale, False, True, 0, e.hist, hist_i,
                  e.bias, e.sensed, e.sense_consts, e.failed)
        e.end_step()
        out.append(e.sensed[0, S_GPS_POS:S_GPS_POS + 6].copy())
    return np.array(out)


def test_gps_noise_is_sensor_gps_sims_white_noise_per_axis():
    """SensorGpsSim: white Gaussian noise, σ 0.2 m north and east (latitude, longitude), 0.5 m
    in altitude, (0.06, 0.077, 0.158) m/s in velocity; no correlation from fix to fix."""
    fixes = _gps_samples(4000)
    sigmas = (*est.GPS_POS_NOISE_M, *est.GPS_VEL_NOISE_MPS)
    assert sigmas == (0.2, 0.2, 0.5, 0.06, 0.077, 0.158)
    for axis, sigma in enumerate(sigmas):
        x = fixes[:, axis]
        assert abs(x.mean()) < 4 * sigma / math.sqrt(len(x))
        assert x.std() == pytest.approx(sigma, rel=0.05), axis
        lag1 = float(np.corrcoef(x[1:], x[:-1])[0, 1])
        assert abs(lag1) < 0.06, axis  # white: a Gauss-Markov process would be ~0.9
    # Exact sensors: the truth itself; a GPS that is off gives no fix (the last one stays).
    assert not _gps_samples(10, scale=0.0).any()
    assert not _gps_samples(10, failed=est.F_GPS_OFF).any()


def test_gps_raw_int_reports_sensor_gps_sims_accuracies_and_ekf2_fuses_them():
    # Ekf::updateGnssPos/updateGnssVel fuse max(eph, EKF2_GPS_P_NOISE), max(s_variance,
    # EKF2_GPS_V_NOISE): with the defaults, the receiver's.
    assert (est.GPS_EPH_M, est.GPS_S_VARIANCE_MPS) == (0.9, 0.4)
    from gateway.mavlink import telemetry
    assert (telemetry.GPS_EPH_CM, telemetry.GPS_EPV_CM) == (70, 110)  # hdop, vdop x 100
    assert (telemetry.GPS_H_ACC_MM, telemetry.GPS_V_ACC_MM, telemetry.GPS_VEL_ACC_MM) == (
        900, 1780, 400)  # eph, epv, s_variance_m_s x 1000
    assert telemetry.GPS_SATELLITES == 10  # SIM_GPS_USED


def test_same_seed_same_noise_other_seed_other_noise():
    def run(seed):
        sc = scenario_mod.parse({"network": {"seed": seed}})
        with Sim(scenario=sc) as sim:
            sim.advance(2.0)
            return sim.vehicles[0].sensors, sim.vehicles[0].kinematics.position_ned_m

    assert run(3) == run(3)
    assert run(3) != run(4)


def test_wind_is_estimated_from_the_drag():
    windy = scenario_mod.parse({"environment": {"wind_speed_mps": 5.0, "wind_from_deg": 270.0}})
    with Sim(scenario=windy) as sim:
        hovering(sim)
        sim.advance(20.0)
        e = sim.vehicles[0].estimator
        assert e[E_WIND] == pytest.approx(0.0, abs=0.5)
        assert e[E_WIND + 1] == pytest.approx(5.0, abs=0.5)  # blowing towards the east
        assert max(e[E_RATIOS:E_RATIOS + 4]) < 1.0  # every innovation test passes


@pytest.mark.parametrize("doc", [{"noise": -1}, {"noise": "loud"}, {"nosie": 1}])
def test_sensors_table_is_checked(doc):
    with pytest.raises(scenario_mod.ScenarioError, match="sensors"):
        scenario_mod.parse({"sensors": doc})


def test_telemetry_reports_the_sensors_and_the_estimator():
    from gateway.mavlink.link import LinkKind
    with Sim(links=(LinkKind.API, LinkKind.GCS)) as sim:
        gcs, api = sim.gcs(0), sim.api(0)
        gcs.start_heartbeat()
        sim.advance(12.0)
        for name in ("ESTIMATOR_STATUS", "VIBRATION", "HIGHRES_IMU", "GPS_RAW_INT"):
            assert api.messages(name), name
        # EKF2 publishes no wind without drag fusion (EKF2_DRAG_CTRL 0): no WIND_COV.
        assert not api.messages("WIND_COV") and not gcs.messages("WIND_COV")
        # PX4's rates: ESTIMATOR_STATUS 0.5 Hz, VIBRATION 0.1 Hz (normal mode).
        assert 5 <= len(gcs.messages("ESTIMATOR_STATUS")) <= 7
        assert 1 <= len(gcs.messages("VIBRATION")) <= 2
        status = api.last("ESTIMATOR_STATUS")
        assert status.flags & 0x33F == 0x33F and max(status.vel_ratio, status.pos_horiz_ratio) < 1
        imu = api.messages("HIGHRES_IMU")
        assert len({m.xacc for m in imu}) > 1  # noisy, not a constant
        sys_status = gcs.last("SYS_STATUS")
        assert sys_status.onboard_control_sensors_health & 0x200000  # AHRS healthy
def test_rows_grow_in_place_and_keep_their_values():
    from vehicles.estimation import with_rows

    a = np.zeros((0, 3))
    buffers = set()
    for n in range(1, 40):
        a = with_rows(a, n)
        a[-1] = n
        buffers.add(id(a.base))
    assert a.shape == (39, 3) and list(a[:, 0]) == list(range(1, 40))
    assert len(buffers) <= 7  # the buffer doubles: a handful of copies for 39 rows, not 39
    assert a.flags.c_contiguous  # the compiled kernels take the rows as C arrays


def test_noise_rows_refill_in_turn_yet_read_the_draws_of_whole_blocks():
    """Each row refills at its own step, yet reads at every step the draw it read when every row
    drew a whole block at j == 0: a generator's stream does not depend on how it is split."""
    from vehicles.noise_blocks import BLOCK, N_SIZE, NoiseBlocks

    def seeded(i):
        return np.random.default_rng(100 + i)

    blocks = NoiseBlocks(seeded)
    # Rows join at these steps: at j == 0, before their turn in the block and after it.
    joins = [0, 0, 3, 130, 260, 260, 499]
    ref_gens, ref = [], []
    for step in range(4 * BLOCK + 17):
        if step % BLOCK == 0:
            ref = [g.standard_normal((BLOCK, N_SIZE)) for g in ref_gens]
        while joins and joins[0] == step:
            joins.pop(0)
            blocks.add(len(ref_gens))
            ref_gens.append(seeded(len(ref_gens)))
            ref.append(ref_gens[-1].standard_normal((BLOCK, N_SIZE)))
        assert blocks.j == step % BLOCK
        for k in range(len(ref_gens)):
            assert np.array_equal(blocks.block[k, blocks.j], ref[k][blocks.j]), (step, k)
        blocks.advance()


def drift_unaided(w, unaided_s: float) -> None:
    """The GPS of World ``w``'s row 0 off until ``unaided_s`` without aiding, the estimate
    drifted 5 m north and 0.5 m/s east meanwhile (what dead reckoning might do), the GPS back."""
    w.set_sensor_failed(0, est.F_GPS_OFF, True)
    while w.aiding_age_s(0) < unaided_s:
        w.step(w.time_s)
    e, ring = w.estimation.est[0], w.estimation.ehist[0]
    e[est.E_POS] += 5.0
    ring[:, 0] += 5.0
    e[est.E_VEL + 1] += 0.5
    ring[:, 4] += 0.5
    w.set_sensor_failed(0, est.F_GPS_OFF, False)


@pytest.mark.parametrize("ctrl", [7, 4])
def test_a_fix_after_7_s_unaided_resets_the_estimate_to_it(ctrl):
    """EKF2 (gps_control.cpp): fixes back after reset_timeout_max without aiding restart GNSS
    fusion with a reset to the fix (resetHorizontalPositionToGnss, resetVelocityToGnss), not a
    slow convergence; with the velocity alone (EKF2_GPS_CTRL 4) only the velocity resets.
    Before 7 s the fixes are fused as usual."""
    from vehicles.physics import World
    w = World()
    w.add_vehicle(0)
    w.estimation.set_aiding(0, ctrl, None, None)
    for _ in range(500):  # past the GNSS fusion's start (a reset to the fix of its own)
        w.step(w.time_s)

    def drift_and_restore(unaided_s: float) -> float:
        drift_unaided(w, unaided_s)
        e = w.estimation.est[0]
        while w.aiding_age_s(0) > 0.0:  # to the first fix fused
            w.step(w.time_s)
        return e[est.E_POS] - w.inner.measured[0, 0], e[est.E_VEL + 1]

    pos_err, vel = drift_and_restore(3.0)
    assert pos_err > 4.0 if ctrl == 7 else pos_err > 4.9  # one fix's share of it
    for _ in range(2000):  # converged again
        w.step(w.time_s)
    pos_err, vel = drift_and_restore(7.0)
    assert abs(vel) < 0.01  # the velocity reset to the fix's
    if ctrl == 7:
        assert abs(pos_err) < 0.01  # the position too
    else:
        assert pos_err > 4.9  # not fused: it stays
