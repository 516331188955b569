"""The client's clock as a PX4 MAVLink instance estimates it (PX4 src/lib/timesync/Timesync.cpp):
the filter, its convergence, the samples it leaves out, ``sync_stamp``, timesync_status, and
LANDING_TARGET stamped through it (mavlink_receiver handle_message_landing_target)."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
import pyulog
from pymavlink.dialects.v20 import common as M

from gateway.ci.lockstep import Sim
from gateway.mavlink.link import LinkKind
from gateway.mavlink.timesync import CONVERGENCE_WINDOW, Timesync
from tests.unit.test_onboard_shell import shell
from tests.unit.test_precland import _precland, _run
from tests.unit.test_precland import sim as sim  # noqa: F401 - the fixture
from tests.unit.test_vehicles_flight import take_off
from vehicles.nav_precland import PrecLandState
from vehicles.types import CommandResult, NavState

U64 = 1 << 64
AHEAD_US = 1_000_000_000  # the client's clock: 1000 s ahead of ours


def reply(ts: Timesync, now_us: int, rtt_us: int = 2000, ahead_us: int = AHEAD_US) -> None:
    """Our request sent rtt_us before now, answered half-way by a client ``ahead_us`` ahead."""
    sent_us = now_us - rtt_us
    ts.update(now_us, (sent_us + rtt_us // 2 + ahead_us) * 1000, sent_us * 1000)


def converge(ts: Timesync, start_us: int = 1_000_000, **kw) -> int:
    now = start_us
    for _ in range(CONVERGENCE_WINDOW):
        now += 100_000  # PX4's 10 Hz requests
        reply(ts, now, **kw)
    return now


def test_a_constant_offset_is_estimated_exactly_and_converges_after_500_samples():
    ts = Timesync()
    now = 1_000_000
    reply(ts, now)
    # the first sample sets the estimate; offset = ours - theirs
    assert ts.offset_us == -AHEAD_US and ts.sequence == 1
    st = ts.status
    assert (st.timestamp_us, st.source_protocol, st.observed_offset_us, st.estimated_offset_us,
            st.round_trip_time_us) == (now, 0, -AHEAD_US, -AHEAD_US, 2000)
    assert st.remote_timestamp_us == now - 1000 + AHEAD_US
    for _ in range(CONVERGENCE_WINDOW - 2):
        now += 100_000
        reply(ts, now)
    assert not ts.converged
    assert ts.sync_stamp(123, now) == now  # not converged: the time now
    reply(ts, now + 100_000)
    # the double filter of a constant stays on it, to its rounding (offset() truncates)
    assert ts.converged and abs(ts.offset_us + AHEAD_US) <= 1
    # converged: the client's stamp on our clock
    assert ts.sync_stamp(now + AHEAD_US - 5000, now) == now - 5000 + ts.offset_us + AHEAD_US


def test_the_gains_go_from_0_05_to_0_003_along_a_sigmoid():
    ts = Timesync()
    reply(ts, 1_000_000)
    assert ts.filter_alpha == 0.05  # progress 0 (set before the sample)
    reply(ts, 1_100_000)
    p = 1.0 - math.exp(0.5 * (1.0 - 1.0 / (1.0 - 1 / 500)))
    assert ts.filter_alpha == pytest.approx(p * 0.003 + (1 - p) * 0.05)
    converge(ts, 1_200_000)
    assert ts.filter_alpha == 0.003 and ts.filter_beta == 0.003


def test_a_step_in_the_offset_is_followed_with_the_filter_s_lag():
    ts = Timesync()
    now = converge(ts)
    for _ in range(20):
        now += 100_000
        reply(ts, now, ahead_us=AHEAD_US + 50_000)  # within MAX_DEVIATION_SAMPLE: a sample
    # converged gains 0.003: the estimate moved a little towards the new offset
    assert -AHEAD_US - 50_000 < ts.offset_us < -AHEAD_US - 1000


def test_samples_with_an_rtt_of_10_ms_or_more_are_left_out(caplog):
    ts = Timesync("v1 api:")
    reply(ts, 1_000_000)
    with caplog.at_level(logging.WARNING, logger="gateway.mavlink.timesync"):
        for k in range(12):
            reply(ts, 2_000_000 + k * 100_000, rtt_us=10_000, ahead_us=AHEAD_US + 7)
    assert ts.sequence == 1 and ts.offset_us == -AHEAD_US  # none used
    assert ts.status.round_trip_time_us == 10_000  # but each is published
    # said once, at the tenth in a row
    assert [r.getMessage() for r in caplog.records] == ["v1 api: RTT too high for timesync: 10 ms"]
    reply(ts, 4_000_000, rtt_us=9_999)
    assert ts.sequence == 2 and ts.high_rtt_count == 0


def test_more_than_ten_outliers_in_a_row_reset_the_filter(caplog):
    ts = Timesync("v1 api:")
    now = converge(ts)
    with caplog.at_level(logging.WARNING, logger="gateway.mavlink.timesync"):
        for _ in range(10):  # a time jump of 200 ms: outliers, left out
            now += 100_000
            reply(ts, now, ahead_us=AHEAD_US + 200_000)
        assert ts.converged and abs(ts.offset_us + AHEAD_US) <= 1 and not caplog.records
        now += 100_000
        reply(ts, now, ahead_us=AHEAD_US + 200_000)  # the eleventh: reset, sample dropped
    assert ts.sequence == 0 and not ts.converged and ts.offset_us == 0
    assert [r.getMessage() for r in caplog.records] == [
        "v1 api: time jump detected. Resetting time synchroniser."]
    reply(ts, now + 100_000, ahead_us=AHEAD_US + 200_000)  # starts over from the new offset
    assert ts.offset_us == -AHEAD_US - 200_000


def test_stamps_are_uint64():
    ts = Timesync()
    now = converge(ts)
    assert ts.sync_stamp(0, now) == U64 + ts.offset_us  # a stamp of 0: far in the future
    assert ts.sync_stamp(0, now) > U64 - AHEAD_US - 2
    behind = Timesync()
    converge(behind, start_us=600_000_000, ahead_us=-500_000_000)  # a client 500 s behind
    assert behind.sync_stamp(0, now) == behind.offset_us
    assert abs(behind.offset_us - 500_000_000) <= 1


def test_landing_target_time_goes_through_the_link_s_timesync():
    """A client that answers the API link's TIMESYNC requests at once (as MAVROS does), its clock
    1000 s ahead: before 500 answers a LANDING_TARGET is stamped on arrival, after them at its
    own time_usec on our clock; timesync_status follows every answer."""
    with Sim(1) as sim:
        api = sim.api(0)
        session = sim.simulation.links[(0, api.kind)].session
        sim.every(0.002, _answer_timesync(api))
        lt = sim.vehicles[0]._autopilot.navigator.landing_target
        sent_s = sim.now
        api.send(api.mav.landing_target_encode(123, 0, M.MAV_FRAME_LOCAL_NED, 0, 0, 0, 0, 0,
                                               1.0, 2.0, 0.0, (1, 0, 0, 0), 0, 1))
        sim.advance(0.01)
        assert lt.stamp_us == round(sent_s * 1e6)  # on arrival (the ideal network: at once)
        ts = session.timesync
        assert sim.run_until(lambda: ts.converged, timeout_s=60)
        assert ts.offset_us == pytest.approx(-AHEAD_US, abs=2000)
        assert ts.status.round_trip_time_us < 10_000
        sent_at = round(sim.now * 1e6) + AHEAD_US - 250_000  # a report 250 ms old
        api.send(api.mav.landing_target_encode(sent_at, 0, M.MAV_FRAME_LOCAL_NED, 0, 0, 0, 0, 0,
                                               1.0, 2.0, 0.0, (1, 0, 0, 0), 0, 1))
        sim.advance(0.01)
        assert lt.stamp_us == sent_at + ts.offset_us
        assert lt.position_ned_m == (1.0, 2.0, 0.0)


def test_a_target_stamped_more_than_pld_btout_ago_is_never_valid(sim):  # noqa: F811
    """A companion computer whose clock lags ours (after timesync) by 10 s: each report is
    already older than PLD_BTOUT (5 s), so Precision Land never sees a target, searches and
    falls back, landing where it is (PX4: hrt_elapsed_time of the stamp)."""
    take_off(sim)
    target = (6.0, -4.0, 0.0)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_PRECLAND) is CommandResult.ACCEPTED
    pl = _precland(sim)
    end = sim.t + 14.0
    while sim.t < end:
        sim.v.landing_target(sim.t, True, M.MAV_FRAME_LOCAL_NED, target,
                             round((sim.t - 10.0) * 1e6))
        sim.run(0.1)
    assert pl.state in (PrecLandState.SEARCH, PrecLandState.FALLBACK)
    assert math.hypot(*sim.v.state.position_ned_m[:2]) < 1.0  # never went to the pad


def test_a_target_stamped_in_the_future_never_times_out(sim):  # noqa: F811
    """hrt_elapsed_time is 0 for a stamp in the future: reports that stop are still valid
    after PLD_BTOUT, and the approach goes on to where the target was last seen."""
    take_off(sim)
    target = (8.0, 0.0, 0.0)
    future = round((sim.t + 3600.0) * 1e6)
    sim.v.landing_target(sim.t, True, M.MAV_FRAME_LOCAL_NED, target, future)
    assert sim.v.set_nav_state(sim.t, NavState.AUTO_PRECLAND) is CommandResult.ACCEPTED
    pl = _precland(sim)
    _run(sim, 0.2)
    assert pl.state is PrecLandState.HORIZONTAL_APPROACH
    _run(sim, 15.0)  # no more reports, far past PLD_BTOUT
    assert pl._valid
    assert pl.state in (PrecLandState.HORIZONTAL_APPROACH, PrecLandState.DESCEND_ABOVE_TARGET)
    assert math.hypot(sim.v.state.position_ned_m[0] - 8.0, sim.v.state.position_ned_m[1]) < 1.0


def _answer_timesync(api, ahead_us: int = AHEAD_US):
    """An observer that answers the link's TIMESYNC requests within 2 ms, as MAVROS does."""
    answered = [0]

    def answer(now: float) -> None:
        for m in api.messages("TIMESYNC", since=answered[0]):
            if m.tc1 == 0:
                api.send(M.MAVLink_timesync_message(round(now * 1e9) + ahead_us * 1000, m.ts1))
        answered[0] = len(api.frames)
    return answer


