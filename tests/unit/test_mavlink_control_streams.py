"""The streams of what the controllers aim for and of the link itself, on a real vehicle in
lockstep: ATTITUDE_TARGET, POSITION_TARGET_LOCAL_NED/GLOBAL_INT, SERVO_OUTPUT_RAW (PX4 SITL's
GCS link at 50 Hz, the onboard link at 10 Hz), TIMESYNC, PING and GPS_GLOBAL_ORIGIN."""

import math

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.ci.lockstep import LOCKSTEP_EPOCH_UNIX_S, Sim
from gateway.mavlink.session import LinkKind
from tests.unit.test_testing_sim import geo, square_mission
from vehicles.plan_types import PlanResult
from vehicles.types import PX4_SITL_HOME

IGNORE_POSITION_AND_VELOCITY = 1 | 2 | 4 | 8 | 16 | 32


@pytest.fixture(scope="module")
def flight():
    """One vehicle with both links: 3 s on the ground, then 15 s into the square mission."""
    with Sim(1, links=(LinkKind.API, LinkKind.GCS)) as sim:
        gcs, api = sim.gcs(0), sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
        sim.advance(3.0)
        ground = {name: gcs.last(name) for name in (
            "ATTITUDE_TARGET", "POSITION_TARGET_LOCAL_NED", "SERVO_OUTPUT_RAW")}
        assert api.upload_mission(square_mission()) == PlanResult.ACCEPTED
        assert api.arm() == 0 and api.start_mission() == 0
        sim.advance(15.0)
        mission = {name: gcs.last(name) for name in (
            "ATTITUDE_TARGET", "POSITION_TARGET_LOCAL_NED", "POSITION_TARGET_GLOBAL_INT",
            "SERVO_OUTPUT_RAW", "LOCAL_POSITION_NED")}
        start = {name: (len(gcs.messages(name)), len(api.messages(name))) for name in (
            "ATTITUDE_TARGET", "POSITION_TARGET_LOCAL_NED", "POSITION_TARGET_GLOBAL_INT",
            "SERVO_OUTPUT_RAW", "TIMESYNC", "PING")}
        sim.advance(10.0)
        rates = {name: ((len(gcs.messages(name)) - g) / 10.0, (len(api.messages(name)) - a) / 10.0)
                 for name, (g, a) in start.items()}
        yield {"sim": sim, "gcs": gcs, "api": api, "ground": ground, "mission": mission,
               "rates": rates}


def test_rates_are_px4_sitls(flight):
    assert flight["rates"] == {
        "ATTITUDE_TARGET": (50.0, 10.0), "POSITION_TARGET_LOCAL_NED": (50.0, 10.0),
        "POSITION_TARGET_GLOBAL_INT": (1.0, 10.0), "SERVO_OUTPUT_RAW": (50.0, 10.0),
        "TIMESYNC": (0.0, 10.0), "PING": (0.1, 1.0)}


def test_on_the_ground_disarmed_the_setpoint_is_no_thrust_and_the_motors_are_off(flight):
    g = flight["ground"]
    att, pos, out = g["ATTITUDE_TARGET"], g["POSITION_TARGET_LOCAL_NED"], g["SERVO_OUTPUT_RAW"]
    assert att.thrust == 0.0 and (att.body_roll_rate, att.body_pitch_rate) == (0.0, 0.0)
    # mc_pos_control before take-off: no position or velocity, 100 m/s² down.
    assert pos.coordinate_frame == M.MAV_FRAME_LOCAL_NED
    assert pos.type_mask == IGNORE_POSITION_AND_VELOCITY
    assert math.isnan(pos.x) and math.isnan(pos.vz) and (pos.afx, pos.afy, pos.afz) == (0, 0, 100)
    assert [getattr(out, f"servo{i}_raw") for i in range(1, 17)] == [0] * 16


