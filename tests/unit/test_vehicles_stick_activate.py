"""How Altitude and Position modes take over, after PX4 v1.15.2's FlightModeManager::switchTask
(the new task's ``activate`` gets the last trajectory setpoint of the task that ran before) and:

- FlightTaskManualAltitudeSmoothVel::activate: the vertical smoothing restarts from that
  setpoint's z, vz and az, each not finite from the vehicle's altitude, vertical velocity and 0;
- FlightTaskManualAcceleration::activate (Position mode): StickAccelerationXY's position lock
  is released, its velocity is the setpoint's when both horizontal components are finite (else
  the vehicle's) and its acceleration (the jerk limit's slew rates) the setpoint's when finite.

So Position mode entered from an auto flight continues from the auto task's setpoint, not from
the measured state (which lags it).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from tests.unit.test_vehicles_manual import fly
from vehicles.control.position_control import PositionSetpoint
from vehicles.control.velocity_smoothing import A, V, X
from vehicles.manual_control import ManualAltitude, ManualPosition, Sticks
from vehicles.params import ParamStore
from vehicles.types import CommandResult, NavState

CENTRED = Sticks()
ZERO3 = (0.0, 0.0, 0.0)


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def _spy(sim, state):
    """Per tick of the stick task of ``state``: the handed-over setpoint at its activation
    and the setpoints it returns."""
    ap = sim.v._autopilot
    task = ap.tasks.by_state[state].task
    seen: dict = {"activate": [], "sp": []}
    activate, update = task.activate, task.update

    def spied_activate(pos, vel, yaw, last=None):
        activate(pos, vel, yaw, last)
        seen["activate"].append({"last": last, "meas_vel": vel, "meas_pos": pos,
                                 "vel_xy": getattr(task, "_vel_xy", None),
                                 "acc_xy": getattr(task, "_acc_xy", None),
                                 "z": task.smoothing.trajectory.row[[A, V, X]].copy()})

    def spied_update(*args, **kwargs):
        sp = update(*args, **kwargs)
        seen["sp"].append(sp)
        return sp

    task.activate, task.update = spied_activate, spied_update
    return seen


def _fly_a_goto(sim):
    take_off(sim)
    v = sim.v
    g = v.origin.offset_ned(60.0, 0.0, -15.0)
    assert v.goto(sim.t, g.lat_deg, g.lon_deg, g.alt_amsl_m) is CommandResult.ACCEPTED
    sim.run(3.0)  # accelerating north and climbing
    return v._autopilot.stage


def test_position_mode_from_an_auto_flight_continues_from_the_auto_setpoint(sim):
    st = _fly_a_goto(sim)
    seen = _spy(sim, NavState.POSCTL)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED
    fly(sim, 0.05, CENTRED)
    a = seen["activate"][0]
    last = a["last"]
    assert last is not None and math.isfinite(last.velocity_ned_mps[0])
    # the auto setpoint leads the vehicle as it accelerates: they differ
    assert abs(last.velocity_ned_mps[0] - a["meas_vel"][0]) > 0.1
    assert a["vel_xy"] == pytest.approx(last.velocity_ned_mps[:2])
    assert a["acc_xy"] == pytest.approx(last.acceleration_ned_mps2[:2])
    np.testing.assert_allclose(a["z"], [last.acceleration_ned_mps2[2], last.velocity_ned_mps[2],
                                        last.position_ned_m[2]])
    # the first Position-mode setpoint is one tick on from the auto one: no jump
    first = seen["sp"][0]
    dv = np.subtract(first.velocity_ned_mps, last.velocity_ned_mps)
    assert np.abs(dv).max() < 0.2
    assert st.task_setpoint is not None


def test_altitude_mode_from_an_auto_flight_continues_its_vertical(sim):
    _fly_a_goto(sim)
    seen = _spy(sim, NavState.ALTCTL)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.ALTCTL) is CommandResult.ACCEPTED
    fly(sim, 0.05, CENTRED)
    a = seen["activate"][0]
    last = a["last"]
    assert last.velocity_ned_mps[2] < -0.5  # the auto task was climbing
    np.testing.assert_allclose(a["z"], [last.acceleration_ned_mps2[2], last.velocity_ned_mps[2],
                                        last.position_ned_m[2]])
    # the climb is braked from the auto task's speed (jerk-limited), not from the vehicle's
    assert abs(seen["sp"][0].velocity_ned_mps[2] - last.velocity_ned_mps[2]) < 0.1


def test_without_a_last_setpoint_the_tasks_start_from_the_vehicle():
    """The empty setpoint (after Stabilized, Offboard, on the ground): the vehicle's state."""
    task = ManualPosition(ParamStore())
    task.activate((1.0, 2.0, -8.0), (0.5, -0.5, -1.0), 0.0, None)
    assert task._vel_xy == (0.5, -0.5) and task._acc_xy == (0.0, 0.0)
    assert tuple(task.smoothing.trajectory.row[[A, V, X]]) == (0.0, -1.0, -8.0)
    assert math.isnan(task._pos_xy[0])


def test_non_finite_parts_fall_back_as_px4s():
    nan = math.nan
    task = ManualPosition(ParamStore())
    # a horizontal velocity with one NaN component: the vehicle's (Vector2f::isAllFinite);
    # an acceleration with one NaN: the slew rates are not forced (a new task's: zero)
    last = PositionSetpoint((nan, nan, -9.0), (2.0, nan, nan), 0.0, (1.0, nan, 0.5))
    task.activate((0.0, 0.0, -8.0), (0.3, 0.4, 0.2), 0.0, last)
    assert task._vel_xy == (0.3, 0.4) and task._acc_xy == (0.0, 0.0)
    assert tuple(task.smoothing.trajectory.row[[A, V, X]]) == (0.5, 0.2, -9.0)
    alt = ManualAltitude(ParamStore())
    alt.activate((0.0, 0.0, -8.0), ZERO3, 0.0,
                 PositionSetpoint((nan, nan, nan), (nan, nan, -0.7), 0.0, (0.0, 0.0, nan)))
    assert tuple(alt.smoothing.trajectory.row[[A, V, X]]) == (0.0, -0.7, -8.0)
