"""Pure library: PX4 v1.15's position smoothing (src/lib/motion_planning/PositionSmoothing, with
the speed planning of TrajectoryConstraints.hpp and TrajMath.hpp).

From the vehicle's position and three waypoints (previous, target, next) it plans an unsmoothed
velocity setpoint — towards the target, or, while turning, towards an L1 point on the previous →
target line, in one straight 3-D direction; horizontally at a speed the jerk and acceleration
limits allow so as to arrive at the speed the corner to the next waypoint permits (a circle
through the acceptance radius with centripetal acceleration MPC_XY_TRAJ_P × MPC_ACC_HOR, only
with the altitude reached and the next leg level; else a stop), vertically so as to stop at the
target's altitude — and smooths it per axis with VelocitySmoothing (jerk limited, the three axes
time-synchronized). Integration time is stretched while the vehicle lags horizontally behind the
trajectory (MPC_XY_ERR_MAX), on all three axes, so the setpoint does not run away from a vehicle
that cannot follow.

Written from PX4 v1.15's algorithm; its unit tests (PositionSmoothingTest.cpp) are reproduced in
tests/unit/test_control_position_smoothing.py. Vectors are NED tuples; time is an argument.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba.extending import register_jitable

from vehicles.control.compiled import njit_cached
from vehicles.control.velocity_smoothing import (
    AMAX,
    IA,
    IJ,
    IV,
    IX,
    JMAX,
    VMAX,
    A,
    J,
    V,
    VelocitySmoothing,
    X,
    array_field,
    force_set_axes,
    mn,
    mx,
    new_axes,
    reset_axes,
    vs_time_synchronization,
    vs_update_durations,
    vs_update_traj,
)
from vehicles.types import Vec3

_EPS = 1.1920929e-07  # FLT_EPSILON
_UNIT_EPS = 1e-5  # matrix::Vector::unit_or_zero's default
_NAN3: Vec3 = (math.nan, math.nan, math.nan)


# --- TrajMath.hpp -----------------------------------------------------------------------------
@register_jitable
def _min(a: float, b: float) -> float:
    """PX4's math::min: ``a < b ? a : b`` (a NaN ``a`` gives ``b``, a NaN ``b`` gives NaN)."""
    return a if a < b else b


@register_jitable
def _fmax(a: float, b: float) -> float:
    """C's fmaxf: the larger, a NaN argument ignored."""
    if math.isnan(a):
        return b
    return a if a > b or math.isnan(b) else b


@register_jitable
def max_speed_from_distance(jerk: float, accel: float, braking_distance: float,
                            final_speed: float) -> float:
    """computeMaxSpeedFromDistance: the speed from which the vehicle can still brake to
    ``final_speed`` within the distance (constant deceleration after a 2·accel/jerk delay),
    never below ``final_speed`` (the conservative ramp time does not slow it down further)."""
    b = 4.0 * accel * accel / jerk
    c = -2.0 * accel * braking_distance - final_speed * final_speed
    return _fmax(0.5 * (-b + math.sqrt(b * b - 4.0 * c)), final_speed)


@register_jitable
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


@register_jitable
def _sgn(x: float) -> float:
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@register_jitable
def _unit2(x: float, y: float) -> tuple[float, float]:
    n = math.hypot(x, y)
    return (x / n, y / n) if n > _UNIT_EPS else (0.0, 0.0)


