"""Orbit: circle a point (MAV_CMD_DO_ORBIT from MAVSDK ``do_orbit`` or QGC's "Orbit at
location"), after PX4 v1.15 ``flight_mode_manager/tasks/Orbit/FlightTaskOrbit.cpp`` and the
FlightModeManager that runs it.

Rules:
- Entering the mode (a new task, ``activate``) starts a 1 m circle at 1 m/s around the present
  position, nose to the centre, and an approach (``approaching``) from the last task's setpoint;
  a DO_ORBIT then sets radius (sign: + clockwise seen from above, − counter-clockwise), speed,
  yaw behaviour, centre and altitude, each only when given (NaN keeps the present value).
- A radius outside [RADIUS_MIN, MC_ORBIT_RAD_MAX] is refused ("Orbit radius limit exceeded"
  and its event; the command's other fields still apply): ``command`` returns False, and
  FlightModeManager then holds where the vehicle is (FlightTaskFailsafe's one setpoint) until a
  new DO_ORBIT or another mode. The mode switch itself was accepted.
- Speed within ±VELOCITY_MAX and the centripetal acceleration v²/r below ACCELERATION_MAX: the
  speed gives way (``sanitize``, each tick, as the sticks trim them).
- On the circle: within ACCEPTANCE_XY_M of the radius and NAV_MC_ALT_RAD of the centre's
  altitude. The approach (to the nearest point of the circle at cruise speed, nose to the
  centre; flown by the task through PX4's position smoothing) ends once on it, and starts
  again only with a DO_ORBIT that finds the vehicle off the circle: a vehicle that drifts or
  whose altitude the stick moves keeps circling with the radial correction.
- Circling: the tangential velocity plus a radial correction, the centripetal acceleration fed
  forward; the altitude from the throttle stick (FlightTaskManualAltitudeSmoothVel), which does
  not move the centre: ORBIT_EXECUTION_STATUS reports the position setpoint's altitude.
- Sticks are optional; when given, pitch trims the radius (MPC_XY_CRUISE m/s at full
  deflection) and roll the speed (MPC_ACC_HOR m/s²); nose along the tangent, roll the radius
  and pitch the speed, signed by the direction the orbit started in.
- Yaw (ORBIT_YAW_BEHAVIOUR): 0 nose to the centre (default), 1 the heading at the command,
  2 uncontrolled, 3 nose along the tangent, 4 from the yaw stick; slewed at MPC_YAWRAUTO_MAX
  (SlewRateYaw). Uncontrolled makes the slew's value NaN, and it stays NaN (the heading
  uncontrolled) for this task whatever behaviour a later DO_ORBIT asks, as in PX4.
- Pure: time and dt are arguments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vehicles.control.position_control import PositionSetpoint
from vehicles.events import ORBIT_RADIUS_EXCEEDED, Log
from vehicles.manual_control import ManualAltitude, Sticks, expo_deadzone
from vehicles.status_log import StatusLog
from vehicles.types import EstimatorReset, Vec3

# FlightTaskOrbit's constants
RADIUS_MIN = 1.0
VELOCITY_MAX = 10.0
ACCELERATION_MAX = 2.0
ACCEPTANCE_XY_M = 2.0  # _horizontal_acceptance_radius

YAW_FRONT_TO_CENTER = 0
YAW_HOLD_INITIAL_HEADING = 1
YAW_UNCONTROLLED = 2
YAW_FRONT_TANGENT = 3
YAW_RC_CONTROLLED = 4


@dataclass(frozen=True)
class OrbitStatus:
    """ORBIT_EXECUTION_STATUS: signed radius (m), centre (local NED north, east), altitude
    setpoint (local NED down; NaN while the altitude is velocity-controlled)."""

    radius_m: float
    center_ne_m: tuple[float, float]
    down_m: float


def sanitize(radius: float, velocity: float, radius_max: float) -> tuple[float, float]:
    """FlightTaskOrbit::_sanitizeParams: the radius clipped to [RADIUS_MIN, ``radius_max``]
    (MC_ORBIT_RAD_MAX), then the speed lowered, not the radius, until v²/r < 2 m/s²."""
    radius = min(max(radius, RADIUS_MIN), radius_max)
    velocity = min(max(velocity, -VELOCITY_MAX), VELOCITY_MAX)
    if velocity * velocity >= ACCELERATION_MAX * radius:
        velocity = math.copysign(math.sqrt(ACCELERATION_MAX * radius), velocity)
    return radius, velocity


class Orbit:
    def __init__(self, params, log: StatusLog | None = None) -> None:
        self.params = params
        self.log = log
        self._altitude = ManualAltitude(params)
        self.radius = RADIUS_MIN
        self.velocity = 1.0  # signed: + clockwise
        self.started_clockwise = True
        self.center: Vec3 = (0.0, 0.0, 0.0)
        self.yaw_behaviour = YAW_FRONT_TO_CENTER
        self._initial_heading = 0.0
        self._yaw_sp = math.nan
        self.approaching = False  # _in_circle_approach
        self.yawspeed = 0.0
        self.down_sp = math.nan  # the altitude setpoint last flown (status)

    def estimator_reset(self, pos: Vec3, vel: Vec3, r: EstimatorReset) -> None:
        """FlightTaskOrbit's handlers are FlightTaskManualAltitudeSmoothVel's: its altitude."""
        self._altitude.estimator_reset(pos, vel, r)

    def activate(self, pos: Vec3, vel: Vec3, yaw: float,
                 last: PositionSetpoint | None = None) -> None:
        """A new task (FlightModeManager::switchTask): FlightTaskOrbit::activate from the last
        task's setpoint ``last`` (None: PX4's empty one). The task resets its approach's
        smoothing from the same setpoint."""
        self._altitude.activate(pos, vel, yaw, last)
        self.radius, self.velocity = RADIUS_MIN, 1.0
        self.started_clockwise = True
        self.yaw_behaviour = YAW_FRONT_TO_CENTER
        self.center = pos
        self._initial_heading = yaw
        self._yaw_sp = yaw  # _slew_rate_yaw.setForcedValue(_yaw)
        self.approaching = True
        self.yawspeed = 0.0
        self.down_sp = pos[2]

    def command(self, now_s: float, pos: Vec3, yaw: float, radius: float, velocity: float,
                yaw_behaviour: float, center_ne: tuple[float, float] | None,
                center_down: float) -> bool:
        """applyCommandParameters: NaN (or None) keeps what is set. False: the radius is out
        of range (said once, the circle left as it was). ``approaching`` turns True when the
        vehicle is off the new circle and was not approaching: the task then restarts its
        smoothing from its setpoints."""
        success = True
        clockwise = self.velocity > 0.0
        new_radius, speed = self.radius, abs(self.velocity)
        if math.isfinite(radius):
            clockwise = radius > 0.0
            new_radius = abs(radius)
        if math.isfinite(velocity):
            speed = velocity
        radius_max = float(self.params["MC_ORBIT_RAD_MAX"])
        if RADIUS_MIN <= new_radius <= radius_max:
            self.started_clockwise = clockwise
            self.radius, self.velocity = sanitize(new_radius, speed if clockwise else -speed,
                                                  radius_max)
        else:
            success = False
            if self.log is not None:
                self.log.critical(now_s, "Orbit radius limit exceeded\t")
                self.log.event(now_s, ORBIT_RADIUS_EXCEEDED, Log.ALERT)
        if math.isfinite(yaw_behaviour):
            self.yaw_behaviour = int(yaw_behaviour)
        self._initial_heading = yaw
        n, e, d = self.center
        if center_ne is not None:
            n, e = center_ne
        if math.isfinite(center_down):
            d = center_down
        self.center = (n, e, d)
        if not self.on_circle(pos) and not self.approaching:
            self.approaching = True
        return success

    def on_circle(self, pos: Vec3) -> bool:
        dist = math.hypot(pos[0] - self.center[0], pos[1] - self.center[1])
        return (abs(dist - self.radius) < ACCEPTANCE_XY_M
                and abs(pos[2] - self.center[2]) < float(self.params["NAV_MC_ALT_RAD"]))

    def approach_target(self, pos: Vec3) -> Vec3:
        """The nearest point of the circle, at its altitude."""
        dn, de = self.center[0] - pos[0], self.center[1] - pos[1]
        dist = math.hypot(dn, de)
        k = (dist - self.radius) / dist if dist > 1e-6 else 0.0
        return (pos[0] + dn * k, pos[1] + de * k, self.center[2])

    def _trim(self, dt: float, sticks: Sticks) -> None:
        """_adjustParametersByStick, every tick: the sticks' expo'd deflection moves radius and
        speed, which are then sanitized."""
        p = self.params
        dz = float(p["MPC_HOLD_DZ"])
        e = float(p["MPC_XY_MAN_EXPO"])
        pitch = expo_deadzone(sticks.pitch, e, dz)
        roll = expo_deadzone(sticks.roll, e, dz)
        cruise, acc = float(p["MPC_XY_CRUISE"]), float(p["MPC_ACC_HOR"])
        radius, velocity = self.radius, self.velocity
        if self.yaw_behaviour == YAW_FRONT_TANGENT:
            sign = 1.0 if self.started_clockwise else -1.0
            radius -= sign * roll * dt * cruise
            velocity += sign * pitch * dt * acc
        else:
            radius -= pitch * dt * cruise
            velocity -= roll * dt * acc
        self.radius, self.velocity = sanitize(radius, velocity, float(p["MC_ORBIT_RAD_MAX"]))

    def update(self, dt: float, sticks: Sticks, pos: Vec3, vel: Vec3, yaw: float,
               vel_sp_feedback: Vec3, last: PositionSetpoint | None = None,
               home_z: float = math.nan) -> PositionSetpoint | None:
        """Setpoints on the circle, or None while approaching it (then fly ``approach_target``
        with nose to the centre: ``yaw_setpoint``). ``last``: the task's last setpoint (the
        approach's when it reaches the circle); ``home_z``: the home's altitude, if any."""
        self._trim(dt, sticks)
        if self.approaching and self.on_circle(pos):
            # FlightTaskOrbit::update: on reaching the circle the altitude's smoothing restarts
            # from the approach's last setpoint (``last``)
            self.approaching = False
            self._altitude.reset_smoothing(pos, vel, last)
        self.yawspeed = 0.0
        step = math.radians(float(self.params["MPC_YAWRAUTO_MAX"])) * dt
        dn, de = pos[0] - self.center[0], pos[1] - self.center[1]
        if self.approaching:
            self._slew(math.atan2(-de, -dn), step)
            return None
        # FlightTaskManualAltitudeSmoothVel::update, on the circle only
        alt = self._altitude.update(dt, sticks, pos, vel, yaw, vel_sp_feedback, home_z)
        dist = math.hypot(dn, de)
        un, ue = (dn / dist, de / dist) if dist > 1e-6 else (0.0, 0.0)
        v = self.velocity
        vn = -ue * v + (self.radius - dist) * un
        ve = un * v + (self.radius - dist) * ue
        a = v * v / self.radius
        behaviour = self.yaw_behaviour
        if behaviour == YAW_HOLD_INITIAL_HEADING:
            target_yaw = self._initial_heading
        elif behaviour == YAW_UNCONTROLLED:
            target_yaw = math.nan
        elif behaviour == YAW_FRONT_TANGENT:
            sign = 1.0 if self.started_clockwise else -1.0
            target_yaw = math.atan2(sign * dn, -sign * de)
            self.yawspeed = v / self.radius
        elif behaviour == YAW_RC_CONTROLLED:  # the altitude task's
            target_yaw = alt.yaw_rad
            self.yawspeed = self._altitude.yawspeed
        else:
            target_yaw = math.atan2(-de, -dn)
            self.yawspeed = v / self.radius
        self._slew(target_yaw, step)
        down = self.down_sp = alt.position_ned_m[2]
        return PositionSetpoint((math.nan, math.nan, down), (vn, ve, alt.velocity_ned_mps[2]),
                                self._yaw_sp, (-un * a, -ue * a, alt.acceleration_ned_mps2[2]))

    def _slew(self, target: float, step: float) -> None:
        """SlewRateYaw::update: a NaN target makes the value NaN, for good."""
        err = math.remainder(target - self._yaw_sp, math.tau)
        self._yaw_sp = math.remainder(self._yaw_sp + min(max(err, -step), step), math.tau)

    @property
    def yaw_setpoint(self) -> float:
        return self._yaw_sp

    def status(self) -> OrbitStatus:
        return OrbitStatus(math.copysign(self.radius, self.velocity),
                           (self.center[0], self.center[1]), self.down_sp)
