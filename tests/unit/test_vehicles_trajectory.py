"""Auto-mode trajectories fly as PX4's PositionSmoothing plans them (vehicles/auto_trajectory.py):
a fly-through square cuts inside its corners at the corner speed the library plans for that
geometry, legs stay at the cruise speed, a goto creeps in without overshoot."""

from __future__ import annotations

import math

import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from tests.unit.test_vehicles_mission import waypoints
from vehicles.auto_trajectory import AutoTrajectory
from vehicles.control.position_smoothing import PositionSmoothing, ideal_track
from vehicles.nav_core import auto_limits
from vehicles.params import ParamStore
from vehicles.plan_types import PlanType
from vehicles.types import CommandResult, NavState

SIDE_M, ALT_M, CRUISE = 50.0, 10.0, 5.0
CORNERS = [(SIDE_M, 0.0), (SIDE_M, SIDE_M), (0.0, SIDE_M)]


def corner_speeds(track) -> list[float]:
    return [min(s for (n, e), s in track if math.hypot(n - cn, e - ce) < 3.0) for cn, ce in CORNERS]


def reference_track() -> list:
    """PositionSmoothing alone on the same square (ideal_track: perfectly tracked, switching at
    NAV_ACC_RAD; MPC_JERK_AUTO 4, MPC_ACC_HOR 3, MPC_XY_TRAJ_P 0.5)."""
    s = PositionSmoothing()
    s.set_max_jerk(4.0)
    s.set_max_acceleration((3.0, 3.0, 3.0))
    s.set_max_velocity((CRUISE, CRUISE, 1.5))
    s.max_allowed_horizontal_error, s.vertical_acceptance_radius = 2.0, 0.8
    s.cruise_speed, s.horizontal_trajectory_gain, s.target_acceptance_radius = CRUISE, 0.5, 2.0
    pts = [(0.0, 0.0, -ALT_M)] + [(n, e, -ALT_M) for n, e in CORNERS] + [(0.0, 0.0, -ALT_M)]
    return [((p[0], p[1]), v) for p, v in ideal_track(s, pts, 2.0, 0.02)]


def fly_mission(corners, alt_m: float = ALT_M, timeout_s: float = 400.0) -> list:
    """One vehicle flies waypoints at the corners, then home, from the ground (lockstep, 50 Hz
    samples): [(t, (north, east), horizontal speed)] until it rests at home."""
    sim = Sim()
    try:
        v = sim.v
        pts = [(n, e, alt_m) for n, e in corners] + [(0.0, 0.0, alt_m)]
        v.set_plan(sim.t, PlanType.MISSION, waypoints(v, pts))
        sim.run(1.2)
        assert v.start_mission(sim.t) is CommandResult.ACCEPTED
        track = []
        while sim.t < timeout_s:
            sim.run(0.02)
            p, vel = v.state.position_ned_m, v.state.velocity_ned_mps
            track.append((sim.t, (float(p[0]), float(p[1])), math.hypot(vel[0], vel[1])))
            if v.mission_status.reached_count >= len(pts) and track[-1][2] < 0.05:
                break
        return track
    finally:
        sim.close()


def test_fly_through_square_cuts_inside_at_the_planned_corner_speed():
    track = [(ne, s) for _, ne, s in fly_mission(CORNERS)]
    outside = max(max(n - SIDE_M, e - SIDE_M, 0.0) for (n, e), _ in track)
    assert outside <= 0.2  # inside (or within 0.2 m of) the square at every corner
    assert max(s for _, s in track) <= CRUISE * 1.02
    ours, planned = corner_speeds(track), corner_speeds(reference_track())
    for got, want in zip(ours, planned):
        assert got == pytest.approx(want, rel=0.2)
    assert all(s < 0.5 * CRUISE for s in ours)  # it slows for the turn