def test_in_the_mission_the_targets_lead_the_vehicle(flight):
    m = flight["mission"]  # 15 s after the start: on the way to the first corner
    att, pos = m["ATTITUDE_TARGET"], m["POSITION_TARGET_LOCAL_NED"]
    lpos, out = m["LOCAL_POSITION_NED"], m["SERVO_OUTPUT_RAW"]
    assert 0.6 < att.thrust < 0.9 and abs(sum(q * q for q in att.q) - 1.0) < 1e-6  # hover ~0.73
    # vehicle_local_position_setpoint: the trajectory's position, the controller's velocity and
    # acceleration setpoints (the velocity PID's output), all given.
    assert pos.type_mask == 0
    assert all(math.isfinite(a) and abs(a) < 5.0 for a in (pos.afx, pos.afy, pos.afz))
    assert math.dist((pos.x, pos.y, pos.z), (lpos.x, lpos.y, lpos.z)) < 3.0
    assert pos.vx > 1.0  # flying north to the first corner
    motors = [getattr(out, f"servo{i}_raw") for i in range(1, 5)]
    assert all(650 < m < 950 for m in motors)  # commanded rad/s: hover ~769 of 150..1000
    assert [getattr(out, f"servo{i}_raw") for i in range(5, 17)] == [0] * 12
    # The navigator's current setpoint: the first corner, 40 m north, 10 m above home.
    tgt = m["POSITION_TARGET_GLOBAL_INT"]
    lat, lon = geo(40, 0)
    assert (tgt.lat_int, tgt.lon_int) == (int(lat * 1e7), int(lon * 1e7))
    # (home: the estimated altitude at arming, which the GPS height reference moves by cm)
    assert tgt.alt == pytest.approx(PX4_SITL_HOME.alt_amsl_m + 10.0, abs=0.1)
    assert tgt.coordinate_frame == M.MAV_FRAME_GLOBAL_INT and tgt.type_mask == 0


def test_actuator_output_status_is_the_same_command_as_servo_output_raw():
    with Sim(1) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
        assert api.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL,
                                M.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS, 100_000) == 0
        assert api.arm() == 0 and api.takeoff() == 0
        sim.advance(8.0)
        # Both at 10 Hz on the same grid: the last of each come from the same instant.
        status, raw = api.last("ACTUATOR_OUTPUT_STATUS"), api.last("SERVO_OUTPUT_RAW")
        assert status.time_usec == raw.time_usec
        assert [int(a) for a in status.actuator[:4]] == [
            raw.servo1_raw, raw.servo2_raw, raw.servo3_raw, raw.servo4_raw]


