"""How PX4 v1.15's stream classes (src/modules/mavlink/streams/<MESSAGE>.hpp) fill the fields:
C's float→int conversions (truncating), ceilf/roundf where PX4 calls them, the units PX4
really sends, and the messages PX4 skips because their uORB topic has nothing."""

import dataclasses
import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as M
from test_mavlink_support import FakeVehicle, make, of_type

from gateway.mavlink.session import LinkKind, Session
from gateway.mavlink.streams import STREAMS_BY_ID
from gateway.testing import Sim
from vehicles.types import BatteryState, GeoPoint, HomePosition, NavState, VehicleStatus


class BatteryVehicle(FakeVehicle):
    """A FakeVehicle whose battery and status extras a test sets."""

    def __init__(self, battery: BatteryState, **extra) -> None:
        super().__init__()
        self.battery = battery
        self.extra = extra

    @property
    def status(self) -> VehicleStatus:
        st = super().status
        return dataclasses.replace(st, battery=self.battery, extra={**st.extra, **self.extra})


def _session(vehicle, kind=LinkKind.API, boot_unix_s=None):
    from test_mavlink_support import Client
    session = Session(vehicle, kind, now_s=0.0, boot_unix_s=boot_unix_s)
    return session, Client(session)


def test_sys_status_battery_is_truncated_and_its_remaining_ceiled():
    """SYS_STATUS.hpp: voltage_filtered_v * 1000 and current_filtered_a * 100 as C converts them,
    battery_remaining = ceilf(remaining * 100) (computed in float32: 0.9f * 100 is 90)."""
    vehicle = BatteryVehicle(BatteryState(16.2999, 12.3456, 0.501, 10.0, 4))
    vehicle.become_ready()
    _, client = _session(vehicle)
    ss = of_type(client.run_until(0.001), "SYS_STATUS")[0]
    assert (ss.voltage_battery, ss.current_battery, ss.battery_remaining) == (16299, 1234, 51)
    vehicle.battery = BatteryState(16.2, 0.5, 0.9, 12.0, 4)
    ss = of_type(client.run_until(1.001), "SYS_STATUS")[-1]
    assert ss.battery_remaining == 90
    vehicle.battery = BatteryState(1.5, 0.5, 0.0, 12.0, 4)  # under 2.1 V: no battery
    ss = of_type(client.run_until(2.001), "SYS_STATUS")[-1]
    assert (ss.voltage_battery, ss.current_battery, ss.battery_remaining) == (65535, -1, -1)


def test_battery_status_reports_the_total_voltage_in_the_first_cell():
    """lib/battery never fills voltage_cell_v, so BATTERY_STATUS.hpp puts the whole voltage
    in voltages[0] (the rest unknown); current and consumed are truncated, remaining roundf'd,
    the charge state below (not at) a threshold."""
    vehicle = BatteryVehicle(BatteryState(16.2999, 12.3456, 0.155, 99.9, 4))
    vehicle.become_ready()
    _, client = _session(vehicle)
    bs = of_type(client.run_until(0.001), "BATTERY_STATUS")[0]
    assert list(bs.voltages) == [16299] + [65535] * 9
    assert (bs.current_battery, bs.current_consumed, bs.battery_remaining) == (1234, 99, 16)
    assert bs.charge_state == M.MAV_BATTERY_CHARGE_STATE_OK  # 0.155 is not below BAT_LOW_THR
    assert (bs.temperature, bs.time_remaining, bs.energy_consumed) == (32767, 0, -1)
    vehicle.battery = BatteryState(70.0, 0.0, 0.15, 0.0, 20)  # over 65.534 V: two fields
    bs = of_type(client.run_until(2.001), "BATTERY_STATUS")[-1]
    assert list(bs.voltages)[:3] == [65534, 4466, 65535]
    assert bs.charge_state == M.MAV_BATTERY_CHARGE_STATE_OK  # at BAT_LOW_THR: not below it