def fly_goto(distance_m: float = 30.0, seconds: float = 30.0) -> tuple[float, float]:
    """Take off, then DO_REPOSITION ``distance_m`` north: (greatest overshoot past the target,
    final distance from it), lockstep."""
    sim = Sim()
    try:
        v = sim.v
        take_off(sim)
        p0 = [float(x) for x in v.state.position_ned_m]
        target = v.origin.offset_ned(p0[0] + distance_m, p0[1], 0.0)
        assert v.goto(sim.t, target.lat_deg, target.lon_deg,
                      v.origin.alt_amsl_m - p0[2]) is CommandResult.ACCEPTED
        worst = -math.inf
        for _ in range(int(seconds / 0.02)):
            sim.run(0.02)
            worst = max(worst, float(v.state.position_ned_m[0]) - (p0[0] + distance_m))
        return worst, abs(float(v.state.position_ned_m[0]) - (p0[0] + distance_m))
    finally:
        sim.close()


def test_goto_creeps_in_without_overshoot():
    overshoot, error = fly_goto()
    assert overshoot <= 0.2 and error < 0.1


def test_vertical_limits_follow_the_unsmoothed_climb():
    """FlightTaskAuto::_updateTrajConstraints picks the climb's vertical limits while the last
    unsmoothed velocity setpoint climbs, whatever the smoothed velocity does: reset as
    FlightTaskAuto::reActivate leaves it on the ground (0.7 m/s down) and aimed 15 m up, the
    setpoint turns round at the takeoff's MPC_TKO_SPEED / MPC_TKO_RAMP_T (0.5 m/s^2), not at
    MPC_ACC_DOWN_MAX (3 m/s^2, which would have it at 0.24 m/s down by then)."""
    params = ParamStore()
    traj = AutoTrajectory(params)
    lim = auto_limits(params, speed_up_mps=1.5, acc_up_mps2=0.5)
    traj.smoothing.reset((0.0, 0.0, 0.0), (0.0, 0.0, 0.7), (0.0, 0.0, 0.0))
    traj.update(0.02, (0.0, 0.0, -15.0), lim, position_ned_m=(0.0, 0.0, 0.0))
    assert traj.smoothing.out[4, 2] < 0.0  # the unsmoothed setpoint climbs
    for _ in range(24):  # half a second
        traj.update(0.02, (0.0, 0.0, -15.0), lim, position_ned_m=traj.position_ned_m)
    assert traj.velocity_ned_mps[2] > 0.45  # still descending: turning round at 0.5 m/s^2


def test_emergency_braking_starts_beyond_the_maximum_speeds_and_ends_at_rest():
    """FlightTaskAuto::_checkEmergencyBraking: on the smoothing's velocity, beyond 1.3 x
    MPC_Z_VEL_MAX_DN (1.5) down, 1.3 x MPC_Z_VEL_MAX_UP (3) up or 1.3 x MPC_XY_VEL_MAX (12)
    horizontally; it holds until the smoothing has stopped (|vz| < 0.01, |vxy| <= 0.01). While
    it brakes the controller's vertical limits are raised to the smoothing's vertical speed
    (_updateTrajConstraints), else at least 1.2 x MPC_Z_V_AUTO_UP / MPC_Z_V_AUTO_DN."""
    params = ParamStore()
    traj = AutoTrajectory(params)
    assert traj.controller_speed_limits() == pytest.approx((3.6, 1.8))
    for vel, brakes in [((0.0, 0.0, 1.94), False), ((0.0, 0.0, 1.96), True),
                        ((0.0, 0.0, -3.89), False), ((0.0, 0.0, -3.91), True),
                        ((11.1, 11.1, 0.0), True), ((11.0, 11.0, 0.0), False)]:
        traj.emergency_braking = False
        traj.smoothing.reset((0.0, 0.0, 0.0), vel, (0.0, 0.0, 0.0))
        assert traj.check_emergency_braking() is brakes, vel
    traj.smoothing.reset((0.0, 0.0, 0.0), (0.0, 0.0, 5.0), (0.0, 0.0, 0.0))
    assert traj.check_emergency_braking()
    assert traj.controller_speed_limits() == pytest.approx((5.0, 5.0))
    for vel, brakes in [((0.0, 0.0, 1.0), True), ((0.0, 0.0, 0.0099), False)]:
        traj.smoothing.reset((0.0, 0.0, 0.0), vel, (0.0, 0.0, 0.0))
        assert traj.check_emergency_braking() is brakes, vel
    traj.emergency_braking = True
    traj.smoothing.reset((0.0, 0.0, 0.0), (0.0, 0.011, 0.0), (0.0, 0.0, 0.0))
    assert traj.check_emergency_braking()


