"""The multicopter land detector (vehicles/land_detector.py) against PX4 v1.15
MulticopterLandDetector.cpp / LandDetector.cpp (PX4 has no unit test for it: the inputs here are
read off its conditions and thresholds, with the default parameters MPC_THR_MIN 0.12,
MPC_THR_HOVER 0.6, LNDMC_Z_VEL_MAX 0.25, LNDMC_XY_VEL_MAX 1.5, LNDMC_ROT_MAX 20, and
LNDMC_TRIG_TIME 1 s: three stages of 1/3 s)."""

import math

import pytest

from vehicles.land_detector import LandDetector
from vehicles.params import ParamStore
from vehicles.types import GRAVITY_MPS2, Measurement

DT = 0.02  # 50 Hz
HOVER = 0.6


def meas(v=(0.0, 0.0, 0.0), rates=(0.0, 0.0, 0.0), acc=(0.0, 0.0, 0.0)):
    return Measurement((0.0, 0.0, -5.0), v, (1.0, 0.0, 0.0, 0.0), rates, acc)


class Run:
    def __init__(self, **params):
        self.params = ParamStore(params)
        self.ld = LandDetector(self.params)
        self.t = 0.0

    def step(self, seconds, thrust, vz_sp=0.7, m=None, armed=True, hover_valid=False,
             until=None):
        """Updates at 50 Hz for ``seconds``; returns the time ``until`` first held (or None)."""
        for _ in range(round(seconds / DT)):
            self.t += DT
            self.ld.update(self.t, armed, m or meas(), vz_sp, thrust, HOVER, hover_valid)
            if until is not None and until(self.ld):
                return self.t
        return None

    def in_air(self):
        self.step(0.1, 0.0, armed=False)
        self.step(0.1, HOVER, vz_sp=0.0)
        assert not self.ld.landed


def test_the_landing_takes_three_stages_of_a_third_of_a_second():
    """Touched down with a commanded descent and the thrust at MPC_THR_MIN: ground contact after
    1/3 s, maybe landed 1/3 s later, landed 1/3 s after that (LNDMC_TRIG_TIME 1 s in all)."""
    r = Run()
    r.in_air()
    t0 = r.t
    contact = r.step(2.0, 0.12, until=lambda ld: ld.ground_contact)
    maybe = r.step(2.0, 0.12, until=lambda ld: ld.maybe_landed)
    landed = r.step(2.0, 0.12, until=lambda ld: ld.landed)
    assert contact - t0 == pytest.approx(1 / 3 + DT, abs=DT + 1e-9)
    assert maybe - contact == pytest.approx(1 / 3, abs=DT + 1e-9)
    assert landed - maybe == pytest.approx(1 / 3, abs=DT + 1e-9)


@pytest.mark.parametrize("trig_s, stage_s", [(3.0, 1.0), (0.3, 0.1)])
def test_lndmc_trig_time_sets_the_three_stages(trig_s, stage_s):
    """_set_hysteresis_factor(1): each stage LNDMC_TRIG_TIME / 3."""
    r = Run(LNDMC_TRIG_TIME=trig_s)
    r.in_air()
    contact = r.step(5.0, 0.12, until=lambda ld: ld.ground_contact)
    landed = r.step(5.0, 0.12, until=lambda ld: ld.landed)
    assert landed - contact == pytest.approx(2 * stage_s, abs=DT + 1e-9)


def test_a_nan_trigger_time_never_lands():
    """NaN converts to a huge hysteresis time (x86): ground contact is never confirmed."""
    r = Run(LNDMC_TRIG_TIME=math.nan)
    r.in_air()
    assert r.step(5.0, 0.12, until=lambda ld: ld.ground_contact) is None and not r.ld.landed


@pytest.mark.parametrize("vz_sp, contact", [
    (0.30, True),  # >= 1.1 x LNDMC_Z_VEL_MAX (0.275 m/s) down: a commanded descent
    (0.25, False),
    (math.nan, True),  # no climb-rate control (Stabilized, Acro): no descent asked for
])
def test_ground_contact_needs_a_commanded_descent_of_1_1_lndmc_z_vel_max(vz_sp, contact):
    r = Run()
    r.in_air()
    assert (r.step(1.0, 0.12, vz_sp=vz_sp, until=lambda ld: ld.ground_contact) is not None) \
        is contact


