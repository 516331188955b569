"""Pure library: PX4's position smoothing (src/lib/motion_planning/PositionSmoothing, with the
speed planning of TrajectoryConstraints.hpp and TrajMath.hpp).

From the vehicle's position and three waypoints (previous, target, next) it plans an unsmoothed
velocity setpoint — towards the target, or, while turning, towards an L1 point on the previous →
target line; at a speed the jerk and acceleration limits allow so as to arrive at the speed the
corner to the next waypoint permits (a circle through the acceptance radius with centripetal
acceleration MPC_XY_TRAJ_P × MPC_ACC_HOR) — and smooths it per axis with VelocitySmoothing (jerk
limited, the three axes time-synchronized). Integration time is stretched while the vehicle lags
behind the trajectory (MPC_XY_ERR_MAX horizontally; vertically when a vertical error limit is
set), so the setpoint does not run away from a vehicle that cannot follow.

Written from PX4's algorithm; PX4's unit tests (PositionSmoothingTest.cpp) are reproduced in
tests/unit/test_control_position_smoothing.py. Vectors are NED tuples; time is an argument.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vehicles.control.velocity_smoothing import VelocitySmoothing
from vehicles.types import Vec3

_EPS = 1.1920929e-07  # FLT_EPSILON
_NAN3: Vec3 = (math.nan, math.nan, math.nan)


# --- TrajMath.hpp -----------------------------------------------------------------------------
def max_speed_from_distance(jerk: float, accel: float, braking_distance: float,
                            final_speed: float) -> float:
    """The speed from which the vehicle can still brake to ``final_speed`` within the distance
    (constant deceleration after a 2·accel/jerk delay)."""
    b = 4.0 * accel * accel / jerk
    c = -2.0 * accel * braking_distance - final_speed * final_speed
    return 0.5 * (-b + math.sqrt(b * b - 4.0 * c))


def max_speed_in_waypoint(alpha: float, accel: float, d: float) -> float:
    """The tangential speed on the circle tangent to two segments of length ``d`` that meet at
    angle ``alpha``, at centripetal acceleration ``accel``."""
    return math.sqrt(accel * d * math.tan(alpha / 2.0))


# --- TrajectoryConstraints.hpp ----------------------------------------------------------------
@dataclass(frozen=True)
class DynamicLimits:
    z_accept_rad: float
    xy_accept_rad: float
    max_acc_xy: float
    max_jerk: float
    max_speed_xy: float
    max_acc_xy_radius_scale: float


def _sgn(x: float) -> float:
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


def _unit2(x: float, y: float) -> tuple[float, float]:
    n = math.hypot(x, y)
    return (x / n, y / n) if n > _EPS else (0.0, 0.0)


def start_xy_speed(start: Vec3, target: Vec3, next_target: Vec3, exit_speed: float,
                   cfg: DynamicLimits) -> float:
    """computeStartXYSpeedFromWaypoints: the speed at ``start`` that reaches ``target`` at the
    speed the corner towards ``next_target`` allows."""
    d_next = math.hypot(target[0] - next_target[0], target[1] - next_target[1])
    speed_at_target = 0.0
    if d_next > 0.001 and not d_next < cfg.xy_accept_rad:
        u = _unit2(target[0] - start[0], target[1] - start[1])
        w = _unit2(target[0] - next_target[0], target[1] - next_target[1])
        alpha = math.acos(min(max(u[0] * w[0] + u[1] * w[1], -1.0), 1.0))
        alpha = min(max(alpha, 0.0), math.pi - _EPS)
        turn = max_speed_in_waypoint(alpha, cfg.max_acc_xy_radius_scale * cfg.max_acc_xy,
                                     cfg.xy_accept_rad)
        speed_at_target = min(turn, exit_speed, cfg.max_speed_xy)
    distance = math.hypot(start[0] - target[0], start[1] - target[1])
    return min(cfg.max_speed_xy, max_speed_from_distance(cfg.max_jerk, cfg.max_acc_xy, distance,
                                                         speed_at_target))


def xy_speed_from_waypoints(waypoints: list[Vec3], cfg: DynamicLimits) -> float:
    """computeXYSpeedFromWaypoints: backwards from the last waypoint."""
    n = len(waypoints)
    speed = 0.0
    for j in range(n - 1):
        i = n - 2 - j
        speed = start_xy_speed(waypoints[i], waypoints[i + 1], waypoints[min(i + 2, n - 1)],
                               speed, cfg)
    return speed


@dataclass(frozen=True)
class SmoothedSetpoints:
    jerk: Vec3
    acceleration: Vec3
    velocity: Vec3
    position: Vec3
    unsmoothed_velocity: Vec3


class PositionSmoothing:
    def __init__(self) -> None:
        self.trajectory = [VelocitySmoothing(), VelocitySmoothing(), VelocitySmoothing()]
        self.max_allowed_horizontal_error = 0.0
        self.max_allowed_vertical_error = 0.0
        self.vertical_acceptance_radius = 0.0
        self.cruise_speed = 0.0
        self.horizontal_trajectory_gain = 0.0
        self.target_acceptance_radius = 0.0
        self._max_speed_previous = 0.0

    # --- configuration and state ----------------------------------------------------------------
    def set_max_jerk(self, jerk: float) -> None:
        for t in self.trajectory:
            t.max_jerk = jerk

    def set_max_acceleration(self, acc: Vec3) -> None:
        for t, a in zip(self.trajectory, acc):
            t.max_accel = a

    def set_max_velocity(self, vel: Vec3) -> None:
        for t, v in zip(self.trajectory, vel):
            t.max_vel = v

    def reset(self, acceleration: Vec3, velocity: Vec3, position: Vec3) -> None:
        for t, a, v, x in zip(self.trajectory, acceleration, velocity, position):
            t.reset(a, v, x)

    def _pos(self) -> Vec3:
        t = self.trajectory
        return (t[0].state.x, t[1].state.x, t[2].state.x)

    def _vel(self) -> Vec3:
        t = self.trajectory
        return (t[0].state.v, t[1].state.v, t[2].state.v)

    # --- planning -------------------------------------------------------------------------------
    def _is_turning(self, target: Vec3) -> bool:
        px, py, _ = self._pos()
        vx, vy, _ = self._vel()
        ux, uy = _unit2(vx, vy)
        dx, dy = target[0] - px, target[1] - py
        wx, wy = _unit2(dx, dy)
        return (math.hypot(vx, vy) > 0.2 and ux * wx + uy * wy < 0.98
                and math.hypot(dx, dy) > self.target_acceptance_radius)

    def _max_xy_speed(self, waypoints: tuple[Vec3, Vec3, Vec3]) -> float:
        t = self.trajectory
        cfg = DynamicLimits(self.vertical_acceptance_radius, self.target_acceptance_radius,
                            t[0].max_accel, t[0].max_jerk, self.cruise_speed,
                            self.horizontal_trajectory_gain)
        return xy_speed_from_waypoints([self._pos(), waypoints[1], waypoints[2]], cfg)

    def _max_z_speed(self, waypoints: tuple[Vec3, Vec3, Vec3]) -> float:
        start = self._pos()
        target, nxt = waypoints[1], waypoints[2]
        tz = self.trajectory[2]
        arrival = 0.0
        if abs(target[2] - nxt[2]) > 0.001:
            s = (math.hypot(start[0], start[1]), start[2])
            g = (math.hypot(target[0], target[1]), target[2])
            n = (math.hypot(nxt[0], nxt[1]), nxt[2])
            u = _unit2(g[0] - s[0], g[1] - s[1])
            w = _unit2(g[0] - n[0], g[1] - n[1])
            alpha = math.acos(min(max(u[0] * w[0] + u[1] * w[1], -1.0), 1.0))
            alpha = min(max(alpha, 0.0), math.pi - _EPS)
            arrival = min(max_speed_in_waypoint(alpha, tz.max_accel,
                                                self.vertical_acceptance_radius), tz.max_vel)
        distance = abs(target[2] - start[2])
        return min(tz.max_vel, max_speed_from_distance(tz.max_jerk, tz.max_accel, distance,
                                                        arrival))

    def _l1_point(self, waypoints: tuple[Vec3, Vec3, Vec3]) -> Vec3:
        p = self._pos()
        a, b = waypoints[0], waypoints[1]
        d = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
        n = math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
        u = (d[0] / n, d[1] / n, d[2] / n) if n > _EPS else (0.0, 0.0, 0.0)
        along = sum((p[i] - a[i]) * u[i] for i in range(3))
        closest = (a[0] + u[0] * along, a[1] + u[1] * along, a[2] + u[2] * along)
        cross = math.dist(closest, p)
        l1 = max(self.target_acceptance_radius, 5.0)
        ahead = math.sqrt(l1 * l1 - cross * cross) if l1 > cross else 0.0
        return (closest[0] + ahead * u[0], closest[1] + ahead * u[1], closest[2] + ahead * u[2])

    def _crossing_point(self, waypoints: tuple[Vec3, Vec3, Vec3]) -> Vec3:
        target = waypoints[1]
        return self._l1_point(waypoints) if self._is_turning(target) else target

    def velocity_setpoint(self, waypoints: tuple[Vec3, Vec3, Vec3], feedforward: Vec3,
                          single_waypoint: bool = False) -> Vec3:
        """The unsmoothed velocity setpoint (_generateVelocitySetpoint)."""
        target = waypoints[1]
        xy_valid = math.isfinite(target[0]) and math.isfinite(target[1])
        z_valid = math.isfinite(target[2])
        out = list(feedforward)
        pos = self._pos()

        def add(i: int, v: float) -> None:
            out[i] = out[i] + v if math.isfinite(out[i]) else v

        if xy_valid:
            crossing = target if single_waypoint else self._crossing_point(waypoints)
            xy_speed = self._max_xy_speed(waypoints)
            if (not single_waypoint or not z_valid) and self._is_turning(target):
                xy_speed = min(self._max_speed_previous, xy_speed)  # hold the speed in a turn
            else:
                self._max_speed_previous = xy_speed
            ux, uy = _unit2(crossing[0] - pos[0], crossing[1] - pos[1])
            add(0, ux * xy_speed)
            add(1, uy * xy_speed)
            if z_valid:
                dz = crossing[2] - pos[2]
                add(2, _sgn(dz) * self._max_z_speed(waypoints))
        elif z_valid:
            dz = target[2] - pos[2]
            add(2, _sgn(dz) * self._max_z_speed(waypoints))
        return (out[0], out[1], out[2])

    # --- the step -------------------------------------------------------------------------------
    def generate(self, position: Vec3, waypoints: tuple[Vec3, Vec3, Vec3], feedforward: Vec3,
                 dt_s: float, force_zero_velocity: bool = False,
                 single_waypoint: bool = False) -> SmoothedSetpoints:
        """One update (generateSetpoints): ``waypoints`` = (previous, target, next); NaN target
        axes are velocity-controlled at ``feedforward``."""
        vel_sp: Vec3 = (0.0, 0.0, 0.0) if force_zero_velocity else self.velocity_setpoint(
            waypoints, feedforward, single_waypoint)
        t = self.trajectory
        if not all(math.isfinite(v) for v in vel_sp):
            return SmoothedSetpoints(_NAN3, _NAN3, _NAN3, _NAN3, vel_sp)
        px, py, pz = self._pos()
        vx, vy, vz = self._vel()
        ex, ey = px - position[0], py - position[1]
        stretch_xy = 1.0
        behind = ex * vx + ey * vy >= 0.0
        if self.max_allowed_horizontal_error > _EPS and behind:
            stretch_xy = 1.0 - min(max(math.hypot(ex, ey) / self.max_allowed_horizontal_error,
                                       0.0), 1.0)
        stretch_z = 1.0
        ez = pz - position[2]
        if self.max_allowed_vertical_error > _EPS and ez * vz >= 0.0:
            stretch_z = 1.0 - min(max(abs(ez) / self.max_allowed_vertical_error, 0.0), 1.0)
        for traj, stretch in zip(t, (stretch_xy, stretch_xy, stretch_z)):
            traj.update_traj(dt_s, stretch)
        out = SmoothedSetpoints(
            (t[0].state.j, t[1].state.j, t[2].state.j), (t[0].state.a, t[1].state.a, t[2].state.a),
            (t[0].state.v, t[1].state.v, t[2].state.v), (t[0].state.x, t[1].state.x, t[2].state.x),
            vel_sp)
        for traj, v in zip(t, vel_sp):
            traj.update_durations(v)
        VelocitySmoothing.time_synchronization(t)
        return out


def ideal_track(s: PositionSmoothing, waypoints: list[Vec3], acceptance_radius_m: float,
                dt_s: float, max_steps: int = 40000) -> list[tuple[Vec3, float]]:
    """``s`` tracked perfectly along ``waypoints`` (the first is where it starts, at rest), the
    target moving on once within ``acceptance_radius_m`` horizontally, as PX4's navigator
    moves on; the last is a single waypoint, arrived at. Returns (position, horizontal speed) per
    step: PX4's own trajectory for that flight plan, the reference a flown track is held to."""
    s.reset((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), waypoints[0])
    i, pos, track = 1, waypoints[0], []
    for _ in range(max_steps):
        last = i + 1 >= len(waypoints)
        target = waypoints[i]
        out = s.generate(pos, (waypoints[i - 1], target, target if last else waypoints[i + 1]),
                         _NAN3, dt_s, single_waypoint=last)
        pos = out.position
        track.append((pos, math.hypot(out.velocity[0], out.velocity[1])))
        if not last and math.hypot(pos[0] - target[0], pos[1] - target[1]) < acceptance_radius_m:
            i += 1
        elif last and math.dist(pos, target) < 1e-3:
            break
    return track