def test_hold_entered_falling_fast_brakes_at_one_g():
    """Hold entered while the vehicle falls at about 3.4 m/s (Offboard at low thrust), beyond
    1.3 x MPC_Z_VEL_MAX_DN: FlightTaskAuto brakes the setpoint at 1 g with 1 g/s of jerk and no
    velocity setpoint, so it stops after 2 sqrt(v0 / g) and v0 sqrt(v0 / g) metres (the
    descent's own MPC_ACC_DOWN_MAX 3 m/s^2 and MPC_JERK_AUTO 4 m/s^3 would take 1.5 s and
    3.3 m), and the controller lets the vehicle follow it (its descent limit raised to the
    setpoint's speed)."""
    from tests.unit.test_vehicles_offboard import start_offboard, stream
    from vehicles.plan_types import OffboardSetpoint
    from vehicles.types import NavState

    sim = Sim()
    try:
        v = sim.v
        take_off(sim)
        up = OffboardSetpoint(position_ned_m=(0.0, 0.0, -30.0), yaw_rad=0.0)
        start_offboard(sim, up)
        stream(sim, up, 20.0)
        fall = OffboardSetpoint(attitude_q=(1.0, 0.0, 0.0, 0.0), thrust=0.2)
        assert stream(sim, fall, 5.0, until=lambda: v.state.velocity_ned_mps[2] > 3.0)
        v0, z0 = float(v.state.velocity_ned_mps[2]), float(v.state.position_ned_m[2])
        assert v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
        t0, setpoints, lowest = sim.t, [], -math.inf
        for _ in range(200):  # 4 s
            sim.run(0.02)
            setpoints.append((sim.t - t0, v.position_setpoint_ned_m[2] - z0))
            lowest = max(lowest, float(v.state.position_ned_m[2]) - z0)
        t_stop, below = max(setpoints, key=lambda s: s[1])
        v_max = v0 + 0.2  # the speed the setpoint starts from, at the next tick
        assert t_stop <= 2.0 * math.sqrt(v_max / 9.80665) + 0.04
        assert below <= v_max * math.sqrt(v_max / 9.80665) + 0.15
        assert lowest <= below + 0.1
    finally:
        sim.close()


def test_a_goto_across_the_flight_path_flies_back_onto_its_line():
    """A reposition east commanded while flying north at 5 m/s (PX4 v1.15 FlightTaskAuto): the
    triplet's missing previous waypoint is where the vehicle was when it came
    (_evaluateTriplets), and once the braking carries the vehicle more than the acceptance
    radius off that line it flies to the line's closest point first (_getCurrentState offtrack,
    _updateInternalWaypoints), then along the line: 10 m east of the start it is within 1 m
    of the line, where heading straight from the braking point left it 5.6 m off."""
    sim = Sim()
    try:
        v = sim.v
        take_off(sim)
        alt = v.origin.alt_amsl_m + 10.0

        def goto(north, east):
            g = v.origin.offset_ned(north, east, 0.0)
            assert v.goto(sim.t, g.lat_deg, g.lon_deg, alt) is CommandResult.ACCEPTED

        goto(100.0, 0.0)
        assert sim.run(60.0, until=lambda: v.state.position_ned_m[0] > 30.0)
        assert v.state.velocity_ned_mps[0] > 4.5
        line_n = float(v.state.position_ned_m[0])
        goto(line_n, 60.0)
        track = []
        for _ in range(int(40.0 / 0.02)):
            sim.run(0.02)
            track.append((float(v.state.position_ned_m[0]) - line_n,
                          float(v.state.position_ned_m[1])))
        for east, within in [(10.0, 1.0), (30.0, 0.5)]:
            assert abs(next(n for n, e in track if e >= east)) < within, east
        assert abs(track[-1][0]) < 0.1 and track[-1][1] == pytest.approx(60.0, abs=0.1)
    finally:
        sim.close()