@register_jitable
def _start_xy_speed(sx: float, sy: float, sz: float, tx: float, ty: float, tz: float,
                    nx: float, ny: float, nz: float, exit_speed: float, z_accept_rad: float,
                    xy_accept_rad: float, max_acc_xy: float, max_jerk: float,
                    max_speed_xy: float, radius_scale: float) -> float:
    """PX4 v1.15's computeStartXYSpeedFromWaypoints. A corner speed is planned only when the
    next waypoint is elsewhere, outside the acceptance radius, the altitude is reached (start
    within NAV_MC_ALT_RAD of the target's) and the next leg stays at it; otherwise the speed
    plans a stop at the target. A NaN altitude is neither reached nor kept (PX4's comparisons
    are false). The corner's angle is acosf of the unit vectors' dot product unclamped: past ±1
    it is NaN, which math::constrain passes on and math::min then drops."""
    d_next = math.hypot(tx - nx, ty - ny)
    target_next_different = d_next > 0.001
    waypoint_overlap = d_next < xy_accept_rad
    has_reached_altitude = abs(tz - sz) < z_accept_rad
    altitude_stays_same = abs(nz - tz) < z_accept_rad
    speed_at_target = 0.0
    if target_next_different and not waypoint_overlap and has_reached_altitude \
            and altitude_stays_same:
        ux, uy = _unit2(tx - sx, ty - sy)
        wx, wy = _unit2(tx - nx, ty - ny)
        cos_alpha = ux * wx + uy * wy
        alpha = math.acos(cos_alpha) if -1.0 <= cos_alpha <= 1.0 else math.nan
        safe_alpha = 0.0 if alpha < 0.0 else (math.pi - _EPS if alpha > math.pi - _EPS
                                              else alpha)
        turn = max_speed_in_waypoint(safe_alpha, radius_scale * max_acc_xy, xy_accept_rad)
        speed_at_target = _min(_min(turn, exit_speed), max_speed_xy)
    distance = math.hypot(sx - tx, sy - ty)
    return _min(max_speed_xy, max_speed_from_distance(max_jerk, max_acc_xy, distance,
                                                      speed_at_target))


def start_xy_speed(start: Vec3, target: Vec3, next_target: Vec3, exit_speed: float,
                   cfg: DynamicLimits) -> float:
    """computeStartXYSpeedFromWaypoints: the speed at ``start`` that reaches ``target`` at the
    speed the corner towards ``next_target`` allows."""
    return _start_xy_speed(*start, *target, *next_target, exit_speed, cfg.z_accept_rad,
                           cfg.xy_accept_rad, cfg.max_acc_xy, cfg.max_jerk, cfg.max_speed_xy,
                           cfg.max_acc_xy_radius_scale)


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


# --- the compiled step --------------------------------------------------------------------------
# ``cfg``: the planner's settings and memory. ``inp``: the vehicle's position, then the previous,
# target and next waypoints, then the feed-forward velocity (3 floats each).
HERR, VRAD, CRUISE, GAIN, TRAD, SPEED_PREV = range(6)
P_POS, P_PREV, P_TARGET, P_NEXT, P_FF = 0, 3, 6, 9, 12


@register_jitable
def _is_turning(traj, cfg, tx: float, ty: float) -> bool:
    vx, vy = traj[0, V], traj[1, V]
    ux, uy = _unit2(vx, vy)
    dx, dy = tx - traj[0, X], ty - traj[1, X]
    wx, wy = _unit2(dx, dy)
    return (math.hypot(vx, vy) > 0.2 and ux * wx + uy * wy < 0.98
            and math.hypot(dx, dy) > cfg[TRAD])


@register_jitable
def _max_xy_speed(traj, cfg, inp) -> float:
    """computeXYSpeedFromWaypoints over (here, target, next)."""
    tx, ty, tz = inp[P_TARGET], inp[P_TARGET + 1], inp[P_TARGET + 2]
    nx, ny, nz = inp[P_NEXT], inp[P_NEXT + 1], inp[P_NEXT + 2]
    acc, jerk, cruise, rad, gain = traj[0, AMAX], traj[0, JMAX], cfg[CRUISE], cfg[TRAD], cfg[GAIN]
    vrad = cfg[VRAD]
    speed = _start_xy_speed(tx, ty, tz, nx, ny, nz, nx, ny, nz, 0.0, vrad, rad, acc, jerk,
                            cruise, gain)
    return _start_xy_speed(traj[0, X], traj[1, X], traj[2, X], tx, ty, tz, nx, ny, nz, speed,
                           vrad, rad, acc, jerk, cruise, gain)


@register_jitable
def _max_z_speed(traj, inp) -> float:
    """_getMaxZSpeed (v1.15): braking to a stop at the target's altitude."""
    distance = abs(inp[P_TARGET + 2] - traj[2, X])
    return _min(traj[2, VMAX], max_speed_from_distance(traj[2, JMAX], traj[2, AMAX], distance,
                                                       0.0))


