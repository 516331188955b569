"""Attitude, rate control and mixer: pure-library tests (no physics engine)."""

import ast
import math
import pathlib

import pytest

from vehicles.airframe import X500
from vehicles.control.attitude_control import (
    AttitudeControl,
    AttitudeControlGains,
    thrust_to_attitude,
)
from vehicles.control.mixer import Mixer
from vehicles.control.quat import q_dcm_z, q_yaw
from vehicles.control.rate_control import RateControl, RateControlGains
from vehicles.params import ParamStore

LEVEL = (1.0, 0.0, 0.0, 0.0)
CONTROL_DIR = pathlib.Path(__file__).resolve().parents[2] / "vehicles" / "control"


def test_controllers_import_only_numpy_math_and_own_modules():
    # numba: register_jitable (the same source runs as Python or compiled) and njit.
    allowed = {"math", "numpy", "numba", "dataclasses", "typing", "__future__", "enum",
               "vehicles.types", "vehicles.control"}
    for path in CONTROL_DIR.glob("*.py"):
        if path.name == "compiled.py":
            continue  # numba's cache plumbing (files, digests), not a controller
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            for name in names:
                assert any(name == a or name.startswith(a + ".") for a in allowed), (path, name)


@pytest.mark.parametrize("yaw", [0.0, 1.0, -2.5, math.pi / 2])
def test_thrust_to_attitude_body_z_opposes_thrust_and_keeps_yaw(yaw):
    thrust = (0.2, -0.1, -0.5)
    sp = thrust_to_attitude(thrust, yaw)
    bz = q_dcm_z(sp.attitude_q)
    n = math.sqrt(sum(t * t for t in thrust))
    assert bz == pytest.approx(tuple(-t / n for t in thrust))
    assert sp.thrust_body_norm == pytest.approx(n)
    level = thrust_to_attitude((0.0, 0.0, -0.5), yaw)
    assert q_yaw(level.attitude_q) == pytest.approx(yaw)


def att_control():
    return AttitudeControl(AttitudeControlGains.from_params(ParamStore()))


def test_attitude_error_gives_rate_towards_setpoint_and_is_limited():
    # Setpoint: tilted forward-right (thrust towards north-east).
    sp = thrust_to_attitude((0.1, 0.1, -0.5), 0.0)
    rates = att_control().update(LEVEL, sp.attitude_q)
    assert rates[0] > 0.0  # roll right to move east
    assert rates[1] < 0.0  # pitch nose down to move north
    big = thrust_to_attitude((0.0, 0.0, -0.5), 3.0)
    r = att_control().update(LEVEL, big.attitude_q)
    assert abs(r[2]) <= math.radians(200.0) + 1e-9
    assert r[2] > 0.0


def test_rate_control_pushes_towards_setpoint_and_freezes_integrator_when_landed():
    rc = RateControl(RateControlGains.from_params(ParamStore()))
    torque = rc.update(0.004, (0.0, 0.0, 0.0), (1.0, -1.0, 0.5), landed=True)
    assert torque[0] > 0 and torque[1] < 0 and torque[2] > 0
    for _ in range(100):
        rc.update(0.004, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), landed=True)
    assert rc.integral == (0.0, 0.0, 0.0)


def mixer():
    return Mixer(X500.mixer_rows())


def test_mixer_hover_is_equal_thrust_and_a_linear_command():
    out = mixer().mix(0.5, (0.0, 0.0, 0.0))
    assert out.motor_u == pytest.approx((0.5,) * 4)  # linear in thrust (THR_MDL_FAC 0)


def test_mixer_rows_are_px4s_allocation_of_the_gz_x500():
    """PX4's pseudo-inverse of the CA_ROTORn geometry of 4001_gz_x500, normalized as
    ControlAllocationPseudoInverse does: roll and pitch share one scale (the larger), so the
    short pitch arm (0.13 m) gets ±1/√2 and roll (0.20-0.22 m) ±0.438; yaw by its largest."""
    roll, pitch, yaw = X500.mixer_rows()
    assert roll == pytest.approx((-0.4377, 0.4377, 0.4377, -0.4377), abs=1e-4)
    assert pitch == pytest.approx((0.7071, -0.7071, 0.7071, -0.7071), abs=1e-4)
    assert yaw == pytest.approx((0.9091, 1.0, -0.9091, -1.0), abs=1e-4)


def test_mixer_geometry_signs():
    # Roll right: left rotors (2 rear-left, 3 front-left) up.
    t = mixer().mix(0.5, (0.2, 0.0, 0.0)).motor_u
    assert t[1] > t[0] and t[2] > t[3]
    # Pitch up: front rotors (1, 3) up.
    t = mixer().mix(0.5, (0.0, 0.2, 0.0)).motor_u
    assert t[0] > t[1] and t[2] > t[3]
    # Yaw right (clockwise from above): CCW rotors (1, 2) up.
    t = mixer().mix(0.5, (0.0, 0.0, 0.2)).motor_u
    assert t[0] > t[2] and t[1] > t[3]


def allocated_torque(motor_u) -> tuple[float, float, float]:
    """The normalized (roll, pitch, yaw) torque the motor commands make (the mixer rows'
    effectiveness · commands, as PX4's ControlAllocator computes it)."""
    rows = mixer().rows
    return tuple(float(sum(rows[i][3 + axis] * u for i, u in enumerate(motor_u)))
                 for axis in range(3))


def test_mixer_keeps_roll_pitch_over_yaw_when_saturated():
    out = mixer().mix(0.9, (0.3, 0.0, 1.0))
    t = out.motor_u
    assert all(0.0 <= x <= 1.0 for x in t)
    roll, pitch, yaw = allocated_torque(t)
    # Roll survives in full; yaw keeps what MINIMUM_YAW_MARGIN gives it above the top motor (15 %
    # of the range, then taken back from the thrust: the top motor ends at 1).
    assert (roll, pitch) == pytest.approx((0.3, 0.0), abs=1e-9)
    assert yaw == pytest.approx(0.15, abs=1e-9)
    assert max(t) == pytest.approx(1.0)
    assert out.saturation_positive == (False, False, True)
    assert out.saturation_negative == (False, False, False)


def test_mixer_flags_the_torque_the_clipped_outputs_miss():
    """Saturation as MulticopterRateControl reads it from ControlAllocator's unallocated torque:
    none while the torque is met, the sign of setpoint − allocated otherwise."""
    assert mixer().mix(0.5, (0.1, -0.1, 0.05))[1:] == ((False,) * 3, (False,) * 3)
    out = mixer().mix(0.5, (-2.0, 0.0, 0.0))
    assert allocated_torque(out.motor_u)[0] > -2.0
    assert out.saturation_negative == (True, False, False)
    assert out.saturation_positive == (False, False, False)


def test_njit_cached_compiles_without_a_cache_when_numba_has_nowhere_to_keep_it():
    from vehicles.control import compiled

    namespace = {}
    # A source file that does not exist: no cache directory can be found for it.
    exec(compile("def plus_one(x):\n    return x + 1\n", "/nonexistent/plus_one.py", "exec"),
         namespace)
    before = list(compiled.UNCACHED)
    fn = compiled.njit_cached(namespace["plus_one"])
    try:
        assert fn(1) == 2
        assert compiled.UNCACHED == before + ["plus_one"]
    finally:
        compiled.UNCACHED[:] = before
