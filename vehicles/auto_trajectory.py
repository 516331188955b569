"""The auto modes' setpoint generator: PX4's PositionSmoothing (position_smoothing.py) set up as
FlightTaskAuto sets it up (_updateTrajConstraints), behind the interface the flight tasks use.

- Horizontal: jerk MPC_JERK_AUTO, acceleration ``acc_xy`` (MPC_ACC_HOR), speed planned up to the
  cruise speed ``speed_xy`` (MPC_XY_CRUISE, or DO_CHANGE_SPEED's), corners from the acceptance
  radius and MPC_XY_TRAJ_P; the integration slows while the vehicle lags more than
  MPC_XY_ERR_MAX behind (PX4's default 2 m; the parameter is newer than this parameter table).
- Vertical: going up MPC_ACC_UP_MAX and ``speed_up`` (MPC_Z_V_AUTO_UP, MPC_TKO_SPEED during a
  takeoff), going down MPC_ACC_DOWN_MAX and ``speed_down``; NAV_MC_ALT_RAD is the vertical
  acceptance radius. A NaN target altitude is a vertical speed (``vz_cmd``, landing): the position
  setpoint's z is then NaN and the position controller flies the velocity.
- ``previous`` and ``next`` make the triplet PX4's navigator publishes: a fly-through waypoint
  with a next one is passed at the corner speed, inside the corner; without a next one the
  target is arrived at (next = target: still three waypoints, as FlightTaskAuto hands them).
"""

from __future__ import annotations

import math

from vehicles.control.position_smoothing import PositionSmoothing
from vehicles.control.trajectory import TrajectoryLimits
from vehicles.params import ParamStore
from vehicles.types import Vec3

XY_ERR_MAX_M = 2.0  # PX4 MPC_XY_ERR_MAX default


class AutoTrajectory:
    def __init__(self, params: ParamStore) -> None:
        self._params = params
        self.smoothing = PositionSmoothing()
        self.smoothing.max_allowed_horizontal_error = XY_ERR_MAX_M
        self._acc: Vec3 = (0.0, 0.0, 0.0)
        self._params_version = -1  # the parameters below are read at the first update
        self._jerk = self._traj_p = self._alt_rad = self._acc_rad = 0.0
        # What the smoothing's limits were last set from: (limits, going up, parameter version).
        self._set_up: tuple[TrajectoryLimits, bool, int] | None = None

    def _update_params(self) -> None:
        p = self._params
        self._params_version = p.version
        self._jerk = float(p["MPC_JERK_AUTO"])
        self._traj_p = float(p["MPC_XY_TRAJ_P"])
        self._alt_rad = float(p["NAV_MC_ALT_RAD"])
        self._acc_rad = float(p["NAV_ACC_RAD"])

    def reset(self, position_ned_m: Vec3, velocity_ned_mps: Vec3) -> None:
        self.smoothing.reset((0.0, 0.0, 0.0), velocity_ned_mps, position_ned_m)
        self._acc = (0.0, 0.0, 0.0)

    @property
    def position_ned_m(self) -> Vec3:
        return self.smoothing.position

    @property
    def velocity_ned_mps(self) -> Vec3:
        return self.smoothing.velocity

    def stopping_point(self, lim: TrajectoryLimits) -> Vec3:
        """Where the setpoint comes to rest if it brakes now (navigator calculate_breaking_stop:
        computeBrakingDistanceFromVelocity with MPC_JERK_AUTO, MPC_ACC_HOR and an acceleration
        delay of 0.6 x MPC_JERK_AUTO)."""
        (px, py, pz), (vx, vy, vz) = self.smoothing.position_velocity()
        speed = math.hypot(vx, vy)
        k = speed / (2.0 * lim.acc_xy_mps2) + 0.6  # braking distance / speed
        acc_z = lim.acc_down_mps2 if vz > 0.0 else lim.acc_up_mps2
        return (px + vx * k, py + vy * k, pz + vz * abs(vz) / (2.0 * acc_z))

    def set_up(self, lim: TrajectoryLimits) -> None:
        """The smoothing's limits for this tick (what ``update`` does first; the auto task's
        compiled tick, position_stage.py, calls it itself)."""
        p, s = self._params, self.smoothing
        if p.version != self._params_version:
            self._update_params()
        # FlightTaskAuto::_updateTrajConstraints: the vertical limits are the climb's while the
        # last unsmoothed velocity setpoint climbs (0 before the first: the descent's)
        going_up = s.out.item(4, 2) < 0.0
        set_up = self._set_up
        if (set_up is None or lim is not set_up[0] or going_up != set_up[1]
                or self._params_version != set_up[2]):
            # New limits (the limits are shared frozen objects, nav_core.auto_limits): set up
            # the smoothing as FlightTaskAuto does; the same ones again leave it as it is.
            self._set_up = (lim, going_up, self._params_version)
            acc_xy = lim.acc_xy_mps2
            s.set_max_jerk(self._jerk)
            s.set_max_acceleration((acc_xy, acc_xy, lim.acc_up_mps2 if going_up
                                    else lim.acc_down_mps2))
            s.set_max_velocity((lim.speed_xy_mps, lim.speed_xy_mps, lim.speed_up_mps if going_up
                                else lim.speed_down_mps))
            s.cruise_speed = lim.speed_xy_mps
            s.horizontal_trajectory_gain = self._traj_p
            s.vertical_acceptance_radius = self._alt_rad

    def acceptance_radius(self, acceptance_radius_m: float) -> float:
        """The target's acceptance radius: the navigator's, NAV_ACC_RAD when not finite."""
        return acceptance_radius_m if math.isfinite(acceptance_radius_m) else self._acc_rad

    def update(self, dt_s: float, target_ned_m: Vec3, lim: TrajectoryLimits,
               vz_cmd_mps: float = 0.0, current_z_m: float = 0.0,
               position_ned_m: Vec3 | None = None, previous_ned_m: Vec3 | None = None,
               next_ned_m: Vec3 | None = None, acceptance_radius_m: float = math.nan,
               feedforward_ned_mps: Vec3 | None = None) -> tuple[Vec3, Vec3, Vec3]:
        """Advance by ``dt_s``; returns (position, velocity, acceleration) setpoints.
        ``position_ned_m``: the vehicle's (for the lag stretch; the setpoint's own when None).
        ``feedforward_ned_mps``: the target's own velocity (a moving target: Follow Me)."""
        self.set_up(lim)
        # The triplet as FlightTaskAuto completes it: the setpoint's own position for a missing
        # vehicle position or previous waypoint, the target for a missing next one; with a NaN
        # target z only xy is planned and z follows the vehicle.
        return self.smoothing.generate_auto(position_ned_m, previous_ned_m, target_ned_m,
                                            next_ned_m, feedforward_ned_mps, dt_s,
                                            self.acceptance_radius(acceptance_radius_m),
                                            vz_cmd_mps, current_z_m)
