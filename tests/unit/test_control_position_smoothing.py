"""PX4's position smoothing (vehicles/control/position_smoothing.py): PX4's own unit test,
PositionSmoothingTest.cpp, reproduced case by case (matrix's == is within 1e-4)."""

from __future__ import annotations

import math

import numba
import pytest

from vehicles.control.position_smoothing import (
    DynamicLimits,
    PositionSmoothing,
    _unit2,
    max_speed_from_distance,
    max_speed_in_waypoint,
    start_xy_speed,
)

MAX_JERK, MAX_ACCELERATION = 4.0, 3.0
MAX_ALLOWED_HOR_ERR, VERTICAL_ACCEPTANCE_RADIUS = 2.0, 0.8
CRUISE_SPEED = MAX_VELOCITY = 5.0
HORIZONTAL_TRAJECTORY_GAIN, TARGET_ACCEPTANCE_RADIUS = 0.5, 0.5
TARGET = (12.0, 17.0, 8.0)


def equal(a, b, eps=1e-4) -> bool:
    return all(abs(x - y) <= eps for x, y in zip(a, b))


def smoothing() -> PositionSmoothing:
    s = PositionSmoothing()
    s.set_max_jerk(MAX_JERK)
    s.set_max_acceleration((MAX_ACCELERATION,) * 3)
    s.set_max_velocity((MAX_VELOCITY,) * 3)
    s.max_allowed_horizontal_error = MAX_ALLOWED_HOR_ERR
    s.vertical_acceptance_radius = VERTICAL_ACCEPTANCE_RADIUS
    s.cruise_speed = CRUISE_SPEED
    s.horizontal_trajectory_gain = HORIZONTAL_TRAJECTORY_GAIN
    s.target_acceptance_radius = TARGET_ACCEPTANCE_RADIUS
    s.reset((0.0,) * 3, (0.0,) * 3, (0.0,) * 3)
    return s


def within_limits(out) -> bool:
    return all(abs(v) <= MAX_VELOCITY + 1e-6 for v in out.velocity) and \
        all(abs(a) <= MAX_ACCELERATION + 1e-6 for a in out.acceleration) and \
        all(abs(j) <= MAX_JERK + 1e-9 for j in out.jerk)


def test_all_zero_case():
    out = PositionSmoothing().generate((0.0,) * 3, ((0.0,) * 3,) * 3, (0.0,) * 3, 0.0)
    assert out.jerk == out.acceleration == out.velocity == out.position == \
        out.unsmoothed_velocity == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("feedback", ["position", "velocity"])
def test_reaches_target(feedback):
    """reachesTargetPositionSetpoint (the vehicle is where the setpoint is) and
    reachesTargetVelocityIntegration (the vehicle integrates the velocity setpoint)."""
    s, position = smoothing(), (0.0, 0.0, 0.0)
    waypoints = ((0.0, 0.0, 0.0), TARGET, TARGET)
    for _ in range(2000):
        out = s.generate(position, waypoints, (0.0,) * 3, 0.02)
        if feedback == "position":
            position = out.position
        else:
            position = tuple(p + v * 0.02 for p, v in zip(position, out.velocity))
        assert within_limits(out)
        if equal(position, TARGET):
            break
    else:
        pytest.fail("took too long to converge")


def test_reaches_target_initial_velocity():
    """PX4 v1.15's reachesTargetInitialVelocity: with a next waypoint 72 m lower the corner is
    not flown (the altitude does not stay the same), so the setpoint stops exactly at the
    target, within 2000 iterations, from an initial feed-forward velocity."""
    s, position = smoothing(), (0.0, 0.0, 0.0)
    waypoints = ((0.0, 0.0, 0.0), TARGET, (8.0, 12.0, 80.0))
    ff = (1.0, 0.1, 0.3)
    for _ in range(2000):
        out = s.generate(position, waypoints, ff, 0.02)
        position, ff = out.position, (0.0, 0.0, 0.0)
        assert within_limits(out)
        if equal(position, TARGET):
            break
    else:
        pytest.fail("took too long to converge")


