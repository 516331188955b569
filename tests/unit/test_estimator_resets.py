"""Estimator resets, as EKF2 counts them and PX4's controllers take them.

EKF2 (gps_control.cpp, position_fusion.cpp, velocity_fusion.cpp): a GNSS fix after
reset_timeout_max without aiding resets the horizontal position and the velocity, counts each
(_state_reset_status.reset_count posNE, velNE, velD) and keeps the change; vehicle_local_position
publishes them (xy_, vxy_, vz_reset_counter, delta_xy, delta_vxy, delta_vz), vehicle_odometry's
reset_counter is their sum (EKF2::PublishOdometry) and ODOMETRY.hpp sends it. FlightTask's
_checkEkfResetCounters runs the task's handlers (FlightTaskAuto: the smoothing jumps to the new
estimate), and mc_pos_control's adjustSetpointForEKFResets moves a setpoint older than the
estimate by the change (an Offboard setpoint held since it came).
"""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.testing import Sim
from tests.unit.test_vehicles_estimation import drift_unaided
from vehicles import ekf_resets as rs
from vehicles import estimation as est
from vehicles.manual_control import ManualPosition
from vehicles.offboard import Offboard
from vehicles.params import ParamStore
from vehicles.plan_types import OffboardSetpoint
from vehicles.types import EstimatorReset, NavState

GPS, OFF, OK = 4, 1, 0  # MAV_CMD_INJECT_FAILURE: FAILURE_UNIT_SENSOR_GPS, FAILURE_TYPE_OFF / OK
NAN = math.nan


def test_a_gnss_reset_is_counted_with_its_change():
    """A fix fused within reset_timeout_max counts nothing; after 7 s unaided the reset counts
    the position and the velocity (north-east and down) once each, with the change each made."""
    from vehicles.physics import World
    w = World()
    w.add_vehicle(0)
    for _ in range(500):  # 2 s: past the start-up resets (test_start_up_resets_...)
        w.step(w.time_s)
    assert counts(w) == [2.0, 2.0, 2.0, 2.0]

    drift_unaided(w, 3.0)
    while w.aiding_age_s(0) > 0.0:
        w.step(w.time_s)
    # fused as usual: no reset; but the GPS height, the reference, starts again after its data
    # stopped: the height resets to it (gnss_height_control.cpp: "resetting height"), counted
    assert counts(w) == [2.0, 2.0, 2.0, 3.0]
    for _ in range(2000):
        w.step(w.time_s)
    drift_unaided(w, 7.0)
    while w.aiding_age_s(0) > 0.0:
        before = w.estimation.est[0].copy()
        w.step(w.time_s)
    after = w.estimation.est[0]
    xy_n, dx, dy, vxy_n, dvx, dvy, vz_n, dvz, z_n, _ = w.aiding(0)[1:]
    assert (xy_n, vxy_n, vz_n, z_n) == (3.0, 3.0, 3.0, 4.0)  # the height: its restart again
    # the changes the reset made (the step's own integration is a few mm)
    assert dx == pytest.approx(after[est.E_POS] - before[est.E_POS], abs=0.01)
    assert dy == pytest.approx(after[est.E_POS + 1] - before[est.E_POS + 1], abs=0.01)
    assert dx < -4.5 and dvy < -0.4
    assert dvy == pytest.approx(after[est.E_VEL + 1] - before[est.E_VEL + 1], abs=0.01)
    assert abs(dvx) < 0.2 and abs(dvz) < 0.3


def counts(w) -> list[float]:
    """World ``w``'s row 0 reset counts: posNE, velNE, velD, posD."""
    a = w.aiding(0)
    return [a[1], a[4], a[7], a[9]]


def quat_resets(w) -> float:
    return float(w.estimation.est[0][est.E_RS + rs.Q_RESET])


def test_start_up_resets_are_counted_as_ekf2_counts_them_and_the_heading_once_per_flight():
    """PX4 v1.15.2's EKF2 in SITL: the fake height and position start at its first step
    (posD, velD, posNE, velNE), then the GNSS fusion starts, about a second later: the GNSS
    height as the reference (posD), the heading's alignment (quat), the velocity and position
    reset to the fix (velNE, velD, posNE); before take-off 2, 2, 2, 2 and 1, ODOMETRY's
    reset_counter 9. Each take-off adds the in-flight heading reset 1.4 m up (quat), and
    landing nothing."""
    with Sim(params={"MIS_TAKEOFF_ALT": 5.0}) as sim:
        w = sim.vehicles[0]._world
        sim.advance(0.1)
        assert counts(w) == [1.0, 1.0, 1.0, 1.0] and quat_resets(w) == 0.0
        assert w.aiding(0)[1:] == [1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0]
        assert sim.run_until(lambda: counts(w)[0] == 2.0, timeout_s=1.5)
        assert 1.0 <= sim.now < 1.2 and counts(w) == [2.0] * 4 and quat_resets(w) == 1.0
        _, dx, dy, _, dvx, dvy, _, dvz, _, dz = w.aiding(0)[1:]
        assert 0.0 < math.hypot(dx, dy) < 1.5 and abs(dvx) + abs(dvy) + abs(dvz) < 1.0
        assert dz == 0.0
        api = sim.api(0)
        sim.advance(1.0)
        assert api.last("ODOMETRY").reset_counter == 9
        for flight in (1, 2):
            assert api.arm() == 0 and api.takeoff() == 0
            assert sim.run_until(lambda: -sim.state(0).position_ned_m[2] > 1.0, timeout_s=15)
            assert quat_resets(w) == flight
            assert sim.run_until(lambda n=flight + 1: quat_resets(w) == n, timeout_s=5)
            assert 1.3 < -sim.state(0).position_ned_m[2] < 1.9
            assert api.land() == 0
            assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=30)
            assert counts(w) == [2.0] * 4 and quat_resets(w) == flight + 1
        sim.advance(0.5)
        assert api.last("ODOMETRY").reset_counter == 11


