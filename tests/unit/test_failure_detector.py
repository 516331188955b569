"""PX4's failure detector, attitude part (FailureDetector.cpp): a roll or pitch beyond
FD_FAIL_R / FD_FAIL_P held for FD_FAIL_R_TTRI / FD_FAIL_P_TTRI, while attitude control runs."""

import math

from vehicles.failure_detector import FailureDetector, attitude_control
from vehicles.params import ParamStore
from vehicles.types import NavState


def q_roll(deg: float) -> tuple[float, float, float, float]:
    h = math.radians(deg) / 2.0
    return (math.cos(h), math.sin(h), 0.0, 0.0)


def q_pitch(deg: float) -> tuple[float, float, float, float]:
    h = math.radians(deg) / 2.0
    return (math.cos(h), 0.0, math.sin(h), 0.0)


def test_roll_beyond_the_limit_for_the_trigger_time_then_back_at_once():
    p = ParamStore()  # FD_FAIL_R 60 deg, FD_FAIL_R_TTRI 0.3 s
    fd = FailureDetector()
    fd.update(0.0, q_roll(59.0), True, p)
    assert not fd.critical
    for t in (0.1, 0.2, 0.35):
        fd.update(t, q_roll(61.0), True, p)
    assert not fd.roll  # beyond since 0.1 s: 0.25 s so far
    fd.update(0.45, q_roll(-70.0), True, p)
    assert fd.roll and fd.critical and not fd.pitch
    fd.update(0.47, q_roll(10.0), True, p)
    assert not fd.critical  # clears at once
    fd.update(0.5, q_pitch(80.0), True, p)
    fd.update(0.81, q_pitch(80.0), True, p)
    assert fd.pitch and not fd.roll


def test_no_attitude_control_no_failure():
    p = ParamStore()
    fd = FailureDetector()
    fd.update(0.0, q_roll(120.0), True, p)
    fd.update(1.0, q_roll(120.0), True, p)
    assert fd.roll
    fd.update(1.1, q_roll(120.0), False, p)
    assert not fd.critical
    assert not attitude_control(NavState.ACRO, None)
    assert not attitude_control(NavState.TERMINATION, None)
    assert attitude_control(NavState.MANUAL, None) and attitude_control(NavState.AUTO_LOITER, None)
