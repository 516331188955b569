"""Position and Altitude modes' other MPC_POS_MODE values, after PX4 v1.15.2: 3,
FlightTaskManualPositionSmoothVel and its horizontal smoothing (ManualVelocitySmoothingXY, with
ManualVelocitySmoothingXYTest's cases); 0, FlightTaskManualPosition and FlightTaskManualAltitude."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.unit.test_vehicles_flight import Sim, take_off
from tests.unit.test_vehicles_manual import CENTRED, fly
from vehicles.control.manual_velocity_smoothing_xy import ManualVelocitySmoothingXY
from vehicles.manual_control import ManualPosition, Sticks
from vehicles.manual_position_smooth import ManualPositionSmoothVel
from vehicles.types import CommandResult, NavState


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def test_px4_set_get_and_current_state():
    s = ManualVelocitySmoothingXY()
    s.set_limits(11.0, 7.0, 5.0)  # setGet
    t = s.trajectories[0]
    assert (t.max_jerk, t.max_accel, t.max_vel) == (11.0, 7.0, 5.0)
    s.set_current_velocity((11.0, 13.0))  # getCurrentState
    assert (s.j, s.a, s.v, s.position_locked) == ((0.0, 0.0), (0.0, 0.0), (11.0, 13.0),
                                                  (0.0, 0.0))


def test_both_axes_arrive_together_and_the_position_locks_once_stopped():
    s = ManualVelocitySmoothingXY()
    s.reset((0.0, 0.0), (0.0, 0.0), (0.0, 0.0))
    s.set_limits(8.0, 5.0, 10.0)
    seen = []
    for _ in range(200):  # 4 s at 50 Hz towards (3, 4) m/s
        s.update(0.02, (3.0, 4.0))
        s.position_estimate = s.x
        seen.append(s.v)
    assert math.isnan(s.position_locked[0])  # moving: no position setpoint
    # time-synchronised: both axes reach their targets at the same tick
    done_x = next(i for i, v in enumerate(seen) if abs(v[0] - 3.0) < 1e-3)
    done_y = next(i for i, v in enumerate(seen) if abs(v[1] - 4.0) < 1e-3)
    assert abs(done_x - done_y) <= 1
    assert s.v == pytest.approx((3.0, 4.0), abs=1e-3)
    for _ in range(200):
        s.update(0.02, (0.0, 0.0))
        s.position_estimate = s.x
    assert s.lock_active and s.position_locked == pytest.approx(s.x)


def _position_mode(sim, mode):
    sim.v.params.set("MPC_POS_MODE", mode)
    take_off(sim)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.POSCTL) is CommandResult.ACCEPTED


def test_mode_3_flies_the_sticks_as_smoothed_velocity(sim):
    _position_mode(sim, 3)
    start = sim.v.state.position_ned_m.copy()
    fly(sim, 3.0, CENTRED)
    task = sim.v._autopilot.tasks.by_state[NavState.POSCTL].task
    assert isinstance(task, ManualPositionSmoothVel)
    assert np.linalg.norm(sim.v.state.position_ned_m - start) < 0.3
    fly(sim, 6.0, Sticks(pitch=1.0))  # full forward: MPC_VEL_MANUAL at MPC_ACC_HOR_MAX
    assert sim.v.state.velocity_ned_mps[0] == pytest.approx(10.0, abs=0.5)
    fly(sim, 9.0, CENTRED)  # release: the smoothing brakes, then the position locks
    assert np.linalg.norm(sim.v.state.velocity_ned_mps) < 0.2
    assert task.smoothing_xy.lock_active
    held = sim.v.state.position_ned_m.copy()
    fly(sim, 2.0, CENTRED)
    assert np.linalg.norm(sim.v.state.position_ned_m - held) < 0.2


def test_changing_mpc_pos_mode_in_flight_switches_the_task_from_the_last_setpoint(sim):
    _position_mode(sim, 4)
    pt = sim.v._autopilot.tasks.by_state[NavState.POSCTL]
    fly(sim, 3.0, Sticks(pitch=1.0))
    assert isinstance(pt.task, ManualPosition)
    v_before = sim.v.state.velocity_ned_mps[0]
    sim.v.params.set("MPC_POS_MODE", 3)
    fly(sim, 0.1, Sticks(pitch=1.0))
    assert isinstance(pt.task, ManualPositionSmoothVel)
    # the smoothing took over at the last setpoint's velocity: no brake, no jump
    assert sim.v.state.velocity_ned_mps[0] >= v_before - 0.3
    assert sim.v.status.nav_state is NavState.POSCTL


def test_mode_0_position_flies_the_sticks_as_velocity_setpoints(sim):
    """FlightTaskManualPosition: the stick's velocity as the setpoint (no smoothing), the
    position locked once the sticks are centred and the vehicle slower than MPC_HOLD_MAX_XY."""
    from vehicles.manual_direct import ManualPositionDirect

    _position_mode(sim, 0)
    fly(sim, 1.0, CENTRED)
    task = sim.v._autopilot.tasks.by_state[NavState.POSCTL].task
    assert isinstance(task, ManualPositionDirect)
    fly(sim, 0.5, Sticks(pitch=1.0))
    sp = sim.v._autopilot.stage.task_setpoint
    assert sp.velocity_ned_mps[0] == pytest.approx(10.0)  # MPC_VEL_MANUAL at once
    assert math.isnan(sp.position_ned_m[0]) and math.isnan(sp.acceleration_ned_mps2[0])
    fly(sim, 6.0, Sticks(pitch=1.0))
    assert sim.v.state.velocity_ned_mps[0] == pytest.approx(10.0, abs=0.5)
    fly(sim, 8.0, CENTRED)
    assert np.linalg.norm(sim.v.state.velocity_ned_mps) < 0.2
    held = sim.v.state.position_ned_m.copy()
    fly(sim, 2.0, CENTRED)
    assert np.linalg.norm(sim.v.state.position_ned_m - held) < 0.2


def test_mode_0_altitude_climbs_at_the_stick_rate_and_locks(sim):
    from vehicles.manual_direct import ManualAltitudeDirect

    sim.v.params.set("MPC_POS_MODE", 0)
    take_off(sim)
    sim.v.manual_control(sim.t, CENTRED)
    assert sim.v.set_nav_state(sim.t, NavState.ALTCTL) is CommandResult.ACCEPTED
    fly(sim, 1.0, CENTRED)
    assert isinstance(sim.v._autopilot.tasks.by_state[NavState.ALTCTL].task,
                      ManualAltitudeDirect)
    assert fly(sim, 15.0, Sticks(throttle=1.0), until=lambda: sim.v.state.position_ned_m[2] < -12)
    fly(sim, 1.0, Sticks(throttle=1.0))
    assert sim.v.state.velocity_ned_mps[2] == pytest.approx(-3.0, abs=0.3)  # MPC_Z_VEL_MAX_UP
    fly(sim, 4.0, CENTRED)
    z = sim.v.state.position_ned_m[2]
    fly(sim, 3.0, CENTRED)
    assert abs(sim.v.state.position_ned_m[2] - z) < 0.2
    assert abs(sim.v.state.velocity_ned_mps[2]) < 0.1