def drift_and_reset(sim: Sim) -> float:
    """Hover in Hold, the GPS off with EKF2_NOAID_TOUT at its 10 s maximum (still aided), the
    estimate drifted 5 m north (the vehicle follows it south), the GPS back after 7.5 s
    unaided: returns when the reset came."""
    assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
    api = sim.api(0)
    assert api.arm() == 0 and api.takeoff() == 0
    assert sim.run_until(lambda: sim.status(0).nav_state is NavState.AUTO_LOITER, timeout_s=30)
    sim.advance(3.0)
    world = sim.vehicles[0]._world
    assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OFF, 0) == 0
    sim.advance(0.5)
    e, ring = world.estimation.est[0], world.estimation.ehist[0]
    e[est.E_POS] += 5.0
    ring[:, 0] += 5.0
    assert sim.run_until(lambda: world.aiding_age_s(0) > 7.5, timeout_s=10)
    assert sim.status(0).nav_state is NavState.AUTO_LOITER and sim.status(0).position_valid
    # the vehicle followed the estimate 5 m south (give or take 7.5 s of dead reckoning)
    assert sim.vehicles[0].truth.position_ned_m[0] == pytest.approx(-5.0, abs=0.6)
    assert api.command_long(M.MAV_CMD_INJECT_FAILURE, GPS, OK, 0) == 0
    assert sim.run_until(lambda: world.aiding(0)[1] >= 3.0, timeout_s=1)  # after start-up's 2
    return sim.now


def test_after_a_gnss_reset_hold_flies_back_smoothly_and_the_wire_and_log_count_it(tmp_path):
    """FlightTaskAuto::_ekfResetHandlerPositionXY / VelocityXY / VelocityZ: the smoothing
    restarts at the new estimate, so the vehicle flies back to the hold point at the
    trajectory's jerk and acceleration (without them the 5 m jump became a 4.75 m/s velocity
    setpoint at once). ODOMETRY's reset_counter and the logged counters follow."""
    with Sim(params={"MIS_TAKEOFF_ALT": 10.0, "EKF2_NOAID_TOUT": 10_000_000},
             log_dir=tmp_path) as sim:
        api = sim.api(0)
        stage = sim.vehicles[0].autopilot.stage
        since = len(api.frames)
        t_reset = drift_and_reset(sim)
        speeds: list[float] = []

        def record() -> bool:
            vx, vy, _ = stage.vel_sp
            speeds.append(math.hypot(vx, vy))
            return False

        sim.run_until(record, timeout_s=0.5)
        assert max(speeds) < 0.5
        assert sim.run_until(lambda: abs(sim.vehicles[0].truth.position_ned_m[0]) < 0.5,
                             timeout_s=10)
        counters = [(t, m.reset_counter) for t, m in api.timed_messages("ODOMETRY", since)]
        # the start-up's 9, the in-flight heading reset's 1
        assert [c for t, c in counters if t < t_reset - 0.1][-1] == 10
        # position NE, velocity NE and D, and the height (the GPS height restarting as the
        # reference resets it: posD)
        assert counters[-1][1] == 14
    import pyulog
    log = pyulog.ULog(str(sorted((tmp_path / "vehicle-1" / "log").rglob("*.ulg"))[0]))
    lpos = log.get_dataset("vehicle_local_position").data
    # from boot: the fake starts' 1, the GNSS start's 2, the reset's 3
    assert set(lpos["xy_reset_counter"]) == {1, 2, 3} and set(lpos["vz_reset_counter"]) == {1, 2, 3}
    assert lpos["delta_xy[0]"][-1] < -4.5 and lpos["vxy_reset_counter"][-1] == 3
    assert lpos["z_reset_counter"][-1] == 3
    assert lpos["heading_reset_counter"][-1] == 2 and lpos["delta_heading"][-1] == 0.0
    status = log.get_dataset("estimator_status").data
    assert [int(status[f"reset_count_{k}"][-1]) for k in ("pos_ne", "vel_ne", "vel_d", "pod_d",
                                                          "quat")] == [3, 3, 3, 3, 2]
    gpos = log.get_dataset("vehicle_global_position").data
    assert gpos["lat_lon_reset_counter"][-1] == 3 and gpos["alt_reset_counter"][-1] == 3
    assert gpos["delta_alt"][-1] == pytest.approx(-lpos["delta_z"][-1])


