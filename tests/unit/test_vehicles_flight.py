"""Whole vehicles in a PyBullet World: physics + autopilot, on simulated time only."""

import dataclasses

import numpy as np
import pytest

from vehicles.params import ParamStore
from vehicles.types import CommandResult, LandedState, NavState, VehicleStatus
from vehicles.world import World


class Sim:
    def __init__(self, n=1, **overrides):
        self.world = World(dt_s=0.004)
        self.vehicles = [self.world.add_vehicle(i, ParamStore({"MAV_SYS_ID": i + 1, **overrides}))
                         for i in range(n)]
        self.t = 0.0
        self.v = self.vehicles[0]

    def run(self, seconds, until=None):
        for _ in range(int(round(seconds / self.world.dt_s))):
            self.world.step(self.t)
            self.t = self.world.time_s
            if until is not None and until():
                return True
        return False

    def texts(self, v=None):
        return [s.text for s in (v or self.v).status_texts(0)]

    def close(self):
        self.world.close()


@pytest.fixture
def sim():
    s = Sim()
    yield s
    s.close()


def take_off(sim, v=None):
    v = v or sim.v
    sim.run(1.2)
    assert v.arm(sim.t) is CommandResult.ACCEPTED
    assert v.takeoff(sim.t) is CommandResult.ACCEPTED
    assert sim.run(15.0, until=lambda: v.status.nav_state is NavState.AUTO_LOITER)
    # PX4's takeoff ends within NAV_MC_ALT_RAD; the position loop then closes the last metres.
    assert sim.run(10.0, until=lambda: abs(v.state.velocity_ned_mps[2]) < 0.05)


def test_disarmed_vehicle_rests_still_on_the_ground(sim):
    sim.run(3.0)
    s = sim.v.state
    assert np.allclose(s.position_ned_m, 0.0, atol=2e-3)
    assert np.allclose(s.velocity_ned_mps, 0.0, atol=1e-3)
    assert abs(s.euler_rad()[2]) < 1e-5  # spawned facing north (a few µrad of settling)
    st = sim.v.status
    assert st.landed_state is LandedState.ON_GROUND and not st.armed
    assert st.nav_state is NavState.AUTO_LOITER


def test_position_valid_and_home_after_boot(sim):
    assert sim.v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED
    assert sim.v.status.home is None and not sim.v.status.position_valid
    assert "Arming denied: Resolve system health failures first\t" in sim.texts()
    sim.run(1.2)
    st = sim.v.status
    assert st.position_valid and st.prearm_ok and st.home is not None
    assert st.home.geo.alt_amsl_m == pytest.approx(sim.v.origin.alt_amsl_m, abs=0.01)


def test_status_is_the_frozen_dataclass_of_its_values(sim):
    sim.run(1.2)
    st = sim.v.status
    values = {f.name: getattr(st, f.name) for f in dataclasses.fields(VehicleStatus)}
    assert st == VehicleStatus(**values) and repr(st) == repr(VehicleStatus(**values))
    with pytest.raises(dataclasses.FrozenInstanceError):
        st.armed = True  # type: ignore[misc]
    assert sim.v.status is not st and sim.v.status == st  # a new snapshot per read


def test_takeoff_reaches_default_altitude_then_holds_steady(sim):
    take_off(sim)
    assert sim.v.status.landed_state is LandedState.IN_AIR
    sim.run(3.0)
    z = -sim.v.state.position_ned_m[2]
    assert z == pytest.approx(2.5, abs=0.3)
    start = sim.v.state.position_ned_m.copy()
    worst = 0.0
    for _ in range(100):  # 10 s of Hold, sampled every 0.1 s
        sim.run(0.1)
        worst = max(worst, float(np.linalg.norm(sim.v.state.position_ned_m - start)))
    assert worst < 0.1
    texts = sim.texts()
    assert texts[:3] == ["Armed by external command\t", "Using default takeoff altitude: 2.5 m\t",
                         "Takeoff detected\t"]


