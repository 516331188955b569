"""What every flight task (flight_tasks.py) is and gets: ``FlightTask``, the tick's
``TaskInput``, and the hand-over of the last task's setpoint to a trajectory (``reset_from``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from vehicles.auto_trajectory import AutoTrajectory
from vehicles.control.position_control import PositionSetpoint
from vehicles.navigator import NavContext
from vehicles.params import ParamStore
from vehicles.position_stage import PositionStage
from vehicles.types import EstimatorReset, Measurement, NavState, Vec3

ZERO3: Vec3 = (0.0, 0.0, 0.0)


def finite_or(v: Vec3, fallback: Vec3) -> Vec3:
    """``v`` with each component that is not finite taken from ``fallback``."""
    return (v[0] if math.isfinite(v[0]) else fallback[0],
            v[1] if math.isfinite(v[1]) else fallback[1],
            v[2] if math.isfinite(v[2]) else fallback[2])


def reset_from(trajectory: AutoTrajectory, last: PositionSetpoint | None, pos: Vec3,
               vel: Vec3) -> None:
    """The smoothing restarts from the trajectory setpoint the last task published
    (FlightModeManager::switchTask hands it over; None: PX4's empty one, where no task ran),
    each component that is not finite from the vehicle's position and velocity and a zero
    acceleration (FlightTaskAuto::activate, FlightTaskOrbit::activate)."""
    if last is None:
        trajectory.reset(pos, vel)
    else:
        trajectory.reset(finite_or(last.position_ned_m, pos), finite_or(last.velocity_ned_mps, vel),
                         finite_or(last.acceleration_ned_mps2, ZERO3))


def check_resets(task: FlightTask, t: TaskInput, resets: list[float], seen: list[float]
                 ) -> list[float]:
    """FlightTask::_checkEkfResetCounters before ``task``'s update: its handlers for the
    counts of ``resets`` (World.aiding's reset columns) that moved from ``seen``. Returns the
    counts, which the next task starts from (FlightModeManager hands them over)."""
    counts = [resets[0], resets[3], resets[6], resets[8]]  # xy, vxy, vz, z
    if counts != seen:
        task.estimator_reset(t, EstimatorReset(
            counts[0] != seen[0], counts[1] != seen[1], counts[2] != seen[2],
            (resets[1], resets[2]), (resets[4], resets[5]), resets[7], counts[3] != seen[3],
            resets[9]))
    return counts


class TaskInput(NamedTuple):
    """One 50 Hz tick, as every task sees it (a NamedTuple, as Measurement: built every tick)."""

    now_s: float
    dt_s: float
    meas: Measurement
    yaw_rad: float
    armed: bool
    terminated: bool
    nav_state: NavState
    nav: NavContext  # the navigator's view (the auto task)


class FlightTask:
    uses_navigator = False

    def __init__(self, stage: PositionStage, params: ParamStore) -> None:
        self.stage = stage
        self.params = params

    def activate(self, t: TaskInput) -> None:
        """The state was just entered."""

    def estimator_reset(self, t: TaskInput, r: EstimatorReset) -> None:
        """The estimator reset its position or velocity (``r``), before this tick's ``update``
        (FlightTask::update → _checkEkfResetCounters): FlightTask's _ekfResetHandler*, which
        do nothing unless a task has its own."""

    def update(self, t: TaskInput) -> None:
        raise NotImplementedError
