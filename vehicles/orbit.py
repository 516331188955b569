"""Orbit: circle a point (MAV_CMD_DO_ORBIT from MAVSDK ``do_orbit`` or QGC's "Orbit at
location"), after PX4 ``flight_mode_manager/tasks/Orbit/FlightTaskOrbit.cpp``.

Rules:
- Entering the mode starts a 1 m circle at 1 m/s around the present position; a DO_ORBIT then
  sets radius (sign: + clockwise seen from above, − counter-clockwise), tangential speed, yaw
  behaviour, centre and altitude, each only when given (NaN keeps the present value).
- Radius within [RADIUS_MIN, RADIUS_MAX], speed within ±VELOCITY_MAX and the centripetal
  acceleration v²/r below ACCELERATION_MAX: the speed gives way first (PX4's constants).
- Off the circle (more than 1 m from it, or more than NAV_MC_ALT_RAD from its altitude) the
  vehicle first flies to the nearest point of the circle at cruise speed, nose to the centre
  (``approach_target``, smoothed by auto_trajectory.py); on the circle it flies
  the tangential velocity plus a radial correction, with the centripetal acceleration fed
  forward.
- Yaw (ORBIT_YAW_BEHAVIOUR): 0 nose to the centre (default), 1 the heading at the command,
  2 uncontrolled, 3 nose along the tangent, 4 from the yaw stick; slewed at MPC_YAWRAUTO_MAX.
- The altitude follows the throttle stick when there is one (FlightTaskManualAltitude); the
  pitch stick trims the radius (RADIUS_MAX / 8 per second at full deflection) and the roll
  stick the speed (VELOCITY_MAX / 4 per second); sticks are optional in this mode.
- Pure: time and dt are arguments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vehicles.control.position_control import PositionSetpoint
from vehicles.manual_control import ManualAltitude, Sticks, expo_deadzone
from vehicles.types import Vec3

RADIUS_MIN = 1.0
RADIUS_MAX = 100.0
VELOCITY_MAX = 10.0
ACCELERATION_MAX = 2.0
ACCEPTANCE_XY_M = 1.0

YAW_FRONT_TO_CENTER = 0
YAW_HOLD_INITIAL_HEADING = 1
YAW_UNCONTROLLED = 2
YAW_FRONT_TANGENT = 3
YAW_RC_CONTROLLED = 4


@dataclass(frozen=True)
class OrbitStatus:
    """ORBIT_EXECUTION_STATUS: signed radius (m), centre (local NED north, east), altitude
    setpoint (local NED down)."""

    radius_m: float
    center_ne_m: tuple[float, float]
    down_m: float


def sanitize(radius: float, velocity: float) -> tuple[float, float]:
    radius = min(max(radius, RADIUS_MIN), RADIUS_MAX)
    velocity = min(max(velocity, -VELOCITY_MAX), VELOCITY_MAX)
    if velocity * velocity >= ACCELERATION_MAX * radius:
        velocity = math.copysign(math.sqrt(ACCELERATION_MAX * radius), velocity)
    return radius, velocity


class Orbit:
    def __init__(self, params) -> None:
        self.params = params
        self._altitude = ManualAltitude(params)
        self.radius = RADIUS_MIN
        self.velocity = 1.0  # signed: + clockwise
        self.center: Vec3 = (0.0, 0.0, 0.0)
        self.yaw_behaviour = YAW_FRONT_TO_CENTER
        self._initial_heading = 0.0
        self._yaw_sp = math.nan
        self.approaching = False
        self.yawspeed = 0.0

    def activate(self, pos: Vec3, vel: Vec3, yaw: float) -> None:
        self._altitude.activate(pos, vel, yaw)
        self.radius, self.velocity = sanitize(RADIUS_MIN, 1.0)
        self.center = pos
        self._initial_heading = yaw
        self._yaw_sp = yaw
        self.approaching = False
        self.yawspeed = 0.0

    def command(self, pos: Vec3, yaw: float, radius: float, velocity: float, yaw_behaviour: float,
                center_ne: tuple[float, float] | None, center_down: float) -> None:
        """applyCommandParameters: NaN (or None) keeps what is set."""
        clockwise = self.velocity > 0.0
        new_radius, speed = self.radius, abs(self.velocity)
        if math.isfinite(radius):
            clockwise = radius > 0.0
            new_radius = abs(radius)
        if math.isfinite(velocity):
            speed = velocity
        self.radius, self.velocity = sanitize(new_radius, speed if clockwise else -speed)
        if math.isfinite(yaw_behaviour):
            self.yaw_behaviour = int(yaw_behaviour)
        self._initial_heading = yaw
        n, e, d = self.center
        if center_ne is not None:
            n, e = center_ne
        if math.isfinite(center_down):
            d = center_down
        self.center = (n, e, d)
        self.approaching = not self.on_circle(pos)

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

    def update(self, dt: float, sticks: Sticks, pos: Vec3, vel: Vec3, yaw: float,
               vel_sp_feedback: Vec3, last: PositionSetpoint | None = None,
               home_z: float = math.nan) -> PositionSetpoint | None:
        """Setpoints on the circle, or None while approaching it (then fly ``approach_target``
        with nose to the centre: ``yaw_setpoint``). ``last``: the task's last setpoint (the
        approach's when it reaches the circle); ``home_z``: the home's altitude, if any."""
        p = self.params
        # Sticks trim the circle: pitch the radius, roll the speed (FlightTaskOrbit::update).
        dz = float(p["MPC_HOLD_DZ"])
        e = float(p["MPC_XY_MAN_EXPO"])
        trim_r = expo_deadzone(sticks.pitch, e, dz)
        trim_v = expo_deadzone(sticks.roll, e, dz)
        if trim_r or trim_v:
            self.radius, self.velocity = sanitize(
                self.radius - trim_r * dt * (RADIUS_MAX / 8.0),
                self.velocity - trim_v * dt * (VELOCITY_MAX / 4.0))
        dn, de = pos[0] - self.center[0], pos[1] - self.center[1]
        if self.on_circle(pos):
            if self.approaching:
                # FlightTaskOrbit::update: on reaching the circle the altitude's smoothing
                # restarts from the approach's last setpoint (``last``)
                self._altitude.reset_smoothing(pos, vel, last)
            self.approaching = False
        elif not self.approaching:
            self.approaching = True
        self.yawspeed = 0.0
        step = math.radians(float(p["MPC_YAWRAUTO_MAX"])) * dt
        if self.approaching:
            self._slew(math.atan2(-de, -dn), step, yaw)
            return None
        # FlightTaskManualAltitudeSmoothVel::update, on the circle only
        alt = self._altitude.update(dt, sticks, pos, vel, yaw, vel_sp_feedback, home_z)
        dist = math.hypot(dn, de)
        un, ue = (dn / dist, de / dist) if dist > 1e-6 else (0.0, 0.0)
        v = self.velocity
        vn = -ue * v + (self.radius - dist) * un
        ve = un * v + (self.radius - dist) * ue
        a = v * v / self.radius
        target_yaw = math.nan
        if self.yaw_behaviour == YAW_HOLD_INITIAL_HEADING:
            target_yaw = self._initial_heading
        elif self.yaw_behaviour == YAW_FRONT_TANGENT:
            target_yaw = math.atan2(math.copysign(1.0, v) * dn, -math.copysign(1.0, v) * de)
            self.yawspeed = v / self.radius
        elif self.yaw_behaviour == YAW_RC_CONTROLLED:
            target_yaw = alt.yaw_rad
            self.yawspeed = self._altitude.yawspeed
        elif self.yaw_behaviour != YAW_UNCONTROLLED:
            target_yaw = math.atan2(-de, -dn)
            self.yawspeed = v / self.radius
        if math.isnan(target_yaw):
            self._yaw_sp = yaw
        else:
            self._slew(target_yaw, step, yaw)
        down = alt.position_ned_m[2]
        if not math.isnan(down):
            self.center = (self.center[0], self.center[1], down)
        return PositionSetpoint((math.nan, math.nan, down), (vn, ve, alt.velocity_ned_mps[2]),
                                self._yaw_sp, (-un * a, -ue * a, alt.acceleration_ned_mps2[2]))

    def _slew(self, target: float, step: float, yaw: float) -> None:
        if math.isnan(self._yaw_sp):
            self._yaw_sp = yaw
        err = math.remainder(target - self._yaw_sp, math.tau)
        self._yaw_sp = math.remainder(self._yaw_sp + min(max(err, -step), step), math.tau)

    @property
    def yaw_setpoint(self) -> float:
        return self._yaw_sp

    def status(self) -> OrbitStatus:
        return OrbitStatus(math.copysign(self.radius, self.velocity),
                           (self.center[0], self.center[1]), self.center[2])
