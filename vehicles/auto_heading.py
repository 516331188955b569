"""The auto task's heading when the navigator gives none: PX4 v1.15.2 FlightTaskAuto::
_set_heading_from_mode with MPC_YAW_MODE 0 (PX4's default: towards the waypoint) and
_compute_heading_from_2D_vector.

Rules and invariants:
- The heading points from the vehicle to the task's own target (AutoWaypoints' ``target``: the
  closest point of the track while off it, the previous waypoint while short of it), but only
  while that is farther than the target's acceptance radius; then the heading is locked.
- Locked and within the radius, the heading setpoint stays what it was (the last, slewed one);
  the first time without a farther target it is the vehicle's yaw.
- A target exactly south of the vehicle gives heading 0, as PX4's sign(0) · acos(-1) does.
- The lock lasts while the navigator gives headings of its own (PX4's FlightTaskAuto keeps it
  across the auto modes); a new auto task (``AutoHeading()``) starts unlocked.
- Not modelled: MPC_YAW_MODE 1–4 (towards or away from home, along the trajectory, yaw first);
  the navigator's modes compute their own headings where PX4's mission and return do theirs.
"""

from __future__ import annotations

import math

from vehicles.types import Vec3

_MIN_VECTOR_M = 1e-3  # _compute_heading_from_2D_vector: shorter vectors give no heading


def heading_from_vector(dn: float, de: float) -> float:
    """_compute_heading_from_2D_vector: the heading of (north, east), NaN when too short."""
    n = math.hypot(dn, de)
    if not (math.isfinite(n) and n > _MIN_VECTOR_M):
        return math.nan
    sign = (de > 0.0) - (de < 0.0)
    return sign * math.acos(max(-1.0, min(1.0, dn / n)))


class AutoHeading:
    def __init__(self) -> None:
        self.locked = False  # FlightTaskAuto's _yaw_lock

    def setpoint(self, position_ned_m: Vec3, target_ned_m: Vec3, acceptance_radius_m: float,
                 yaw_rad: float, last_setpoint_rad: float) -> float:
        """This tick's heading setpoint (before the MPC_YAWRAUTO_MAX slew) from the vehicle's
        position and yaw, the task's target and radius and the last heading setpoint."""
        dn = target_ned_m[0] - position_ned_m[0]
        de = target_ned_m[1] - position_ned_m[1]
        heading = last_setpoint_rad
        if not (math.isfinite(dn) and math.isfinite(de)):
            self.locked = False
            return math.nan
        if math.hypot(dn, de) > acceptance_radius_m:
            towards = heading_from_vector(dn, de)
            if not math.isnan(towards):
                heading = towards
                self.locked = True
        if not self.locked:
            heading = yaw_rad
            self.locked = True
        return heading