def test_global_position_int_truncates_as_c_converts():
    vehicle = FakeVehicle()
    vehicle.become_ready()
    vehicle.move_to(0.0, 0.0, -5.0067, yaw_rad=math.radians(359.996))
    vehicle.state = dataclasses.replace(vehicle.state,
                                        velocity_ned_mps=np.array([0.126, -0.126, 0.0]))
    _, client = _session(vehicle)
    gp = of_type(client.run_until(0.001), "GLOBAL_POSITION_INT")[0]
    assert (gp.vx, gp.vy) == (12, -12)  # rounding gave 13, -13
    assert gp.relative_alt == 5006 and gp.alt == 493006
    assert gp.hdg == 35999  # rounding gave 36000, wrapped to 0


def test_vfr_hud_multicopter_has_no_airspeed_and_truncates():
    """VFR_HUD.hpp: airspeed_validated (fixed wings only) is 0 on a quad; the heading in
    degrees and the throttle in percent are truncated."""
    vehicle = BatteryVehicle(BatteryState(16.2, 0.5, 0.9, 12.0, 4), thrust_norm=0.7379)
    vehicle.become_ready()
    vehicle.armed = True
    vehicle.move_to(0.0, 0.0, -5.0, yaw_rad=math.radians(12.9))
    vehicle.state = dataclasses.replace(vehicle.state, velocity_ned_mps=np.array([3.0, 4.0, 0.0]))
    _, client = _session(vehicle)
    hud = of_type(client.run_until(0.001), "VFR_HUD")[0]
    assert hud.airspeed == 0.0 and hud.groundspeed == pytest.approx(5.0)
    assert (hud.heading, hud.throttle) == (12, 73)


def test_home_position_truncates_lat_lon_alt():
    vehicle = FakeVehicle()
    vehicle.become_ready()
    home = GeoPoint(47.39774269, 8.54559469, 488.0009)
    vehicle.home = HomePosition(home, (0.0, 0.0, 0.0), 0.0)
    _, client = _session(vehicle)
    hp = of_type(client.run_until(0.001), "HOME_POSITION")[0]
    assert (hp.latitude, hp.longitude, hp.altitude) == (473977426, 85455946, 488000)


def test_orbit_execution_status_truncates_the_centre():
    from vehicles.orbit import OrbitStatus
    vehicle = FakeVehicle()
    vehicle.become_ready()
    vehicle.orbit_status = OrbitStatus(-20.0, (5.0, 6.0), -12.0)
    _, client = _session(vehicle)
    o = of_type(client.run_until(0.001), "ORBIT_EXECUTION_STATUS")[0]
    g = vehicle.origin.offset_ned(5.0, 6.0, -12.0)
    assert (o.x, o.y) == (int(g.lat_deg * 1e7), int(g.lon_deg * 1e7))


def test_system_time_is_skipped_without_a_unix_time():
    """SYSTEM_TIME.hpp sends nothing while the real-time clock is before 2001."""
    vehicle = FakeVehicle()
    _, client = _session(vehicle)
    assert of_type(client.run_until(3.0), "SYSTEM_TIME") == []
    _, client = _session(FakeVehicle(), boot_unix_s=1.7e9)
    st = of_type(client.run_until(3.0), "SYSTEM_TIME")
    assert len(st) == 3 and st[0].time_unix_usec == 1_700_000_000_000_000


def test_current_mode_is_streamed_with_the_standard_and_the_intended_mode():
    """CURRENT_MODE.hpp (PX4 SITL's development dialect) at 0.5 Hz on both links: standard
    mode from getStandardModeFromNavState (RTL 5, mission 7, land 8, takeoff 9, others 0),
    the custom modes of nav_state and of the user's intention."""
    from gateway.mavlink.modes import heartbeat_modes
    vehicle = BatteryVehicle(BatteryState(16.2, 0.5, 0.9, 12.0, 4),
                             user_nav_state=NavState.AUTO_MISSION)
    vehicle.nav_state = NavState.AUTO_RTL  # a failsafe flies RTL; the user chose the mission
    for kind in LinkKind:
        _, client = _session(vehicle, kind)
        cm = of_type(client.run_until(10.0), "CURRENT_MODE")
        assert len(cm) == 5
        assert (cm[0].standard_mode, cm[0].custom_mode, cm[0].intended_custom_mode) == (
            5, heartbeat_modes(NavState.AUTO_RTL, False)[1],
            heartbeat_modes(NavState.AUTO_MISSION, False)[1])
    vehicle.nav_state = vehicle.extra["user_nav_state"] = NavState.POSCTL
    _, client = _session(vehicle)
    assert of_type(client.run_until(0.001), "CURRENT_MODE")[0].standard_mode == 0


