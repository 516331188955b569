"""Position controller, trajectory limiter: pure-library tests (no physics engine)."""

import math

import pytest

from vehicles.airframe import X500
from vehicles.control.position_control import (
    PositionControl,
    PositionControlGains,
    PositionSetpoint,
    limit_tilt,
)
from vehicles.control.trajectory import TrajectoryLimiter, TrajectoryLimits
from vehicles.params import ParamStore

ZERO = (0.0, 0.0, 0.0)


def make_control(**overrides):
    return PositionControl(PositionControlGains.from_params(ParamStore(overrides),
                                                            hover_thrust=X500.hover_thrust_norm))


def tilt_rad(thrust):
    return math.acos(-thrust[2] / math.sqrt(sum(t * t for t in thrust)))


def test_hover_at_setpoint_gives_hover_thrust_straight_up():
    out = make_control().update(0.02, ZERO, ZERO, ZERO, PositionSetpoint(position_ned_m=ZERO))
    assert out.thrust_ned[0] == pytest.approx(0.0)
    assert out.thrust_ned[1] == pytest.approx(0.0)
    assert out.thrust_ned[2] == pytest.approx(-X500.hover_thrust_norm)


@pytest.mark.parametrize("target", [(5.0, 0.0, 0.0), (0.0, -3.0, 0.0), (2.0, 2.0, 0.0),
                                    (-1.0, 4.0, 0.0)])
def test_thrust_vector_points_towards_target(target):
    out = make_control().update(0.02, ZERO, ZERO, ZERO, PositionSetpoint(position_ned_m=target))
    horizontal = (out.thrust_ned[0], out.thrust_ned[1])
    cos = (horizontal[0] * target[0] + horizontal[1] * target[1]) / (
        math.hypot(*horizontal) * math.hypot(target[0], target[1]))
    assert cos == pytest.approx(1.0, abs=1e-6)
    assert out.thrust_ned[2] < 0.0


def test_climb_target_increases_thrust_and_descent_reduces_it():
    up = make_control().update(0.02, ZERO, ZERO, ZERO, PositionSetpoint(position_ned_m=(0, 0, -2.0)))
    down = make_control().update(0.02, ZERO, ZERO, ZERO, PositionSetpoint(position_ned_m=(0, 0, 2.0)))
    assert -up.thrust_ned[2] > X500.hover_thrust_norm > -down.thrust_ned[2]


def test_tilt_limit_holds_for_huge_position_error():
    ctrl = make_control()
    for _ in range(200):  # let the integrator try to wind up too
        out = ctrl.update(0.02, ZERO, ZERO, ZERO,
                          PositionSetpoint(position_ned_m=(1e5, -1e5, 0.0)))
        assert tilt_rad(out.thrust_ned) <= math.radians(45.0) + 1e-6
        assert math.sqrt(sum(t * t for t in out.thrust_ned)) <= 1.0 + 1e-9


def test_tilt_limit_follows_mpc_tiltmax_air():
    out = make_control(MPC_TILTMAX_AIR=20.0).update(
        0.02, ZERO, ZERO, ZERO, PositionSetpoint(position_ned_m=(1e4, 0.0, 0.0)))
    assert tilt_rad(out.thrust_ned) == pytest.approx(math.radians(20.0), abs=1e-6)


def test_velocity_setpoint_is_limited():
    out = make_control().update(0.02, ZERO, ZERO, ZERO,
                                PositionSetpoint(position_ned_m=(1e4, 0.0, -1e4)))
    assert math.hypot(*out.velocity_sp_ned_mps[:2]) == pytest.approx(12.0)  # MPC_XY_VEL_MAX
    assert out.velocity_sp_ned_mps[2] == pytest.approx(-3.0)  # MPC_Z_VEL_MAX_UP


def test_nan_position_means_velocity_control():
    sp = PositionSetpoint(position_ned_m=(math.nan, math.nan, math.nan),
                          velocity_ned_mps=(1.0, 0.0, 0.0))
    out = make_control().update(0.02, (50.0, 50.0, -9.0), ZERO, ZERO, sp)
    assert out.velocity_sp_ned_mps == pytest.approx((1.0, 0.0, 0.0))
    assert out.thrust_ned[0] > 0.0


def test_thrust_never_below_thrust_min():
    # Climbing fast but asked to descend: the controller wants less than MPC_THR_MIN.
    out = make_control().update(0.02, ZERO, (0.0, 0.0, -10.0), ZERO,
                                PositionSetpoint(position_ned_m=(0.0, 0.0, 1e4)))
    assert -out.thrust_ned[2] == pytest.approx(0.12)  # MPC_THR_MIN