def test_timesync_status_is_logged_with_its_own_stamps_and_listened_per_instance(tmp_path):
    """timesync_status at most every second (logged_topics.cpp: 1000 ms, 3 instances), each
    record stamped when its reply came (not on the logger's 20 ms grid), instance 0 the first
    link to publish; the shell's listener prints each published instance of a topic."""
    with Sim(1, log_dir=tmp_path, links=(LinkKind.GCS, LinkKind.API),
             params={"SDLOG_MODE": 1}) as sim:
        api = sim.api(0)
        sim.every(0.002, _answer_timesync(api))
        sim.advance(4.5)
        listened = shell(sim, "listener timesync_status\n")
        assert "TOPIC: timesync_status\n timesync_status\n" in listened  # one instance
        assert "    round_trip_time: " in listened and "    source_protocol: 0\n" in listened
        both = shell(sim, "listener telemetry_status\n")
        assert "TOPIC: telemetry_status 2 instances\n" in both
        assert "\nInstance 0:\n telemetry_status\n" in both and "\nInstance 1:\n" in both
    log = pyulog.ULog(str(sorted((tmp_path / "vehicle-1" / "log").rglob("*.ulg"))[0]))
    (data,) = [d for d in log.data_list if d.name == "timesync_status"]
    assert data.multi_id == 0
    stamps = data.data["timestamp"]
    assert len(stamps) >= 3 and (np.diff(stamps) >= 1_000_000).all()
    assert (stamps % 20_000 != 0).any()  # the replies' arrival, not the logger's sampling
    assert (data.data["round_trip_time"] < 10_000).all()
    assert (data.data["source_protocol"] == 0).all()
    assert abs(int(data.data["estimated_offset"][-1]) + AHEAD_US) < 2000