def test_motors_run_through_the_gz_x500_esc_range(sim):
    """PX4's mixer output u (linear in thrust, THR_MDL_FAC 0) drives the rotor at 150 + 850·u
    rad/s (4001_gz_x500: SIM_GZ_EC_MIN 150, SIM_GZ_EC_MAX 1000): disarmed 0, armed idle 150,
    and a hover command of ~0.73 (thrust k·ω² balances the weight at ~769 rad/s)."""
    af = sim.v.airframe
    assert (af.rotor_speed_radps(0.0), af.rotor_speed_radps(1.0)) == (150.0, 1000.0)
    assert af.hover_thrust_norm == pytest.approx(0.7287, abs=1e-4)  # 2.064 kg with its rotors
    assert af.rotor_count * af.rotor_thrust_n(af.hover_thrust_norm) == pytest.approx(
        af.mass_kg * 9.80665)
    sim.run(1.2)
    assert sim.v.targets.outputs[:4] == (0.0,) * 4  # disarmed: SIM_GZ_EC_DIS 0
    assert sim.v.arm(sim.t) is CommandResult.ACCEPTED
    sim.run(0.5)
    assert sim.v.targets.outputs[:4] == pytest.approx((150.0,) * 4)  # armed, zero command
    assert sim.v.takeoff(sim.t) is CommandResult.ACCEPTED
    assert sim.run(15.0, until=lambda: sim.v.status.nav_state is NavState.AUTO_LOITER)
    sim.run(5.0)
    t = sim.v.targets
    assert t.thrust_norm == pytest.approx(af.hover_thrust_norm, abs=0.01)
    assert t.outputs[:4] == pytest.approx((769.4,) * 4, abs=10.0)
    assert all(w == int(w) for w in t.outputs)  # whole rad/s, as MixingOutput rounds them


def test_landed_state_is_takeoff_during_the_climb(sim):
    sim.run(1.2)
    sim.v.arm(sim.t)
    sim.v.takeoff(sim.t)
    sim.run(0.5)  # spooling up (COM_SPOOLUP_TIME): still on the ground, as PX4 reports it
    assert sim.v.status.landed_state is LandedState.ON_GROUND
    assert sim.run(6.0, until=lambda: -sim.v.state.position_ned_m[2] > 0.5)
    assert sim.v.status.landed_state is LandedState.TAKEOFF


def test_takeoff_altitude_param_changes_the_height():
    sim = Sim(MIS_TAKEOFF_ALT=6.0)
    try:
        take_off(sim)
        sim.run(3.0)
        assert -sim.v.state.position_ned_m[2] == pytest.approx(6.0, abs=0.3)
        assert "Using default takeoff altitude: 6.0 m\t" in sim.texts()
    finally:
        sim.close()


def test_takeoff_to_explicit_amsl_altitude(sim):
    sim.run(1.2)
    sim.v.arm(sim.t)
    sim.v.takeoff(sim.t, alt_amsl_m=sim.v.origin.alt_amsl_m + 4.0)
    sim.run(10.0)
    assert -sim.v.state.position_ned_m[2] == pytest.approx(4.0, abs=0.3)


def test_land_touches_down_and_auto_disarms_two_seconds_later(sim):
    take_off(sim)
    sim.run(2.0)
    assert sim.v.land(sim.t) is CommandResult.ACCEPTED
    assert sim.run(1.0) is False
    assert sim.v.status.landed_state is LandedState.LANDING
    assert sim.run(20.0, until=lambda: sim.v.status.landed_state is LandedState.ON_GROUND)
    landed_at = sim.t
    assert sim.run(5.0, until=lambda: not sim.v.status.armed)
    assert sim.t - landed_at == pytest.approx(2.0, abs=0.1)  # COM_DISARM_LAND
    assert sim.v.status.nav_state is NavState.AUTO_LOITER  # Land forbids arming -> Hold
    assert abs(sim.v.state.position_ned_m[2]) < 0.02
    texts = sim.texts()
    assert texts[-3:] == ["Landing at current position\t", "Landing detected\t",
                         "Disarmed by landing\t"]


