"""vehicle_acceleration's low-pass follows IMU_ACCEL_CUTOFF as PX4 v1.15.2's VehicleAcceleration
does (ParametersUpdate → CheckAndUpdateFilters: a change of more than 0.1 Hz from the filter's
cutoff sets LowPassFilter2p anew and resets it to the last corrected sample)."""

import math

import numpy as np
import pytest

from tests.unit.test_vehicles_flight import Sim
from vehicles.estimation import R_ACC_IN, R_ACC_LP
from vehicles.types import CommandResult
from vehicles.vehicle_acceleration import cutoff_update, filter_cutoff_hz


class LowPassFilter2p:
    """PX4's math::LowPassFilter2p (direct form II), for one axis."""

    def __init__(self, sample_hz: float, cutoff_hz: float) -> None:
        self.set_cutoff_frequency(sample_hz, cutoff_hz)

    def set_cutoff_frequency(self, fs: float, fc: float) -> None:
        self.d1 = self.d2 = 0.0
        if fs <= 0 or fc <= 0 or fc >= fs / 2 or not math.isfinite(fs + fc):
            self.b, self.a1, self.a2 = (1.0, 0.0, 0.0), 0.0, 0.0
            return
        ohm = math.tan(math.pi / (fs / max(fc, fs * 0.001)))
        c = 1.0 + 2.0 * math.cos(math.pi / 4.0) * ohm + ohm * ohm
        b0 = ohm * ohm / c
        self.b = (b0, 2.0 * b0, b0)
        self.a1 = 2.0 * (ohm * ohm - 1.0) / c
        self.a2 = (1.0 - 2.0 * math.cos(math.pi / 4.0) * ohm + ohm * ohm) / c

    def apply(self, x: float) -> float:
        d0 = x - self.d1 * self.a1 - self.d2 * self.a2
        out = d0 * self.b[0] + self.d1 * self.b[1] + self.d2 * self.b[2]
        self.d1, self.d2 = d0, self.d1
        return out

    def reset(self, x: float) -> float:
        s = 1.0 + self.a1 + self.a2
        self.d1 = self.d2 = x / s if abs(s) > 1.1920929e-07 else x
        return self.apply(x)


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def steps(sim, n):
    """(corrected inputs, filtered outputs) of vehicle 0 over ``n`` physics steps."""
    xs, ys = [], []
    for _ in range(n):
        sim.run(sim.world.dt_s)
        r = sim.world.recent[0, sim.world.estimation.hist_i]
        xs.append(r[R_ACC_IN:R_ACC_IN + 3].copy())
        ys.append(r[R_ACC_LP:R_ACC_LP + 3].copy())
    return np.array(xs), np.array(ys)


def test_cutoff_update_needs_more_than_0_1_hz_and_disables_as_lowpassfilter2p():
    assert filter_cutoff_hz(250.0, 30.0) == 30.0
    assert filter_cutoff_hz(250.0, 0.1) == 0.25  # at least a thousandth of the rate
    assert filter_cutoff_hz(250.0, 0.0) == filter_cutoff_hz(250.0, 125.0) == 0.0  # disabled
    assert cutoff_update(250.0, 30.0, 30.05) is None
    assert cutoff_update(250.0, 30.0, 10.0) == 10.0
    assert cutoff_update(250.0, 0.0, 0.05) is None  # disabled, and 0.05 Hz is no change
    assert cutoff_update(250.0, 0.0, 200.0) == 0.0  # set again (still disabled) and reset
    assert cutoff_update(250.0, 30.0, math.nan) is None


def test_a_new_cutoff_sets_the_filter_anew_from_the_last_sample(sim):
    sim.run(1.2)
    assert sim.v.arm(sim.t) is CommandResult.ACCEPTED
    assert sim.v.takeoff(sim.t) is CommandResult.ACCEPTED
    sim.run(2.0)  # climbing: the samples move
    before, old = steps(sim, 1)
    sim.v.params.set("IMU_ACCEL_CUTOFF", 10.0)
    xs, ys = steps(sim, 60)
    assert np.abs(np.diff(xs[:, 2])).max() > 1e-3  # a signal the filters tell apart
    fs = 1.0 / sim.world.dt_s
    filters = [LowPassFilter2p(fs, 10.0) for _ in range(3)]
    for i, f in enumerate(filters):
        f.reset(before[0, i])  # CheckAndUpdateFilters: reset(_acceleration_prev)
    expected = np.array([[f.apply(x[i]) for i, f in enumerate(filters)] for x in xs])
    assert np.allclose(ys, expected, rtol=0.0, atol=1e-9)
    # less than 0.1 Hz off the filter's cutoff: nothing changes, the filter runs on
    sim.v.params.set("IMU_ACCEL_CUTOFF", 10.05)
    xs, ys = steps(sim, 20)
    expected = np.array([[f.apply(x[i]) for i, f in enumerate(filters)] for x in xs])
    assert np.allclose(ys, expected, rtol=0.0, atol=1e-9)
    # another parameter's change runs the check too, and finds nothing to do
    sim.v.params.set("MPC_XY_CRUISE", 4.0)
    xs, ys = steps(sim, 5)
    expected = np.array([[f.apply(x[i]) for i, f in enumerate(filters)] for x in xs])
    assert np.allclose(ys, expected, rtol=0.0, atol=1e-9)
    # 0 disables the filter: the corrected samples pass
    sim.v.params.set("IMU_ACCEL_CUTOFF", 0.0)
    xs, ys = steps(sim, 5)
    assert np.array_equal(xs, ys)