@pytest.mark.parametrize("name, gcs_hz, api_hz", [
    ("GPS_GLOBAL_ORIGIN", 1.0, 1.0),
    ("RC_CHANNELS", 20.0, 20.0),  # px4-rc.mavlink: 20 Hz on the GCS link
    ("DISTANCE_SENSOR", 0.5, 10.0),
    ("CURRENT_MODE", 0.5, 0.5),
    ("AVAILABLE_MODES", 0.3, 0.3),  # its stream sends nothing until the mode list changes
    ("GPS_RAW_INT", 5.0, -1.0),  # onboard: unlimited, every fix of sensor_gps_sim (8 Hz)
])
def test_default_rates_are_configure_streams_to_default(name, gcs_hz, api_hz):
    from pymavlink.dialects.v20 import development
    spec = STREAMS_BY_ID[getattr(development, f"MAVLINK_MSG_ID_{name}")]
    assert (spec.gcs_hz, spec.api_hz) == (gcs_hz, api_hz)


def test_a_lockstep_vehicle_sends_no_wind_cov_and_the_current_mode():
    with Sim(1) as sim:
        sim.advance(5.0)
        api = sim.api()
        assert api.messages("WIND_COV") == []  # no drag fusion: EKF2 publishes no wind
        assert api.messages("UTM_GLOBAL_POSITION") == []
        cm = api.messages("CURRENT_MODE")
        hb = api.last("HEARTBEAT")
        assert len(cm) >= 2 and cm[-1].custom_mode == hb.custom_mode
        assert api.last("HEARTBEAT").system_status == (3 if sim.status().prearm_ok else 0)


def test_gcs_link_reports_pxs_rates_for_streams_without_data():
    vehicle, session, client = make(LinkKind.GCS)
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)
    assert got[0].interval_us == 1_000_000


class OffsetSensorsVehicle(FakeVehicle):
    """A FakeVehicle whose barometer reads 2 m high and whose last GPS fix is 20 ms old."""

    @property
    def sensors(self) -> list[float]:
        from vehicles import estimation as est
        s = super().sensors
        s[est.S_BARO_DOWN] -= 2.0
        return s

    @property
    def estimator(self) -> list[float]:
        from vehicles import estimation as est
        e = super().estimator
        e[est.E_GPS_AGE] = 0.02
        return e


def test_gps_raw_int_time_is_the_fixs_and_altitude_monotonic_the_barometers():
    """GPS_RAW_INT.hpp: time_usec = sensor_gps.timestamp (the fix's); ALTITUDE.hpp:
    altitude_monotonic = vehicle_air_data.baro_alt_meter, altitude_amsl the estimate's."""
    vehicle = OffsetSensorsVehicle()
    vehicle.become_ready()
    vehicle.move_to(0.0, 0.0, -10.0)
    _, client = _session(vehicle)
    msgs = client.run_until(0.5)
    gps, alt = of_type(msgs, "GPS_RAW_INT")[-1], of_type(msgs, "ALTITUDE")[-1]
    assert abs(gps.time_usec - (375_000 - 20_000)) <= 1  # sent at 0.375 s (8 Hz), 20 ms old
    assert alt.altitude_amsl == pytest.approx(vehicle.origin.alt_amsl_m + 10.0)
    # baro_alt_meter: the gz barometer's pressure through PX4's getAltitudeFromPressure
    assert alt.altitude_monotonic == pytest.approx(vehicle.origin.alt_amsl_m + 12.0, abs=0.2)
    assert math.isnan(alt.altitude_terrain) and math.isnan(alt.bottom_clearance)