# PX4 v1.15.2's PositionSmoothing (PositionSmoothing.cpp, VelocitySmoothing.cpp, float) run with
# PositionSmoothingTest.cpp's settings: (iteration, position, velocity, acceleration) towards
# TARGET from rest, the vehicle where the setpoint is (float32 against float64: to ~5 digits;
# by iteration 400 the float32 jerk switching differs in the acceleration's 4th digit).
PX4_TOWARDS_TARGET = [
    (50, (0.5416713, 0.6562499, 0.3957816), (1.344831, 1.875, 0.9028123),
     (1.710599, 3.0, 1.037315)),
    (200, (8.129448, 11.48012, 5.431105), (2.078219, 2.913727, 1.407327),
     (-0.9202663, -1.180233, -0.6083184)),
    (400, (11.66164, 16.52862, 7.777025), (0.2256607, 0.3138437, 0.1486046), None),
]


def close(a, b) -> bool:
    """Equal to PX4's float32 values (to ~5 digits: float64 here)."""
    return a == pytest.approx(b, rel=1e-4, abs=5e-5)


def test_matches_px4_v115_towards_a_3d_target():
    """One straight 3-D direction at the xy and z speeds' combined norm (v1.15
    _generateVelocitySetpoint), not xy and z planned apart."""
    s, position, checks = smoothing(), (0.0, 0.0, 0.0), dict((c[0], c) for c in PX4_TOWARDS_TARGET)
    for i in range(401):
        out = s.generate(position, ((0.0, 0.0, 0.0), TARGET, TARGET), (0.0,) * 3, 0.02)
        position = out.position
        if i in checks:
            _, pos, vel, acc = checks[i]
            assert close(out.position, pos) and close(out.velocity, vel), i
            assert acc is None or close(out.acceleration, acc), i  # by 400 jerk switches apart


def test_matches_px4_v115_time_stretch_on_all_axes():
    """A vehicle that stays at the start: _generateTrajectory's time stretch, from the
    horizontal lag (MPC_XY_ERR_MAX 2 m), slows all three axes alike (PX4 v1.15.2's values);
    the setpoint settles ~2 m ahead instead of running away, z with it."""
    s = smoothing()
    want = {50: ((0.4250171, 0.4962116, 0.3169948), (1.187226, 1.59856, 0.8072284)),
            100: ((1.009793, 1.335358, 0.7052532), (1.84667, 2.755044, 1.207109)),
            300: ((1.190453, 1.606845, 0.8229895), (2.007059, 3.035263, 1.304366))}
    for i in range(301):
        out = s.generate((0.0, 0.0, 0.0), ((0.0, 0.0, 0.0), TARGET, TARGET), (0.0,) * 3, 0.02)
        if i in want:
            assert close(out.position, want[i][0]) and close(out.velocity, want[i][1]), i


def test_matches_px4_v115_towards_an_altitude_only():
    """A target with only an altitude (xy NaN): the z speed brakes to a stop there, the xy
    feed-forward is flown as it is (PX4 v1.15.2's values)."""
    s, position = smoothing(), (0.0, 0.0, 0.0)
    target = (math.nan, math.nan, -6.0)
    want = {50: ((0.1394063, 0.0, -0.656064), (0.2931395, 0.0, -1.866457), -2.748053),
            100: ((0.5741431, 0.0, -3.22515), (0.5033102, 0.0, -2.605047), -1.600261),
            200: ((1.575089, 0.0, -5.42887), (0.5, 0.0, -0.3820569), -0.3706193)}
    for i in range(201):
        out = s.generate(position, (target,) * 3, (0.5, 0.0, math.nan), 0.02,
                         single_waypoint=True)
        position = out.position
        if i in want:
            pos, vel, vz = want[i]
            assert close(out.position, pos) and close(out.velocity, vel), i
            assert close(out.unsmoothed_velocity, (0.5, 0.0, vz)), i


