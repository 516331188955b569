"""The flight-task table and the autopilot's step contract: ``Autopilot.step(measurement, t)``
returns the inner loop's command; between 50 Hz ticks a command comes only when one is due."""

from __future__ import annotations

import math

from vehicles.airframe import X500
from vehicles.autopilot import Autopilot
from vehicles.flight_tasks import AutoTask, FlightTask, make_tasks
from vehicles.inner_loop import MODE_FLY, MODE_IDLE, MODE_OFF, InnerCommand
from vehicles.params import ParamStore
from vehicles.types import PX4_SITL_HOME, CommandResult, Measurement, NavState

AT_REST = Measurement((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                      (0.0, 0.0, 0.0))


def autopilot() -> Autopilot:
    return Autopilot(ParamStore(), X500, PX4_SITL_HOME, 0.004, name="vehicle 1")


def test_every_navigation_state_has_a_flight_task():
    ap = autopilot()
    table = ap.tasks.by_state
    assert set(table) == set(NavState)
    assert all(isinstance(task, FlightTask) for task in table.values())
    # The navigator's states share the auto task; the rest have their own kinds.
    for state in (NavState.AUTO_MISSION, NavState.AUTO_LOITER, NavState.AUTO_RTL,
                  NavState.AUTO_TAKEOFF, NavState.AUTO_LAND):
        assert isinstance(table[state], AutoTask)
    for state in (NavState.MANUAL, NavState.STAB, NavState.ACRO, NavState.ALTCTL,
                  NavState.POSCTL, NavState.OFFBOARD, NavState.TERMINATION, NavState.ORBIT,
                  NavState.AUTO_FOLLOW_TARGET, NavState.DESCEND):
        assert not table[state].uses_navigator, state


def test_make_tasks_builds_one_table_per_autopilot():
    a, b = autopilot(), autopilot()
    assert a.tasks.by_state[NavState.ORBIT] is not b.tasks.by_state[NavState.ORBIT]
    assert callable(make_tasks)


def test_step_returns_the_command_and_poll_only_what_is_due():
    ap = autopilot()
    first = ap.step(AT_REST, 0.0)
    assert isinstance(first, InnerCommand)
    assert first.mode == MODE_OFF and first.landed
    assert first.gains is not None  # the inner loop takes the gains once, at the start
    assert ap.poll(0.004) is None  # nothing changed between ticks
    for k in range(1, 60):  # GPS and the EKF settle, prearm checks pass
        ap.step(AT_REST, k * 0.02)
    assert ap.arm(1.2, AT_REST) is CommandResult.ACCEPTED
    armed = ap.poll(1.204)  # an arm between ticks: the motors spin up at the next step
    assert armed is not None and armed.mode == MODE_IDLE and armed.gains is None
    assert ap.poll(1.208) is None
    ap.params.set("MC_ROLLRATE_P", 0.2)
    regained = ap.poll(1.212)
    assert regained is not None and regained.gains is not None
    assert ap.home is not None and ap.home.position_ned_m == (0.0, 0.0, 0.0)


def test_takeoff_flies_and_the_command_says_so():
    ap = autopilot()
    for k in range(60):
        ap.step(AT_REST, k * 0.02)
    assert ap.arm(1.2, AT_REST) is CommandResult.ACCEPTED
    assert ap.takeoff(1.2) is CommandResult.ACCEPTED
    cmd = ap.step(AT_REST, 1.22)
    # spooling up (COM_SPOOLUP_TIME): PX4's floor of the minimum thrust, no more
    assert cmd.mode == MODE_FLY and cmd.thrust_norm == 1e-3
    thrusts = [ap.step(AT_REST, 1.22 + 0.02 * k).thrust_norm for k in range(1, 250)]
    assert max(thrusts) > 0.3 and not any(math.isnan(t) for t in thrusts)  # the ramp
    assert ap.position_setpoint_ned_m() is not None