def test_an_offboard_setpoint_held_moves_with_the_reset():
    """adjustSetpointForEKFResets: a setpoint older than the estimate moves by delta_xy,
    delta_vxy, delta_vz, delta_z (NaN stays NaN); one received at the reset's tick does not."""
    off = Offboard()
    off.set(1.0, OffboardSetpoint(position_ned_m=(10.0, 20.0, -5.0),
                                  velocity_ned_mps=(1.0, NAN, 0.5)))
    r = EstimatorReset(True, True, True, (-2.0, 3.0), (0.5, 0.25), -0.1)
    off.shift(1.0, r)
    assert off.setpoint is not None and off.setpoint.position_ned_m == (10.0, 20.0, -5.0)
    off.shift(1.02, r)
    sp = off.setpoint
    assert sp.position_ned_m == (8.0, 23.0, -5.0)
    assert sp.velocity_ned_mps[0] == 1.5 and math.isnan(sp.velocity_ned_mps[1])
    assert sp.velocity_ned_mps[2] == pytest.approx(0.4)
    off.shift(1.04, EstimatorReset(False, False, True, (9.0, 9.0), (9.0, 9.0), 0.1))
    assert off.setpoint.position_ned_m == (8.0, 23.0, -5.0)
    assert off.setpoint.velocity_ned_mps[2] == pytest.approx(0.5)
    # a height reset (z_reset_counter): setpoint.position[2] += delta_z
    off.shift(1.06, EstimatorReset(False, False, False, (9.0, 9.0), (9.0, 9.0), 9.0, True, 0.75))
    assert off.setpoint.position_ned_m == (8.0, 23.0, -4.25)


def test_position_mode_drops_its_lock_and_takes_the_new_velocity():
    """FlightTaskManualAcceleration: StickAccelerationXY::resetPosition (no lock) on a position
    reset, resetVelocity(the estimate's) on a velocity reset; the vertical smoothing takes the
    new vertical velocity (FlightTaskManualAltitudeSmoothVel)."""
    task = ManualPosition(ParamStore())
    task.activate((0.0, 0.0, -10.0), (0.0, 0.0, 0.0), 0.0)
    task._pos_xy = (1.0, 2.0)
    task.estimator_reset((4.0, 5.0, -10.0), (0.3, -0.2, 0.1),
                         EstimatorReset(True, True, True, (3.0, 3.0), (0.3, -0.2), 0.1))
    assert all(math.isnan(v) for v in task._pos_xy)
    assert task._vel_xy == (0.3, -0.2)
    assert task.smoothing.v == 0.1
    # a height reset: the vertical smoothing takes the new height (setCurrentPosition)
    task.estimator_reset((4.0, 5.0, -12.5), (0.3, -0.2, 0.1),
                         EstimatorReset(False, False, False, (0, 0), (0, 0), 0, True, -2.5))
    assert task.smoothing.x == -12.5


def test_a_position_glitch_is_rejected_then_reset_after_twice_reset_timeout_max():
    """An estimate 20 m off the fixes (a GNSS position glitch, as EKF2 sees one): each fix's
    position fails its innovation gate (test ratio √(innovation² / (gate² · variance)) over 1,
    ESTIMATOR_STATUS's pos_horiz_ratio) and is not fused, its velocity still is (aided, no
    reset); once no position was fused for 2 × reset_timeout_max (shouldResetGpsFusion), the
    position and the velocity reset to the fix, counted once each."""
    from vehicles.physics import World
    w = World()
    w.add_vehicle(0)
    for _ in range(250):
        w.step(w.time_s)
    e, ring = w.estimation.est[0], w.estimation.ehist[0]
    assert e[est.E_RATIOS + 1] < 0.2 and e[est.E_RATIOS] < 0.5
    e[est.E_POS] += 20.0
    ring[:, 0] += 20.0
    for _ in range(int(13.5 * 250)):
        w.step(w.time_s)
        assert w.aiding_age_s(0) < 0.2  # the velocity is fused all along
    assert e[est.E_POS_AGE] > 13.0
    assert w.aiding(0)[1] == 2.0  # no reset yet but the start-up's
    assert e[est.E_RATIOS + 1] == pytest.approx(20.0 / 4.5, rel=1e-3)  # |−20 m| / (5 × 0.9 m)
    for _ in range(250):
        w.step(w.time_s)
    xy_n, dx, _, vxy_n = w.aiding(0)[1:5]
    assert (xy_n, vxy_n) == (3.0, 3.0)
    assert dx == pytest.approx(-20.0, abs=1.0)
    assert e[est.E_RATIOS + 1] < 0.3 and e[est.E_POS_AGE] < 0.2