def test_auto_waypoints_follow_flight_task_auto_states():
    """FlightTaskAuto::_getCurrentState / _updateInternalWaypoints on a line from (0, 0) to
    (10, 0), acceptance radius 2 m; a missing previous waypoint is the vehicle's position when
    the triplet came, and an unchanged triplet keeps it."""
    from vehicles.auto_waypoints import NONE, OFFTRACK, PREVIOUS_INFRONT, TARGET_BEHIND, AutoWaypoints

    wp, target, nowhere = AutoWaypoints(), (10.0, 0.0, -5.0), (0.0, 0.0, -5.0)
    assert wp.update((0.0, 1.0, -5.0), target, None, None, 2.0) == (
        (0.0, 1.0, -5.0), target, target)
    assert wp.state == NONE
    assert wp.update((5.0, 1.5, -5.0), target, None, None, 2.0)[0] == (0.0, 1.0, -5.0)
    # off the track: the closest point first (at the target's altitude), the target next
    prev, tgt, nxt = wp.update((5.0, 4.0, -5.0), target, None, None, 2.0)
    assert wp.state == OFFTRACK and prev == (5.0, 4.0, -5.0) and nxt == target
    ux, uy = 10.0 / math.hypot(10.0, 1.0), -1.0 / math.hypot(10.0, 1.0)  # (0, 1) -> (10, 0)
    along = 5.0 * ux + 3.0 * uy
    assert tgt == pytest.approx((along * ux, 1.0 + along * uy, -5.0))
    assert wp.update((11.0, 1.0, -5.0), target, None, None, 2.0) == (
        (11.0, 1.0, -5.0), target, target)
    assert wp.state == TARGET_BEHIND
    wp = AutoWaypoints()
    prev, tgt, nxt = wp.update((-3.0, 0.0, -5.0), target, nowhere, None, 2.0)
    assert wp.state == PREVIOUS_INFRONT and (prev, tgt, nxt) == ((-3.0, 0.0, -5.0), nowhere, target)
    # a landing's NaN altitude is no change and stays NaN
    wp = AutoWaypoints()
    land = (10.0, 0.0, math.nan)
    wp.update((0.0, 0.0, -5.0), land, None, None, 2.0)
    assert wp.update((1.0, 0.0, -4.0), land, None, None, 2.0)[0] == (0.0, 0.0, -5.0)



