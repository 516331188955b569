"""HIGH_LATENCY2 as PX4 v1.15's stream sends it (gateway/mavlink/telemetry_high_latency.py):
SimpleAnalyzer's arithmetic, the streamed message with PX4's consumed-topic zeros, a request's
full answer, the analysers between sends."""

import math

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.mavlink.session import LinkKind
from gateway.mavlink.telemetry_high_latency import FLT_MIN, Analyzer
from gateway.testing import Sim

HL2 = M.MAVLINK_MSG_ID_HIGH_LATENCY2
RC_AND_OFFBOARD_LOST = M.HL_FAILURE_FLAG_RC_RECEIVER | M.HL_FAILURE_FLAG_OFFBOARD_LINK


def test_simple_analyzer_as_px4_computes():
    """mavlink_simple_analyzer.cpp: a sample counts only once the update rate is over 1 Hz
    (the average still takes its value); the average in float32; the maximum starts at
    FLT_MIN; get_scaled rounds half away from zero, clamps, truncates; a non-finite result
    resets."""
    avg = Analyzer(average=True)
    avg.add(0.5, 0.003)  # the first pass: rate under 1 Hz
    assert not avg.valid and avg.result == 0.5 and avg.scaled(100.0, -128, 127) == 50
    for v in (1.0, 2.0, 3.0):
        avg.add(v, 666.0)
    assert avg.valid and avg.n == 3
    assert avg.result == pytest.approx((((0.5 * 0 + 1.0) / 1 * 1 + 2.0) / 2 * 2 + 3.0) / 3)
    third = Analyzer(average=True)
    for v in (0.1, 0.2, 0.3):  # float32 steps, not the double mean
        third.add(v, 666.0)
    assert third.result == pytest.approx(0.2, abs=1e-7) and third.result != 0.2
    peak = Analyzer(average=False)
    assert peak.result == FLT_MIN and peak.scaled(10.0, 0, 255) == 0
    peak.add(0.04, 666.0)
    peak.add(0.26, 666.0)
    peak.add(0.1, 666.0)
    assert peak.scaled(10.0, 0, 255) == 3  # 2.6 + 0.5 → 3
    peak.add(40.0, 666.0)
    assert peak.scaled(10.0, 0, 255) == 255  # clamped
    neg = Analyzer(average=True)
    neg.add(-0.126, 666.0)
    assert neg.scaled(10.0, -128, 127) == -1  # -1.26 - 0.5 → -1.76 → -1
    neg.add(math.inf, 666.0)
    assert not neg.valid and neg.result == 0.0  # reset


def _flags(m) -> int:
    return m.failure_flags


def test_streamed_as_px4_sends_it_then_averages_between_sends():
    """SET_MESSAGE_INTERVAL 1 s: the first message at once (its analysers empty: eph/epv 255,
    battery the one sample), then one a second. Position, altitude, heading and mode read 0
    (update_data consumed those topics); wp_num is the mission's current item on the first
    send (the navigator's start-up mission_result) and UINT16_MAX while it does not change;
    without sticks or offboard setpoints failsafe_flags has both signals lost. Flying, the
    averages follow the flight: the throttle VFR_HUD shows, the climb rate's maximum."""
    with Sim(links=(LinkKind.API, LinkKind.GCS)) as sim:
        sim.advance(6.0)
        gcs = sim.gcs(0)
        since = len(gcs.frames)
        assert gcs.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, HL2, 1_000_000) == 0
        sim.advance(2.5)
        got = gcs.messages("HIGH_LATENCY2", since)
        assert len(got) == 3
        first, second = got[0], got[1]
        assert second.timestamp - first.timestamp == 1000
        assert (first.eph, first.epv, first.climb_rate, first.groundspeed) == (255, 255, 0, 0)
        assert first.battery == 100 and first.wp_num == 0
        assert (second.eph, second.epv) == (9, 18)  # sensor_gps_sim's eph 0.9, epv 1.78 m
        assert second.battery == 100 and second.wp_num == 65535
        for m in got:
            assert (m.latitude, m.longitude, m.altitude, m.heading, m.custom_mode) == (0,) * 5
            assert (m.type, m.autopilot, m.temperature_air) == (2, 12, -128)
            assert (m.custom0, m.custom1, m.custom2) == (-128, -128, -128)
            assert _flags(m) == RC_AND_OFFBOARD_LOST
            assert m.throttle == 0  # disarmed
        api = sim.api(0)
        assert api.arm() == 0 and api.takeoff() == 0
        mark = len(gcs.frames)
        sim.run_until(lambda: sim.state(0).position_ned_m[2] < -1.5, 20.0)
        sim.advance(1.2)
        climb = gcs.messages("HIGH_LATENCY2", mark)[-1]
        start_s, end_s = climb.timestamp / 1000.0 - 1.0, climb.timestamp / 1000.0
        hud = [m.throttle for t, m in gcs.timed_messages("VFR_HUD", mark) if start_s < t <= end_s]
        # sampled at each vehicle_status (2 Hz and on change), VFR_HUD's at its 4 Hz
        assert climb.throttle == pytest.approx(sum(hud) / len(hud), abs=6)
        vz = [abs(m.vz) for m in gcs.messages("LOCAL_POSITION_NED", mark)
              if start_s < m.time_boot_ms / 1000.0 <= end_s]
        assert climb.climb_rate == pytest.approx(max(vz) * 10, abs=1.0)
        assert climb.climb_rate >= 5
        assert climb.battery < 100  # the simulator drains while armed (SIM_BAT_DRAIN)


def test_a_request_without_the_stream_has_the_position_and_no_averages():
    """REQUEST_MESSAGE on a link without the stream: a temporary stream's send(), whose fresh
    subscriptions see every topic: latitude/longitude (×1e7, truncated), altitude (rounded
    metres), heading (half degrees), the mode (custom_mode's upper 16 bits); its analysers have
    nothing: eph/epv 255, and the battery — connected — reads 0. Setting the stream's rate to 0
    deletes it: set again, it starts afresh."""
    with Sim(links=(LinkKind.API, LinkKind.GCS)) as sim:
        sim.advance(6.0)
        gcs = sim.gcs(0)
        since = len(gcs.frames)
        assert gcs.command_long(M.MAV_CMD_REQUEST_MESSAGE, HL2) == 0
        (m,) = gcs.messages("HIGH_LATENCY2", since)
        pos = gcs.messages("GLOBAL_POSITION_INT")[-1]
        assert abs(m.latitude - pos.lat) <= 1 and abs(m.longitude - pos.lon) <= 1
        assert m.altitude == round(pos.alt / 1000.0)
        att = gcs.messages("ATTITUDE")[-1]
        assert m.heading == int(math.degrees(att.yaw % (2 * math.pi)) * 0.5)
        assert m.custom_mode == gcs.messages("HEARTBEAT")[-1].custom_mode >> 16
        assert (m.eph, m.epv, m.battery, m.throttle) == (255, 255, 0, 0)
        assert _flags(m) == RC_AND_OFFBOARD_LOST and m.wp_num == 0

        assert gcs.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, HL2, 500_000) == 0
        sim.advance(1.2)
        assert gcs.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, HL2, -1) == 0  # deleted
        mark = len(gcs.frames)
        sim.advance(1.0)
        assert gcs.messages("HIGH_LATENCY2", mark) == []
        assert gcs.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, HL2, 500_000) == 0
        sim.advance(0.1)
        again = gcs.messages("HIGH_LATENCY2", mark)
        assert len(again) == 1 and (again[0].eph, again[0].wp_num) == (255, 0)  # a new stream