def test_home_position_time_is_when_home_was_set():
    """HOME_POSITION.hpp: time_usec = home_position.timestamp, the moment home was set (at the
    first position fix, then at each arming), not the sending instant."""
    with Sim(1) as sim:
        api = sim.api()
        assert sim.run_until(lambda: sim.status().home is not None, timeout_s=10)
        set_at_s = sim.now
        sim.advance(5.0)
        homes = api.messages("HOME_POSITION")
        set_us = homes[0].time_usec
        assert len(homes) >= 2 and {h.time_usec for h in homes} == {set_us}
        assert set_us <= set_at_s * 1e6
        assert api.arm() == 0
        sim.advance(2.5)
        assert api.last("HOME_POSITION").time_usec > set_us  # set again on arming


def test_open_drone_id_location_and_system_as_px4_fills_them():
    """OPEN_DRONE_ID_LOCATION.hpp / OPEN_DRONE_ID_SYSTEM.hpp at 1 Hz on both links, from
    sensor_gps_sim's fix (eph 0.9 m: 1 m class, epv 1.78 m: 3 m, s_variance 0.4 m/s: 1 m/s; no
    UTC time), the barometer, home and the land detector."""
    vehicle = FakeVehicle()
    vehicle.become_ready()
    vehicle.move_to(0.0, 0.0, -10.0)
    vehicle.landed_state = vehicle.landed_state.IN_AIR
    vehicle.state = dataclasses.replace(vehicle.state,
                                        velocity_ned_mps=np.array([-1.0, -1.0, 0.555]))
    for kind in LinkKind:
        _, client = _session(vehicle, kind)
        msgs = client.run_until(2.5)
        loc, sys_ = of_type(msgs, "OPEN_DRONE_ID_LOCATION"), of_type(msgs, "OPEN_DRONE_ID_SYSTEM")
        assert len(loc) == len(sys_) == 3
    loc, sys_ = loc[-1], sys_[-1]
    assert loc.status == M.MAV_ODID_STATUS_AIRBORNE
    assert loc.direction == 22500  # south-west, whole degrees
    assert (loc.speed_horizontal, loc.speed_vertical) == (141, -56)  # truncated; roundf
    assert (loc.horizontal_accuracy, loc.vertical_accuracy, loc.speed_accuracy) == (
        M.MAV_ODID_HOR_ACC_1_METER, M.MAV_ODID_VER_ACC_3_METER,
        M.MAV_ODID_SPEED_ACC_1_METERS_PER_SECOND)
    assert loc.altitude_geodetic == 498.0 and loc.height == pytest.approx(10.0)
    assert loc.altitude_barometric == pytest.approx(498.0, abs=0.2)  # baro_alt_meter
    assert loc.barometer_accuracy == M.MAV_ODID_VER_ACC_150_METER
    assert (loc.timestamp, loc.timestamp_accuracy) == (65535.0, 0)  # no UTC time in SITL
    assert (sys_.operator_latitude, sys_.operator_longitude) == (
        int(vehicle.origin.lat_deg * 1e7), int(vehicle.origin.lon_deg * 1e7))
    assert (sys_.area_count, sys_.area_radius, sys_.area_ceiling, sys_.area_floor) == (
        1, 0, -1000.0, -1000.0)
    assert sys_.operator_altitude_geo == pytest.approx(488.0)
    assert sys_.timestamp == 2748666496  # (uint32_t)(0 / 1e6 - 1546300800) on x86-64
    vehicle.failsafe = vehicle.armed = True
    _, client = _session(vehicle)
    assert of_type(client.run_until(0.001), "OPEN_DRONE_ID_LOCATION")[0].status == \
        M.MAV_ODID_STATUS_EMERGENCY


def test_open_drone_id_system_waits_for_home():
    _, client = _session(FakeVehicle())
    msgs = client.run_until(2.0)
    assert of_type(msgs, "OPEN_DRONE_ID_SYSTEM") == []
    loc = of_type(msgs, "OPEN_DRONE_ID_LOCATION")[-1]
    assert loc.height == -1000.0 and loc.status == M.MAV_ODID_STATUS_GROUND
