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

An axis is one row of NCOL floats (the column constants below), so that PositionSmoothing runs
its three axes in one compiled call (position_smoothing.py): the ``vs_*`` functions are numba
``register_jitable`` — compiled into that call, plain Python when called from here.
``VelocitySmoothing`` is the object view of one row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba.extending import register_jitable

from vehicles.control.compiled import njit_cached

_EPS = 1.1920929e-07  # FLT_EPSILON

# Columns of an axis row: the state (jerk, acceleration, velocity, position), the state at the
# last update_durations (integration starts there), the limits, the velocity setpoint, the
# direction of the first jerk (-1, 0, 1), the phase durations and the time since update_durations.
J, A, V, X, IJ, IA, IV, IX, JMAX, AMAX, VMAX, VSP, DIR, T1, T2, T3, LT = range(17)
NCOL = 17
DEFAULT_LIMITS = {JMAX: 22.0, AMAX: 8.0, VMAX: 6.0}  # PX4's constructor defaults


@dataclass(slots=True)
class TrajectoryState:
    j: float = 0.0
    a: float = 0.0
    v: float = 0.0
    x: float = 0.0


def new_axes(n: int) -> np.ndarray:
    """``n`` axis rows at rest at 0 with PX4's default limits."""
    rows = np.zeros((n, NCOL))
    for col, value in DEFAULT_LIMITS.items():
        rows[:, col] = value
    return rows


@njit_cached
def reset_axes(rows: Any, accel: Any, vel: Any, pos: Any) -> None:
    """Every row's ``VelocitySmoothing.reset`` to its component of the 3-vectors ``accel``,
    ``vel``, ``pos``: one compiled call (the auto tasks reset every tick while the vehicle is not
    flying under the trajectory; numpy's write of a nested list costs twice as much)."""
    a0, a1, a2 = accel
    v0, v1, v2 = vel
    x0, x1, x2 = pos
    _reset_row(rows[0], a0, v0, x0)
    _reset_row(rows[1], a1, v1, x1)
    _reset_row(rows[2], a2, v2, x2)



def force_set_axes(rows: Any, position: Any, velocity: Any) -> None:
    """PositionSmoothing::forceSetPosition and forceSetVelocity on the rows of ``rows`` (x, y,
    z): each finite component of ``position`` is that axis's ``setCurrentPosition``, of
    ``velocity`` its ``setCurrentVelocity`` (the state and the initial state); NaN leaves the
    axis alone."""
    for i in range(3):
        if math.isfinite(position[i]):
            rows[i, X] = rows[i, IX] = position[i]
        if math.isfinite(velocity[i]):
            rows[i, V] = rows[i, IV] = velocity[i]


@register_jitable
def _reset_row(s: Any, accel: float, vel: float, pos: float) -> None:
    s[J] = s[IJ] = 0.0
    s[A] = s[IA] = accel
    s[V] = s[IV] = vel
    s[X] = s[IX] = pos


# --- the row functions (compiled into position_smoothing's kernel) ------------------------------
@register_jitable
def _sign(x: float) -> float:
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@register_jitable
def mn(a: float, b: float) -> float:
    """``min(a, b)`` as Python has it (a unless b is smaller: NaN-safe the same way)."""
    return b if b < a else a


@register_jitable
def mx(a: float, b: float) -> float:
    """``max(a, b)`` as Python has it."""
    return b if b > a else a


@register_jitable
def _poly(j: float, a0: float, v0: float, x0: float, t: float,
          d: float) -> tuple[float, float, float, float]:
    jt = d * j
    t2 = t * t
    return (jt, a0 + jt * t, v0 + a0 * t + 0.5 * jt * t2,
            x0 + v0 * t + 0.5 * a0 * t2 + jt * t2 * t / 6.0)