@pytest.mark.parametrize("distance, unsmoothed", [
    (10.0, (4.6241436, 0.0, -0.277448624)), (30.0, (5.0, 0.0, -0.1)),
    (100.0, (5.0, 0.0, -0.03))])
def test_matches_px4_v115_towards_a_waypoint_just_above_the_ground(distance, unsmoothed):
    """Landed, reset as FlightTaskAuto::reActivate leaves it (0.7 m/s down), towards a waypoint
    0.6 m up and ``distance`` ahead with a level next leg: the 3-D direction's xy part is held
    to the xy speed (at most the 5 m/s cruise), so the climb is at most 5 x 0.6 / distance, never
    past FlightTaskAuto's takeoff trigger of -0.3 m/s (PX4 v1.15.2's values)."""
    s = smoothing()
    s.target_acceptance_radius = 2.0
    s.reset((0.0, 0.0, 0.0), (0.0, 0.0, 0.7), (0.0, 0.0, 0.0))
    target = (distance, 0.0, -0.6)
    out = s.generate((0.0, 0.0, 0.0), ((0.0, 0.0, 0.0), target, (distance, 10.0, -0.6)),
                     (math.nan,) * 3, 0.02)
    assert close(out.unsmoothed_velocity, unsmoothed)
    # the same plan without advancing the trajectory (the auto task's takeoff trigger)
    s.reset((0.0, 0.0, 0.0), (0.0, 0.0, 0.7), (0.0, 0.0, 0.0))
    assert close(s.unsmoothed_velocity_auto((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), target,
                                            (distance, 10.0, -0.6), 2.0), unsmoothed)


@pytest.mark.parametrize("next_z, checks", [
    # level: the corner speed sqrt(MPC_XY_TRAJ_P * acc * radius * tan(45 deg)) = sqrt(3)
    (-10.0, [(100, 4.006558, 4.652774), (200, 13.44236, 3.74765), (289, 18.01846, 1.732051)]),
    # the next leg climbs 5 m: a stop planned at the corner
    (-15.0, [(100, 4.006558, 4.652774), (200, 13.3096, 3.597427), (300, 17.9572, 1.2987)]),
])
def test_matches_px4_v115_into_a_corner(next_z, checks):
    """Towards a 90 degree corner 20 m ahead (2 m acceptance radius, PositionSmoothingTest.cpp's
    other settings): (iteration, north position, north speed) as PX4 v1.15.2's own
    PositionSmoothing / VelocitySmoothing library gives them, run with these inputs."""
    s = smoothing()
    s.target_acceptance_radius = 2.0
    s.reset((0.0,) * 3, (0.0,) * 3, (0.0, 0.0, -10.0))
    waypoints = ((0.0, 0.0, -10.0), (20.0, 0.0, -10.0), (20.0, 20.0, next_z))
    position, want = (0.0, 0.0, -10.0), dict((c[0], c[1:]) for c in checks)
    for i in range(max(want) + 1):
        out = s.generate(position, waypoints, (0.0,) * 3, 0.02)
        position = out.position
        if i in want:
            assert close((position[0], out.velocity[0]), want[i]), i


def test_matches_px4_v115_on_a_climbing_leg():
    """A leg climbing 10 m over 30 m: both axes on the straight line (PX4 v1.15.2's values)."""
    s = smoothing()
    s.target_acceptance_radius = 2.0
    waypoints = ((0.0, 0.0, 0.0), (30.0, 0.0, -10.0), (30.0, 30.0, -10.0))
    position = (0.0, 0.0, 0.0)
    for _ in range(101):
        out = s.generate(position, waypoints, (0.0,) * 3, 0.02)
        position = out.position
    assert close(out.position, (4.006558, 0.0, -1.359336))
    assert close(out.velocity, (4.652774, 0.0, -1.424794))


