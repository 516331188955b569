"""What PX4 keeps about a link (telemetry_status) and sends of it (LINK_NODE_STATUS), against
PX4 v1.15 mavlink_main.cpp, mavlink_receiver.cpp (update_rx_stats) and
streams/LINK_NODE_STATUS.hpp."""

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.ci.lockstep import Sim
from gateway.mavlink.codec import Decoder, DecodeStats
from gateway.mavlink.link import SessionStats
from gateway.mavlink.link_status import TelemetryStatus


def _frames(seqs, sysid=255, compid=190):
    mav = M.MAVLink(None, sysid, compid)
    out = []
    for seq in seqs:
        mav.seq = seq
        out.append(mav.heartbeat_encode(6, 8, 0, 0, 4).pack(mav))
    return out


@pytest.mark.parametrize("seqs, lost", [
    ([0, 1, 2, 3], 0),
    ([0, 4], 3),
    ([250, 2], 6),  # 251..255, 0, 1 are 7 lost; across the wrap PX4 counts one short (+255)
    ([10, 10], 254),  # a repeat: seq below the expected one
    ([255, 0], 0),  # expected_seq is a uint8_t: 0 follows 255
])
def test_lost_messages_are_counted_as_update_rx_stats_counts_them(seqs, lost):
    stats = DecodeStats()
    dec = Decoder(stats)
    for frame in _frames(seqs):
        dec.feed(frame, 0.0)
    assert (stats.rx_lost, stats.rx_counted) == (lost, len(seqs))


def test_only_the_first_16_senders_are_counted():
    """MAX_REMOTE_COMPONENTS: a 17th sender is neither received nor lost in the counts (its
    messages are still handled)."""
    stats = DecodeStats()
    dec = Decoder(stats)
    for sysid in range(1, 18):
        for frame in _frames([0, 5], sysid=sysid):
            assert dec.feed(frame, 0.0)
    assert (stats.rx_frames, stats.rx_counted, stats.rx_lost) == (34, 32, 16 * 4)


def test_rates_are_the_bytes_of_windows_longer_than_a_second():
    """task_main: no rate for the first window (from the first loop after 1 s), whose bytes are
    not reset, so the second window's rate counts them too; then bytes / window."""
    stats = SessionStats()
    ts = TelemetryStatus(stats)
    stats.tx_bytes, stats.rx_bytes = 500, 50
    ts.update(1.0)  # not past 0 + 1 s
    ts.update(1.01)  # the first window begins: no rate yet
    assert (ts.tx_rate_avg, ts.rx_rate_avg) == (0.0, 0.0)
    stats.tx_bytes, stats.rx_bytes = 1500, 150
    ts.update(2.0)  # not past 1.01 + 1 s
    ts.update(2.02)
    assert ts.tx_rate_avg == pytest.approx(1500 / 1.01, rel=1e-6)
    stats.tx_bytes += 2000
    ts.update(3.03)
    assert ts.tx_rate_avg == pytest.approx(2000 / 1.01, rel=1e-6) and ts.rx_rate_avg == 0.0


def test_link_node_status_is_streamed_at_1_hz_with_the_links_counts():
    with Sim(1) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=5)
        sim.advance(5.0)
        api.mav.seq = (api.mav.seq + 3) % 256  # three of the client's frames lost
        api.heartbeat()
        sim.advance(1.0)
        timed = api.timed_messages("LINK_NODE_STATUS")
        assert [round(t, 3) for t, _ in timed[-3:]] == [round(timed[-1][0] - k, 3)
                                                       for k in (2, 1, 0)]
        msg = timed[-1][1]
        assert msg.timestamp == round(timed[-1][0] * 1e6)  # µs, though the field says ms
        assert (msg.tx_buf, msg.rx_buf, msg.tx_overflows, msg.rx_overflows) == (0, 0, 0, 0)
        assert 20_000 < msg.tx_rate < 40_000 and 0 < msg.rx_rate < 1000
        assert msg.messages_lost == 3 and msg.rx_parse_err == 0
        assert msg.messages_received > 5 and msg.messages_sent > 2000