@register_jitable
def _saturate_t1_for_accel(a0: float, j_max: float, t1: float, a_max: float) -> float:
    accel_t1 = a0 + j_max * t1
    if accel_t1 > a_max:
        return (a_max - a0) / j_max
    if accel_t1 < -a_max:
        return (-a_max - a0) / j_max
    return t1


@register_jitable
def _compute_t1(a0: float, v3: float, j_max: float, a_max: float) -> float:
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
    return mx(_saturate_t1_for_accel(a0, j_max, t1, a_max), 0.0)


@register_jitable
def _compute_t1_given_total(t123: float, a0: float, v3: float, j_max: float,
                            a_max: float) -> float:
    a = -j_max
    b = j_max * t123 - a0
    delta = t123 * t123 * j_max * j_max + 2.0 * t123 * a0 * j_max - a0 * a0 - 4.0 * j_max * v3
    if delta < 0.0:
        return 0.0
    sq = math.sqrt(delta)
    inv = 1.0 / (2.0 * a)
    t1_plus, t1_minus = mx((-b + sq) * inv, 0.0), mx((-b - sq) * inv, 0.0)
    t3_plus, t3_minus = a0 / j_max + t1_plus, a0 / j_max + t1_minus
    t1 = 0.0
    if t1_plus >= 0.0 and t3_plus >= 0.0 and t1_plus + t3_plus <= t123:
        t1 = t1_plus
    elif t1_minus >= 0.0 and t3_minus >= 0.0 and t1_minus + t3_minus <= t123:
        t1 = t1_minus
    return _saturate_t1_for_accel(a0, j_max, t1, a_max)


@register_jitable
def _compute_t2(t1: float, t3: float, a0: float, v3: float, j_max: float) -> float:
    den = a0 + j_max * t1
    t2 = 0.0
    if abs(den) > _EPS:
        t2 = (-0.5 * t1 * t1 * j_max - t1 * t3 * j_max - t1 * a0 + 0.5 * t3 * t3 * j_max
              - t3 * a0 + v3) / den
    return mx(t2, 0.0)


@register_jitable
def vs_update_durations(s: Any, vel_setpoint: float) -> None:
    """A new velocity setpoint (clamped to +-max_vel): the time-optimal phase durations from
    the present state."""
    vsp = mn(mx(vel_setpoint, -s[VMAX]), s[VMAX])
    s[VSP] = vsp
    s[LT] = 0.0
    a, v = s[A], s[V]
    s[IJ], s[IA], s[IV], s[IX] = s[J], a, v, s[X]
    v_zero_acc = v  # the velocity once the acceleration is brought back to zero
    if abs(a) > _EPS:
        jz = -_sign(a) * s[JMAX]
        tz = -a / jz
        v_zero_acc = v + a * tz + 0.5 * jz * tz * tz
    direction = _sign(vsp - v_zero_acc)
    if direction == 0.0:
        direction = _sign(a)
    s[DIR] = direction
    j = direction * s[JMAX]
    dv = vsp - v
    if abs(j) > _EPS:
        t1 = _compute_t1(a, dv, j, s[AMAX])
        t3 = mx(a / j + t1, 0.0)
        s[T1], s[T2], s[T3] = t1, _compute_t2(t1, t3, a, dv, j), t3
    else:
        s[T1] = s[T2] = s[T3] = 0.0


@register_jitable
def vs_update_durations_given_total_time(s: Any, t123: float) -> None:
    j = s[DIR] * s[JMAX]
    a = s[A]
    dv = s[VSP] - s[V]
    if abs(j) > _EPS:
        t1 = _compute_t1_given_total(t123, a, dv, j, s[AMAX])
        t3 = mx(a / j + t1, 0.0)
        s[T1], s[T2], s[T3] = t1, mx(t123 - t1 - t3, 0.0), t3
    else:  # nothing to change: coast at constant velocity for the whole time (PX4's test)
        s[T1] = s[T3] = 0.0
        s[T2] = t123


