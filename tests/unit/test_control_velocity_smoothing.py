"""PX4's jerk-limited velocity smoothing (vehicles/control/velocity_smoothing.py): PX4's own unit
test, VelocitySmoothingTest.cpp, reproduced case by case."""

from __future__ import annotations

import math

import pytest

from vehicles.control.velocity_smoothing import VelocitySmoothing


def axes(j_max=None, a_max=None, v_max=None, a0=(0, 0, 0), v0=(0, 0, 0), x0=(0, 0, 0)):
    trajectories = [VelocitySmoothing() for _ in range(3)]
    for i, t in enumerate(trajectories):
        if j_max is not None:
            t.max_jerk, t.max_accel, t.max_vel = j_max, a_max, v_max
        t.set_current_acceleration(a0[i])
        t.set_current_velocity(v0[i])
        t.set_current_position(x0[i])
    return trajectories


def update(trajectories, dt, setpoints):
    """VelocitySmoothingTest::updateTrajectories: integrate (within the limits), then new
    durations, XY synchronized."""
    for t in trajectories:
        t.update_traj(dt)
        s = t.state
        assert abs(s.j) <= t.max_jerk + 1e-9
        assert abs(s.a) <= t.max_accel + 1e-6
        assert abs(s.v) <= t.max_vel + 1e-6
    for t, sp in zip(trajectories, setpoints):
        t.update_durations(sp)
    VelocitySmoothing.time_synchronization(trajectories[:2])


def test_time_synchronization():
    t = axes(55.2, 6.0, 6.0, a0=(0.22, 0.0, 0.22), v0=(2.47, -5.59e-6, 2.47))
    update(t, 0.0, (-3.0, 1.0, 0.0))
    assert abs(t[0].total_time - t[1].total_time) <= 1e-4


def test_time_synchronization_same_delta():
    t = axes(v0=(0.5, -0.2, 0.0))
    for traj, sp in zip(t, (0.8, 0.1, 0.0)):
        traj.update_durations(sp)
    VelocitySmoothing.time_synchronization(t)
    assert t[0].total_time == pytest.approx(t[1].total_time, rel=1e-6)
    assert (t[0].t1, t[0].t2, t[0].t3) == pytest.approx((t[1].t1, t[1].t2, t[1].t3), rel=1e-6)
    assert t[2].total_time == pytest.approx(t[0].total_time, rel=1e-6)
    assert t[2].t1 == 0.0 and t[2].t3 == 0.0
    assert t[2].t2 == pytest.approx(t[0].total_time, rel=1e-6)


def test_constant_setpoint():
    t = axes(55.2, 6.0, 6.0)
    setpoints = (-3.0, 0.0, -1.0)
    dt = 0.01
    update(t, 0.0, setpoints)
    for _ in range(math.ceil(t[0].total_time / dt)):
        update(t, dt, setpoints)
    for traj, sp in zip(t, setpoints):
        assert abs(traj.state.v - sp) <= 0.01
        assert abs(traj.state.a) <= 1e-4


def test_zero_setpoint():
    t = axes()
    for _ in range(60):
        update(t, 0.01, (0.0, 0.0, 0.0))
    for traj in t:
        assert (traj.state.j, traj.state.a, traj.state.v, traj.state.x) == (0.0, 0.0, 0.0, 0.0)