@register_jitable
def _l1_point(traj, cfg, inp) -> tuple[float, float, float]:
    p0, p1, p2 = traj[0, X], traj[1, X], traj[2, X]
    a0, a1, a2 = inp[P_PREV], inp[P_PREV + 1], inp[P_PREV + 2]
    d0, d1, d2 = inp[P_TARGET] - a0, inp[P_TARGET + 1] - a1, inp[P_TARGET + 2] - a2
    n = math.sqrt(d0 ** 2 + d1 ** 2 + d2 ** 2)
    u0, u1, u2 = (d0 / n, d1 / n, d2 / n) if n > _UNIT_EPS else (0.0, 0.0, 0.0)
    along = (p0 - a0) * u0 + (p1 - a1) * u1 + (p2 - a2) * u2
    c0, c1, c2 = a0 + u0 * along, a1 + u1 * along, a2 + u2 * along
    cross = math.sqrt((c0 - p0) ** 2 + (c1 - p1) ** 2 + (c2 - p2) ** 2)
    l1 = mx(cfg[TRAD], 5.0)
    ahead = math.sqrt(l1 * l1 - cross * cross) if l1 > cross else 0.0
    return (c0 + ahead * u0, c1 + ahead * u1, c2 + ahead * u2)


@register_jitable
def _added(out: float, v: float) -> float:
    return out + v if math.isfinite(out) else v


@register_jitable
def _clamp_to_norm(v0: float, v1: float, v2: float, norm: float, max_norm: float, z: bool
                   ) -> tuple[float, float, float]:
    """TrajectoryConstraints.hpp clampToXYNorm / clampToZNorm (accuracy 0.5): the whole vector
    scaled down to ``max_norm`` on its xy (``z`` False) or z norm ``norm``; when both are below
    0.5 only that part is scaled."""
    scale = max_norm / norm if norm > _EPS else 1.0
    if scale < 1.0:
        if max_norm < 0.5 and norm < 0.5:
            return (v0, v1, v2 * scale) if z else (v0 * scale, v1 * scale, v2)
        return v0 * scale, v1 * scale, v2 * scale
    return v0, v1, v2


@register_jitable
def _velocity_setpoint(traj, cfg, inp, single_waypoint: bool) -> tuple[float, float, float]:
    """The unsmoothed velocity setpoint (v1.15 _generateVelocitySetpoint): the feed-forward plus,
    with a 3-D target, one straight direction towards the crossing point at the xy and z speeds'
    combined norm, clamped to each; with an xy target only, the xy speed; with a z target only,
    the z speed."""
    tx, ty, tz = inp[P_TARGET], inp[P_TARGET + 1], inp[P_TARGET + 2]
    xy_valid = math.isfinite(tx) and math.isfinite(ty)
    z_valid = math.isfinite(tz)
    o0, o1, o2 = inp[P_FF], inp[P_FF + 1], inp[P_FF + 2]
    px, py, pz = traj[0, X], traj[1, X], traj[2, X]
    if xy_valid:
        cx, cy, cz = tx, ty, tz
        turning = _is_turning(traj, cfg, tx, ty)
        if not single_waypoint and turning:  # _getCrossingPoint
            cx, cy, cz = _l1_point(traj, cfg, inp)
        xy_speed = _max_xy_speed(traj, cfg, inp)
        if (not single_waypoint or not z_valid) and turning:
            xy_speed = _min(cfg[SPEED_PREV], xy_speed)  # hold the speed in a turn
        else:
            cfg[SPEED_PREV] = xy_speed
        if z_valid:
            z_speed = _max_z_speed(traj, inp)
            d0, d1, d2 = cx - px, cy - py, cz - pz
            n = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            speed = math.sqrt(xy_speed * xy_speed + z_speed * z_speed)
            v0, v1, v2 = ((d0 / n * speed, d1 / n * speed, d2 / n * speed) if n > _UNIT_EPS
                          else (0.0, 0.0, 0.0))
            v0, v1, v2 = _clamp_to_norm(v0, v1, v2, math.hypot(v0, v1), xy_speed, False)
            v0, v1, v2 = _clamp_to_norm(v0, v1, v2, abs(v2), z_speed, True)
            o0, o1, o2 = _added(o0, v0), _added(o1, v1), _added(o2, v2)
        else:
            ux, uy = _unit2(cx - px, cy - py)
            o0, o1 = _added(o0, ux * xy_speed), _added(o1, uy * xy_speed)
    elif z_valid:
        o2 = _added(o2, _sgn(tz - pz) * _max_z_speed(traj, inp))
    return (o0, o1, o2)