@register_jitable
def vs_time_synchronization(rows: Any) -> None:
    """Stretch every row's trajectory to the longest one's total time."""
    longest, desired = 0, 0.0
    for i in range(len(rows)):
        total = rows[i][T1] + rows[i][T2] + rows[i][T3]
        if total > desired:
            longest, desired = i, total
    if desired > _EPS:
        for i in range(len(rows)):
            if i != longest and rows[i][T1] + rows[i][T2] + rows[i][T3] < desired:
                vs_update_durations_given_total_time(rows[i], desired)


@register_jitable
def vs_update_traj(s: Any, dt: float, time_stretch: float) -> None:
    s[LT] += dt * time_stretch
    rest = s[LT]
    t = mn(rest, s[T1])
    j, a, v, x = _poly(s[JMAX], s[IA], s[IV], s[IX], t, s[DIR])
    rest -= t
    if rest > 0.0:
        t = mn(rest, s[T2])
        j, a, v, x = _poly(0.0, a, v, x, t, 0.0)
        rest -= t
    if rest > 0.0:
        t = mn(rest, s[T3])
        j, a, v, x = _poly(s[JMAX], a, v, x, t, 0.0 - s[DIR])
        rest -= t
    if rest > 0.0:
        j, a, v, x = _poly(0.0, 0.0, v, x, rest, 0.0)
    s[J], s[A], s[V], s[X] = j, a, v, x


# --- the object view ----------------------------------------------------------------------------
def array_field(array: str, col: int) -> property:
    """A float attribute kept in column ``col`` of the instance's 1-D array ``array``."""
    def get(self: Any) -> float:
        return float(getattr(self, array)[col])

    def set_(self: Any, value: float) -> None:
        getattr(self, array)[col] = value

    return property(get, set_)


class VelocitySmoothing:
    """One axis; ``row`` (NCOL floats) is its whole state, its own or a row of PositionSmoothing's
    array."""

    max_jerk = array_field("row", JMAX)
    max_accel = array_field("row", AMAX)
    max_vel = array_field("row", VMAX)
    vel_sp = array_field("row", VSP)
    t1 = array_field("row", T1)
    t2 = array_field("row", T2)
    t3 = array_field("row", T3)

    def __init__(self, accel: float = 0.0, vel: float = 0.0, pos: float = 0.0,
                 row: np.ndarray | None = None) -> None:
        self.row = new_axes(1)[0] if row is None else row
        if row is None:
            self.reset(accel, vel, pos)

    @property
    def direction(self) -> int:
        return int(self.row[DIR])

    @property
    def state(self) -> TrajectoryState:
        j, a, v, x = self.row[:4].tolist()
        return TrajectoryState(j, a, v, x)

    def reset(self, accel: float, vel: float, pos: float) -> None:
        self.row[J:X + 1] = (0.0, accel, vel, pos)
        self.row[IJ:IX + 1] = (0.0, accel, vel, pos)

    def set_current_acceleration(self, accel: float) -> None:
        self.row[A] = self.row[IA] = accel

    def set_current_velocity(self, vel: float) -> None:
        self.row[V] = self.row[IV] = vel

    def set_current_position(self, pos: float) -> None:
        self.row[X] = self.row[IX] = pos

    @property
    def total_time(self) -> float:
        return self.t1 + self.t2 + self.t3

    def update_durations(self, vel_setpoint: float) -> None:
        vs_update_durations(self.row, vel_setpoint)

    def update_durations_given_total_time(self, t123: float) -> None:
        vs_update_durations_given_total_time(self.row, t123)

    @staticmethod
    def time_synchronization(trajectories: list[VelocitySmoothing]) -> None:
        """Stretch every trajectory to the longest one's total time."""
        vs_time_synchronization([t.row for t in trajectories])

    def update_traj(self, dt: float, time_stretch: float = 1.0) -> None:
        vs_update_traj(self.row, dt, time_stretch)