def test_matches_px4_v115_round_the_corner_to_the_last_waypoint():
    """FlightTaskAuto always hands the smoothing three waypoints (next = target when there is
    none), never the single-waypoint form: turning towards a mission's last waypoint after a
    corner it flies the L1 point on the previous -> target line at the held speed. The corner
    of test_matches_px4_v115_into_a_corner, the navigator switching at 2 m, then (iterations
    after the switch, position, velocity) as PX4 v1.15.2 gives them."""
    s = smoothing()
    s.target_acceptance_radius = 2.0
    s.reset((0.0,) * 3, (0.0,) * 3, (0.0, 0.0, -10.0))
    w0, w3, w4 = (0.0, 0.0, -10.0), (20.0, 0.0, -10.0), (20.0, 20.0, -10.0)
    want = {25: ((18.81324, 0.073728, -10.0), (1.31601, 0.4608001, 0.0)),
            50: ((19.2746, 0.5809618, -10.0), (0.5017593, 1.499852, 0.0)),
            100: ((19.48421, 2.989766, -10.0), (0.1550779, 3.735444, 0.0)),
            300: ((19.93417, 17.58886, -10.0), (0.04155701, 1.512787, 0.0))}
    position, switched = w0, None
    for i in range(600):
        if switched is None:
            out = s.generate(position, (w0, w3, w4), (math.nan,) * 3, 0.02)
            position = out.position
            if math.dist(position[:2], w3[:2]) < 2.0:
                switched = i
            continue
        position, velocity, _ = s.generate_auto(position, w3, w4, None, None, 0.02, 2.0)
        if i - switched in want:
            assert close(position, want[i - switched][0]), i - switched
            # by 300 the float32 run's small cross-track speed is 1e-3 m/s apart
            assert velocity == pytest.approx(want[i - switched][1], rel=1e-4, abs=1e-3), \
                i - switched
    assert switched == 289


def test_traj_math():
    """TrajMath: braking from the speed it gives takes the whole distance; a straight line
    (alpha = pi) allows any speed, a reversal (alpha = 0) none."""
    v = max_speed_from_distance(4.0, 3.0, 10.0, 0.0)
    delay = 2.0 * 3.0 / 4.0
    assert v * delay + v * v / (2 * 3.0) == pytest.approx(10.0)
    assert max_speed_in_waypoint(0.0, 3.0, 2.0) == 0.0
    assert max_speed_in_waypoint(math.pi - 1e-6, 3.0, 2.0) > 100.0


def test_a_corner_is_planned_inside_and_slower():
    """A 90 degree fly-through corner: the smoothed path cuts inside it and slows below cruise
    (the speed planned from MPC_XY_TRAJ_P x MPC_ACC_HOR and the acceptance radius)."""
    s, position = smoothing(), (0.0, 0.0, 0.0)
    s.target_acceptance_radius = 2.0
    corner, nxt = (30.0, 0.0, 0.0), (30.0, 30.0, 0.0)
    prev = (0.0, 0.0, 0.0)
    speeds, outside = [], 0.0
    target = corner
    for _ in range(3000):
        out = s.generate(position, (prev, target, nxt), (0.0,) * 3, 0.02)
        position = out.position
        if target == corner and math.dist(position[:2], corner[:2]) < 2.0:
            prev, target = corner, nxt  # the navigator switches at the acceptance radius
        speeds.append((position, math.hypot(out.velocity[0], out.velocity[1])))
        outside = max(outside, position[0] - corner[0])
        if equal(position, nxt, 1e-2):
            break
    near = [v for p, v in speeds if math.dist(p[:2], corner[:2]) < 3.0]
    assert outside <= 0.2 and max(v for _, v in speeds) <= CRUISE_SPEED + 1e-6
    assert min(near) < 0.8 * CRUISE_SPEED


# --- computeStartXYSpeedFromWaypoints (TrajectoryConstraints.hpp, PX4 v1.15) ----------------------
LIMITS = DynamicLimits(z_accept_rad=0.8, xy_accept_rad=2.0, max_acc_xy=3.0, max_jerk=4.0,
                       max_speed_xy=5.0, max_acc_xy_radius_scale=0.5)


