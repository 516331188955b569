"""Flight tasks: what the vehicle flies in each navigation state, one small class per kind.

After PX4's FlightModeManager (src/modules/flight_mode_manager), which maps ``nav_state`` to a
FlightTask (Auto, ManualAltitude, ManualPosition, Orbit, AutoFollowTarget, Descend …) and runs the
active one every position-loop tick; Offboard and Termination have no flight task in PX4 (the
position controller takes the offboard setpoint directly), here they are tasks too so that the
table covers every state.

Rules and invariants:
- ``make_tasks`` returns the table: one entry per ``NavState``, nothing else decides what flies
  (the completeness test checks every state has one).
- A task is activated when its state is entered (``activate``), then updated every 50 Hz tick
  (``update``); both get the tick's ``TaskInput``. Tasks write only through the PositionStage,
  whose ``task_setpoint`` is the last trajectory setpoint, what the auto and stick tasks start
  from.
- Tasks that are not the navigator's tell the autopilot so (``uses_navigator``): it then
  deactivates the navigator, as PX4's navigator goes inactive outside the auto modes.
- Lost stick input reads as centred sticks; disarmed tasks idle the motors.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

from vehicles.auto_heading import AutoHeading
from vehicles.auto_waypoints import AutoWaypoints
from vehicles.control.attitude_control import AttitudeSetpoint, thrust_to_attitude
from vehicles.control.hover_thrust import HoverThrustEstimator
from vehicles.control.position_control import REACTIVATE_VEL, PositionSetpoint
from vehicles.control.takeoff import RAMPUP
from vehicles.flight_task import FlightTask, TaskInput, reset_from
from vehicles.follow_target import FollowTarget
from vehicles.manual_attitude import Stabilized, acro_rates, acro_thrust, throttle_to_thrust
from vehicles.manual_control import (
    CENTRED,
    ManualAltitude,
    ManualControl,
    ManualPosition,
)
from vehicles.manual_direct import ManualAltitudeDirect, ManualPositionDirect
from vehicles.manual_position_smooth import ManualPositionSmoothVel
from vehicles.navigator import Navigator, NavSetpoint
from vehicles.offboard import Offboard, acceleration_to_thrust
from vehicles.orbit import Orbit
from vehicles.orbit_task import OrbitTask
from vehicles.params import ParamStore
from vehicles.position_slow import ManualPositionSlow, VelocityLimits
from vehicles.position_stage import PositionStage
from vehicles.types import EstimatorReset, NavState, Vec3

log = logging.getLogger(__name__)

# The offboard setpoint must ask for this much climb before a landed vehicle spools up.
TAKEOFF_TRIGGER_M = 0.2
# FlightTaskAuto::update: an auto task wants a takeoff when its unsmoothed velocity setpoint
# climbs faster than this (NED, m/s).
TAKEOFF_TRIGGER_VZ_MPS = -0.3


class AutoTask(FlightTask):
    """The navigator's modes (Mission, Hold, Takeoff, Land, Return …) through PX4's position
    smoothing with the navigator's triplet (auto_trajectory.py), the heading slewed at
    MPC_YAWRAUTO_MAX (FlightTaskAuto)."""

    uses_navigator = True

    def __init__(self, stage: PositionStage, params: ParamStore, navigator: Navigator) -> None:
        super().__init__(stage, params)
        self.navigator = navigator
        self.setpoint: NavSetpoint | None = None  # the navigator's last (None outside auto)
        self._params_version = -1  # MPC_YAWRAUTO_MAX, read when first needed
        self._yawrate_max_radps = 0.0
        self.waypoints = AutoWaypoints()  # what the smoothing flies (FlightTaskAuto's own)
        self.heading = AutoHeading()  # the heading when the navigator gives none
        self._yaw_mode = 0
        self._yaw_err_rad = 0.0

    def activate(self, t: TaskInput) -> None:
        # FlightTaskAuto::activate, when another task flew the last tick: all the navigator's
        # states share this one task, as PX4's share FlightTaskAuto, and from one to another
        # FlightModeManager::switchTask does not activate it again (the smoothing flies on).
        if self.setpoint is not None:
            return
        st, meas = self.stage, t.meas
        st.trajectory.emergency_braking = False
        self.waypoints = AutoWaypoints()
        self.heading = AutoHeading()
        # The smoothing restarts from the trajectory setpoint the last task published
        # (switchTask hands it over: PX4's empty one where no task ran), each component that is
        # not finite from the vehicle's position and velocity and a zero acceleration; the
        # heading slews on from its yaw setpoint, else from the vehicle's (_yaw_sp_prev).
        last = st.task_setpoint
        reset_from(st.trajectory, last, meas.position_ned_m, meas.velocity_ned_mps)
        st.yaw_sp = t.yaw_rad if last is None or not math.isfinite(last.yaw_rad) else last.yaw_rad

    def estimator_reset(self, t: TaskInput, r: EstimatorReset) -> None:
        """FlightTaskAuto::_ekfResetHandlerPositionXY, VelocityXY, PositionZ, VelocityZ: the
        smoothing jumps to the new estimate (forceSetPosition, forceSetVelocity); the waypoints
        stay (the navigator's triplet is global)."""
        pos, vel, nan = t.meas.position_ned_m, t.meas.velocity_ned_mps, math.nan
        self.stage.trajectory.smoothing.force_set(
            (pos[0] if r.xy else nan, pos[1] if r.xy else nan, pos[2] if r.z else nan),
            (vel[0] if r.vxy else nan, vel[1] if r.vxy else nan, vel[2] if r.vz else nan))

    def update(self, t: TaskInput) -> None:
        st, pos = self.stage, t.meas.position_ned_m
        nav_sp = self.setpoint = self.navigator.update(t.nav_state, t.nav)
        traj = st.trajectory
        p = self.params
        if p.version != self._params_version:
            self._params_version = p.version
            self._yawrate_max_radps = math.radians(float(p["MPC_YAWRAUTO_MAX"]))
            self._yaw_mode = int(p["MPC_YAW_MODE"])
            self._yaw_err_rad = math.radians(float(p["MIS_YAW_ERR"]))
        # FlightTaskAuto::_evaluateTriplets (every update): the waypoints flown, from the triplet
        prev_wp, target, next_wp = self.waypoints.update(
            pos, nav_sp.target_ned_m, nav_sp.previous_ned_m, nav_sp.next_ned_m,
            traj.acceptance_radius(nav_sp.acceptance_radius_m))
        if not t.armed or nav_sp.idle:
            self._idle(t)
            return
        # FlightTaskAuto::update: _checkEmergencyBraking on the smoothing's velocity before this
        # tick's (the autopilot has restarted the trajectory from the state if it was not flying
        # under it); while braking the velocity setpoint is zero (force_zero_velocity_setpoint)
        braking = traj.check_emergency_braking()
        # MPC_YAW_MODE 4 waits for the heading its last tick left unaligned (_yaw_sp_aligned):
        # a zero velocity setpoint as while braking (force_zero_velocity_setpoint)
        wait = self._yaw_mode == 4 and not self.heading.aligned
        traj.set_up(nav_sp.limits)
        if (t.nav_state is NavState.AUTO_TAKEOFF or nav_sp.taking_off) \
                and nav_sp.target_ned_m[2] < pos[2] and not braking:
            # FlightTaskAuto::_updateTrajConstraints: climbing to a takeoff setpoint closer to
            # the ground than MPC_LAND_ALT1 the trajectory's altitude stays at the vehicle's
            # (it does not run ahead while the takeoff ramp spools up)
            home = t.nav.home
            height = (home.position_ned_m[2] if home is not None else 0.0) - pos[2]
            if height < float(self.params["MPC_LAND_ALT1"]):
                traj.smoothing.force_set((math.nan, math.nan, pos[2]))
        landed = st.land_detector.landed and not st.taking_off
        if landed:
            # FlightTaskAuto::update: the task wants a takeoff when its unsmoothed velocity
            # setpoint climbs faster than 0.3 m/s (_want_takeoff, its _checkTakeoff); planned
            # from where FlightTaskAuto::reActivate left the smoothing (see ``_idle``); zero
            # while braking.
            vz = 0.0 if braking or wait else traj.smoothing.unsmoothed_velocity_auto(
                pos, prev_wp, target, next_wp, self.waypoints.acceptance_radius_m,
                nav_sp.vz_cmd_mps)[2]
            if not vz < TAKEOFF_TRIGGER_VZ_MPS:
                self._idle(t)
                return
        if not st.flying or math.isnan(st.yaw_sp):
            st.yaw_sp = t.yaw_rad
        # On the ground the smoothing is where reActivate left it, not restarted from the state.
        st.start_flying(t.meas, reset_trajectory=not landed)
        heading = self.heading
        yaw_sp = nav_sp.yaw_rad
        home = t.nav.home
        home_ned = home.position_ned_m if home is not None else None
        acc_rad = self.waypoints.acceptance_radius_m
        if math.isnan(yaw_sp) and heading.along_trajectory(self._yaw_mode):
            # FlightTaskAuto::update: _generateHeadingAlongTraj on this tick's smoothed
            # velocity setpoint, after the smoothing and before position control
            last_sp = st.yaw_sp

            def along(velocity_sp: Vec3) -> tuple[float, float]:
                sp = heading.setpoint(self._yaw_mode, pos, target, home_ned, acc_rad, t.yaw_rad,
                                      last_sp, velocity_sp)
                return heading.limit(sp, last_sp, t.dt_s, self._yawrate_max_radps,
                                     self._yaw_err_rad)

            st.apply_auto(t.dt_s, t.meas, target, nav_sp.limits, nav_sp.vz_cmd_mps, prev_wp,
                          next_wp, acc_rad, t.yaw_rad, hold=wait, heading_of=along)
            return
        if math.isnan(yaw_sp):  # FlightTaskAuto::_set_heading_from_mode (auto_heading.py)
            yaw_sp = heading.setpoint(self._yaw_mode, pos, target, home_ned, acc_rad, t.yaw_rad,
                                      st.yaw_sp, traj.smoothing.velocity)
        st.yaw_sp, yawspeed = heading.limit(yaw_sp, st.yaw_sp, t.dt_s, self._yawrate_max_radps,
                                            self._yaw_err_rad)
        # The trajectory towards the triplet, then position control on it at the slewed
        # heading (one compiled call).
        st.apply_auto(t.dt_s, t.meas, target, nav_sp.limits, nav_sp.vz_cmd_mps, prev_wp,
                      next_wp, acc_rad, t.yaw_rad, yawspeed, wait)

    def _idle(self, t: TaskInput) -> None:
        """No takeoff (disarmed, the navigator idles, or landed without a climb to fly): the
        motors idle. PX4 runs the task on and re-activates it after every update until the
        takeoff ramps (FlightModeManager: FlightTaskAuto::reActivate), which restarts the
        smoothing at the vehicle at rest but for a 0.7 m/s descent (and ends an emergency
        braking, as activate does): the next tick plans from there."""
        st = self.stage
        st.set_idle(t.meas)
        st.trajectory.smoothing.reset((0.0, 0.0, 0.0), REACTIVATE_VEL, t.meas.position_ned_m)
        st.trajectory.emergency_braking = False


class OffboardTask(FlightTask):
    """Offboard setpoints straight to the controllers (mc_pos_control, no smoothing)."""

    def __init__(self, stage: PositionStage, params: ParamStore, offboard: Offboard) -> None:
        super().__init__(stage, params)
        self.offboard = offboard

    def activate(self, t: TaskInput) -> None:
        self.offboard.on_entry(t.yaw_rad)

    def estimator_reset(self, t: TaskInput, r: EstimatorReset) -> None:
        """No flight task runs in Offboard: mc_pos_control's adjustSetpointForEKFResets moves
        the setpoint it holds (the last one received, older than the estimate) by the changes,
        until the next one arrives."""
        self.offboard.shift(t.now_s, r)

    def update(self, t: TaskInput) -> None:
        st, meas = self.stage, t.meas
        pos = meas.position_ned_m
        # the shared trajectory follows the state (Orbit's and Follow Me's approaches start
        # there; the auto task from PX4's empty setpoint, the state too)
        st.trajectory.reset(pos, meas.velocity_ned_mps)
        oc = self.offboard.command(t.now_s, t.yaw_rad) if not t.terminated else None
        if oc is None or not t.armed:
            st.set_idle(meas)
            return
        sp = oc.setpoint
        if oc.kind in ("position", "acceleration"):
            p, v, a = sp.position_ned_m, sp.velocity_ned_mps, sp.acceleration_ned_mps2
            wants_climb = ((not math.isnan(p[2]) and p[2] < pos[2] - TAKEOFF_TRIGGER_M)
                           or (not math.isnan(v[2]) and v[2] < -0.1)
                           or (not math.isnan(a[2]) and a[2] < -0.1))
            if st.land_detector.landed and not wants_climb and not st.taking_off:
                st.set_idle(meas)
                return
            if oc.kind == "position":
                st.start_flying(meas)
                yawspeed = (sp.yaw_rate_radps if math.isnan(sp.yaw_rad)
                            and not math.isnan(sp.yaw_rate_radps) else 0.0)
                st.apply(t.dt_s, meas, PositionSetpoint(p, v, oc.yaw_rad, a), t.yaw_rad, yawspeed)
                # no flight task runs in Offboard (FlightModeManager: FlightTaskIndex::None):
                # the next task gets the empty setpoint
                st.task_setpoint = None
                return
            pc = st.position_control
            acc: Vec3 = (0.0 if math.isnan(a[0]) else a[0], 0.0 if math.isnan(a[1]) else a[1],
                         0.0 if math.isnan(a[2]) else a[2])
            thrust = acceleration_to_thrust(acc, pc.hover_thrust, pc.gains.tilt_max_rad)
            st.direct(thrust_to_attitude(thrust, oc.yaw_rad), flying=True)
            return
        thrust_norm = 0.0 if math.isnan(sp.thrust) else min(max(sp.thrust, 0.0), 1.0)
        if oc.kind == "attitude":
            q = sp.attitude_q if sp.attitude_q is not None else meas.attitude_q
            # SET_ATTITUDE_TARGET's body yaw rate: mc_att_control's yaw_sp_move_rate feed-forward
            yawspeed = sp.body_rates_frd_radps[2]
            stop = math.isnan(q[0])  # a degenerate quaternion: the motors stop (see offboard)
            st.direct(AttitudeSetpoint(meas.attitude_q if stop else q, 0.0 if stop else thrust_norm,
                                       0.0 if math.isnan(yawspeed) else yawspeed))
            st.motors_stopped = stop
        else:
            r = sp.body_rates_frd_radps
            st.direct(AttitudeSetpoint(meas.attitude_q, thrust_norm),
                      (0.0 if math.isnan(r[0]) else r[0], 0.0 if math.isnan(r[1]) else r[1],
                       0.0 if math.isnan(r[2]) else r[2]))


class TerminationTask(FlightTask):
    """Flight termination: the motors are cut (the inner loop's OFF mode) and stay so."""

    def update(self, t: TaskInput) -> None:
        self.stage.set_idle(t.meas)


class DescendTask(FlightTask):
    """Descend (PX4 FlightTaskDescend, the failsafe without a position estimate): no position
    control, level (no horizontal acceleration), down at MPC_LAND_SPEED, the heading held; the
    land detector then disarms as after a landing."""

    def __init__(self, stage: PositionStage, params: ParamStore) -> None:
        super().__init__(stage, params)
        self._yaw = 0.0

    def activate(self, t: TaskInput) -> None:
        self._yaw = t.yaw_rad

    def update(self, t: TaskInput) -> None:
        st = self.stage
        if not st.take_off_or_idle(t.meas, t.armed):
            return
        down = float(self.params["MPC_LAND_SPEED"])
        sp = PositionSetpoint((math.nan,) * 3, (math.nan, math.nan, down), self._yaw,
                              (0.0, 0.0, math.nan))
        st.trajectory.reset(t.meas.position_ned_m, t.meas.velocity_ned_mps)
        st.apply(t.dt_s, t.meas, sp, self._yaw)


class FollowTask(FlightTask):
    """Follow Me (follow_target.py): its setpoints straight to position control, as PX4's
    FlightTaskAutoFollowTarget publishes them (no smoothing); the sticks trim it while there is
    stick input."""

    def __init__(self, stage: PositionStage, params: ParamStore, follow: FollowTarget,
                 manual: ManualControl) -> None:
        super().__init__(stage, params)
        self.follow = follow
        self.manual = manual

    def activate(self, t: TaskInput) -> None:
        home = t.nav.home
        self.follow.activate(t.meas.position_ned_m, t.yaw_rad, self.stage.task_setpoint,
                             home.position_ned_m[2] if home is not None else math.nan)

    def update(self, t: TaskInput) -> None:
        st, meas = self.stage, t.meas
        st.trajectory.reset(meas.position_ned_m, meas.velocity_ned_mps)
        if not st.take_off_or_idle(meas, t.armed):
            return
        manual = self.manual
        sticks = (manual.current(t.now_s)
                  if manual.fresh(t.now_s, float(self.params["COM_RC_LOSS_T"])) else None)
        sp = self.follow.update(t.now_s, t.dt_s, meas.position_ned_m, sticks)
        st.apply(t.dt_s, meas, sp, t.yaw_rad)


class StickPositionTask(FlightTask):
    """Altitude and Position modes (FlightTaskManualAltitudeSmoothVel / ManualAcceleration): the
    sticks drive velocity setpoints; on the ground the motors idle until the sticks ask for a
    takeoff."""

    def __init__(self, stage: PositionStage, params: ParamStore, manual: ManualControl,
                 task: ManualAltitude, by_mode: dict[int, ManualAltitude] | None = None,
                 position: bool = False) -> None:
        """``task``: the mode's task for MPC_POS_MODE values not in ``by_mode``; ``position``:
        Position mode, which sets an invalid MPC_POS_MODE back to 4."""
        super().__init__(stage, params)
        self.manual = manual
        self.task = self._default = task
        self._by_mode = by_mode
        self._position = position

    def _choose(self) -> None:
        """FlightModeManager::start_flight_task's task for MPC_POS_MODE, checked every tick as
        PX4 does: Position mode 0 ManualPosition, 3 ManualPositionSmoothVel, 4 (and an invalid
        value, set back to 4 and committed with PX4_ERR's line) ManualAcceleration; Altitude
        mode 0 ManualAltitude, else ManualAltitudeSmoothVel."""
        assert self._by_mode is not None
        mode = int(self.params["MPC_POS_MODE"])
        if self._position and mode not in (0, 3, 4):
            log.error("MPC_POS_MODE %d invalid, resetting", mode)
            self.params.set("MPC_POS_MODE", 4)
            mode = 4
        self.task = self._by_mode.get(mode, self._default)

    def activate(self, t: TaskInput) -> None:
        # from the trajectory setpoint the last task published (switchTask hands it over;
        # FlightTaskManualAltitudeSmoothVel / ManualAcceleration::activate)
        if self._by_mode is not None:
            self._choose()
        self.task.activate(t.meas.position_ned_m, t.meas.velocity_ned_mps, t.yaw_rad,
                           self.stage.task_setpoint)

    def estimator_reset(self, t: TaskInput, r: EstimatorReset) -> None:
        self.task.estimator_reset(t.meas.position_ned_m, t.meas.velocity_ned_mps, r)

    def update(self, t: TaskInput) -> None:
        st, meas = self.stage, t.meas
        pos, vel = meas.position_ned_m, meas.velocity_ned_mps
        if self._by_mode is not None:
            before = self.task
            self._choose()
            if self.task is not before:  # switchTask: the new task from the last setpoint
                self.task.activate(pos, vel, t.yaw_rad, st.task_setpoint)
        task = self.task
        # the shared trajectory follows the state (Orbit's and Follow Me's approaches start
        # there; the auto task starts from this task's setpoint, ``task_setpoint``)
        st.trajectory.reset(pos, vel)
        sticks = self.manual.current(t.now_s) if t.armed else CENTRED
        home = t.nav.home
        home_z = home.position_ned_m[2] if home is not None else math.nan
        # FlightModeManager::generateTrajectorySetpoint: the task runs, then is re-activated
        # while the takeoff state mc_pos_control last published is below the ramp
        # (FlightTask::reActivate: its vertical velocity setpoint kept)
        reactivate = st.takeoff.state < RAMPUP
        task.tilt_limit_rad = st.tilt_limit_rad  # takeoff_status, published by the last tick
        if not t.armed or (st.land_detector.landed and not task.want_takeoff(sticks)
                           and not st.taking_off):
            task.update(t.dt_s, sticks, pos, vel, t.yaw_rad, st.vel_sp, home_z)
            task.reactivate(pos, vel, t.yaw_rad)
            st.set_idle(meas)
            return
        st.idle, st.flying = False, True
        sp = task.update(t.dt_s, sticks, pos, vel, t.yaw_rad, st.vel_sp, home_z)
        st.apply(t.dt_s, meas, sp, t.yaw_rad, task.yawspeed)
        if reactivate:
            task.reactivate(pos, vel, t.yaw_rad)
            st.task_setpoint = None  # as after set_idle: the vehicle's state
            return
        if not isinstance(task, (ManualPosition, ManualPositionSmoothVel, ManualPositionDirect)):
            # FlightTaskManualAltitude has no horizontal velocity setpoint (the measured one
            # here only keeps the velocity loop out): the next task takes the vehicle's
            st.task_setpoint = sp._replace(
                velocity_ned_mps=(math.nan, math.nan, sp.velocity_ned_mps[2]))


class StickAttitudeTask(FlightTask):
    """Stabilized (and Manual, which is Stabilized on a multicopter) or Acro: attitude or body
    rates and thrust straight from the sticks."""

    def __init__(self, stage: PositionStage, params: ParamStore, manual: ManualControl,
                 stabilized: Stabilized, hover: HoverThrustEstimator, acro: bool = False) -> None:
        super().__init__(stage, params)
        self.manual = manual
        self.stabilized = stabilized
        self.hte = hover  # its hover_thrust: the throttle curve's centre (mc_att_control)
        self.acro = acro

    def activate(self, t: TaskInput) -> None:
        self.stabilized.activate(t.yaw_rad)

    def update(self, t: TaskInput) -> None:
        st, meas = self.stage, t.meas
        st.trajectory.reset(meas.position_ned_m, meas.velocity_ned_mps)
        sticks = self.manual.current(t.now_s) if t.armed else CENTRED
        hover = self.hte.hover_thrust
        if self.acro:
            thrust = acro_thrust(sticks)
        else:
            thrust = throttle_to_thrust(sticks.throttle, self.params, hover)
        landed = st.land_detector.landed
        if not t.armed or (landed and thrust <= hover):
            self.stabilized.activate(t.yaw_rad)
            st.set_idle(meas)
            return
        if self.acro:
            st.direct(AttitudeSetpoint(meas.attitude_q, thrust), acro_rates(sticks, self.params))
        else:
            q = self.stabilized.update(t.dt_s, sticks, t.yaw_rad, landed)
            st.direct(AttitudeSetpoint(q, thrust, self.stabilized.yawspeed))


@dataclass
class Tasks:
    """The table (``by_state``) and the tasks the autopilot's commands reach."""

    by_state: dict[NavState, FlightTask]
    auto: AutoTask
    orbit: OrbitTask


def make_tasks(stage: PositionStage, params: ParamStore, navigator: Navigator,
               offboard: Offboard, manual: ManualControl, orbit: Orbit, follow: FollowTarget,
               hover: HoverThrustEstimator, limits: VelocityLimits) -> Tasks:
    auto = AutoTask(stage, params, navigator)
    orbit_task = OrbitTask(stage, params, orbit, manual)
    stabilized = Stabilized(params)
    stab = StickAttitudeTask(stage, params, manual, stabilized, hover)
    by_state: dict[NavState, FlightTask] = {
        NavState.MANUAL: stab,
        NavState.STAB: stab,
        NavState.ACRO: StickAttitudeTask(stage, params, manual, stabilized, hover, acro=True),
        NavState.ALTCTL: StickPositionTask(stage, params, manual, ManualAltitude(params),
                                           {0: ManualAltitudeDirect(params)}),
        NavState.POSCTL: StickPositionTask(
            stage, params, manual, ManualPosition(params),
            {0: ManualPositionDirect(params), 3: ManualPositionSmoothVel(params)}, position=True),
        NavState.POSITION_SLOW: StickPositionTask(stage, params, manual,
                                                  ManualPositionSlow(params, limits)),
        NavState.OFFBOARD: OffboardTask(stage, params, offboard),
        NavState.TERMINATION: TerminationTask(stage, params),
        NavState.DESCEND: DescendTask(stage, params),
        NavState.AUTO_FOLLOW_TARGET: FollowTask(stage, params, follow, manual),
        NavState.ORBIT: orbit_task,
    }
    for state in NavState:  # the rest are the navigator's (Navigator.update: Hold if it has none)
        by_state.setdefault(state, auto)
    return Tasks(by_state, auto, orbit_task)
