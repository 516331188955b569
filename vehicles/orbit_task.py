"""Orbit's flight task: what FlightModeManager does around FlightTaskOrbit (vehicles/orbit.py),
the approach's position smoothing, and the hold after a refused DO_ORBIT."""

from __future__ import annotations

import math

from vehicles.control.position_control import PositionSetpoint
from vehicles.flight_task import ZERO3, FlightTask, TaskInput, finite_or, reset_from
from vehicles.manual_control import ManualControl
from vehicles.nav_core import auto_limits
from vehicles.orbit import ACCEPTANCE_XY_M, Orbit
from vehicles.params import ParamStore
from vehicles.position_stage import PositionStage
from vehicles.types import EstimatorReset


class OrbitTask(FlightTask):
    """Orbit (orbit.py): on the circle its setpoints go straight to position control; the
    approach to the circle goes through PX4's position smoothing, reset from the last task's
    setpoint (the shared trajectory: FlightTaskOrbit's own PositionSmoothing), towards the one
    point (generateSetpoints' single-waypoint form). DO_ORBIT's parameters are taken at the
    next tick. A refused one (``Orbit.command`` False) leaves FlightTaskFailsafe's setpoint,
    hold here, which position control keeps flying (FlightModeManager runs no task after it)
    until a new DO_ORBIT starts the orbit anew."""

    def __init__(self, stage: PositionStage, params: ParamStore, orbit: Orbit,
                 manual: ManualControl) -> None:
        super().__init__(stage, params)
        self.orbit = orbit
        self.manual = manual
        self.pending: tuple[float, float, float, tuple[float, float] | None, float] | None = None
        self.failed: PositionSetpoint | None = None  # the hold after a refused DO_ORBIT

    def activate(self, t: TaskInput) -> None:
        self._activate(t, self.stage.task_setpoint)

    def estimator_reset(self, t: TaskInput, r: EstimatorReset) -> None:
        self.orbit.estimator_reset(t.meas.position_ned_m, t.meas.velocity_ned_mps, r)

    def _activate(self, t: TaskInput, last: PositionSetpoint | None) -> None:
        pos, vel = t.meas.position_ned_m, t.meas.velocity_ned_mps
        self.failed = None
        self.orbit.activate(pos, vel, t.yaw_rad, last)
        reset_from(self.stage.trajectory, last, pos, vel)

    def _command(self, t: TaskInput,
                 pending: tuple[float, float, float, tuple[float, float] | None, float]) -> None:
        st, orbit = self.stage, self.orbit
        pos, vel = t.meas.position_ned_m, t.meas.velocity_ned_mps
        if self.failed is not None:
            # a new DO_ORBIT clears FlightModeManager's _command_failed: the Orbit task starts
            # again, after no task (an empty last setpoint)
            self._activate(t, None)
        approaching = orbit.approaching
        if not orbit.command(t.now_s, pos, t.yaw_rad, *pending):
            # FlightModeManager::tryApplyCommandIfAny → FlightTaskFailsafe: hold the position
            # and altitude at the heading of now, no horizontal acceleration
            self.failed = PositionSetpoint(pos, ZERO3, t.yaw_rad, (0.0, 0.0, math.nan))
        elif orbit.approaching and not approaching:
            # back off the circle: the approach's smoothing restarts from the task's setpoints
            last = st.task_setpoint
            if last is None:
                st.trajectory.reset(pos, vel)
            else:
                st.trajectory.reset(pos, finite_or(last.velocity_ned_mps, vel),
                                    finite_or(last.acceleration_ned_mps2, ZERO3))

    def update(self, t: TaskInput) -> None:
        st, orbit = self.stage, self.orbit
        pos, vel = t.meas.position_ned_m, t.meas.velocity_ned_mps
        pending, self.pending = self.pending, None
        if pending is not None:
            self._command(t, pending)
        if not st.take_off_or_idle(t.meas, t.armed):
            return
        if self.failed is not None:
            st.apply(t.dt_s, t.meas, self.failed, t.yaw_rad)
            return
        home = t.nav.home
        sp = orbit.update(t.dt_s, self.manual.current(t.now_s), pos, vel, t.yaw_rad, st.vel_sp,
                          st.task_setpoint,
                          home.position_ned_m[2] if home is not None else math.nan)
        if sp is None:
            # _generate_circle_approach_setpoints, set up as _updateTrajectoryBoundaries sets it
            traj = st.trajectory
            traj.set_up(auto_limits(self.params))
            smoothing = traj.smoothing
            smoothing.target_acceptance_radius = ACCEPTANCE_XY_M
            target = orbit.approach_target(pos)
            out = smoothing.generate(pos, (target, target, target), ZERO3, t.dt_s,
                                     single_waypoint=True)
            p_sp = out.position
            orbit.down_sp = p_sp[2]
            sp = PositionSetpoint(p_sp, out.velocity, orbit.yaw_setpoint, out.acceleration)
        else:
            st.trajectory.reset(pos, vel)
        st.apply(t.dt_s, t.meas, sp, t.yaw_rad, orbit.yawspeed)