def test_hold_point_passed_close_by_is_flown_away_from_down_the_short_line():
    """PX4 v1.15.2 in Hold's worst case: Hold's target at (0, 0) on a track from (0, -3.5) (no
    previous waypoint: the vehicle's position when the triplet came), passed 0.13 m to its side,
    so FlightTaskAuto's previous waypoint becomes that point (target_behind) and the line to the
    target runs across the track. PositionSmoothing::_getL1Point puts its point on that line
    past the target without bound, and _isTurning (beyond the acceptance radius, not heading at
    the target) keeps the speed at _max_speed_previous, planned last inside the 2 m radius
    (computeMaxSpeedFromDistance, ~1.17 m/s): perfectly tracked from 1.5 m past the target,
    moving away at 1.5 m/s, the trajectory flies on down the line for 6.66 s until it leaves
    the target_behind half-plane, then offtrack brings it back. The numbers are PX4's own
    PositionSmoothing.cpp / VelocitySmoothing.cpp (compiled from v1.15.2) under the transcribed
    _getCurrentState / _updateInternalWaypoints, with FlightTaskAuto's constraints."""
    from vehicles.auto_waypoints import NONE, OFFTRACK, TARGET_BEHIND, AutoWaypoints

    s = PositionSmoothing()
    s.set_max_jerk(4.0)
    s.set_max_acceleration((3.0, 3.0, 3.0))
    s.set_max_velocity((12.0, 12.0, 1.5))
    s.max_allowed_horizontal_error, s.vertical_acceptance_radius = 2.0, 0.8
    s.cruise_speed, s.horizontal_trajectory_gain, s.target_acceptance_radius = 5.0, 0.5, 2.0
    wp, hold = AutoWaypoints(), (0.0, 0.0, -10.0)
    wp.update((0.0, -3.5, -10.0), hold, None, None, 2.0)
    assert wp.state == NONE
    assert wp.update((0.13, 0.001, -10.0), hold, None, None, 2.0)[0] == (0.13, 0.001, -10.0)
    assert wp.state == TARGET_BEHIND
    s.reset((0.0, 0.0, 0.0), (-1.5, 0.0, 0.0), (-1.5, 0.3, -10.0))
    pos, track = s.position, []
    for _ in range(1501):
        waypoints_ = wp.update(pos, hold, None, None, 2.0)
        out = s.generate(pos, waypoints_, (math.nan,) * 3, 0.02)
        pos = out.position
        track.append((wp.state, pos, out.velocity))
    away = next(i for i, (state, _, _) in enumerate(track) if state != TARGET_BEHIND)
    assert away == 333 and track[away][0] == OFFTRACK
    assert track[away][1][:2] == pytest.approx((-9.3628, -0.0010), abs=2e-3)
    assert track[250][2][0] == pytest.approx(-1.1700, abs=1e-3)  # 5 s: still flying away
    assert max(math.hypot(p[0], p[1]) for _, p, _ in track) == pytest.approx(9.96, abs=0.01)
    assert track[500][1][0] == pytest.approx(-2.8396, abs=2e-3)  # 10 s: on its way back
    assert track[750][0] == NONE and math.hypot(*track[750][1][:2]) == pytest.approx(0.0875,
                                                                                     abs=2e-3)
    assert math.hypot(*track[-1][1][:2]) < 1e-3

def _cruise_north(sim, v) -> None:
    """A mission to a waypoint 100 m north at 10 m, flown until at MPC_XY_CRUISE past 30 m."""
    sim.run(1.2)
    v.set_plan(sim.t, PlanType.MISSION, waypoints(v, [(100.0, 0.0, 10.0)]))
    assert v.start_mission(sim.t) is CommandResult.ACCEPTED
    assert sim.run(90.0, until=lambda: v.state.position_ned_m[0] > 30.0)


def test_hold_at_cruise_stops_at_the_navigators_braking_point():
    """Loiter::set_loiter_position for a multicopter (setLoiterItemFromCurrentPositionWithBreaking,
    Navigator::calculate_breaking_stop): the vehicle's position moved along its course by
    v (v / (2 MPC_ACC_HOR) + 0.6) (computeBrakingDistanceFromVelocity), at its altitude."""
    sim = Sim()
    try:
        v = sim.v
        _cruise_north(sim, v)
        n0, _, d0 = (float(x) for x in v.state.position_ned_m)
        speed = float(v.state.velocity_ned_mps[0])
        assert speed > 4.5
        assert v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
        assert sim.run(20.0, until=lambda: math.hypot(*v.state.velocity_ned_mps) < 0.02)
        stop = n0 + speed * (speed / (2.0 * float(v.params["MPC_ACC_HOR"])) + 0.6)
        n, e, d = (float(x) for x in v.state.position_ned_m)
        assert n == pytest.approx(stop, abs=0.3) and abs(e) < 0.1
        assert d == pytest.approx(d0, abs=0.1)
    finally:
        sim.close()