def test_esc_reports_are_the_gz_bridges_esc_status():
    """ESC_INFO.hpp / ESC_STATUS.hpp on the gz bridge's esc_status: one batch of four, all
    online, PPM, no failures or temperature; esc_rpm the commanded rotor speed as
    SERVO_OUTPUT_RAW has it. 1 Hz on the GCS link, 10 Hz onboard; the frames carry mavgen's
    CRC_EXTRA (251, 10), so pymavlink's parser checked them."""
    with Sim(1, links=(LinkKind.API, LinkKind.GCS)) as sim:
        api, gcs = sim.api(0), sim.gcs(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
        assert api.arm() == 0 and api.takeoff() == 0
        t0, n_api, n_gcs = sim.now, len(api.messages("ESC_STATUS")), len(gcs.messages("ESC_INFO"))
        sim.advance(8.0)
        assert len(api.messages("ESC_STATUS")) - n_api == pytest.approx(10 * (sim.now - t0), abs=1)
        assert len(gcs.messages("ESC_INFO")) - n_gcs == pytest.approx(sim.now - t0, abs=1)
        info, status, raw = api.last("ESC_INFO"), api.last("ESC_STATUS"), api.last("SERVO_OUTPUT_RAW")
        assert (info.index, info.counter, info.count, info.connection_type, info.info) == (
            0, 0, 4, 0, 0b1111)
        assert list(info.failure_flags) == list(info.error_count) == list(info.temperature) == [0] * 4
        assert status.time_usec == info.time_usec == raw.time_usec
        assert list(status.rpm) == [raw.servo1_raw, raw.servo2_raw, raw.servo3_raw, raw.servo4_raw]
        assert min(status.rpm) > 150 and list(status.voltage) == list(status.current) == [0.0] * 4
        assert (type(info).crc_extra, type(status).crc_extra) == (251, 10)


def test_timesync_ping_and_origin(flight):
    api, gcs = flight["api"], flight["gcs"]
    ts = api.timed_messages("TIMESYNC")
    assert len(ts) > 200 and all(m.tc1 == 0 and abs(m.ts1 - t * 1e9) < 1e3 for t, m in ts)
    assert [m.seq for m in api.messages("PING")][:5] == [0, 1, 2, 3, 4]
    assert all((m.target_system, m.target_component) == (0, 0) for m in api.messages("PING"))
    for client in (api, gcs):
        origins = client.messages("GPS_GLOBAL_ORIGIN")
        assert len(origins) == 1  # once, then only if it moves
        o = origins[0]
        assert (o.latitude, o.longitude, o.altitude) == (
            round(PX4_SITL_HOME.lat_deg * 1e7), round(PX4_SITL_HOME.lon_deg * 1e7),
            round(PX4_SITL_HOME.alt_amsl_m * 1e3))
    assert api.command_long(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN) == 0
    assert len(api.messages("GPS_GLOBAL_ORIGIN")) == 2  # a request always gets it


def test_clients_answer_the_vehicles_pings_as_mavsdk_and_qgc_do(flight):
    """PX4 pings its peers (0.1 Hz on the GCS link, 1 Hz onboard); MAVSDK and QGC answer each
    request at once, and the vehicle counts the answers."""
    sim = flight["sim"]
    for kind, client in ((LinkKind.API, flight["api"]), (LinkKind.GCS, flight["gcs"])):
        stats = sim.simulation.links[(0, kind)].session.stats
        assert stats.rx_ping_replies == len(client.messages("PING")) > 0


def test_while_landing_the_global_target_is_on_the_ground():
    """PX4's land setpoint (navigator set_land_item, RTL's and a mission's land) carries an
    altitude: POSITION_TARGET_GLOBAL_INT.alt is the ground's (home's), never NaN."""
    with Sim(1) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        assert api.arm() == 0 and api.takeoff() == 0
        assert sim.run_until(lambda: sim.status(0).nav_state.name == "AUTO_LOITER", timeout_s=20)
        assert api.command_long(M.MAV_CMD_NAV_LAND, 0, 0, 0, math.nan, math.nan, math.nan,
                                math.nan) == 0
        since = len(api.frames)
        sim.advance(2.0)
        targets = api.messages("POSITION_TARGET_GLOBAL_INT", since)
        # (home: the estimated altitude at arming, which the GPS height reference moves by cm)
    assert targets and all(t.alt == pytest.approx(PX4_SITL_HOME.alt_amsl_m, abs=0.1)
                               for t in targets)


def test_system_time_is_the_clock_of_the_run_at_1_hz_on_the_onboard_link(flight):
    """SYSTEM_TIME.hpp: the real-time clock (past 2001) with time_boot_ms, configured at 1 Hz in
    onboard mode and not in normal mode (mavlink_main.cpp); the clock of a run is its epoch plus
    the simulated time (a lockstep run: its fixed epoch), what MAVSDK's unix_epoch_time reads."""
    api, gcs = flight["api"], flight["gcs"]
    st = api.timed_messages("SYSTEM_TIME")
    assert len(st) >= 10 and gcs.messages("SYSTEM_TIME") == []
    assert all(m.time_unix_usec == int((LOCKSTEP_EPOCH_UNIX_S + t) * 1e6)
               and m.time_boot_ms == int(t * 1000) for t, m in st)
    gaps = {round(b - a, 6) for (a, _), (b, _) in zip(st, st[1:])}
    assert gaps == {1.0}