@pytest.mark.parametrize("thrust, hover_valid, contact", [
    (0.26, False, True),  # MPC_THR_MIN + 30 % of (hover - MPC_THR_MIN) = 0.264
    (0.27, False, False),
    (0.40, True, True),  # with a valid hover-thrust estimate 60 %: 0.408
    (0.41, True, False),
])
def test_ground_contact_needs_low_thrust(thrust, hover_valid, contact):
    r = Run()
    r.in_air()
    got = r.step(1.0, thrust, hover_valid=hover_valid, until=lambda ld: ld.ground_contact)
    assert (got is not None) is contact


def test_maybe_landed_needs_minimum_thrust_and_no_rotation():
    """Minimum thrust under climb-rate control: MPC_THR_MIN + 10 % of (hover - MPC_THR_MIN) =
    0.168; tilt rates above LNDMC_ROT_MAX (20 deg/s) keep it off."""
    r = Run()
    r.in_air()
    assert r.step(2.0, 0.17, until=lambda ld: ld.maybe_landed) is None
    assert r.ld.ground_contact
    spin = meas(rates=(math.radians(25.0), 0.0, 0.0))
    assert r.step(2.0, 0.16, m=spin, until=lambda ld: ld.maybe_landed) is None
    assert r.step(2.0, 0.16, until=lambda ld: ld.maybe_landed) is not None


def test_a_takeoff_is_seen_as_soon_as_the_thrust_leaves_its_minimum():
    """The hysteresis only delays becoming true: landed drops in the update where the thrust
    exceeds 0.168, before the vehicle moves."""
    r = Run()
    r.step(0.1, 0.0, armed=False)
    r.step(1.0, 0.0)
    assert r.ld.landed
    r.step(0.02, 0.17, vz_sp=-1.0)
    assert not r.ld.landed


def test_landed_widens_the_vertical_and_rotation_thresholds():
    r = Run()
    r.step(0.1, 0.0, armed=False)
    r.step(0.5, 0.0)
    r.step(0.5, 0.0, m=meas(v=(0.0, 0.0, -0.6), rates=(math.radians(45.0), 0.0, 0.0)))
    assert r.ld.landed  # 2.5 x 0.25 m/s and 2.5 x 20 deg/s
    r.step(0.02, 0.0, m=meas(v=(0.0, 0.0, -0.7)))
    assert not r.ld.landed


def test_freefall_after_0_3_s_blocks_maybe_landed():
    r = Run()
    r.in_air()
    falling = meas(acc=(0.0, 0.0, GRAVITY_MPS2))  # no specific force
    t0 = r.t
    got = r.step(1.0, 0.12, m=falling, until=lambda ld: ld.freefall)
    assert got - t0 == pytest.approx(0.3 + DT, abs=DT + 1e-9)
    assert r.step(2.0, 0.12, m=falling, until=lambda ld: ld.maybe_landed) is None


def test_disarmed_in_air_is_landed_a_third_of_a_second_later():
    r = Run()
    r.in_air()
    t0 = r.t
    landed = r.step(1.0, 0.0, armed=False, until=lambda ld: ld.landed)
    assert landed - t0 == pytest.approx(1 / 3 + DT, abs=DT + 1e-9)


def test_lndmc_z_vel_max_is_capped_below_the_landing_speeds():
    """_update_params: above min(MPC_LAND_CRWL, MPC_LAND_SPEED) / 1.2 it is lowered to that,
    committed without notification."""
    r = Run(LNDMC_Z_VEL_MAX=0.5)
    seen = []
    r.params.on_change(lambda name, value: seen.append(name))
    r.step(0.02, 0.0)
    assert r.params["LNDMC_Z_VEL_MAX"] == pytest.approx(0.3 / 1.2)
    assert "LNDMC_Z_VEL_MAX" not in seen
