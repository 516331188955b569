"""The auto task's heading when the navigator gives none and its slew: PX4 v1.15.2
FlightTaskAuto::_set_heading_from_mode (MPC_YAW_MODE), _compute_heading_from_2D_vector,
_generateHeadingAlongTraj and _limitYawRate.

Rules and invariants:
- The heading points from the vehicle to the task's own target (AutoWaypoints' ``target``: the
  closest point of the track while off it, the previous waypoint while short of it), but only
  while that is farther than the target's acceptance radius; then the heading is locked.
- Locked and within the radius, the heading setpoint stays what it was (the last, slewed one);
  the first time without a farther target it is the vehicle's yaw.
- A target exactly south of the vehicle gives heading 0, as PX4's sign(0) · acos(-1) does.
- The lock lasts while the navigator gives headings of its own (PX4's FlightTaskAuto keeps it
  across the auto modes); a new auto task (``AutoHeading()``) starts unlocked.
- MPC_YAW_MODE 0 and 4 point at the target, 1 at home, 2 away from home (without a home the
  vector is zero: the heading locks); 3 (or another value) gives none, and then the heading
  follows the smoothing's velocity setpoint (faster than 0.1 m/s, more than 2 m from the target:
  this tick's, the auto task asks after the smoothing as FlightTaskAuto::update does), else
  stays.
- MPC_YAW_MODE 4 holds the trajectory (zero velocity setpoint) while the last tick's slewed
  heading is more than MIS_YAW_ERR from its target or turning at the full rate.
"""

from __future__ import annotations

import math

from vehicles.cnum import wrap_remainder
from vehicles.types import Vec3

_MIN_VECTOR_M = 1e-3  # _compute_heading_from_2D_vector: shorter vectors give no heading


def heading_from_vector(dn: float, de: float) -> float:
    """_compute_heading_from_2D_vector: the heading of (north, east), NaN when too short."""
    n = math.hypot(dn, de)
    if not (math.isfinite(n) and n > _MIN_VECTOR_M):
        return math.nan
    sign = (de > 0.0) - (de < 0.0)
    return sign * math.acos(max(-1.0, min(1.0, dn / n)))


YAWSPEED_FILTER_TAU_S = 0.2  # _limitYawRate's _yawspeed_filter time constant
FLT_EPSILON = 1.1920929e-07
ALONG_TRAJECTORY_MIN_SPEED_MPS = 0.1  # _generateHeadingAlongTraj
ALONG_TRAJECTORY_MIN_DISTANCE_M = 2.0