def test_land_at_speed_comes_down_where_it_was_commanded():
    """Land::on_activation (MissionBlock::set_land_item): the landing point is the vehicle's
    position when Land was commanded, no braking distance: a vehicle commanded to land at
    cruise brakes past it and flies back."""
    sim = Sim()
    try:
        v = sim.v
        _cruise_north(sim, v)
        n0 = float(v.state.position_ned_m[0])
        assert v.land(sim.t) is CommandResult.ACCEPTED
        ahead = 0.0
        for _ in range(int(60.0 / 0.1)):
            sim.run(0.1)
            ahead = max(ahead, float(v.state.position_ned_m[0]) - n0)
            if not v.status.armed:
                break
        assert not v.status.armed and ahead > 3.0
        assert float(v.state.position_ned_m[0]) == pytest.approx(n0, abs=0.5)
    finally:
        sim.close()


def goto_east(sim, v, east_m: float) -> None:
    """DO_REPOSITION ``east_m`` east of the origin at 2.5 m, no heading (param4 NaN)."""
    g = v.origin.offset_ned(0.0, east_m, 0.0)
    assert v.goto(sim.t, g.lat_deg, g.lon_deg, v.origin.alt_amsl_m + 2.5) is \
        CommandResult.ACCEPTED


def test_a_goto_without_a_heading_turns_towards_its_target():
    """DO_REPOSITION with param4 NaN (QGC's "go to location"): the navigator gives no yaw and
    FlightTaskAuto::_set_heading_from_mode (MPC_YAW_MODE 0) turns the vehicle towards the target
    at MPC_YAWRAUTO_MAX while it is farther than the acceptance radius, then keeps the heading."""
    sim = Sim()
    try:
        v = sim.v
        take_off(sim)
        goto_east(sim, v, 30.0)
        sim.run(1.0)  # the setpoint slews at 45 deg/s, its rate fed forward (_limitYawRate)
        assert math.degrees(v.state.euler_rad()[2]) == pytest.approx(45.0, abs=4.0)
        sim.run(3.0)
        assert math.degrees(v.state.euler_rad()[2]) == pytest.approx(90.0, abs=3.0)
        assert sim.run(30.0, until=lambda: abs(v.state.position_ned_m[1] - 30.0) < 0.05)
        assert math.degrees(v.state.euler_rad()[2]) == pytest.approx(90.0, abs=1.0)
    finally:
        sim.close()


def test_auto_heading_points_at_the_target_and_locks_within_the_radius():
    from vehicles.auto_heading import AutoHeading, heading_from_vector

    assert heading_from_vector(0.0, 1.0) == pytest.approx(math.pi / 2)
    assert heading_from_vector(-1.0, -1.0) == pytest.approx(-3 * math.pi / 4)
    assert heading_from_vector(-1.0, 0.0) == 0.0  # sign(0) * acos(-1): PX4's quirk
    assert math.isnan(heading_from_vector(1e-4, 0.0))
    o, still = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    h = AutoHeading()
    # within the radius, unlocked: the vehicle's yaw, then locked at the last setpoint
    assert h.setpoint(0, o, (1.0, 0.0, 0.0), None, 2.0, 0.3, 0.1, still) == 0.3 and h.locked
    assert h.setpoint(0, o, (1.0, 0.0, 0.0), None, 2.0, 0.3, 0.2, still) == 0.2
    assert h.setpoint(0, o, (0.0, 5.0, 0.0), None, 2.0, 0.3, 0.2, still) == \
        pytest.approx(math.pi / 2)
    # MPC_YAW_MODE 1 / 2: towards / away from home; 3: along the velocity setpoint
    home = (0.0, -10.0, 0.0)
    assert h.setpoint(1, o, (9.0, 0.0, 0.0), home, 2.0, 0.3, 0.2, still) == \
        pytest.approx(-math.pi / 2)
    assert h.setpoint(2, o, (9.0, 0.0, 0.0), home, 2.0, 0.3, 0.2, still) == \
        pytest.approx(math.pi / 2)
    assert h.setpoint(3, o, (9.0, 0.0, 0.0), home, 2.0, 0.3, 0.2, (-1.0, -1.0, 0.0)) == \
        pytest.approx(-3 * math.pi / 4) and not h.locked
    assert h.setpoint(3, o, (1.0, 0.0, 0.0), home, 2.0, 0.3, 0.2, (-1.0, -1.0, 0.0)) == 0.2
    # _limitYawRate: slewed at the rate, fed forward, aligned within MIS_YAW_ERR unsaturated
    sp, rate = h.limit(1.0, 0.0, 0.02, math.radians(45.0), math.radians(12.0))
    assert sp == pytest.approx(math.radians(0.9)) and 0.0 < rate < math.radians(45.0)
    assert not h.aligned
    for _ in range(200):
        sp, rate = h.limit(1.0, sp, 0.02, math.radians(45.0), math.radians(12.0))
    assert sp == pytest.approx(1.0) and h.aligned and abs(rate) < 1e-3


