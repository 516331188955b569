"""The auto task's own waypoints: PX4 v1.15's FlightTaskAuto::_evaluateTriplets (the waypoint
part), _getCurrentState and _updateInternalWaypoints. From the navigator's triplet and the
vehicle's position they make the (previous, target, next) the position smoothing flies.

Rules and invariants:
- The triplet is taken again only when its target moves by 1 mm or more on an axis, or its
  previous or next waypoint comes or goes (the navigator republishes an unchanged triplet every
  tick). Then a missing previous waypoint is the vehicle's position at that moment (not later
  ones) and a missing next one is the target.
- Every tick the vehicle is placed against the previous → target line, horizontally, with the
  target's acceptance radius: past the target (``TARGET_BEHIND``) the target is flown to
  straight from where the vehicle is; short of the previous waypoint by more than the radius
  (``PREVIOUS_INFRONT``) the previous waypoint is flown to first; more than the radius off the
  line (``OFFTRACK``) the closest point of the line (at the target's altitude) is flown to
  first, the target next. Otherwise (``NONE``; also when previous and target coincide) the
  triplet is flown as it is. The waypoints are rebuilt when the triplet was taken again, the
  state changed, or every tick while off the track.
- A NaN target altitude (a landing: vertical speed control) stays NaN, and an unchanged NaN is
  no change (PX4's land setpoint carries the ground's altitude there, which does not move).
- A new auto task (``AutoWaypoints()``) starts with all waypoints at zero, as PX4 constructs
  its task on a switch.
"""

from __future__ import annotations

import math

from vehicles.types import Vec3

_FLT_EPSILON = 1.1920929e-07
_UNIT_EPS = 1e-5  # matrix::Vector::unit_or_zero's default
_CHANGED_M = 0.001  # FlightTaskAuto::_evaluateTriplets: a target within 1 mm is unchanged

NONE, TARGET_BEHIND, PREVIOUS_INFRONT, OFFTRACK = range(4)  # FlightTaskAuto's State
_ZERO: Vec3 = (0.0, 0.0, 0.0)


def _moved(a: float, b: float) -> bool:
    if math.isnan(a) and math.isnan(b):
        return False
    return not abs(a - b) < _CHANGED_M


class AutoWaypoints:
    def __init__(self) -> None:
        self.triplet_target: Vec3 = _ZERO
        self.triplet_previous: Vec3 = _ZERO
        self.triplet_next: Vec3 = _ZERO
        self._prev_was_valid = self._next_was_valid = False
        self.acceptance_radius_m = 0.0
        self.state = NONE
        # The internal waypoints (_prev_wp, _target, _next_wp)
        self.previous: Vec3 = _ZERO
        self.target: Vec3 = _ZERO
        self.next: Vec3 = _ZERO

    def update(self, position_ned_m: Vec3, target_ned_m: Vec3, previous_ned_m: Vec3 | None,
               next_ned_m: Vec3 | None, acceptance_radius_m: float) -> tuple[Vec3, Vec3, Vec3]:
        """This tick's (previous, target, next) from the navigator's triplet (None: not valid)
        and the vehicle's position."""
        t, tt = target_ned_m, self.triplet_target
        has_prev, has_next = previous_ned_m is not None, next_ned_m is not None
        # (``_moved`` asked only past the 1 mm: within it an axis has not moved, NaN or not)
        update = ((not abs(tt[0] - t[0]) < _CHANGED_M and _moved(tt[0], t[0]))
                  or (not abs(tt[1] - t[1]) < _CHANGED_M and _moved(tt[1], t[1]))
                  or (not abs(tt[2] - t[2]) < _CHANGED_M and _moved(tt[2], t[2]))
                  or has_prev != self._prev_was_valid or has_next != self._next_was_valid)
        if update:
            x, y, _ = position_ned_m
            # a target without a horizontal position is the vehicle's (its altitude stays as it
            # is: NaN is vertical speed control)
            self.triplet_target = t if math.isfinite(t[0]) and math.isfinite(t[1]) \
                else (x, y, t[2])
            self.acceptance_radius_m = acceptance_radius_m
            self.triplet_previous = position_ned_m if previous_ned_m is None else previous_ned_m
            self.triplet_next = self.triplet_target if next_ned_m is None else next_ned_m
            self._prev_was_valid, self._next_was_valid = has_prev, has_next
        previous_state = self.state
        closest = self._current_state(position_ned_m)
        if update or self.state != previous_state or self.state == OFFTRACK:
            self._update_internal(position_ned_m, closest)
        return self.previous, self.target, self.next

    def _current_state(self, pos: Vec3) -> Vec3:
        """_getCurrentState: sets ``state``; returns the closest point of the track."""
        (tx, ty, tz), (px, py, _) = self.triplet_target, self.triplet_previous
        x, y = pos[0], pos[1]
        dx, dy = tx - px, ty - py
        n = math.hypot(dx, dy)
        ux, uy = (dx / n, dy / n) if n > _UNIT_EPS else (0.0, 0.0)
        along = (x - px) * ux + (y - py) * uy
        closest = (px + ux * along, py + uy * along, tz)
        rad = self.acceptance_radius_m
        if math.hypot(ux, uy) < _FLT_EPSILON:
            self.state = NONE  # previous and target coincide: no line to follow
        elif ux * (tx - x) + uy * (ty - y) < 0.0:
            self.state = TARGET_BEHIND
        elif along < 0.0 and math.hypot(x - px, y - py) > rad:
            self.state = PREVIOUS_INFRONT
        elif math.hypot(x - closest[0], y - closest[1]) > rad:
            self.state = OFFTRACK
        else:
            self.state = NONE
        return closest

    def _update_internal(self, pos: Vec3, closest: Vec3) -> None:
        """_updateInternalWaypoints."""
        s = self.state
        if s == TARGET_BEHIND:
            self.previous, self.target, self.next = pos, self.triplet_target, self.triplet_next
        elif s == PREVIOUS_INFRONT:
            self.previous, self.target, self.next = pos, self.triplet_previous, self.triplet_target
        elif s == OFFTRACK:
            self.previous, self.target, self.next = pos, closest, self.triplet_target
        else:
            self.previous, self.target, self.next = (self.triplet_previous, self.triplet_target,
                                                     self.triplet_next)