class AutoHeading:
    def __init__(self) -> None:
        self.locked = False  # FlightTaskAuto's _yaw_lock
        self.aligned = True  # _yaw_sp_aligned, of the last tick
        self._yawspeed_ff = 0.0  # _yawspeed_filter's state

    @staticmethod
    def along_trajectory(mode: int) -> bool:
        """The mode gives no vector (3, or another value): the heading follows the trajectory's
        velocity setpoint (_set_heading_from_mode leaves it to _generateHeadingAlongTraj)."""
        return mode not in (0, 1, 2, 4)

    def setpoint(self, mode: int, position_ned_m: Vec3, target_ned_m: Vec3,
                 home_ned_m: Vec3 | None, acceptance_radius_m: float, yaw_rad: float,
                 last_setpoint_rad: float, velocity_sp_ned_mps: Vec3) -> float:
        """This tick's heading setpoint (before the MPC_YAWRAUTO_MAX slew) for MPC_YAW_MODE
        ``mode`` from the vehicle's position and yaw, the task's target and radius, home, the
        last heading setpoint and the smoothing's velocity setpoint."""
        x, y = position_ned_m[0], position_ned_m[1]
        if mode in (0, 4):
            dn, de = target_ned_m[0] - x, target_ned_m[1] - y
        elif mode in (1, 2):  # towards / away from home; (0, 0) without one
            dn = de = 0.0
            if home_ned_m is not None:
                dn, de = home_ned_m[0] - x, home_ned_m[1] - y
                if mode == 2:
                    dn, de = -dn, -de
        else:  # 3: along the trajectory (and any other value: no vector)
            dn = de = math.nan
        heading = last_setpoint_rad
        if not (math.isfinite(dn) and math.isfinite(de)):
            self.locked = False
            return self._along_trajectory(position_ned_m, target_ned_m, yaw_rad,
                                          last_setpoint_rad, velocity_sp_ned_mps)
        if math.hypot(dn, de) > acceptance_radius_m:
            towards = heading_from_vector(dn, de)
            if not math.isnan(towards):
                heading = towards
                self.locked = True
        if not self.locked:
            heading = yaw_rad
            self.locked = True
        return heading

    @staticmethod
    def _along_trajectory(position_ned_m: Vec3, target_ned_m: Vec3, yaw_rad: float,
                          last_setpoint_rad: float, velocity_sp_ned_mps: Vec3) -> float:
        """FlightTaskAuto::update without a heading: _generateHeadingAlongTraj (the velocity
        setpoint's direction, when faster than 0.1 m/s and farther than 2 m from the target),
        else the last heading setpoint (the vehicle's yaw without one)."""
        vn, ve = velocity_sp_ned_mps[0], velocity_sp_ned_mps[1]
        dn = target_ned_m[0] - position_ned_m[0]
        de = target_ned_m[1] - position_ned_m[1]
        if math.hypot(vn, ve) > ALONG_TRAJECTORY_MIN_SPEED_MPS \
                and math.hypot(dn, de) > ALONG_TRAJECTORY_MIN_DISTANCE_M:
            heading = heading_from_vector(vn, ve)
            if not math.isnan(heading):
                return heading
        return last_setpoint_rad if math.isfinite(last_setpoint_rad) else yaw_rad

    def limit(self, heading_rad: float, last_setpoint_rad: float, dt_s: float,
              rate_max_radps: float, yaw_err_rad: float) -> tuple[float, float]:
        """FlightTaskAuto::_limitYawRate: (the heading setpoint slewed from the last one at
        ``rate_max_radps``, the heading rate fed forward: the step's rate through a 0.2 s
        AlphaFilter, within the maximum). Sets ``aligned``: the slewed setpoint is within
        ``yaw_err_rad`` (MIS_YAW_ERR) of the heading and its rate is not saturated."""
        self.aligned = True
        if not (math.isfinite(heading_rad) and math.isfinite(last_setpoint_rad)):
            return (heading_rad if math.isfinite(heading_rad) else last_setpoint_rad), 0.0
        step = rate_max_radps * dt_s
        # a non-finite MPC_YAWRAUTO_MAX makes the step infinite and matrix::wrap_pi of it NaN
        # (the next tick starts from the yaw again)
        # (the clamps min(max(·, -step), step) as comparisons: the same values, NaN included)
        dyaw = math.remainder(heading_rad - last_setpoint_rad, math.tau)
        dyaw = -step if -step > dyaw else dyaw
        dyaw = step if step < dyaw else dyaw
        slewed = wrap_remainder(last_setpoint_rad + dyaw, math.tau)
        self.aligned = abs(math.remainder(heading_rad - slewed, math.tau)) < yaw_err_rad
        yawspeed = 0.0
        if dt_s > FLT_EPSILON:
            f = self._yawspeed_ff
            f += dt_s / (YAWSPEED_FILTER_TAU_S + dt_s) * (dyaw / dt_s - f)
            self._yawspeed_ff = f
            self.aligned = self.aligned and abs(f) < rate_max_radps
            yawspeed = -rate_max_radps if -rate_max_radps > f else f
            yawspeed = rate_max_radps if rate_max_radps < yawspeed else yawspeed
        return slewed, (yawspeed if math.isfinite(yawspeed) else 0.0)
