"""Pure library: PX4's jerk-limited velocity smoothing (src/lib/motion_planning/VelocitySmoothing).

One axis. Given a velocity setpoint, the trajectory reaches it in at most three phases: jerk at
+-max for T1 (acceleration rises, capped at max acceleration), constant acceleration for T2, jerk
at -+max for T3 (acceleration back to zero) — the durations that minimise the total time
(``update_durations``). ``time_synchronization`` stretches the faster axes to the slowest one's
total time, so a 2-D or 3-D move stays on a straight line. ``update_traj`` integrates the
piecewise-cubic state (jerk, acceleration, velocity, position) over elapsed time, optionally
stretched (PositionSmoothing slows the trajectory when the vehicle lags behind it).

Written from PX4's algorithm; PX4's own unit test (VelocitySmoothingTest.cpp) is reproduced in
tests/unit/test_control_velocity_smoothing.py. Time is an argument; no clock, no physics. Float
arithmetic is double here where PX4 uses float: results agree to float precision.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

_EPS = 1.1920929e-07  # FLT_EPSILON


@dataclass(slots=True)
class TrajectoryState:
    j: float = 0.0
    a: float = 0.0
    v: float = 0.0
    x: float = 0.0


def _sign(x: float) -> int:
    return (x > 0.0) - (x < 0.0)


def _poly(j: float, a0: float, v0: float, x0: float, t: float, d: int) -> TrajectoryState:
    jt = d * j
    t2 = t * t
    return TrajectoryState(jt, a0 + jt * t, v0 + a0 * t + 0.5 * jt * t2,
                           x0 + v0 * t + 0.5 * a0 * t2 + jt * t2 * t / 6.0)


class VelocitySmoothing:
    def __init__(self, accel: float = 0.0, vel: float = 0.0, pos: float = 0.0) -> None:
        self.max_jerk = 22.0
        self.max_accel = 8.0
        self.max_vel = 6.0
        self.vel_sp = 0.0
        self.direction = 0
        self.t1 = self.t2 = self.t3 = 0.0
        self._local_time = 0.0
        self.state = TrajectoryState()
        self._init = TrajectoryState()
        self.reset(accel, vel, pos)

    # --- state ------------------------------------------------------------------------------
    def reset(self, accel: float, vel: float, pos: float) -> None:
        self.state = TrajectoryState(0.0, accel, vel, pos)
        self._init = TrajectoryState(0.0, accel, vel, pos)

    def set_current_acceleration(self, accel: float) -> None:
        self.state.a = self._init.a = accel

    def set_current_velocity(self, vel: float) -> None:
        self.state.v = self._init.v = vel

    def set_current_position(self, pos: float) -> None:
        self.state.x = self._init.x = pos

    @property
    def total_time(self) -> float:
        return self.t1 + self.t2 + self.t3

    # --- durations --------------------------------------------------------------------------
    @staticmethod
    def _saturate_t1_for_accel(a0: float, j_max: float, t1: float, a_max: float) -> float:
        accel_t1 = a0 + j_max * t1
        if accel_t1 > a_max:
            return (a_max - a0) / j_max
        if accel_t1 < -a_max:
            return (-a_max - a0) / j_max
        return t1

    def _compute_t1(self, a0: float, v3: float, j_max: float, a_max: float) -> float:
        delta = 2.0 * a0 * a0 + 4.0 * j_max * v3
        if delta < 0.0:
            return 0.0
        sq = math.sqrt(delta)
        t1_plus, t1_minus = (-a0 + 0.5 * sq) / j_max, (-a0 - 0.5 * sq) / j_max
        t3_plus, t3_minus = a0 / j_max + t1_plus, a0 / j_max + t1_minus
        t1 = 0.0
        if t1_plus >= 0.0 and t3_plus >= 0.0:
            t1 = t1_plus
        elif t1_minus >= 0.0 and t3_minus >= 0.0:
            t1 = t1_minus
        return max(self._saturate_t1_for_accel(a0, j_max, t1, a_max), 0.0)

    def _compute_t1_given_total(self, t123: float, a0: float, v3: float, j_max: float,
                                a_max: float) -> float:
        a = -j_max
        b = j_max * t123 - a0
        delta = t123 * t123 * j_max * j_max + 2.0 * t123 * a0 * j_max - a0 * a0 - 4.0 * j_max * v3
        if delta < 0.0:
            return 0.0
        sq = math.sqrt(delta)
        inv = 1.0 / (2.0 * a)
        t1_plus, t1_minus = max((-b + sq) * inv, 0.0), max((-b - sq) * inv, 0.0)
        t3_plus, t3_minus = a0 / j_max + t1_plus, a0 / j_max + t1_minus
        t1 = 0.0
        if t1_plus >= 0.0 and t3_plus >= 0.0 and t1_plus + t3_plus <= t123:
            t1 = t1_plus
        elif t1_minus >= 0.0 and t3_minus >= 0.0 and t1_minus + t3_minus <= t123:
            t1 = t1_minus
        return self._saturate_t1_for_accel(a0, j_max, t1, a_max)

    @staticmethod
    def _compute_t2(t1: float, t3: float, a0: float, v3: float, j_max: float) -> float:
        den = a0 + j_max * t1
        t2 = 0.0
        if abs(den) > _EPS:
            t2 = (-0.5 * t1 * t1 * j_max - t1 * t3 * j_max - t1 * a0 + 0.5 * t3 * t3 * j_max
                  - t3 * a0 + v3) / den
        return max(t2, 0.0)

    def _vel_at_zero_acc(self) -> float:
        s = self.state
        if abs(s.a) > _EPS:
            j = -_sign(s.a) * self.max_jerk
            t = -s.a / j
            return s.v + s.a * t + 0.5 * j * t * t
        return s.v

    def _compute_direction(self) -> int:
        direction = _sign(self.vel_sp - self._vel_at_zero_acc())
        return direction if direction != 0 else _sign(self.state.a)

    def update_durations(self, vel_setpoint: float) -> None:
        """A new velocity setpoint (clamped to +-max_vel): the time-optimal phase durations
        from the present state."""
        self.vel_sp = min(max(vel_setpoint, -self.max_vel), self.max_vel)
        self._local_time = 0.0
        s = self.state
        self._init = TrajectoryState(s.j, s.a, s.v, s.x)
        self.direction = self._compute_direction()
        j = self.direction * self.max_jerk
        dv = self.vel_sp - s.v
        if abs(j) > _EPS:
            self.t1 = self._compute_t1(s.a, dv, j, self.max_accel)
            self.t3 = max(s.a / j + self.t1, 0.0)
            self.t2 = self._compute_t2(self.t1, self.t3, s.a, dv, j)
        else:
            self.t1 = self.t2 = self.t3 = 0.0

    def update_durations_given_total_time(self, t123: float) -> None:
        j = self.direction * self.max_jerk
        s = self.state
        dv = self.vel_sp - s.v
        if abs(j) > _EPS:
            self.t1 = self._compute_t1_given_total(t123, s.a, dv, j, self.max_accel)
            self.t3 = max(s.a / j + self.t1, 0.0)
            self.t2 = max(t123 - self.t1 - self.t3, 0.0)
        else:  # nothing to change: coast at constant velocity for the whole time (PX4's test)
            self.t1 = self.t3 = 0.0
            self.t2 = t123

    @staticmethod
    def time_synchronization(trajectories: list[VelocitySmoothing]) -> None:
        """Stretch every trajectory to the longest one's total time."""
        longest, desired = 0, 0.0
        for i, t in enumerate(trajectories):
            if t.total_time > desired:
                longest, desired = i, t.total_time
        if desired > _EPS:
            for i, t in enumerate(trajectories):
                if i != longest and t.total_time < desired:
                    t.update_durations_given_total_time(desired)

    # --- integration ------------------------------------------------------------------------
    def update_traj(self, dt: float, time_stretch: float = 1.0) -> None:
        self._local_time += dt * time_stretch
        rest = self._local_time
        i = self._init
        t = min(rest, self.t1)
        s = _poly(self.max_jerk, i.a, i.v, i.x, t, self.direction)
        rest -= t
        if rest > 0.0:
            t = min(rest, self.t2)
            s = _poly(0.0, s.a, s.v, s.x, t, 0)
            rest -= t
        if rest > 0.0:
            t = min(rest, self.t3)
            s = _poly(self.max_jerk, s.a, s.v, s.x, t, -self.direction)
            rest -= t
        if rest > 0.0:
            s = _poly(0.0, 0.0, s.v, s.x, rest, 0)
        self.state = s
