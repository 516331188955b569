"""How the auto task takes over, after PX4 v1.15.2's FlightModeManager::switchTask and
FlightTaskAuto::activate / reActivate:

- switchTask hands the new task the last trajectory setpoint of the task that ran before
  (FlightTask::getTrajectorySetpoint), or the empty (all NaN) one when no task ran (Offboard,
  Stabilized, Acro, Manual); a mode that maps to the task already running (Mission, Hold,
  Return, Takeoff, Land are all FlightTaskAuto) activates nothing.
- FlightTaskAuto::activate resets _position_smoothing from that setpoint's position, velocity
  and acceleration, each non-finite component from the vehicle's position and velocity, or
  zero acceleration; the heading slews on from its yaw (_yaw_sp_prev), else the vehicle's.
- Until the takeoff ramps FlightModeManager re-activates the task after every update
  (FlightTaskAuto::reActivate: activate with the empty setpoint but for the vertical velocity).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from tests.unit.test_vehicles_manual import fly
from vehicles.airframe import X500
from vehicles.autopilot import Autopilot
from vehicles.control.takeoff import RAMPUP
from vehicles.control.velocity_smoothing import A, V, X
from vehicles.flight_tasks import TaskInput
from vehicles.manual_control import Sticks
from vehicles.params import ParamStore
from vehicles.types import PX4_SITL_HOME, CommandResult, Measurement, NavState

CENTRED = Sticks()


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def _spy(sim):
    """Record the smoothing's state right after every auto-task activation (the autopilot calls
    ``activate`` on every state entered; the auto task acts only after another task), and what
    the Position and Altitude tasks last returned."""
    ap = sim.v._autopilot
    st, auto = ap.stage, ap.tasks.auto
    activations: list[dict] = []
    last: dict = {}
    activate = auto.activate

    def spied_activate(t):
        if auto.setpoint is not None:  # called on every entered state, acts after other tasks
            activate(t)
            return
        activate(t)
        axes = st.trajectory.smoothing.axes
        activations.append({"pos": axes[:, X].copy(), "vel": axes[:, V].copy(),
                            "acc": axes[:, A].copy(), "yaw_sp": st.yaw_sp,
                            "meas_pos": np.array(t.meas.position_ned_m),
                            "meas_vel": np.array(t.meas.velocity_ned_mps),
                            "sp": last.get("sp"), "state": t.nav_state})

    auto.activate = spied_activate
    for state in (NavState.POSCTL, NavState.ALTCTL):
        task = ap.tasks.by_state[state].task
        update = task.update

        def spied_update(*args, _update=update):
            sp = _update(*args)
            last["sp"] = sp
            return sp

        task.update = spied_update
    return activations


def test_hold_from_position_mode_starts_from_its_last_setpoint(sim):
    """Entering Hold while accelerating in Position mode: the smoothing starts from Position
    mode's (FlightTaskManualAcceleration's) velocity and acceleration setpoints and its locked
    altitude, the horizontal position (NaN there while moving) from the vehicle."""
    take_off(sim)
    activations = _spy(sim)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    fly(sim, 1.5, Sticks(pitch=1.0))  # full forward: accelerating north
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    sim.run(0.05)
    assert len(activations) == 1
    a = activations[0]
    sp = a["sp"]
    assert a["state"] is NavState.AUTO_LOITER
    assert math.isnan(sp.position_ned_m[0]) and math.isfinite(sp.position_ned_m[2])
    # the velocity setpoint leads the vehicle while it accelerates: they differ
    assert sp.velocity_ned_mps[0] - a["meas_vel"][0] > 0.2
    np.testing.assert_allclose(a["vel"], sp.velocity_ned_mps)
    np.testing.assert_allclose(a["acc"][:2], sp.acceleration_ned_mps2[:2])
    assert sp.acceleration_ned_mps2[0] > 1.0 and a["acc"][2] == 0.0  # z: NaN → 0
    np.testing.assert_allclose(a["pos"][:2], a["meas_pos"][:2])
    assert a["pos"][2] == sp.position_ned_m[2]
    assert a["yaw_sp"] == sp.yaw_rad


def test_hold_from_altitude_mode_takes_the_vehicles_horizontal_velocity(sim):
    """FlightTaskManualAltitude has no horizontal velocity setpoint (NaN): the smoothing takes
    the vehicle's, and the tilt's acceleration setpoint."""
    take_off(sim)
    activations = _spy(sim)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.ALTCTL) is CommandResult.ACCEPTED
    fly(sim, 1.0, Sticks(pitch=0.5))
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    sim.run(0.05)
    a = activations[0]
    sp = a["sp"]
    np.testing.assert_allclose(a["vel"][:2], a["meas_vel"][:2])
    assert a["vel"][2] == sp.velocity_ned_mps[2]
    np.testing.assert_allclose(a["acc"][:2], sp.acceleration_ned_mps2[:2])
    assert sp.acceleration_ned_mps2[0] > 1.0


def test_hold_after_yawing_in_position_mode_keeps_position_modes_heading(sim):
    """_yaw_sp_prev comes from the last setpoint's yaw: the heading turned in Position mode, not
    the auto task's from before it."""
    take_off(sim)
    activations = _spy(sim)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    yaw0 = sim.v.state.euler_rad()[2]
    fly(sim, 1.0, Sticks(yaw=1.0))  # about 150°: MPC_MAN_Y_MAX (2 s would wrap round)
    fly(sim, 2.0, CENTRED)
    yaw1 = sim.v.state.euler_rad()[2]
    assert abs(math.remainder(yaw1 - yaw0, math.tau)) > 1.0
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    sim.run(0.05)
    assert activations[0]["yaw_sp"] == activations[0]["sp"].yaw_rad
    sim.run(3.0)  # Hold keeps the heading it was entered with
    assert abs(math.remainder(sim.v.state.euler_rad()[2] - yaw1, math.tau)) < 0.1