@njit_cached
def generate_step(traj, cfg, inp, dt_s, force_zero_velocity, single_waypoint, out
                  ):  # pragma: no cover - compiled
    """One generateSetpoints on ``traj`` (3 axis rows) and ``cfg``, both updated in place;
    ``out`` rows: jerk, acceleration, velocity, position, unsmoothed velocity."""
    if force_zero_velocity:
        vel_sp = (0.0, 0.0, 0.0)
    else:
        vel_sp = _velocity_setpoint(traj, cfg, inp, single_waypoint)
    out[4, 0], out[4, 1], out[4, 2] = vel_sp
    if not (math.isfinite(vel_sp[0]) and math.isfinite(vel_sp[1]) and math.isfinite(vel_sp[2])):
        out[:4, :] = math.nan
        return
    px, py = traj[0, X], traj[1, X]
    vx, vy = traj[0, V], traj[1, V]
    ex, ey = px - inp[P_POS], py - inp[P_POS + 1]
    # _generateTrajectory (v1.15): one time stretch, from the horizontal lag, for all 3 axes
    stretch = 1.0
    if cfg[HERR] > _EPS and ex * vx + ey * vy >= 0.0:  # behind the trajectory
        stretch = 1.0 - mn(mx(math.hypot(ex, ey) / cfg[HERR], 0.0), 1.0)
    for i in range(3):
        vs_update_traj(traj[i], dt_s, stretch)
    for i in range(3):
        out[0, i], out[1, i], out[2, i], out[3, i] = traj[i, J], traj[i, A], traj[i, V], traj[i, X]
        vs_update_durations(traj[i], vel_sp[i])
    vs_time_synchronization(traj)


@register_jitable
def _complete_auto_input(traj, cfg, inp, has_position, has_previous, has_next,
                         acceptance_radius, vz_cmd) -> bool:
    """``inp``'s rows whose ``has_*`` is False filled as ``generate_auto_step`` takes them, the
    acceptance radius set; True for vertical speed control (a NaN target z)."""
    hx, hy, hz = traj[0, X], traj[1, X], traj[2, X]
    cfg[TRAD] = acceptance_radius
    if not has_position:
        inp[P_POS], inp[P_POS + 1], inp[P_POS + 2] = hx, hy, hz
    if not has_previous:
        inp[P_PREV], inp[P_PREV + 1], inp[P_PREV + 2] = hx, hy, hz
    if not has_next:
        inp[P_NEXT], inp[P_NEXT + 1], inp[P_NEXT + 2] = (inp[P_TARGET], inp[P_TARGET + 1],
                                                         inp[P_TARGET + 2])
    vertical_speed = math.isnan(inp[P_TARGET + 2])
    if vertical_speed:
        inp[P_PREV + 2] = inp[P_NEXT + 2] = math.nan
        inp[P_FF + 2] = vz_cmd
    return vertical_speed


@njit_cached
def auto_unsmoothed_velocity(traj, cfg, inp, has_position, has_previous, has_next,
                             acceptance_radius, vz_cmd, out):  # pragma: no cover - compiled
    """The unsmoothed velocity setpoint ``generate_auto_step`` would plan now (the trajectory
    not advanced), also kept in ``out``'s row 4: what FlightTaskAuto's takeoff trigger judges."""
    _complete_auto_input(traj, cfg, inp, has_position, has_previous, has_next,
                         acceptance_radius, vz_cmd)
    vel_sp = _velocity_setpoint(traj, cfg, inp, False)
    out[4, 0], out[4, 1], out[4, 2] = vel_sp
    return vel_sp