def test_limit_tilt_keeps_unit_length():
    v = limit_tilt((0.8, 0.0, 0.6), math.radians(30))
    assert math.sqrt(sum(c * c for c in v)) == pytest.approx(1.0)
    assert math.acos(v[2]) == pytest.approx(math.radians(30))


LIMITS = TrajectoryLimits(5.0, 1.5, 1.0, 3.0, 4.0, 3.0)


def test_trajectory_respects_speed_and_acceleration_and_arrives():
    traj = TrajectoryLimiter()
    traj.reset(ZERO, ZERO)
    prev_v = ZERO
    for _ in range(1000):
        p, v, a = traj.update(0.02, (40.0, 30.0, -5.0), LIMITS)
        assert math.hypot(v[0], v[1]) <= 5.0 + 1e-9
        assert -1.5 - 1e-9 <= v[2] <= 1.0 + 1e-9
        assert math.hypot(v[0] - prev_v[0], v[1] - prev_v[1]) <= 3.0 * 0.02 + 1e-9
        assert math.hypot(a[0], a[1]) <= 3.0 + 1e-6
        assert -4.0 - 1e-6 <= a[2] <= 3.0 + 1e-6
        prev_v = v
    assert p == pytest.approx((40.0, 30.0, -5.0))
    assert v == pytest.approx(ZERO)


def test_trajectory_velocity_mode_for_nan_z():
    traj = TrajectoryLimiter()
    traj.reset(ZERO, ZERO)
    for _ in range(100):
        p, v, _ = traj.update(0.02, (0.0, 0.0, math.nan), LIMITS, vz_cmd_mps=0.7, current_z_m=-3.0)
    assert math.isnan(p[2])
    assert v[2] == pytest.approx(0.7)


def test_axis_with_only_acceleration_is_not_velocity_controlled():
    # PX4 (addIfNotNan): no position or velocity setpoint on an axis -> its acceleration
    # feed-forward alone, whatever the velocity (no damping, the integrator untouched).
    ctrl = make_control()
    sp = PositionSetpoint(acceleration_ned_mps2=(0.0, 0.0, 100.0))
    out = ctrl.update(0.02, ZERO, (3.0, -2.0, 1.0), (0.5, 0.5, 0.0), sp)
    assert out.valid
    assert out.thrust_ned[:2] == (0.0, 0.0)
    assert out.thrust_ned[2] == pytest.approx(-0.12)  # MPC_THR_MIN
    assert ctrl.velocity_integral == (0.0, 0.0, 0.0)


def test_invalid_setpoint_fails_and_the_flight_path_stops():
    # Nothing commanded vertically: PositionControl::update fails and leaves the integrator;
    # mc_pos_control then flies its failsafe setpoint, zero velocity.
    sp = PositionSetpoint(position_ned_m=(5.0, 5.0, math.nan))
    ctrl = make_control()
    out = ctrl.update(0.02, ZERO, (1.0, 0.0, 0.5), ZERO, sp)
    assert not out.valid
    assert ctrl.velocity_integral == (0.0, 0.0, 0.0)
    q, thrust, vel_sp, _ = ctrl.update_attitude(0.02, ZERO, (1.0, 0.0, 0.5), ZERO, sp, 0.0)
    assert vel_sp == (0.0, 0.0, 0.0)
    assert all(math.isfinite(c) for c in q) and 0.12 <= thrust <= 1.0


def test_horizontal_speed_limit_keeps_the_position_term_first():
    # PX4 ControlMath::constrainXY: the P term towards the position setpoint (4 m/s north) is
    # kept whole, the feed-forward (4 m/s west) gets what is left of the 5 m/s.
    sp = PositionSetpoint(position_ned_m=(4.0, 0.0, 0.0), velocity_ned_mps=(0.0, -4.0, 0.0))
    out = make_control(MPC_XY_VEL_MAX=5.0, MPC_XY_P=1.0).update(0.02, ZERO, ZERO, ZERO, sp)
    assert out.velocity_sp_ned_mps == pytest.approx((4.0, -3.0, 0.0))


def test_minimum_thrust_is_never_zero():
    # PX4 PositionControl::setThrustLimits: at least 10e-4, so that the attitude still comes
    # from a thrust vector (mc_pos_control asks for 0 before takeoff).
    ctrl = make_control()
    ctrl.set_limits(3.0, 0.0, math.radians(45.0))
    out = ctrl.update(0.02, ZERO, ZERO, ZERO, PositionSetpoint(acceleration_ned_mps2=(0, 0, 100.0)))
    assert out.thrust_ned == pytest.approx((0.0, 0.0, -1e-3))
