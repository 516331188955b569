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
- Emergency braking (FlightTaskAuto::_checkEmergencyBraking, run by the auto task before each
  update): when the smoothing's velocity is more than 1.3 x MPC_XY_VEL_MAX horizontally or
  1.3 x MPC_Z_VEL_MAX_DN / MPC_Z_VEL_MAX_UP vertically, the velocity setpoint is forced to zero
  and the smoothing brakes at 1 g and 1 g/s on every axis until it has stopped; meanwhile the
  position controller's vertical speed limits are raised to the smoothing's vertical speed.
"""

from __future__ import annotations

import math

from vehicles.control.position_smoothing import PositionSmoothing
from vehicles.control.trajectory import TrajectoryLimits
from vehicles.control.velocity_smoothing import VMAX
from vehicles.params import ParamStore
from vehicles.types import GRAVITY_MPS2, Vec3

XY_ERR_MAX_M = 2.0  # PX4 MPC_XY_ERR_MAX default
# FlightTaskAuto::_checkEmergencyBraking: braking starts beyond this many times the maximum speeds
# and ends once the smoothing's speed is within this on every axis (m/s).
BRAKING_FACTOR = 1.3
BRAKING_STOPPED_MPS = 0.01


class AutoTrajectory:
    def __init__(self, params: ParamStore) -> None:
        self._params = params
        self.smoothing = PositionSmoothing()
        self.smoothing.max_allowed_horizontal_error = XY_ERR_MAX_M
        self._params_version = -1  # the parameters below are read at the first update
        self._jerk = self._traj_p = self._alt_rad = self._acc_rad = 0.0
        self._xy_vel_max = self._z_vel_max_dn = self._z_vel_max_up = 0.0
        self._z_v_auto_dn = self._z_v_auto_up = 0.0
        # What the smoothing's limits were last set from: (limits, going up, braking, parameter
        # version).
        self._set_up: tuple[TrajectoryLimits, bool, bool, int] | None = None
        # FlightTaskAuto's _is_emergency_braking_active (only the auto task checks it: the other
        # tasks that use the trajectory are no FlightTaskAuto in PX4)
        self.emergency_braking = False

    def _update_params(self) -> None:
        p = self._params
        self._params_version = p.version
        self._jerk = float(p["MPC_JERK_AUTO"])
        self._traj_p = float(p["MPC_XY_TRAJ_P"])
        self._alt_rad = float(p["NAV_MC_ALT_RAD"])
        self._acc_rad = float(p["NAV_ACC_RAD"])
        self._xy_vel_max = float(p["MPC_XY_VEL_MAX"])
        self._z_vel_max_dn = float(p["MPC_Z_VEL_MAX_DN"])
        self._z_vel_max_up = float(p["MPC_Z_VEL_MAX_UP"])
        self._z_v_auto_dn = float(p["MPC_Z_V_AUTO_DN"])
        self._z_v_auto_up = float(p["MPC_Z_V_AUTO_UP"])

    def reset(self, position_ned_m: Vec3, velocity_ned_mps: Vec3,
              acceleration_ned_mps2: Vec3 = (0.0, 0.0, 0.0)) -> None:
        """Restart the smoothing at this state (PositionSmoothing::reset)."""
        self.smoothing.reset(acceleration_ned_mps2, velocity_ned_mps, position_ned_m)

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

    def check_emergency_braking(self) -> bool:
        """FlightTaskAuto::_checkEmergencyBraking on the smoothing's present velocity (before
        this tick's update): starts when it is more than 1.3 x MPC_XY_VEL_MAX horizontally,
        1.3 x MPC_Z_VEL_MAX_DN down or 1.3 x MPC_Z_VEL_MAX_UP up; ends once the smoothing has
        stopped (|vz| < 0.01 and |vxy| <= 0.01 m/s). Returns whether it brakes."""
        if self._params.version != self._params_version:
            self._update_params()
        vx, vy, vz = self.smoothing.velocity
        vxy = math.hypot(vx, vy)
        if not self.emergency_braking:
            k = BRAKING_FACTOR
            self.emergency_braking = (vz > k * self._z_vel_max_dn or vz < -k * self._z_vel_max_up
                                      or vxy > k * self._xy_vel_max)
        elif -BRAKING_STOPPED_MPS < vz < BRAKING_STOPPED_MPS and not vxy > BRAKING_STOPPED_MPS:
            self.emergency_braking = False
        return self.emergency_braking

    def controller_speed_limits(self) -> tuple[float, float]:
        """The position controller's (up, down) speed constraints FlightTaskAuto publishes:
        FlightTask::_setDefaultConstraints' MPC_Z_VEL_MAX_UP / MPC_Z_VEL_MAX_DN, while braking
        raised to the smoothing's vertical speed so that its feed-forward is not cut, then at
        least 1.2 x MPC_Z_V_AUTO_UP / MPC_Z_V_AUTO_DN (_updateTrajConstraints)."""
        if self._params.version != self._params_version:
            self._update_params()
        up, down = self._z_vel_max_up, self._z_vel_max_dn
        if self.emergency_braking:
            vz = abs(self.smoothing.velocity[2])
            up, down = (up if up > vz else vz), (down if down > vz else vz)  # max(vz, ·)
        # max(up, ·), max(down, ·) as comparisons (the same values, NaN included): every tick
        min_up, min_down = 1.2 * self._z_v_auto_up, 1.2 * self._z_v_auto_dn
        return (min_up if min_up > up else up), (min_down if min_down > down else down)

    def set_up(self, lim: TrajectoryLimits) -> None:
        """The smoothing's limits for this tick (what ``update`` does first; the auto task's
        compiled tick, position_stage.py, calls it itself)."""
        p, s = self._params, self.smoothing
        if p.version != self._params_version:
            self._update_params()
        # FlightTaskAuto::_updateTrajConstraints: the vertical limits are the climb's while the
        # last unsmoothed velocity setpoint climbs (0 before the first: the descent's)
        going_up = s.out.item(4, 2) < 0.0
        braking = self.emergency_braking
        set_up = self._set_up
        if (set_up is None or lim is not set_up[0] or going_up != set_up[1]
                or braking != set_up[2] or self._params_version != set_up[3]):
            # New limits (the limits are shared frozen objects, nav_core.auto_limits): set up
            # the smoothing as FlightTaskAuto does; the same ones again leave it as it is.
            self._set_up = (lim, going_up, braking, self._params_version)
            acc_xy = lim.acc_xy_mps2
            if braking:
                # 1 g of acceleration on all axes and 1 g/s of jerk; the vertical speed limit
                # is left as it was (the velocity setpoint is zero meanwhile)
                s.set_max_jerk(GRAVITY_MPS2)
                s.set_max_acceleration((GRAVITY_MPS2, GRAVITY_MPS2, GRAVITY_MPS2))
                s.axes[:2, VMAX] = lim.speed_xy_mps
            else:
                s.set_max_jerk(self._jerk)
                s.set_max_acceleration((acc_xy, acc_xy, lim.acc_up_mps2 if going_up
                                        else lim.acc_down_mps2))
                s.set_max_velocity((lim.speed_xy_mps, lim.speed_xy_mps,
                                    lim.speed_up_mps if going_up else lim.speed_down_mps))
            s.cruise_speed = lim.speed_xy_mps
            s.horizontal_trajectory_gain = self._traj_p
            s.vertical_acceptance_radius = self._alt_rad

    def acceptance_radius(self, acceptance_radius_m: float) -> float:
        """The target's acceptance radius: the navigator's, NAV_ACC_RAD when not finite."""
        if self._params.version != self._params_version:
            self._update_params()
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
