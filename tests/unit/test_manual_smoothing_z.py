"""The jerk-limited vertical of Altitude and Position modes: PX4's ManualVelocitySmoothingZ
(src/lib/motion_planning/ManualVelocitySmoothingZ.cpp) in FlightTaskManualAltitudeSmoothVel, the
task of both modes with the default MPC_POS_MODE 4 (FlightModeManager::start_flight_task; Position
mode's FlightTaskManualAcceleration extends it).

PX4 has no unit test of ManualVelocitySmoothingZ (motion_planning tests VelocitySmoothing,
PositionSmoothing and ManualVelocitySmoothingXY only); these check the facts of its source:
- ``update(dt, target)`` integrates the trajectory over ``dt`` on the durations of the previous
  call, then sets the limits of the target's direction (MPC_ACC_UP_MAX / MPC_Z_VEL_MAX_UP when
  it climbs, MPC_ACC_DOWN_MAX / MPC_Z_VEL_MAX_DN otherwise) and plans towards it with
  MPC_JERK_MAX: from rest the acceleration grows at the jerk limit;
- the lock (checkPositionLock): zero target, |v| < 0.1 m/s and |a| < 0.2 m/s² → the altitude
  setpoint is the trajectory's position; otherwise none (NaN), the trajectory's position follows
  the estimate, and leaving a lock restarts its velocity from the velocity controller's input;
- FlightTaskManualAltitudeSmoothVel::activate restarts the smoothing from the last setpoint's
  z, vz, az, each not finite from the altitude, the vertical velocity and 0;
- FlightTask::reActivate (on the ground until the takeoff ramp) keeps the vertical velocity
  setpoint; FlightTaskManualAltitude::_respectGroundSlowdown limits the target by the height
  above home (MPC_LAND_ALT1/2, MPC_LAND_SPEED, MPC_TKO_SPEED).
"""

from __future__ import annotations

import math

import pytest

from vehicles.control.manual_velocity_smoothing_z import ManualVelocitySmoothingZ
from vehicles.control.position_control import PositionSetpoint
from vehicles.manual_control import ManualAltitude, ManualPosition, Sticks
from vehicles.params import ParamStore

DT = 0.02
ZERO3 = (0.0, 0.0, 0.0)
NAN3 = (math.nan, math.nan, math.nan)


def _smoothing(jerk=8.0, acc_up=4.0, acc_dn=3.0, vel_up=3.0, vel_dn=1.5):
    s = ManualVelocitySmoothingZ()
    s.set_limits(jerk, acc_up, acc_dn, vel_up, vel_dn)
    s.reset(0.0, 0.0, -10.0)
    s.position_estimate = -10.0
    return s


def test_from_rest_the_acceleration_grows_at_the_jerk_limit_one_tick_late():
    s = _smoothing()
    s.update(DT, -3.0)  # the first call integrates the durations of the reset: none
    assert s.a == 0.0 and s.v == 0.0
    for _ in range(5):
        s.update(DT, -3.0)
    # 5 ticks (0.1 s) of jerk -8 m/s³ from rest
    assert s.j == pytest.approx(-8.0)
    assert s.a == pytest.approx(-0.8, abs=1e-9)
    assert s.v == pytest.approx(-0.5 * 8.0 * 0.1 ** 2, abs=1e-9)


@pytest.mark.parametrize("target, acc_max, vel", [(-3.0, 4.0, -3.0), (1.5, 3.0, 1.5),
                                                   (-9.0, 4.0, -3.0), (9.0, 3.0, 1.5)])
def test_the_direction_picks_its_acceleration_and_speed_limits(target, acc_max, vel):
    s = _smoothing()
    peak = 0.0
    for _ in range(300):
        s.update(DT, target)
        peak = max(peak, abs(s.a))
    assert peak == pytest.approx(acc_max, abs=1e-6)
    assert s.v == pytest.approx(vel, abs=1e-6)  # capped at MPC_Z_VEL_MAX_UP / _DN


def test_unlocked_the_trajectory_follows_the_estimate_and_there_is_no_altitude_setpoint():
    s = _smoothing()
    s.position_estimate = -12.5
    s.update(DT, -1.0)
    assert math.isnan(s.position_locked) and not s.lock_active
    assert s.trajectory.row[3] == -12.5  # the trajectory's position is the estimate's


def test_the_lock_waits_for_the_trajectory_to_stop_and_holds_its_position():
    s = _smoothing()
    for _ in range(100):
        s.update(DT, -2.0)
    assert s.v == pytest.approx(-2.0)
    s.position_estimate = -20.0  # where the vehicle is as the stick is centred
    s.update(DT, 0.0)
    assert not s.lock_active  # still climbing at 2 m/s: no lock yet, the brake is smoothed
    ticks = 1
    while not s.lock_active:
        assert math.isnan(s.position_locked)
        s.update(DT, 0.0)
        ticks += 1
    assert abs(s.v) < 0.1 and abs(s.a) < 0.2
    # braking from 2 m/s at 8 m/s³ and 3 m/s² takes over a second
    assert ticks * DT > 0.9
    assert s.position_locked == s.x
    assert s.position_locked < -20.0  # above where the stick was centred: it braked upwards
    s.position_estimate = -30.0  # the estimate no longer moves the locked trajectory
    s.update(DT, 0.0)
    assert s.position_locked == pytest.approx(s.x) and s.x > -25.0