@njit_cached
def generate_auto_step(traj, cfg, inp, dt_s, has_position, has_previous, has_next,
                       acceptance_radius, vz_cmd, current_z, out, force_zero):  # pragma: no cover - compiled
    """``generate_step`` with the waypoints as FlightTaskAuto hands them (``generate_auto``;
    ``force_zero``: its force_zero_velocity_setpoint): ``inp`` as ``generate_step`` takes it, the
    rows whose ``has_*`` is False to be filled here (position and previous waypoint: where the
    setpoint is; next: the target). A NaN target z is vertical speed control: the triplet's
    altitude is left out, ``vz_cmd`` is the vertical feed-forward and the setpoint's altitude
    then follows ``current_z``. Returns (position, velocity, acceleration); with nothing to plan
    the setpoint holds still where it was."""
    hx, hy, hz = traj[0, X], traj[1, X], traj[2, X]
    vertical_speed = _complete_auto_input(traj, cfg, inp, has_position, has_previous, has_next,
                                          acceptance_radius, vz_cmd)
    generate_step(traj, cfg, inp, dt_s, force_zero, False, out)
    px, py, pz = out[3, 0], out[3, 1], out[3, 2]
    if not (math.isfinite(px) and math.isfinite(py) and math.isfinite(pz)):
        for i, x in ((0, hx), (1, hy), (2, hz)):  # PositionSmoothing.reset at rest
            traj[i, J] = traj[i, A] = traj[i, V] = traj[i, IJ] = traj[i, IA] = traj[i, IV] = 0.0
            traj[i, X] = traj[i, IX] = x
        return (hx, hy, hz), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    if vertical_speed:
        traj[2, X] = traj[2, IX] = current_z
        pz = math.nan
    return (px, py, pz), (out[2, 0], out[2, 1], out[2, 2]), (out[1, 0], out[1, 1], out[1, 2])


class PositionSmoothing:
    max_allowed_horizontal_error = array_field("cfg", HERR)
    vertical_acceptance_radius = array_field("cfg", VRAD)
    cruise_speed = array_field("cfg", CRUISE)
    horizontal_trajectory_gain = array_field("cfg", GAIN)
    target_acceptance_radius = array_field("cfg", TRAD)

    def __init__(self) -> None:
        self.axes = new_axes(3)
        self.cfg = np.zeros(6)
        self.trajectory = [VelocitySmoothing(row=self.axes[i]) for i in range(3)]
        self.inp = np.zeros(15)  # the compiled step's input (P_POS …) and output rows
        self.out = np.zeros((5, 3))

    # --- configuration and state ----------------------------------------------------------------
    def set_max_jerk(self, jerk: float) -> None:
        self.axes[:, JMAX] = jerk

    def set_max_acceleration(self, acc: Vec3) -> None:
        self.axes[:, AMAX] = acc

    def set_max_velocity(self, vel: Vec3) -> None:
        self.axes[:, VMAX] = vel

    def reset(self, acceleration: Vec3, velocity: Vec3, position: Vec3) -> None:
        """Every axis's VelocitySmoothing.reset, in one write (the auto tasks reset every tick
        while the vehicle is not flying under the trajectory)."""
        reset_axes(self.axes, acceleration, velocity, position)

    def force_set(self, position: Vec3 = _NAN3, velocity: Vec3 = _NAN3) -> None:
        """PX4 forceSetPosition(position), forceSetVelocity(velocity): each finite component."""
        force_set_axes(self.axes, position, velocity)

    @property
    def position(self) -> Vec3:
        x, y, z = self.axes[:, X].tolist()
        return (x, y, z)

    @property
    def velocity(self) -> Vec3:
        x, y, z = self.axes[:, V].tolist()
        return (x, y, z)

    def position_velocity(self) -> tuple[Vec3, Vec3]:
        """(``position``, ``velocity``) in one read of the axes."""
        (vx, x), (vy, y), (vz, z) = self.axes[:, V:X + 1].tolist()
        return (x, y, z), (vx, vy, vz)

    # --- the step -------------------------------------------------------------------------------
    def generate(self, position: Vec3, waypoints: tuple[Vec3, Vec3, Vec3], feedforward: Vec3,
                 dt_s: float, force_zero_velocity: bool = False,
                 single_waypoint: bool = False) -> SmoothedSetpoints:
        """One update (generateSetpoints): ``waypoints`` = (previous, target, next); NaN target
        axes are velocity-controlled at ``feedforward``."""
        prev, target, nxt = waypoints
        self.inp[:] = (*position, *prev, *target, *nxt, *feedforward)
        generate_step(self.axes, self.cfg, self.inp, float(dt_s), bool(force_zero_velocity),
                      bool(single_waypoint), self.out)
        j, a, v, x, u = self.out.tolist()
        return SmoothedSetpoints((j[0], j[1], j[2]), (a[0], a[1], a[2]), (v[0], v[1], v[2]),
                                 (x[0], x[1], x[2]), (u[0], u[1], u[2]))

    def generate_auto(self, position: Vec3 | None, previous: Vec3 | None, target: Vec3,
                      next_: Vec3 | None, feedforward: Vec3 | None, dt_s: float,
                      acceptance_radius: float, vz_cmd: float = 0.0, current_z: float = 0.0
                      ) -> tuple[Vec3, Vec3, Vec3]:
        """One update as FlightTaskAuto runs it (``generate_auto_step``, one compiled call):
        None stands for the vehicle's position and the previous waypoint as where the setpoint
        is, for the next waypoint as the target (never the single-waypoint form: FlightTaskAuto
        always hands over three) and for no feed-forward; ``target_acceptance_radius`` is set to
        ``acceptance_radius``. Returns (position, velocity, acceleration)."""
        self.set_auto_input(position, previous, target, next_, feedforward)
        return generate_auto_step(self.axes, self.cfg, self.inp, float(dt_s),
                                  position is not None, previous is not None, next_ is not None,
                                  float(acceptance_radius), float(vz_cmd), float(current_z),
                                  self.out, False)

    def unsmoothed_velocity_auto(self, position: Vec3, previous: Vec3 | None, target: Vec3,
                                 next_: Vec3 | None, acceptance_radius: float,
                                 vz_cmd: float = 0.0) -> Vec3:
        """The unsmoothed velocity setpoint ``generate_auto`` would plan now, the trajectory
        not advanced (``auto_unsmoothed_velocity``; the last one, as ``generate``'s)."""
        self.set_auto_input(position, previous, target, next_, None)
        v0, v1, v2 = auto_unsmoothed_velocity(self.axes, self.cfg, self.inp, True,
                                              previous is not None, next_ is not None,
                                              float(acceptance_radius), float(vz_cmd),
                                              self.out)
        return (v0, v1, v2)

    def set_auto_input(self, position: Vec3 | None, previous: Vec3 | None, target: Vec3,
                       next_: Vec3 | None, feedforward: Vec3 | None) -> None:
        """``inp`` for ``generate_auto_step`` (None: a row it fills itself, or no feed-forward)."""
        n3 = _NAN3
        self.inp[:] = (*(n3 if position is None else position),
                       *(n3 if previous is None else previous), *target,
                       *(n3 if next_ is None else next_),
                       *(n3 if feedforward is None else feedforward))