def test_yaw_mode_3_heads_along_this_ticks_velocity_setpoint():
    """MPC_YAW_MODE 3: FlightTaskAuto::update runs _generateHeadingAlongTraj after the position
    smoothing, on the velocity setpoint it has just generated: at a yaw rate limit that does not
    bind, every tick's heading setpoint is the direction of that tick's smoothed velocity."""
    from vehicles.auto_heading import heading_from_vector

    sim = Sim(MPC_YAW_MODE=3, MPC_YAWRAUTO_MAX=360.0)
    try:
        v = sim.v
        take_off(sim)
        goto_east(sim, v, 30.0)
        sim.run(2.0)
        g = v.origin.offset_ned(20.0, 30.0, 0.0)  # turns north-east while flying east
        assert v.goto(sim.t, g.lat_deg, g.lon_deg, v.origin.alt_amsl_m + 2.5) is \
            CommandResult.ACCEPTED
        stage, checked, turned = v.autopilot.stage, 0, []
        for _ in range(1500):  # 6 s of physics steps, the 50 Hz tick among them
            sim.run(sim.world.dt_s)
            vel = stage.trajectory.smoothing.velocity
            if math.hypot(vel[0], vel[1]) > 0.5:
                along = heading_from_vector(vel[0], vel[1])
                assert abs(math.remainder(stage.yaw_sp - along, math.tau)) < 1e-6
                checked += 1
                turned.append(along)
        assert checked > 1000 and max(turned) - min(turned) > 0.5  # through the turn
    finally:
        sim.close()


def test_yaw_mode_4_turns_first_then_goes():
    """MPC_YAW_MODE 4: FlightTaskAuto holds the trajectory (force_zero_velocity_setpoint) until
    the heading setpoint is within MIS_YAW_ERR of the way to the target and no longer turning
    at MPC_YAWRAUTO_MAX: a goto 30 m east from facing north starts ~2 s later, facing east."""
    sim = Sim(MPC_YAW_MODE=4)
    try:
        v = sim.v
        take_off(sim)
        e0 = float(v.state.position_ned_m[1])
        goto_east(sim, v, 30.0)
        sim.run(1.5)  # turning at 45 deg/s: not moving yet
        assert abs(float(v.state.position_ned_m[1]) - e0) < 0.1
        assert sim.run(5.0, until=lambda: v.state.position_ned_m[1] - e0 > 0.5)
        assert math.degrees(v.state.euler_rad()[2]) == pytest.approx(90.0, abs=12.0)
        assert sim.run(30.0, until=lambda: abs(v.state.position_ned_m[1] - 30.0) < 0.1)
    finally:
        sim.close()