def test_start_speed_plans_the_corner_on_level_legs():
    """A level 90 degree corner 20 m ahead: braking to the corner speed sqrt(0.5 * 3 * 2 *
    tan(pi/4)) = sqrt(3) from the speed the distance allows (capped at cruise)."""
    corner_speed = math.sqrt(0.5 * 3.0 * 2.0 * math.tan(math.pi / 4.0))
    start, target, nxt = (0.0, 0.0, -10.0), (20.0, 0.0, -10.0), (20.0, 20.0, -10.0)
    assert start_xy_speed(target, nxt, nxt, 0.0, LIMITS) == 5.0
    near = (19.0, 0.0, -10.0)
    assert start_xy_speed(near, target, nxt, 5.0, LIMITS) == pytest.approx(
        max_speed_from_distance(4.0, 3.0, 1.0, corner_speed))
    assert start_xy_speed(start, target, nxt, 5.0, LIMITS) == 5.0
    # at the corner itself the speed is the corner's (computeMaxSpeedFromDistance: fmaxf)
    assert start_xy_speed(target, target, nxt, 5.0, LIMITS) == pytest.approx(corner_speed)


@pytest.mark.parametrize("start_z, next_z", [
    (-5.0, -10.0),    # still 5 m below the target's altitude: not reached
    (-9.1, -10.0),    # 0.9 m off: outside NAV_MC_ALT_RAD (0.8)
    (-10.0, -15.0),   # the next leg climbs
    (-10.0, -9.1),    # the next leg descends by more than the radius
    (math.nan, -10.0),  # no altitude (vertical speed control): never reached
])
def test_start_speed_plans_a_stop_unless_level(start_z, next_z):
    """PX4 v1.15 plans a corner speed only with the altitude reached and the next leg at it;
    otherwise the speed brakes to a stop at the target."""
    near, target, nxt = (19.0, 0.0, start_z), (20.0, 0.0, -10.0), (20.0, 20.0, next_z)
    assert start_xy_speed(near, target, nxt, 5.0, LIMITS) == pytest.approx(
        max_speed_from_distance(4.0, 3.0, 1.0, 0.0))
    assert start_xy_speed((20.0, 0.0, start_z), target, nxt, 5.0, LIMITS) == 0.0


def test_start_speed_altitude_within_the_radius_is_reached():
    near, target, nxt = (19.0, 0.0, -9.3), (20.0, 0.0, -10.0), (20.0, 20.0, -10.7)
    assert start_xy_speed(near, target, nxt, 5.0, LIMITS) > \
        max_speed_from_distance(4.0, 3.0, 1.0, 0.0)


@numba.njit
def _compiled_cos(ax: float, ay: float, bx: float, by: float) -> float:
    ux, uy = _unit2(ax, ay)
    wx, wy = _unit2(bx, by)
    return ux * wx + uy * wy


def test_start_speed_reversal_past_acos_domain_is_not_a_stop():
    """An exact reversal whose dot product rounds past 1: acosf gives NaN, math::constrain keeps
    it and math::min(NaN, exit_speed) drops it, so PX4 plans the exit speed (not 0)."""
    d = 0.7  # (0.7, 0.7) and (7.7, 7.7) normalize to a dot product of 1 + 2e-16
    start, target, nxt = (0.0, 0.0, 0.0), (d, d, 0.0), (-10 * d, -10 * d, 0.0)
    if _compiled_cos(d, d, 11 * d, 11 * d) <= 1.0:
        pytest.skip("this platform rounds the dot product into acos's domain")
    assert start_xy_speed(start, target, nxt, 1.5, LIMITS) == pytest.approx(
        max_speed_from_distance(4.0, 3.0, math.hypot(d, d), 1.5))
    # inside the domain the reversal is alpha = 0: a stop
    assert start_xy_speed(start, target, (d, -10 * d, 0.0), 1.5, LIMITS) < 1.5