def test_auto_to_auto_does_not_activate_again(sim):
    """Takeoff → Hold → Return → Hold: one FlightTaskAuto throughout (switchTask returns at
    once for the running task): the smoothing flies on through every switch."""
    activations = _spy(sim)
    sim.run(1.2)
    assert sim.v.arm(sim.t) is CommandResult.ACCEPTED
    n = len(activations)
    assert sim.v.takeoff(sim.t) is CommandResult.ACCEPTED
    assert sim.run(15.0, until=lambda: sim.v.status.nav_state is NavState.AUTO_LOITER)
    sim.run(2.0)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_RTL) is CommandResult.ACCEPTED
    sim.run(1.0)
    st = sim.v._autopilot.stage
    before = st.trajectory.smoothing.axes[:, V].copy()
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_LOITER) is CommandResult.ACCEPTED
    sim.run(0.02)
    assert len(activations) == n
    # one tick on from where Return left it, not from the vehicle
    assert np.abs(st.trajectory.smoothing.axes[:, V] - before).max() < 0.2


def test_auto_after_offboard_starts_from_the_vehicle():
    """No flight task runs in Offboard (FlightTaskIndex::None): the auto task gets the empty
    setpoint and starts at the vehicle's position and velocity with zero acceleration."""
    ap = Autopilot(ParamStore(), X500, PX4_SITL_HOME, 0.004, name="vehicle 1")
    st = ap.stage
    st.task_setpoint = None
    meas = Measurement((1.0, 2.0, -10.0), (3.0, -1.0, 0.5), (1.0, 0.0, 0.0, 0.0),
                       (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    st.trajectory.reset((9.0, 9.0, 9.0), (9.0, 9.0, 9.0), (9.0, 9.0, 9.0))
    ap.tasks.auto.setpoint = None
    ap.tasks.auto.activate(TaskInput(0.0, 0.02, meas, 0.3, True, False, NavState.AUTO_LOITER,
                                     None))
    axes = st.trajectory.smoothing.axes
    assert axes[:, X].tolist() == [1.0, 2.0, -10.0]
    assert axes[:, V].tolist() == [3.0, -1.0, 0.5]
    assert axes[:, A].tolist() == [0.0, 0.0, 0.0]
    assert st.yaw_sp == 0.3



def test_heading_setpoint_follows_the_vehicle_on_the_ground_until_the_takeoff_ramps(sim):
    """Armed with a goto 30 m east at 10 m: during COM_SPOOLUP_TIME the task wants to take off
    but is re-activated after every update, and activate's _yaw_sp_prev is then the vehicle's
    heading; the turn towards the target (MPC_YAW_MODE 0, at MPC_YAWRAUTO_MAX 45 deg/s) starts
    from the vehicle's heading when the ramp starts, not a second of slewing ahead of it."""
    sim.run(1.2)
    v = sim.v
    st = v._autopilot.stage
    g = v.origin.offset_ned(0.0, 30.0, -10.0)
    assert v.arm(sim.t) is CommandResult.ACCEPTED
    assert v.goto(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m) is CommandResult.ACCEPTED
    spooling = 0
    for _ in range(1000):
        sim.run(0.004)
        if st.takeoff.state >= RAMPUP:
            break
        spooling += 1
        assert st.yaw_sp == pytest.approx(v.state.euler_rad()[2], abs=1e-3)
    assert spooling > 200  # 1 s of 4 ms physics steps
    # the ramp's first tick re-activated too (the state published before it was not RAMPUP)
    assert st.yaw_sp == pytest.approx(v.state.euler_rad()[2], abs=1e-3)
    sim.run(1.0)  # then it slews from there: 50 ticks of 0.9 deg
    assert math.remainder(st.yaw_sp - v.state.euler_rad()[2], math.tau) == pytest.approx(
        math.radians(45.0), abs=math.radians(3.0))
