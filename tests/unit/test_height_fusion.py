"""The estimator's vertical channel (vehicles/height_fusion.py) as EKF2 v1.15 runs it: every
height source fused less its bias, the reference's bias fixed, a failing barometer latched
faulty while the GPS height works, the reference falling back, and EKF2_HGT_REF taking effect
when the estimator starts (reboot_required), not when it is set."""

from __future__ import annotations

import pytest

from gateway.testing import Sim
from vehicles import estimation as est
from vehicles import height_fusion as hf
from vehicles.types import PX4_SITL_HOME


def column(sim: Sim, col: int) -> float:
    return float(sim.simulation.world.estimation.est[0][est.E_HGT + col])


def baro(col: int) -> int:
    return hf.H_SRC + hf.BARO * hf.SRC_SIZE + col


def gnss(col: int) -> int:
    return hf.H_SRC + hf.GNSS * hf.SRC_SIZE + col


def true_down(sim: Sim) -> float:
    return float(sim.simulation.world.inner.measured[0][2])


def est_down(sim: Sim) -> float:
    return float(sim.simulation.world.estimation.est[0][est.E_POS + 2])


def take_off(sim: Sim, alt_m: float) -> None:
    assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
    api = sim.api(0)
    assert api.arm() == 0 and api.takeoff(PX4_SITL_HOME.alt_amsl_m + alt_m) == 0


def hover(sim: Sim, alt_m: float = 10.0) -> None:
    take_off(sim, alt_m)
    assert sim.run_until(lambda: sim.status(0).nav_state.name == "AUTO_LOITER", timeout_s=40)
    sim.advance(3.0)


@pytest.mark.parametrize("ref", [0, 1])
def test_both_sources_are_fused_and_only_the_other_ones_bias_moves(ref):
    with Sim(1, params={"EKF2_HGT_REF": ref}) as sim:
        hover(sim)
        assert column(sim, hf.H_REF) == ref
        assert column(sim, baro(hf.SRC_ON)) == column(sim, gnss(hf.SRC_ON)) == 1.0
        assert column(sim, baro(hf.SRC_AGE)) < 0.1 and column(sim, gnss(hf.SRC_AGE)) < 0.5
        ref_bias = column(sim, baro(hf.SRC_BIAS) if ref == 0 else gnss(hf.SRC_BIAS))
        assert ref_bias == 0.0  # HeightBiasEstimator: not for the reference
        assert abs(est_down(sim) - true_down(sim)) < 0.3


def test_a_stuck_barometer_is_outweighed_by_its_bias_and_the_vehicle_lands():
    """PX4's SITL test "Continue on baro stuck during mission": the barometer stuck at 10 m,
    then the return. Not the reference, the barometer is fused less its bias, which follows
    the offset the GPS height shows (HeightBiasEstimator, its noise boosted once the offset
    persists), so the vehicle lands, is detected landed, disarms, and the estimate comes back
    to the ground."""
    with Sim(1) as sim:
        hover(sim, 10.0)
        sim.simulation.world.set_sensor_failed(0, est.F_BARO_STUCK, True)
        sim.advance(5.0)
        assert sim.api(0).land() == 0
        assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=60)
        assert abs(true_down(sim)) < 0.1
        sim.advance(30.0)
        assert abs(est_down(sim)) < 0.5
        assert column(sim, baro(hf.SRC_BIAS)) < -8.0  # (down) the stuck reading: 10 m up


def test_hgt_ref_takes_effect_at_start_not_when_set():
    """EKF2_HGT_REF is reboot_required: the estimator keeps the reference it started with."""
    with Sim(1) as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        assert column(sim, hf.H_REF) == hf.REF_GNSS  # module.yaml's default, 1
        sim.vehicles[0].params.set("EKF2_HGT_REF", 0)
        sim.advance(2.0)
        assert column(sim, hf.H_REF) == hf.REF_GNSS


def test_a_lost_gps_leaves_the_barometer_as_the_reference():
    with Sim(1) as sim:
        hover(sim, 5.0)
        sim.simulation.world.set_sensor_failed(0, est.F_GPS_OFF, True)
        sim.advance(2.0)  # two GNSS intervals without data: the GPS height stops
        assert column(sim, gnss(hf.SRC_ON)) == 0.0
        assert column(sim, hf.H_REF) == hf.REF_BARO
        assert abs(est_down(sim) - true_down(sim)) < 0.3


def test_the_noise_parameters_are_followed():
    """EKF2_BARO_NOISE, EKF2_GPS_P_NOISE...: the vertical channel's weights are the vehicle's
    parameters, changed in flight as EKF2's updateParameters takes them; SENS_BARO_RATE sets
    how often the barometer reaches it."""
    with Sim(1) as sim:
        hover(sim, 5.0)
        est_rows = sim.simulation.world.estimation
        assert est_rows.hparams[0][hf.P_BARO_NOISE] == pytest.approx(3.5)
        sim.vehicles[0].params.set("EKF2_BARO_NOISE", 0.5)
        sim.vehicles[0].params.set("SENS_BARO_RATE", 5.0)
        sim.advance(1.0)
        assert est_rows.hparams[0][hf.P_BARO_NOISE] == pytest.approx(0.5)
        fused = []
        for _ in range(250):
            sim.advance(0.004)
            if column(sim, baro(hf.SRC_AGE)) == 0.0 and (not fused or sim.now - fused[-1] > 0.01):
                fused.append(sim.now)
        assert len(fused) == pytest.approx(5, abs=1)  # 5 Hz, not 20


def test_every_height_source_failing_resets_the_height_and_the_vertical_velocity():
    """height_control.cpp: every height source failing its gate for hgt_fusion_timeout_max (the
    estimate 50 m off both), the next sample resets the height to its source
    (resetVerticalPositionTo: the other source's bias follows the jump, so that one stays as far
    off as it was) and the vertical velocity (resetVerticalVelocityTo: the fix's, else zero;
    counted as EKF2 counts velD resets)."""
    from vehicles.physics import World
    w = World()
    w.add_vehicle(0)
    for _ in range(500):
        w.step(w.time_s)
    e, ring = w.estimation.est[0], w.estimation.ehist[0]
    e[est.E_POS + 2] -= 50.0
    ring[:, 2] -= 50.0
    resets = e[est.E_VZ_RESET]
    for _ in range(int(4.5 * 250)):
        w.step(w.time_s)
    assert e[est.E_POS + 2] - w.inner.measured[0][2] < -49.0  # nothing fused
    assert e[est.E_VZ_RESET] == resets
    h = e[est.E_HGT:est.E_HGT + hf.H_SIZE]
    for _ in range(250):
        before = (e[est.E_POS + 2], h[baro(hf.SRC_BIAS)], h[gnss(hf.SRC_BIAS)])
        w.step(w.time_s)
        if e[est.E_VZ_RESET] != resets:
            break
    assert e[est.E_VZ_RESET] == resets + 1 and abs(e[est.E_VEL + 2]) < 0.5
    assert abs(e[est.E_POS + 2] - w.inner.measured[0][2]) < 1.0
    # the bias of the source not reset to moved against the jump (as EKF2's estimators do)
    jump = e[est.E_POS + 2] - before[0]
    moved = (h[baro(hf.SRC_BIAS)] - before[1], h[gnss(hf.SRC_BIAS)] - before[2])
    assert jump > 45.0 and min(moved) == pytest.approx(-jump, abs=0.5), (jump, moved)
