"""Position mode's horizontal (MPC_POS_MODE 4): PX4's StickAccelerationXY::generateSetpoints
(src/modules/flight_mode_manager/tasks/Utility/StickAccelerationXY.cpp, v1.15.2), and the yaw
stick (StickYaw.cpp); neither has a unit test in PX4. The facts of their source checked here:

- the stick (expo, deadzone, unit length) times 2 × MPC_ACC_HOR, minus a drag of
  2 × MPC_ACC_HOR / MPC_VEL_MANUAL times the velocity setpoint: with the stick held the drag is
  linear (the brake boost filter stays at 1, brake_scale 0), so the speed settles at the
  stick's share of MPC_VEL_MANUAL, also below 1 m/s;
- the jerk limit (MPC_JERK_MAX, split over the axes by the change's direction) acts on the
  acceleration after the drag: releasing the stick at speed changes the acceleration setpoint
  by at most MPC_JERK_MAX × dt per tick, though the brake boost raises the drag meanwhile;
- centred, the brake boost (towards max(2, √MPC_VEL_MANUAL), 0.8 s) blends in a square-root
  drag below 1 m/s, and a velocity the drag would overshoot stops: the vehicle comes to rest
  and the position locks;
- StickYaw: no heading setpoint while the filtered rate is not zero, then the vehicle's.
"""

from __future__ import annotations

import math

import pytest

from vehicles.manual_control import ManualPosition, Sticks, expo_deadzone
from vehicles.params import ParamStore

DT = 0.02
POS = (0.0, 0.0, -10.0)


def _run(task, sticks, ticks):
    sps = []
    for _ in range(ticks):
        fb = (*task._vel_xy, 0.0)
        sps.append(task.update(DT, sticks, POS, (0.0, 0.0, 0.0), 0.0, fb))
    return sps


def _task():
    p = ParamStore()
    task = ManualPosition(p)
    task.activate(POS, (0.0, 0.0, 0.0), 0.0)
    return task, p


@pytest.mark.parametrize("stick", [0.2, 0.5, 1.0])
def test_a_held_stick_settles_at_its_share_of_mpc_vel_manual(stick):
    task, p = _task()
    sps = _run(task, Sticks(pitch=stick), 2000)
    share = expo_deadzone(stick, float(p["MPC_XY_MAN_EXPO"]), float(p["MPC_HOLD_DZ"]))
    assert sps[-1].velocity_ned_mps[0] == pytest.approx(share * float(p["MPC_VEL_MANUAL"]),
                                                        rel=1e-3)
    assert share * 10.0 < 1.0 or stick > 0.2  # 0.2: a speed below 1 m/s (linear drag there too)


def test_releasing_the_stick_at_speed_is_jerk_limited_after_the_drag():
    task, p = _task()
    _run(task, Sticks(pitch=1.0), 1500)
    jerk = float(p["MPC_JERK_MAX"])
    sps = _run(task, Sticks(), 200)
    acc = [sp.acceleration_ned_mps2[0] for sp in sps]
    steps = [abs(b - a) for a, b in zip(acc, acc[1:])]
    assert max(steps) <= jerk * DT + 1e-9
    assert min(acc) < -6.0  # the boosted drag brakes harder than the stick accelerates


def test_centred_the_vehicle_comes_to_rest_and_the_position_locks():
    task, p = _task()
    _run(task, Sticks(pitch=1.0), 200)
    sps = _run(task, Sticks(), 600)
    stopped = [i for i, sp in enumerate(sps) if sp.velocity_ned_mps[0] == 0.0]
    assert stopped
    i = stopped[0]
    assert math.isfinite(sps[i].position_ned_m[0])  # locked where the vehicle is
    assert all(sp.velocity_ned_mps[0] >= 0.0 for sp in sps)  # never turned round


# --- StickYaw --------------------------------------------------------------------------------
def test_the_yaw_stick_turns_by_rate_and_the_heading_locks_where_the_vehicle_points():
    """StickYaw::generateYawSetpoint / updateYawLock: while the filtered rate (MPC_MAN_Y_TAU) is
    not zero (above FLT_EPSILON) there is no heading setpoint, only the rate; once it is, the
    heading locks at the vehicle's heading of that tick (not at an integrated setpoint)."""
    task, p = _task()
    fb = (0.0, 0.0, 0.0)
    sp = task.update(DT, Sticks(yaw=1.0), POS, fb, 0.3, fb)
    assert math.isnan(sp.yaw_rad) and task.yawspeed > 0.0
    for _ in range(50):
        sp = task.update(DT, Sticks(yaw=1.0), POS, fb, 0.3, fb)
    assert task.yawspeed == pytest.approx(math.radians(float(p["MPC_MAN_Y_MAX"])), rel=1e-4)
    yaws = []
    for i in range(200):
        sp = task.update(DT, Sticks(), POS, fb, 1.0 + 0.001 * i, fb)
        yaws.append(sp.yaw_rad)
    locked = [i for i, y in enumerate(yaws) if math.isfinite(y)]
    # the filter (alpha = 0.02 / 0.1) takes about 70 ticks to fall below FLT_EPSILON
    assert 60 < locked[0] < 80
    assert yaws[locked[0]] == pytest.approx(1.0 + 0.001 * locked[0])
    assert yaws[-1] == yaws[locked[0]] and task.yawspeed < 1.2e-7