def compile_now() -> None:
    """Compile ``generate_step`` (or load it from numba's cache) now, not in the first flight."""
    PositionSmoothing().generate((0.0,) * 3, ((0.0,) * 3,) * 3, (0.0,) * 3, 0.02)
    PositionSmoothing().generate_auto(None, None, (0.0,) * 3, None, None, 0.02, 0.0)
    PositionSmoothing().unsmoothed_velocity_auto((0.0,) * 3, None, (0.0,) * 3, None, 0.0)


def ideal_track(s: PositionSmoothing, waypoints: list[Vec3], acceptance_radius_m: float,
                dt_s: float, max_steps: int = 40000) -> list[tuple[Vec3, float]]:
    """``s`` tracked perfectly along ``waypoints`` (the first is where it starts, at rest), the
    target moving on once within ``acceptance_radius_m`` horizontally, as PX4's navigator
    moves on; the last is arrived at (next = target, as FlightTaskAuto hands it). Returns
    (position, horizontal speed) per step: PX4's own trajectory for that flight plan, the
    reference a flown track is held to."""
    s.reset((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), waypoints[0])
    i, pos, track = 1, waypoints[0], []
    for _ in range(max_steps):
        last = i + 1 >= len(waypoints)
        target = waypoints[i]
        out = s.generate(pos, (waypoints[i - 1], target, target if last else waypoints[i + 1]),
                         _NAN3, dt_s)
        pos = out.position
        track.append((pos, math.hypot(out.velocity[0], out.velocity[1])))
        if not last and math.hypot(pos[0] - target[0], pos[1] - target[1]) < acceptance_radius_m:
            i += 1
        elif last and math.dist(pos, target) < 1e-3:
            break
    return track
