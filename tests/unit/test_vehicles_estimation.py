"""Sensors with PX4's Gazebo x500 noise and the estimator the vehicle flies on
(vehicles/estimation.py): noise levels, GPS delay, convergence, wind from the drag, seeded
repeatability, a scenario's [sensors] noise, and what the telemetry says of them."""

from __future__ import annotations

import math
import statistics

import numpy as np
import pytest

from gateway.sim import scenario as scenario_mod
from gateway.testing import Sim
from vehicles import estimation as est
from vehicles.estimation import E_RATIOS, E_WIND, S_ACC, S_GPS_POS, S_GYRO


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
    # the drag alone, so there the whole IMU signal stays within twice the model's noise.
    for axis in range(3):
        acc = [s[S_ACC + axis] - specific_force_frd(t)[axis] for s, t, _ in samples]
        gyro = [s[S_GYRO + axis] - t.rates_frd_radps[axis] for s, t, _ in samples]
        assert statistics.pstdev(acc) == pytest.approx(est.ACCEL_NOISE_MPS2, rel=0.2)
        assert statistics.pstdev(gyro) == pytest.approx(est.GYRO_NOISE_RADPS, rel=0.2)
    for axis in range(2):
        assert statistics.pstdev(s[S_ACC + axis] for s, _, _ in samples) < 2 * est.ACCEL_NOISE_MPS2
    # The estimate is within centimetres of the truth and varies less than the GPS fixes.
    errors = [math.dist(k.position_ned_m, t.position_ned_m) for _, t, k in samples]
    assert max(errors) < 0.15
    north = [k.position_ned_m[0] for _, _, k in samples]
    fixes = [s[S_GPS_POS] for s, _, _ in samples]
    assert 0.001 < statistics.pstdev(north) < statistics.pstdev(fixes)
    # Attitude estimate within a degree (the heading follows the noisy magnetometer).
    for _, t, k in samples[::50]:
        dot = abs(sum(a * b for a, b in zip(t.attitude_q, k.attitude_q)))
        assert math.degrees(2 * math.acos(min(1.0, dot))) < 1.0


def test_gps_fix_is_ekf2_gps_delay_old_and_exact_without_noise():
    exact = scenario_mod.parse({"sensors": {"noise": 0}})
    with Sim(scenario=exact) as sim:
        hovering(sim)
        api = sim.api(0)
        from vehicles.types import NavState
        assert api.set_mode(NavState.AUTO_RTL) == 0  # moving: the delay shows
        sim.advance(3.0)
        dt = sim.simulation.world.dt_s
        delay = int(round(est.GPS_DELAY_S / dt))
        world = sim.simulation.world
        truths = {}  # physics step -> the truth after it
        fixes = []  # (physics step, the GPS fix after it)
        for _ in range(200):
            sim.advance(dt)  # one step, or none or two where the float clock rounds
            v = sim.vehicles[0]
            truths[world.steps] = v.truth.position_ned_m
            fixes.append((world.steps, tuple(v.sensors[S_GPS_POS:S_GPS_POS + 3])))
        # Each new fix is the truth of ``delay`` steps before it was taken.
        new = [(step, fix) for (step, fix), (before_step, before) in zip(fixes[1:], fixes)
               if fix != before and before_step == step - 1 and step - delay in truths]
        assert len(new) >= 15  # 0.8 s of 30 Hz fixes, less the first delay
        for step, fix in new:
            assert fix == pytest.approx(truths[step - delay], abs=1e-9)
        # Without noise the estimate stays on the truth.
        v = sim.vehicles[0]
        assert math.dist(v.kinematics.position_ned_m, v.truth.position_ned_m) < 0.02


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
