"""The autopilot wrapper: owns params, timestamps, commander, navigator and the control libraries.

After PX4's split between libraries (PositionControl, AttitudeControl, RateControl) and module
wrappers (MulticopterPositionControl, mc_att_control, mc_rate_control, control_allocator).

Rules and invariants:
- ``step(now_s)`` is called once per physics step (250 Hz). Commander, land detector,
  navigator, trajectory and position control run every POSITION_CONTROL_DIVIDER-th step (50 Hz,
  like PX4's EKF-driven position loop; ``phase`` picks which of the five steps); attitude, rate
  control and the mixer run every step in the World's compiled inner loop
  (vehicles/inner_loop.py), from the setpoints, gains and resets this class publishes
  (``attitude_setpoint``, ``rates_setpoint``, ``attitude_gains``, ``rate_gains``,
  ``gains_changed``, ``rates_reset``).
- Disarmed -> no motor output (the inner loop's OFF mode).
- On the ground (landed) the motors idle unless the navigator's target is clearly above the
  vehicle (PX4 takeoff handling); while the land detector reports ground contact the thrust is cut
  (PX4 ``limit_thrust_during_landing``).
- Gains come from PX4 parameter names, re-read when a parameter changes. No scale factors are
  applied: the mixer's normalization (airframe.py) makes PX4's rate gains fit this plant.
- OFFBOARD bypasses navigator and trajectory (offboard.py); TERMINATION cuts the motors.
- Auto-mode yaw setpoints are slewed at MPC_YAWRAUTO_MAX (FlightTaskAuto yaw rate limit).
- Failsafe inputs (battery level, geofence, offboard freshness) are gathered here every 50 Hz
  tick and handed to the commander, which owns the failsafe state machine.
- Time is an argument; nothing here calls a clock or a physics engine.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from vehicles.airframe import Airframe
from vehicles.battery import BatterySim
from vehicles.commander import Commander
from vehicles.control.attitude_control import (
    AttitudeControlGains,
    AttitudeSetpoint,
    thrust_to_attitude,
)
from vehicles.control.position_control import (
    PositionControl,
    PositionControlGains,
    PositionSetpoint,
)
from vehicles.control.quat import q_yaw
from vehicles.control.rate_control import RateControlGains
from vehicles.control.trajectory import TrajectoryLimiter
from vehicles.failsafe import FailsafeFlags
from vehicles.follow_target import FollowTarget
from vehicles.geofence import Geofence
from vehicles.inner_loop import MODE_FLY, MODE_IDLE, MODE_OFF
from vehicles.land_detector import LandDetector
from vehicles.manual_control import (
    CENTRED,
    ManualAltitude,
    ManualControl,
    ManualPosition,
    Stabilized,
    Sticks,
    acro_rates,
    acro_thrust,
    throttle_to_thrust,
)
from vehicles.navigator import NavContext, Navigator, NavSetpoint, auto_limits
from vehicles.offboard import Offboard, acceleration_to_thrust
from vehicles.orbit import Orbit, OrbitStatus
from vehicles.plan_types import PlanType
from vehicles.plans import PlanStore
from vehicles.status_log import StatusLog
from vehicles.types import CommandResult, GeoPoint, HomePosition, LandedState, NavState, Severity

if TYPE_CHECKING:
    from vehicles.vehicle import Measurement

Vec3 = tuple[float, float, float]

POSITION_CONTROL_DIVIDER = 5  # 250 Hz / 5 = 50 Hz
# Motors spin at this normalized thrust when armed and idle (PX4 idle PWM / CA idle).
IDLE_THRUST_NORM = 0.02
# The navigator must ask for this much climb before a landed vehicle spools up.
TAKEOFF_TRIGGER_M = 0.2
# The stick-driven modes (manual_control.py); Manual is Stabilized on a multicopter.
MANUAL_NAV_STATES = frozenset({NavState.MANUAL, NavState.STAB, NavState.ACRO, NavState.ALTCTL,
                               NavState.POSCTL})
# COM_RC_OVERRIDE bit 0: sticks take over these modes (Commander: isAutoMode). Not Orbit: there
# the sticks are part of the mode (altitude; PX4 also trims radius and speed with them).
STICK_OVERRIDE_AUTO = frozenset({NavState.AUTO_MISSION, NavState.AUTO_LOITER, NavState.AUTO_RTL,
                                 NavState.AUTO_TAKEOFF, NavState.AUTO_LAND,
                                 NavState.AUTO_PRECLAND, NavState.AUTO_FOLLOW_TARGET,
                                 NavState.DESCEND})
BATTERY_TEXTS = {
    1: (Severity.WARNING, "Low battery level, return advised"),
    2: (Severity.CRITICAL, "Critical battery level, land now"),
    3: (Severity.EMERGENCY, "Emergency battery level, land immediately"),
}


class Autopilot:
    def __init__(self, params, airframe: Airframe, origin: GeoPoint, dt_s: float,
                 boot_time_s: float = 0.0, name: str = "", *,
                 measure: Callable[[], tuple[Measurement, Vec3]], phase: int = 0) -> None:
        """``measure()``: the vehicle's latest measurement and acceleration (the World's).
        ``phase``: the 50 Hz part runs on physics steps phase, phase + 5, … (mod 5 it is the
        same loop; the World staggers its vehicles so that their 50 Hz work does not all land
        on one step)."""
        self._measure = measure
        self.rates_reset = False  # _set_idle asks the inner loop to restart its rate controller
        self.params = params
        self.airframe = airframe
        self.origin = origin
        self.dt_s = dt_s
        self.log = StatusLog(name)
        self.commander = Commander(params, self.log, boot_time_s)
        self.plans = PlanStore()
        self.navigator = Navigator(self.plans)
        self.geofence = Geofence(params)
        self.plans.on_change(self._plan_changed)
        self.offboard = Offboard()
        self.manual = ManualControl(params)
        self._manual_altitude = ManualAltitude(params)
        self._manual_position = ManualPosition(params)
        self._stabilized = Stabilized(params)
        self.orbit_task = Orbit(params)
        self.follow_target = FollowTarget(params)
        self._follow_hold: Vec3 | None = None  # Follow Me without a target holds here
        self._orbit_command: tuple | None = None  # DO_ORBIT parameters, applied at the next tick
        self._vel_sp_feedback: Vec3 = (math.nan, math.nan, math.nan)
        self._rates_sp: tuple[float, float, float] | None = None
        self._yaw_sp = math.nan
        self._prev_nav_state: NavState | None = None
        self._fence_breach: str | None = None
        self._battery_level = 0
        self.land_detector = LandDetector(params)
        self.battery = BatterySim(params, airframe.hover_thrust_norm)
        self.trajectory = TrajectoryLimiter()
        self.home: HomePosition | None = None
        self._hover = airframe.hover_thrust_norm
        self._load_gains()
        params.on_change(lambda name, value: self._load_gains())
        self._tick = -phase % POSITION_CONTROL_DIVIDER
        self._att_sp = AttitudeSetpoint((1.0, 0.0, 0.0, 0.0), 0.0)
        self._idle = True
        self._flying = False  # trajectory/controllers are live (not idling on the ground)
        self._nav_sp: NavSetpoint | None = None
        self._vel_sp_z = 0.0
        self._thrust = 0.0
        self.time_s = boot_time_s

    def _plan_changed(self, plan_type: PlanType) -> None:
        if plan_type is PlanType.FENCE:
            home = self.home.position_ned_m[:2] if self.home is not None else None
            here = None
            if not self.land_detector.landed:
                n, e, _ = self._measure()[0].position_ned_m
                here = (n, e)
            for text in self.geofence.load(self.plans.get(PlanType.FENCE), self.origin, home, here):
                self.log.critical(self.time_s, text)
        if plan_type is PlanType.MISSION:
            self.navigator.cruise_mps = math.nan  # a new mission starts at cruise speed

    def _load_gains(self) -> None:
        self.position_control = PositionControl(
            PositionControlGains.from_params(self.params, hover_thrust=self._hover))
        self.attitude_gains = AttitudeControlGains.from_params(self.params)
        self.rate_gains = RateControlGains.from_params(self.params)
        self.gains_changed = True  # the inner loop re-reads them (and restarts its integrator)
        self.inner_dirty = True

    # --- commands (the Vehicle API delegates here) -----------------------------------------------
    def arm(self, now_s: float, forced: bool = False,
            text: str = "Armed by external command") -> CommandResult:
        was_armed = self.commander.armed
        self._refresh_requirements(now_s)
        result = self.commander.arm(now_s, forced, text)
        if result is CommandResult.ACCEPTED and not was_armed:
            self._set_home()
        return result

    def disarm(self, now_s: float, forced: bool = False) -> CommandResult:
        return self.commander.disarm(now_s, forced)

    def takeoff(self, now_s: float, alt_amsl_m: float = math.nan) -> CommandResult:
        if not self.commander.position_valid:
            return CommandResult.TEMPORARILY_REJECTED
        result = self.commander.request_nav_state(now_s, NavState.AUTO_TAKEOFF)
        if result is CommandResult.ACCEPTED:
            self.navigator.takeoff.requested_alt_amsl_m = alt_amsl_m
            self.navigator.takeoff.origin_alt_amsl_m = self.origin.alt_amsl_m
            self.navigator.reactivate()
        return result

    def land(self, now_s: float) -> CommandResult:
        return self.commander.request_nav_state(now_s, NavState.AUTO_LAND)

    def return_to_launch(self, now_s: float) -> CommandResult:
        if self.home is None:
            return CommandResult.TEMPORARILY_REJECTED
        return self.commander.request_nav_state(now_s, NavState.AUTO_RTL)

    def reposition(self, now_s: float, target_ned_m: tuple[float, float, float]) -> CommandResult:
        """Fly to a local NED point and hold there (what DO_REPOSITION does in PX4: Hold + target)."""
        result = self.commander.request_nav_state(now_s, NavState.AUTO_LOITER)
        if result is CommandResult.ACCEPTED:
            self.navigator.hold.hint = target_ned_m
            self.navigator.reactivate()
        return result

    def set_nav_state(self, now_s: float, nav_state: NavState) -> CommandResult:
        self._refresh_requirements(now_s)
        if nav_state is NavState.AUTO_RTL and self.home is None:
            return CommandResult.TEMPORARILY_REJECTED
        if nav_state is NavState.AUTO_TAKEOFF:
            return self.takeoff(now_s)
        return self.commander.request_nav_state(now_s, nav_state)

    # --- missions, offboard, actions (README "the PX4 persona") ----------------------------------
    def _refresh_requirements(self, now_s: float) -> None:
        c = self.commander
        c.mission_valid = self.navigator.mission.valid()
        c.offboard_available = self.offboard.fresh(now_s, float(self.params["COM_OF_LOSS_T"]))
        c.manual_control_available = self.manual.fresh(now_s, float(self.params["COM_RC_LOSS_T"]))
        c.home_valid = self.home is not None

    def manual_control(self, now_s: float, sticks: Sticks, source: object = None) -> None:
        """Stick input (MANUAL_CONTROL) from ``source``. Moving the sticks in an auto mode
        (COM_RC_OVERRIDE bit 0) or in Offboard (bit 1) switches to Position, as Commander's
        stick override does."""
        self.manual.set(now_s, sticks, source)
        c = self.commander
        if not (self.manual.moving and c.armed) or c.terminated:
            return
        bits = int(self.params["COM_RC_OVERRIDE"])
        state = c.nav_state
        if (bits & 1 and state in STICK_OVERRIDE_AUTO) or (bits & 2 and state is NavState.OFFBOARD):
            self._refresh_requirements(now_s)
            if c.request_nav_state(now_s, NavState.POSCTL) is CommandResult.ACCEPTED:
                self.log.info(now_s, "Pilot took over using sticks")

    def start_mission(self, now_s: float, first_seq: int = -1) -> CommandResult:
        """MISSION_START (Commander.cpp): Mission mode and arm."""
        mission = self.navigator.mission
        if not mission.valid():
            self.log.critical(now_s, "Mission start denied! No valid mission")
            return CommandResult.DENIED
        if first_seq >= len(mission.items):
            return CommandResult.DENIED
        if first_seq >= 0:
            mission.set_current(first_seq)
        if (self.set_nav_state(now_s, NavState.AUTO_MISSION) is not CommandResult.ACCEPTED
                or self.arm(now_s, text="Armed by mission start") is not CommandResult.ACCEPTED):
            self.log.critical(now_s, "Mission start denied")
            return CommandResult.TEMPORARILY_REJECTED
        return CommandResult.ACCEPTED

    def goto(self, now_s: float, lat_deg: float, lon_deg: float, alt_amsl_m: float,
             yaw_rad: float = math.nan, speed_mps: float = math.nan) -> CommandResult:
        """DO_REPOSITION: Hold at a global target (navigator.cpp handle reposition)."""
        if not self.commander.position_valid:
            return CommandResult.TEMPORARILY_REJECTED
        n, e, d = self._measure()[0].position_ned_m
        if not (math.isnan(lat_deg) or math.isnan(lon_deg)):
            n, e, _ = self.origin.ned_of(GeoPoint(lat_deg, lon_deg, self.origin.alt_amsl_m))
        if not math.isnan(alt_amsl_m):
            d = self.origin.alt_amsl_m - alt_amsl_m
        if self.geofence.enabled and self.geofence.check(
                (n, e, d), self.home.position_ned_m if self.home else None) is not None:
            self.log.critical(now_s, "Reposition is outside geofence")
            return CommandResult.DENIED
        result = self.set_nav_state(now_s, NavState.AUTO_LOITER)
        if result is CommandResult.ACCEPTED:
            if speed_mps > 0:
                self.navigator.set_cruise_mps(speed_mps)
            if self.commander.armed:  # the navigator acts only when armed
                self.navigator.hold.hint = (n, e, d)
                self.navigator.hold.hint_yaw = yaw_rad
                self.navigator.reactivate()
        return result

    def orbit(self, now_s: float, radius_m: float, speed_mps: float, yaw_behaviour: float,
              lat_deg: float, lon_deg: float, alt_amsl_m: float) -> CommandResult:
        """DO_ORBIT: switch to Orbit; its task takes the parameters at the next 50 Hz tick."""
        result = self.set_nav_state(now_s, NavState.ORBIT)
        if result is CommandResult.ACCEPTED:
            center = None
            if not (math.isnan(lat_deg) or math.isnan(lon_deg)):
                n, e, _ = self.origin.ned_of(GeoPoint(lat_deg, lon_deg, self.origin.alt_amsl_m))
                center = (n, e)
            down = self.origin.alt_amsl_m - alt_amsl_m if math.isfinite(alt_amsl_m) else math.nan
            self._orbit_command = (radius_m, speed_mps, yaw_behaviour, center, down)
        return result

    def set_follow_target(self, now_s: float, lat_deg: float, lon_deg: float, alt_amsl_m: float,
                          velocity_ned_mps: tuple[float, float, float]) -> None:
        """FOLLOW_TARGET: where the target is (used in Follow Me)."""
        n, e, d = self.origin.ned_of(GeoPoint(lat_deg, lon_deg, alt_amsl_m))
        self.follow_target.set_target(now_s, (n, e, d), velocity_ned_mps)

    @property
    def orbit_status(self) -> OrbitStatus | None:
        if self.commander.nav_state is not NavState.ORBIT or not self._flying:
            return None
        return self.orbit_task.status()

    def change_speed(self, now_s: float, speed_mps: float) -> CommandResult:
        self.navigator.set_cruise_mps(speed_mps)
        return CommandResult.ACCEPTED

    def set_home(self, now_s: float, geo: GeoPoint | None = None) -> CommandResult:
        if not int(self.params["COM_HOME_EN"]) or not self.commander.position_valid:
            return CommandResult.TEMPORARILY_REJECTED
        if geo is None:
            self._set_home()
            return CommandResult.ACCEPTED
        if not all(math.isfinite(v) for v in (geo.lat_deg, geo.lon_deg, geo.alt_amsl_m)):
            return CommandResult.DENIED
        yaw = self.home.yaw_rad if self.home else 0.0
        self.home = HomePosition(geo, self.origin.ned_of(geo), yaw)
        return CommandResult.ACCEPTED

    def terminate(self, now_s: float) -> CommandResult:
        return self.commander.terminate(now_s)

    # --- status ------------------------------------------------------------------------------
    @property
    def landed_state(self) -> LandedState:
        if self.land_detector.landed:
            return LandedState.ON_GROUND
        if self.commander.nav_state is NavState.AUTO_TAKEOFF or (
                self._nav_sp is not None and self._nav_sp.taking_off):
            return LandedState.TAKEOFF
        if self._nav_sp is not None and self._nav_sp.landing:
            return LandedState.LANDING
        return LandedState.IN_AIR

    @property
    def thrust_norm(self) -> float:
        return self._thrust

    def _set_home(self) -> None:
        m = self._measure()[0]
        n, e, d = m.position_ned_m
        self.home = HomePosition(self.origin.offset_ned(n, e, d), (n, e, d), q_yaw(m.attitude_q))

    # --- the loop ----------------------------------------------------------------------------
    def step(self, now_s: float) -> int:
        """Once per physics step, before the inner loop runs: the 50 Hz part when due. Returns
        the inner loop's mode for this step (vehicles/inner_loop.py): OFF when disarmed or
        terminated, IDLE on the ground, FLY otherwise; ``inner_dirty`` says the setpoints
        changed (the World then copies them with ``InnerLoop.load``)."""
        self.time_s = now_s
        if self._tick % POSITION_CONTROL_DIVIDER == 0:
            meas, accel = self._measure()
            self._update_slow(now_s, meas, accel)
            self.inner_dirty = True
        self._tick += 1
        cmd = self.commander
        if not cmd.armed or cmd.terminated:
            return MODE_OFF
        return MODE_IDLE if self._idle else MODE_FLY

    # --- what the inner loop reads (InnerLoop.load) -------------------------------------------
    @property
    def attitude_setpoint(self) -> AttitudeSetpoint:
        return self._att_sp

    @property
    def rates_setpoint(self) -> tuple[float, float, float] | None:
        """A body-rate setpoint that replaces the attitude controller (offboard rates)."""
        return self._rates_sp

    def _failsafe_flags(self, now_s: float, pos) -> FailsafeFlags:
        p = self.params
        remaining = self.battery.state().remaining
        level = 0
        for i, name in enumerate(("BAT_LOW_THR", "BAT_CRIT_THR", "BAT_EMERGEN_THR")):
            if remaining <= float(p[name]):
                level = i + 1
        if level > self._battery_level:  # framework.cpp notifyUser texts per battery cause
            self.log.add(now_s, BATTERY_TEXTS[level][0], BATTERY_TEXTS[level][1])
        self._battery_level = level
        breach = None
        if self.geofence.enabled and self.home is not None and int(p["GF_ACTION"]) != 0:
            breach = self.geofence.check(pos, self.home.position_ned_m)
        if breach is not None and self._fence_breach is None:
            self.log.critical(now_s, breach)
        self._fence_breach = breach
        c = self.commander
        return FailsafeFlags(armed=c.armed, user_nav_state=c.user_nav_state,
                             offboard_lost=not c.offboard_available, battery_warning=level,
                             geofence_breached=breach is not None,
                             manual_control_lost=not c.manual_control_available)

    def _update_slow(self, now_s: float, meas, accel) -> None:
        cmd = self.commander
        dt = self.dt_s * POSITION_CONTROL_DIVIDER
        ld = self.land_detector
        ld.update(now_s, cmd.armed, meas.velocity_ned_mps, self._vel_sp_z, self._thrust, self._hover)
        was_armed = cmd.armed
        pos, vel = meas.position_ned_m, meas.velocity_ned_mps
        self._refresh_requirements(now_s)
        if cmd.nav_state is NavState.AUTO_MISSION and not cmd.mission_valid:
            cmd.switch_by_vehicle(NavState.AUTO_LOITER)  # mission cleared under our feet
        if cmd.update(now_s, ld.landed, self._failsafe_flags(now_s, pos)):
            self._set_home()
        self.battery.update(now_s, cmd.armed, self._thrust if cmd.armed else 0.0)
        if was_armed and not cmd.armed:
            ld.update(now_s, False, meas.velocity_ned_mps, 0.0, 0.0, self._hover)
        yaw = q_yaw(meas.attitude_q)
        if not self._flying:
            self.trajectory.reset(pos, vel)
        ctx = NavContext(now_s, self.params, self.log, cmd.armed, ld.landed, pos, vel, yaw,
                         self.home, self.trajectory.position_ned_m, self.trajectory.stopping_point(
                             self._nav_sp.limits if self._nav_sp else auto_limits(self.params)),
                         self._switch_by_vehicle, self.origin, self.navigator.cruise_mps,
                         self.navigator.set_cruise_mps)
        entered = cmd.nav_state is not self._prev_nav_state
        self._prev_nav_state = cmd.nav_state
        self._rates_sp = None
        if cmd.nav_state in (NavState.OFFBOARD, NavState.TERMINATION):
            self.navigator.deactivate(ctx)
            self._nav_sp = None
            if entered:
                self.offboard.on_entry(yaw)
            if cmd.nav_state is NavState.OFFBOARD and not cmd.terminated:
                self._update_offboard(now_s, dt, meas, accel, yaw)
            else:
                self._set_idle(meas)
            return
        if cmd.nav_state is NavState.AUTO_FOLLOW_TARGET:
            self.navigator.deactivate(ctx)
            self._nav_sp = None
            self._update_follow(now_s, dt, meas, accel, yaw, entered)
            return
        if cmd.nav_state is NavState.ORBIT:
            self.navigator.deactivate(ctx)
            self._nav_sp = None
            self._update_orbit(now_s, dt, meas, accel, yaw, entered)
            return
        if cmd.nav_state in MANUAL_NAV_STATES:
            self.navigator.deactivate(ctx)
            self._nav_sp = None
            self._update_manual(now_s, dt, meas, accel, yaw, entered)
            return
        nav_sp = self.navigator.update(cmd.nav_state, ctx)
        self._nav_sp = nav_sp
        wants_climb = (nav_sp.target_ned_m[2] < pos[2] - TAKEOFF_TRIGGER_M
                       if not math.isnan(nav_sp.target_ned_m[2]) else nav_sp.vz_cmd_mps < -0.1)
        if not cmd.armed or nav_sp.idle or (ld.landed and not wants_climb):
            self._set_idle(meas)
            return
        if not self._flying or math.isnan(self._yaw_sp):
            self._yaw_sp = yaw
        self._idle = False
        self._flying = True
        p_sp, v_sp, a_sp = self.trajectory.update(dt, nav_sp.target_ned_m, nav_sp.limits,
                                                  nav_sp.vz_cmd_mps, pos[2])
        if not math.isnan(nav_sp.yaw_rad):
            step = math.radians(float(self.params["MPC_YAWRAUTO_MAX"])) * dt
            err = math.remainder(nav_sp.yaw_rad - self._yaw_sp, math.tau)
            self._yaw_sp = math.remainder(self._yaw_sp + min(max(err, -step), step), math.tau)
        self._apply_position_control(dt, meas, accel, PositionSetpoint(p_sp, v_sp, self._yaw_sp,
                                                                       a_sp), yaw)

    def _fly_task(self, meas) -> bool:
        """For Orbit and Follow Me: False (motors idle) when disarmed or on the ground — these
        modes do not take off; else flying, the trajectory limiter starting from the state."""
        pos, vel = meas.position_ned_m, meas.velocity_ned_mps
        if not self.commander.armed or self.land_detector.landed:
            self.trajectory.reset(pos, vel)
            self._set_idle(meas)
            return False
        if not self._flying:
            self.trajectory.reset(pos, vel)
        self._idle = False
        self._flying = True
        return True

    def _update_follow(self, now_s: float, dt: float, meas, accel, yaw: float, entered: bool
                       ) -> None:
        """Follow Me (vehicles/follow_target.py) through the trajectory limiter."""
        pos = meas.position_ned_m
        task = self.follow_target
        if entered:
            task.activate(pos, yaw)
            self._follow_hold = None
        if not self._fly_task(meas):
            return
        sp = task.update(now_s, dt, pos, yaw)
        limits = auto_limits(self.params, speed_xy_mps=float(self.params["MPC_XY_VEL_MAX"]))
        if sp is None:  # no target: brake and hold
            if self._follow_hold is None:
                self._follow_hold = self.trajectory.stopping_point(limits)
            target = self._follow_hold
        else:
            self._follow_hold = None
            target = sp.position_ned_m
        p_sp, v_sp, a_sp = self.trajectory.update(dt, target, limits, 0.0, pos[2])
        self._apply_position_control(dt, meas, accel, PositionSetpoint(p_sp, v_sp, task.yaw_sp,
                                                                       a_sp), yaw)

    def _update_orbit(self, now_s: float, dt: float, meas, accel, yaw: float, entered: bool
                      ) -> None:
        """Orbit (vehicles/orbit.py): on the circle its setpoints go straight to position
        control; the approach to the circle goes through the trajectory limiter."""
        pos, vel = meas.position_ned_m, meas.velocity_ned_mps
        orbit = self.orbit_task
        if entered:
            orbit.activate(pos, vel, yaw)
        if self._orbit_command is not None:
            orbit.command(pos, yaw, *self._orbit_command)
            self._orbit_command = None
        if not self._fly_task(meas):
            return
        sp = orbit.update(dt, self.manual.current(now_s), pos, vel, yaw, self._vel_sp_feedback)
        if sp is None:
            p_sp, v_sp, a_sp = self.trajectory.update(dt, orbit.approach_target(pos),
                                                      auto_limits(self.params), 0.0, pos[2])
            sp = PositionSetpoint(p_sp, v_sp, orbit.yaw_setpoint, a_sp)
        else:
            self.trajectory.reset(pos, vel)
        self._apply_position_control(dt, meas, accel, sp, yaw, orbit.yawspeed)

    def _update_manual(self, now_s: float, dt: float, meas, accel, yaw: float, entered: bool
                       ) -> None:
        """The stick-driven modes (manual_control.py): lost input reads as centred sticks."""
        state = self.commander.nav_state
        pos, vel = meas.position_ned_m, meas.velocity_ned_mps
        sticks = self.manual.current(now_s) if self.commander.armed else CENTRED
        ld = self.land_detector
        self.trajectory.reset(pos, vel)  # a switch to an auto mode brakes from the real state
        if state in (NavState.ALTCTL, NavState.POSCTL):
            task = self._manual_position if state is NavState.POSCTL else self._manual_altitude
            if entered:
                task.activate(pos, vel, yaw)
            if not self.commander.armed or (ld.landed and not task.want_takeoff(sticks)):
                task.activate(pos, vel, yaw)
                self._set_idle(meas)
                return
            self._idle = False
            self._flying = True
            sp = task.update(dt, sticks, pos, vel, yaw, self._vel_sp_feedback)
            self._apply_position_control(dt, meas, accel, sp, yaw, task.yawspeed)
            return
        # Stabilized (Manual) and Acro: attitude or rates and thrust straight from the sticks.
        if entered:
            self._stabilized.activate(yaw)
        if state is NavState.ACRO:
            thrust = acro_thrust(sticks)
        else:
            thrust = throttle_to_thrust(sticks.throttle, self.params, self._hover)
        if not self.commander.armed or (ld.landed and thrust <= self._hover):
            self._stabilized.activate(yaw)
            self._set_idle(meas)
            return
        self._idle = False
        self._flying = False
        self._vel_sp_z = math.nan
        if state is NavState.ACRO:
            self._att_sp = AttitudeSetpoint(meas.attitude_q, thrust)
            self._rates_sp = acro_rates(sticks, self.params)
        else:
            q = self._stabilized.update(dt, sticks, yaw, ld.landed)
            self._att_sp = AttitudeSetpoint(q, thrust, self._stabilized.yawspeed)
        self._thrust = thrust

    def _set_idle(self, meas) -> None:
        self._idle = True
        self._flying = False
        self._thrust = 0.0
        self._vel_sp_z = 0.0
        self._yaw_sp = math.nan
        self.position_control.reset_integral()
        self.rates_reset = True
        self._att_sp = AttitudeSetpoint(meas.attitude_q, 0.0)

    def _apply_position_control(self, dt: float, meas, accel, sp: PositionSetpoint,
                                yaw: float, yawspeed: float = 0.0) -> None:
        ld = self.land_detector
        out = self.position_control.update(dt, meas.position_ned_m, meas.velocity_ned_mps,
                                           accel, sp)
        thrust = out.thrust_ned
        yaw_sp = out.yaw_rad if not math.isnan(out.yaw_rad) else yaw
        self._vel_sp_z = out.velocity_sp_ned_mps[2]
        self._vel_sp_feedback = out.velocity_sp_ned_mps
        if ld.ground_contact or ld.maybe_landed:
            thrust = (0.0, 0.0, 0.0)
            yaw_sp = yaw
            self.position_control.reset_integral()
        att_sp = thrust_to_attitude(thrust, yaw_sp)
        if yawspeed != 0.0 and not (ld.ground_contact or ld.maybe_landed):
            att_sp = AttitudeSetpoint(att_sp.attitude_q, att_sp.thrust_body_norm, yawspeed)
        self._att_sp = att_sp
        self._thrust = self._att_sp.thrust_body_norm

    def _update_offboard(self, now_s: float, dt: float, meas, accel, yaw: float) -> None:
        """Offboard setpoints straight to the controllers (mc_pos_control, no smoothing)."""
        pos, vel = meas.position_ned_m, meas.velocity_ned_mps
        self.trajectory.reset(pos, vel)  # leaving offboard brakes from the real state
        oc = self.offboard.command(now_s, yaw)
        if oc is None or not self.commander.armed:
            self._set_idle(meas)
            return
        sp = oc.setpoint
        ld = self.land_detector
        if oc.kind in ("position", "acceleration"):
            p, v, a = sp.position_ned_m, sp.velocity_ned_mps, sp.acceleration_ned_mps2
            wants_climb = ((not math.isnan(p[2]) and p[2] < pos[2] - TAKEOFF_TRIGGER_M)
                           or (not math.isnan(v[2]) and v[2] < -0.1)
                           or (not math.isnan(a[2]) and a[2] < -0.1))
            if ld.landed and not wants_climb:
                self._set_idle(meas)
                return
            self._idle = False
            self._flying = True
            if oc.kind == "position":
                yawspeed = (sp.yaw_rate_radps if math.isnan(sp.yaw_rad)
                            and not math.isnan(sp.yaw_rate_radps) else 0.0)
                self._apply_position_control(dt, meas, accel, PositionSetpoint(p, v, oc.yaw_rad, a),
                                             yaw, yawspeed)
                return
            g = self.position_control.gains
            acc = tuple(0.0 if math.isnan(x) else x for x in a)
            thrust = acceleration_to_thrust(acc, g.hover_thrust, g.tilt_max_rad)
            self._att_sp = thrust_to_attitude(thrust, oc.yaw_rad)
            self._vel_sp_z = math.nan
        else:
            self._idle = False
            self._flying = False
            self._vel_sp_z = math.nan
            thrust = 0.0 if math.isnan(sp.thrust) else min(max(sp.thrust, 0.0), 1.0)
            if oc.kind == "attitude":
                self._att_sp = AttitudeSetpoint(sp.attitude_q, thrust)
            else:
                self._att_sp = AttitudeSetpoint(meas.attitude_q, thrust)
                self._rates_sp = tuple(0.0 if math.isnan(x) else x
                                       for x in sp.body_rates_frd_radps)
        self._thrust = self._att_sp.thrust_body_norm

    def _switch_by_vehicle(self, nav_state: NavState, hold_at: tuple[float, float, float] | None
                           ) -> None:
        if nav_state is NavState.AUTO_LOITER:
            self.navigator.hold.hint = hold_at
        if nav_state is NavState.AUTO_RTL and self.home is None:
            nav_state = NavState.AUTO_LAND
        self.commander.switch_by_vehicle(nav_state)