def test_auto_disarm_ten_seconds_after_arming_without_takeoff(sim):
    sim.run(1.2)
    armed_at = sim.t
    sim.v.arm(sim.t)
    assert sim.run(12.0, until=lambda: not sim.v.status.armed)
    assert sim.t - armed_at == pytest.approx(10.0, abs=0.05)  # COM_DISARM_PRFLT
    assert sim.texts()[-1] == "Disarmed by auto preflight disarming\t"
    assert np.allclose(sim.v.state.position_ned_m, 0.0, atol=2e-3)  # idle never lifted it


def test_disarm_denied_in_air_unless_forced(sim):
    take_off(sim)
    assert sim.v.disarm(sim.t) is CommandResult.TEMPORARILY_REJECTED
    assert sim.v.status.armed
    assert sim.v.disarm(sim.t, forced=True) is CommandResult.ACCEPTED
    sim.run(0.5)
    assert not sim.v.status.armed
    assert sim.v.state.velocity_ned_mps[2] > 1.0  # motors off: falling


def test_manual_modes_mission_and_offboard_are_rejected_armed_and_granted_disarmed(sim):
    """UserModeIntention::change: armed, a mode must be able to run (sticks, a mission, an
    offboard signal); disarmed any is granted and arming in it is what is refused."""
    sim.run(1.2)
    modes = (NavState.MANUAL, NavState.POSCTL, NavState.ALTCTL, NavState.STAB, NavState.ACRO,
             NavState.AUTO_MISSION, NavState.OFFBOARD)
    assert sim.v.arm(sim.t) is CommandResult.ACCEPTED
    for mode in modes:
        assert sim.v.set_nav_state(sim.t, mode) is CommandResult.TEMPORARILY_REJECTED
    assert sim.v.status.nav_state is NavState.AUTO_LOITER
    assert sim.v.disarm(sim.t) is CommandResult.ACCEPTED
    for mode in modes:
        assert sim.v.set_nav_state(sim.t, mode) is CommandResult.ACCEPTED
        assert sim.v.status.nav_state is mode
        assert sim.v.arm(sim.t) is CommandResult.TEMPORARILY_REJECTED


def test_rtl_returns_home_and_lands():
    sim = Sim(RTL_RETURN_ALT=8.0, RTL_DESCEND_ALT=4.0)
    try:
        take_off(sim)
        sim.v.reposition(sim.t, (25.0, -15.0, -5.0))
        sim.run(15.0)
        assert sim.v.state.position_ned_m == pytest.approx((25.0, -15.0, -5.0), abs=0.3)
        assert sim.v.return_to_launch(sim.t) is CommandResult.ACCEPTED
        climbed = []
        assert sim.run(60.0, until=lambda: climbed.append(-sim.v.state.position_ned_m[2])
                       or not sim.v.status.armed)
        assert max(climbed) == pytest.approx(8.0, abs=0.5)
        home = np.array(sim.v.status.home.position_ned_m)
        assert np.linalg.norm(sim.v.state.position_ned_m[:2] - home[:2]) < 1.0
        assert sim.v.status.nav_state is NavState.AUTO_LOITER
        assert "Returning to launch\t" in sim.texts() and "Disarmed by landing\t" in sim.texts()
    finally:
        sim.close()


def test_two_vehicles_in_one_world_do_not_interact():
    sim = Sim(n=2)
    try:
        a, b = sim.vehicles
        spawn = sim.world.spawn_offset_ned_m
        assert np.linalg.norm(np.subtract(spawn(1), spawn(0))) >= 5
        take_off(sim, a)
        sim.run(2.0)
        assert -a.state.position_ned_m[2] == pytest.approx(2.5, abs=0.3)
        assert np.allclose(b.state.position_ned_m, 0.0, atol=2e-3)
        assert not b.status.armed and b.status_texts(0) == []
        assert a.origin != b.origin
        ga, gb = a.global_position, b.global_position
        assert a.origin.ned_of(gb)[1] == pytest.approx(5.0, abs=0.05)  # b sits 5 m east of a
        assert ga.alt_amsl_m - gb.alt_amsl_m == pytest.approx(2.5, abs=0.3)
    finally:
        sim.close()