@pytest.mark.parametrize("loiter_item", [True, False])
def test_hold_on_the_way_to_a_loiter_item_keeps_flying_to_it(loiter_item):
    """Loiter::set_loiter_position: when the current setpoint is a loiter setpoint (a
    LOITER_TIME item's, without a radius of its own: NAV_LOITER_RAD) within its loiter radius
    + NAV_ACC_RAD, Hold keeps it
    (setLoiterItemFromCurrentPositionSetpoint) rather than braking where the vehicle is; a
    waypoint's is a position setpoint and Hold brakes."""
    from tests.unit.test_vehicles_mission import item
    from vehicles.plan_types import MavCmd

    cmd = MavCmd.NAV_LOITER_TIME if loiter_item else MavCmd.NAV_WAYPOINT
    sim = Sim()
    try:
        v = sim.v
        sim.run(1.2)
        v.set_plan(sim.t, PlanType.MISSION, [
            item(0, MavCmd.NAV_WAYPOINT, 10.0, 0.0, 10.0, v.origin),
            item(1, cmd, 70.0, 0.0, 10.0, v.origin, p1=5.0)])
        assert v.start_mission(sim.t) is CommandResult.ACCEPTED
        assert sim.run(90.0, until=lambda: v.state.position_ned_m[0] > 35.0)
        n0, speed = float(v.state.position_ned_m[0]), float(v.state.velocity_ned_mps[0])
        assert v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
        sim.run(2.0)
        assert sim.run(30.0, until=lambda: math.hypot(*v.state.velocity_ned_mps) < 0.02)
        n = float(v.state.position_ned_m[0])
        if loiter_item:
            assert n == pytest.approx(70.0, abs=0.2)
        else:
            stop = n0 + speed * (speed / (2.0 * float(v.params["MPC_ACC_HOR"])) + 0.6)
            assert n == pytest.approx(stop, abs=0.3)
    finally:
        sim.close()


def test_hold_keeps_a_loiter_item_only_within_its_own_loiter_radius():
    """Loiter::set_loiter_position measures the vehicle against NAV_ACC_RAD plus the current
    setpoint's own loiter_radius: a LOITER_TIME item's param3 (mavlink_mission.cpp) when not
    about zero (mission_item_to_position_setpoint), not NAV_LOITER_RAD. 35 m short of an item
    with a 5 m radius the vehicle is not on it: Hold brakes."""
    import dataclasses

    from tests.unit.test_vehicles_mission import item
    from vehicles.plan_types import MavCmd

    sim = Sim()
    try:
        v = sim.v
        sim.run(1.2)
        loiter = dataclasses.replace(item(1, MavCmd.NAV_LOITER_TIME, 70.0, 0.0, 10.0, v.origin,
                                          p1=5.0), param3=5.0)
        v.set_plan(sim.t, PlanType.MISSION, [
            item(0, MavCmd.NAV_WAYPOINT, 10.0, 0.0, 10.0, v.origin), loiter])
        assert v.start_mission(sim.t) is CommandResult.ACCEPTED
        assert sim.run(90.0, until=lambda: v.state.position_ned_m[0] > 35.0)
        n0, speed = float(v.state.position_ned_m[0]), float(v.state.velocity_ned_mps[0])
        assert v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
        sim.run(2.0)
        assert sim.run(30.0, until=lambda: math.hypot(*v.state.velocity_ned_mps) < 0.02)
        stop = n0 + speed * (speed / (2.0 * float(v.params["MPC_ACC_HOR"])) + 0.6)
        assert float(v.state.position_ned_m[0]) == pytest.approx(stop, abs=0.3)
    finally:
        sim.close()


def test_return_heading_is_the_auto_tasks():
    """rtl_direct.cpp gives no heading on the way back: FlightTaskAuto's MPC_YAW_MODE does (2:
    away from home, so the vehicle returns backwards)."""
    sim = Sim()
    try:
        v = sim.v
        take_off(sim)
        goto_east(sim, v, 40.0)
        assert sim.run(40.0, until=lambda: abs(v.state.position_ned_m[1] - 40.0) < 0.1)
        v.params.set("MPC_YAW_MODE", 2)
        assert v.set_nav_state(sim.t, NavState.AUTO_RTL) is CommandResult.ACCEPTED
        assert sim.run(60.0, until=lambda: v.state.position_ned_m[1] < 20.0)
        assert v.state.velocity_ned_mps[1] < -1.0  # flying west, home-wards
        assert math.degrees(v.state.euler_rad()[2]) == pytest.approx(90.0, abs=5.0)  # facing east
    finally:
        sim.close()