def test_leaving_the_lock_starts_from_the_velocity_controllers_input():
    s = _smoothing()
    s.update(DT, 0.0)
    assert s.lock_active and s.position_locked == -10.0
    s.vel_sp_feedback = 0.4  # the position loop was pulling down
    s.update(DT, -1.0)
    assert not s.lock_active and math.isnan(s.position_locked)
    assert s.v == 0.4 and s.trajectory.row[2] == 0.4


# --- FlightTaskManualAltitudeSmoothVel -------------------------------------------------------
def _altitude(cls=ManualAltitude, **params) -> ManualAltitude:
    task = cls(ParamStore(params or None))
    task.activate((0.0, 0.0, -10.0), ZERO3, 0.0)
    return task


@pytest.mark.parametrize("cls", [ManualAltitude, ManualPosition])
def test_full_throttle_ramps_the_climb_instead_of_stepping_it(cls):
    task = _altitude(cls)
    up = Sticks(throttle=1.0)
    sp = task.update(DT, up, (0.0, 0.0, -10.0), ZERO3, 0.0, ZERO3)
    assert sp.velocity_ned_mps[2] == 0.0  # was -3 m/s at once (MPC_Z_VEL_MAX_UP)
    assert math.isnan(sp.position_ned_m[2])
    vz = [task.update(DT, up, (0.0, 0.0, -10.0), ZERO3, 0.0, ZERO3).velocity_ned_mps[2]
          for _ in range(200)]
    steps = [b - a for a, b in zip([0.0, *vz], vz)]
    assert max(abs(d) for d in steps) <= 4.0 * DT + 1e-9  # MPC_ACC_UP_MAX
    assert vz[-1] == pytest.approx(-3.0)
    sp = task.update(DT, up, (0.0, 0.0, -10.0), ZERO3, 0.0, ZERO3)
    assert sp.acceleration_ned_mps2[2] == pytest.approx(0.0, abs=1e-9)  # fed forward, finite


def test_centred_after_a_descent_locks_where_the_smoothed_brake_ends():
    task = _altitude()
    pos = (0.0, 0.0, -10.0)
    for _ in range(150):
        task.update(DT, Sticks(throttle=-1.0), pos, ZERO3, 0.0, ZERO3)
    assert task.smoothing.v == pytest.approx(1.5)  # MPC_Z_VEL_MAX_DN
    sps = [task.update(DT, Sticks(), pos, ZERO3, 0.0, ZERO3) for _ in range(100)]
    locked = [i for i, sp in enumerate(sps) if math.isfinite(sp.position_ned_m[2])]
    assert locked and locked[0] > 20  # not at once (MPC_HOLD_MAX_Z's check is not PX4's here)
    assert sps[locked[0]].position_ned_m[2] > -10.0  # the trajectory went on down from the estimate
    assert all(math.isfinite(sps[i].position_ned_m[2]) for i in range(locked[0], 100))


def test_the_ground_slowdown_is_above_home():
    task = _altitude()
    # home 5 m above the origin, the vehicle 1 m above home: below MPC_LAND_ALT2 (5 m)
    pos = (0.0, 0.0, -6.0)
    task.activate(pos, ZERO3, 0.0)
    for _ in range(200):
        sp = task.update(DT, Sticks(throttle=-1.0), pos, ZERO3, 0.0, ZERO3, home_z=-5.0)
    assert sp.velocity_ned_mps[2] == pytest.approx(0.7)  # MPC_LAND_SPEED
    for _ in range(300):
        sp = task.update(DT, Sticks(throttle=1.0), pos, ZERO3, 0.0, ZERO3, home_z=-5.0)
    assert sp.velocity_ned_mps[2] == pytest.approx(-1.5)  # MPC_TKO_SPEED
    for _ in range(300):  # without a home, 6 m above the origin: a fifth of the way from
        sp = task.update(DT, Sticks(throttle=1.0), pos, ZERO3, 0.0, ZERO3)  # ALT2 to ALT1 (10 m)
    assert sp.velocity_ned_mps[2] == pytest.approx(-(1.5 + (3.0 - 1.5) / 5.0))


def test_activate_starts_from_the_last_setpoint_each_non_finite_part_from_the_state():
    task = ManualAltitude(ParamStore())
    last = PositionSetpoint((1.0, 2.0, -7.0), (0.5, 0.0, -1.2), 0.3, (0.0, 0.0, -0.4))
    task.activate((0.0, 0.0, -8.0), (0.0, 0.0, -2.0), 0.0, last)
    assert tuple(task.smoothing.trajectory.row[1:4]) == (-0.4, -1.2, -7.0)
    task.activate((0.0, 0.0, -8.0), (0.0, 0.0, -2.0), 0.0,
                  PositionSetpoint(NAN3, NAN3, math.nan, NAN3))
    assert tuple(task.smoothing.trajectory.row[1:4]) == (0.0, -2.0, -8.0)


def test_reactivate_keeps_the_vertical_velocity_setpoint():
    """On the ground FlightTask::reActivate after each update keeps the vertical velocity
    setpoint (the stick can descend for the land detector); the acceleration restarts at 0 and
    the position at the vehicle's."""
    task = _altitude()
    pos = (0.0, 0.0, 0.0)
    task.activate(pos, ZERO3, 0.0)
    for _ in range(20):
        task.update(DT, Sticks(throttle=-1.0), pos, ZERO3, 0.0, ZERO3)
        task.reactivate(pos, ZERO3, 0.0)
    j, a, v, x = task.smoothing.trajectory.row[:4]
    assert a == 0.0 and x == 0.0
    # each tick one step of jerk from a zero acceleration: 19 × ½·8·0.02²
    assert v == pytest.approx(19 * 0.5 * 8.0 * DT * DT)