def test_battery_drains_while_armed_but_not_below_min(sim):
    take_off(sim)
    b0 = sim.v.status.battery
    assert b0.cell_count == 4 and b0.current_a > 5.0
    sim.run(40.0)
    b1 = sim.v.status.battery
    assert b1.remaining == pytest.approx(0.5)  # SIM_BAT_MIN_PCT
    assert b1.voltage_v < b0.voltage_v and b1.consumed_mah > b0.consumed_mah


def test_state_time_and_attitude_frames(sim):
    sim.run(1.2)
    s = sim.v.state
    assert s.time_s == pytest.approx(sim.t)
    assert np.linalg.norm(s.attitude_q) == pytest.approx(1.0)
    assert s.attitude_q[0] == pytest.approx(1.0, abs=1e-6)  # level, facing north


def test_a_repeated_takeoff_command_does_not_climb_higher(sim):
    # A client retrying NAV_TAKEOFF (its ACK was lost) while the vehicle climbs: PX4 takes off to
    # MIS_TAKEOFF_ALT above home, not above the current position.
    v = sim.v
    sim.run(1.2)
    assert v.arm(sim.t) is CommandResult.ACCEPTED
    assert v.takeoff(sim.t) is CommandResult.ACCEPTED
    assert sim.run(8.0, until=lambda: -v.state.position_ned_m[2] > 0.2)  # climbing
    assert v.takeoff(sim.t) is CommandResult.ACCEPTED
    assert sim.run(15.0, until=lambda: v.status.nav_state is NavState.AUTO_LOITER)
    sim.run(3.0)
    assert abs(-v.state.position_ned_m[2] - 2.5) < 0.3


def test_battery_current_is_zero_disarmed_and_follows_thrust_armed(sim):
    sim.run(1.0)
    assert sim.v.status.battery.current_a == 0.0
    take_off(sim)
    assert sim.v.status.battery.current_a > 5.0
    consumed = sim.v.status.battery.consumed_mah
    assert sim.v.land(sim.t) is CommandResult.ACCEPTED
    assert sim.run(40.0, until=lambda: not sim.v.status.armed)
    sim.run(1.0)
    assert sim.v.status.battery.current_a == 0.0
    after = sim.v.status.battery.consumed_mah
    sim.run(2.0)
    assert sim.v.status.battery.consumed_mah == after > consumed


def test_pause_stops_at_the_braking_point_without_flying_back():
    """QGC's Pause (DO_REPOSITION, all NaN) on a multicopter: Navigator::calculate_breaking_stop,
    the position moved along the course by computeBrakingDistanceFromVelocity; the vehicle
    stops there, not back at where the command found it."""
    sim = Sim()
    try:
        take_off(sim)
        v = sim.v
        far = v.origin.offset_ned(200.0, 0.0, 0.0)
        assert v.goto(sim.t, far.lat_deg, far.lon_deg, v.origin.alt_amsl_m + 5.0) \
            is CommandResult.ACCEPTED
        assert sim.run(60.0, until=lambda: v.state.position_ned_m[0] > 80.0)  # cruising
        n0, speed = v.state.position_ned_m[0], v.state.velocity_ned_mps[0]
        expected = speed * (speed / (2.0 * float(v.params["MPC_ACC_HOR"])) + 0.6)
        nan = float("nan")
        assert v.goto(sim.t, nan, nan, nan) is CommandResult.ACCEPTED
        furthest = [n0]
        sim.run(15.0, until=lambda: furthest.append(v.state.position_ned_m[0]) and False)
        stop = v.state.position_ned_m[0]
        assert stop - n0 == pytest.approx(expected, abs=1.5)
        assert max(furthest) - stop < 1.0  # no overshoot to fly back from
    finally:
        sim.close()
