"""ULog streaming over MAVLink as PX4 does it (logger's LogWriterMavlink, mavlink's MavlinkULog):
the packets' offsets, the reliable header, acks and resends, the logger's answers, and the ULog
a client puts back together (pyulog reads it) over an ideal and a lossy network."""

from __future__ import annotations

import math
import struct

import pytest
import pyulog
from pymavlink.dialects.v20 import common as M

from gateway.ci.ulog_receiver import UlogReceiver
from gateway.mavlink.link import LinkKind
from gateway.mavlink.log_streaming import ACK_MAX_TRIES, LogStreamingService
from gateway.onboard import ulog
from gateway.onboard.ulog_stream import (
    DATA_LEN,
    NO_MESSAGE_START,
    ORB_QUEUE_LENGTH,
    MavlinkLogWriter,
    UlogStreamTopic,
)
from gateway.sim.scenario import NetworkConfig
from gateway.testing import Sim
from vehicles.types import CommandResult

LOSSY = NetworkConfig.from_flags(latency_ms=20, jitter_ms=5, loss=0.2, seed=11)


def _message(n: int) -> bytes:
    """A ULog message of n payload bytes."""
    return struct.pack("<HB", n, ord("D")) + bytes(i & 0xFF for i in range(n))


class Recorder:
    def __init__(self, topic: UlogStreamTopic) -> None:
        self.topic = topic
        topic.owner = self
        self.seen = 0

    def on_published(self, now_s: float) -> None:
        self.seen += 1

    def packets(self):
        return [self.topic.take(g - 1)[1]
                for g in range(self.topic.generation - len(self.topic._queue) + 1,
                               self.topic.generation + 1)]


def test_packets_carry_249_bytes_and_where_the_first_message_starts():
    topic = UlogStreamTopic()
    rec = Recorder(topic)
    writer = MavlinkLogWriter(topic)
    writer.start()
    writer.write_raw(b"H" * 16, 0.0)  # the file header: the first packet starts at 0
    big, small, huge = _message(300), _message(20), _message(600)
    writer.write(big + small, 0.0)
    writer.write(huge, 0.0)
    packets = rec.packets()
    assert [len(p.data) for p in packets] == [DATA_LEN] * 3  # 945 bytes: the rest waits
    # big (303 bytes) runs from 16 to 319 = 70 in packet 1, where small starts; huge starts
    # at 93 of packet 1 and fills packet 2, in which no message starts.
    assert [p.first_message_offset for p in packets] == [0, 70, NO_MESSAGE_START]
    assert [p.msg_sequence for p in packets] == [0, 1, 2]
    assert not any(p.need_ack for p in packets)
    joined = b"".join(p.data for p in packets)
    assert joined == (b"H" * 16 + big + small + huge)[:len(joined)]


def test_the_reliable_part_goes_one_packet_per_ack_and_the_logger_waits():
    topic = UlogStreamTopic()
    rec = Recorder(topic)
    writer = MavlinkLogWriter(topic)
    writer.start()
    writer.set_reliable(True, 0.0)
    writer.write(_message(600), 0.0)
    writer.set_reliable(False, 0.0)  # the partial last packet goes reliably too
    assert topic.generation == 1 and writer.blocked  # one out, two behind it
    first = rec.packets()[-1]
    assert first.need_ack and first.msg_sequence == 0
    topic.publish_ack(5, 0.01)  # not its sequence: nothing
    assert topic.generation == 1
    topic.publish_ack(0, 0.01)
    topic.publish_ack(1, 0.02)
    assert topic.generation == 3 and writer.blocked
    last = rec.packets()[-1]
    assert last.need_ack and len(last.data) == 603 - 2 * DATA_LEN
    topic.publish_ack(2, 0.03)
    assert not writer.blocked
    writer.write(_message(10), 0.04)
    writer.write(_message(300), 0.04)
    assert not rec.packets()[-1].need_ack  # data goes unacknowledged


def test_no_ack_for_2_5_s_stops_the_mavlink_log():
    topic = UlogStreamTopic()
    writer = MavlinkLogWriter(topic)
    writer.start()
    writer.set_reliable(True, 0.0)
    writer.write(_message(600), 0.0)
    writer.poll(2.49)
    assert writer.started and writer.blocked
    writer.poll(2.5)
    assert not writer.started and not writer.blocked and writer.ack_timeouts == 1


class FakeLink:
    def __init__(self) -> None:
        from gateway.mavlink.codec import Encoder
        from gateway.mavlink.link import LinkContext, SessionStats
        self.sent: list = []
        self.texts: list = []
        self.mav = M.MAVLink(None, 1, 1)
        self.mav.robust_parsing = True
        ctx = LinkContext(None, LinkKind.API, 1, Encoder(1, 1), SessionStats(),  # type: ignore
                          self._send, lambda: None)
        self.service = LogStreamingService(ctx, lambda t, s, text: self.texts.append(text))
        self.topic = UlogStreamTopic()
        self.service.topic = self.topic
        self.writer = MavlinkLogWriter(self.topic)

    def _send(self, frame: bytes) -> None:
        self.sent.append(self.mav.parse_char(frame))

    def run(self, until_s: float) -> None:
        while self.service.due_s <= until_s:
            self.service.handle_timer(self.service.due_s)

    def start(self, now_s: float, header_bytes: int) -> None:
        """LOGGING_START from MAVSDK (245/190), the logger's ACCEPTED, and a reliable header of
        one message of ``header_bytes`` payload."""
        assert self.service.on_command(M.MAV_CMD_LOGGING_START, (245, 190), 0.0) is None
        self.service.on_logger_ack(M.MAV_CMD_LOGGING_START, 0, now_s)
        self.writer.start()
        self.writer.set_reliable(True, now_s)
        self.writer.write(_message(header_bytes), now_s)
        self.writer.set_reliable(False, now_s)


def test_a_link_resends_an_unacked_packet_every_50_ms_and_gives_up_after_50_tries():
    link = FakeLink()
    s = link.service
    link.start(0.02, 100)
    link.run(0.03)
    assert [m.get_type() for m in link.sent] == ["LOGGING_DATA_ACKED"]
    m = link.sent[0]
    assert (m.target_system, m.target_component, m.sequence, m.length,
            m.first_message_offset) == (245, 190, 0, 103, 0)
    link.run(0.2)
    times = len(link.sent)
    assert times == 4  # at 0.02, then every 50 ms (and a loop): 0.0715, 0.123, 0.1745
    link.run(10.0)
    assert len(link.sent) == ACK_MAX_TRIES and not s.active  # "stream update failed"
    assert s.due_s == math.inf


def test_an_ack_lets_the_next_packet_out_within_a_loop():
    link = FakeLink()
    s = link.service
    link.start(0.0, 400)
    link.run(0.0)
    s.on_logging_ack(M.MAVLink_logging_ack_message(1, 1, 0), 0.005)
    assert s.due_s == pytest.approx(0.0065)
    link.run(0.007)
    assert [m.sequence for m in link.sent] == [0, 1]
    for k in range(3):  # the data that follows: every packet published, none lost
        link.writer.write(_message(2000), 0.01 + k)
    s.on_logging_ack(M.MAVLink_logging_ack_message(1, 1, 1), 0.01)
    link.run(0.02)
    # 3 × 2003 bytes: 24 packets published while the link waited, the 16 newest kept
    assert s.missed == 24 - ORB_QUEUE_LENGTH and len(link.sent) == 2 + ORB_QUEUE_LENGTH


def test_without_the_loggers_ack_a_link_gives_up_after_300_ms():
    link = FakeLink()
    s = link.service
    s.on_command(M.MAV_CMD_LOGGING_START, (245, 190), 0.0)
    assert link.topic.owner is s
    link.run(1.0)
    assert link.topic.owner is None and not link.sent


def test_a_link_without_the_bandwidth_denies_and_says_why():
    link = FakeLink()
    link.service.datarate_b_s = 1200
    assert link.service.on_command(M.MAV_CMD_LOGGING_START, (245, 190), 0.0) == \
        CommandResult.DENIED
    assert link.texts == ["Not enough bandwidth to enable log streaming"]
    link.service.topic = None  # no logger
    assert link.service.on_command(M.MAV_CMD_LOGGING_START, (245, 190), 0.0) == \
        CommandResult.UNSUPPORTED


def _acks(client, command):
    return [m.result for m in client.messages("COMMAND_ACK") if m.command == command]


def test_the_logger_answers_as_px4s(tmp_path):
    with Sim(1) as sim:  # no log dir: PX4's logger streams without its SD card
        api = sim.api(0)
        assert api.command_long(M.MAV_CMD_LOGGING_START, 1) == CommandResult.UNSUPPORTED
        assert api.command_long(M.MAV_CMD_LOGGING_STOP) == CommandResult.ACCEPTED
        assert api.start_log_stream() == CommandResult.ACCEPTED
        assert api.command_long(M.MAV_CMD_LOGGING_START, 0) == \
            CommandResult.TEMPORARILY_REJECTED
        sim.advance(2.0)
        result, data = api.stop_log_stream()
        assert result == CommandResult.ACCEPTED
        assert _acks(api, M.MAV_CMD_LOGGING_STOP)[-2:] == [CommandResult.IN_PROGRESS,
                                                          CommandResult.ACCEPTED]
        size = len(data)
        sim.advance(1.0)  # nothing after the stop
        assert api.log_stream is None and size > 50_000


def _stream_flight(network=None, log_dir=None):
    with Sim(1, network, log_dir=log_dir) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        started = api.start_log_stream()
        # A lossy link may lose the ACK. The stream runs anyway, and the logger answers the
        # retries (TEMPORARILY_REJECTED) only once the reliable header is through: while a
        # packet waits for its ack, LogWriterMavlink blocks PX4's logger thread.
        assert started == CommandResult.ACCEPTED or (network is not None and started is None)
        assert api.arm() == 0 and api.takeoff() == 0
        # The reliable header (~155 acknowledged packets, one at a time) takes ~8.5 s through
        # a link that loses a fifth of them each way: the flight goes on well past that.
        sim.advance(10.0 if network is None else 14.0)  # up past 2 m (the takeoff ~9 s)
        receiver = api.log_stream
        result, data = api.stop_log_stream()
        return result, data, receiver, sim


@pytest.mark.parametrize("network", [None, LOSSY], ids=["ideal", "lossy"])
def test_a_streamed_flight_is_a_ulog_that_pyulog_reads(tmp_path, network):
    result, data, receiver, _ = _stream_flight(network)
    assert result == CommandResult.ACCEPTED
    path = tmp_path / "stream.ulg"
    path.write_bytes(data)
    log = pyulog.ULog(str(path))
    # The reliable part always arrives whole, whatever the link loses.
    assert log.msg_info_dict["ver_hw"] == "PX4_SITL" and len(log.initial_parameters) > 600
    names = {d.name for d in log.data_list}
    assert {"vehicle_local_position", "sensor_combined"} <= names
    # vehicle_status is written on change, twice here: unacknowledged LOGGING_DATA on a link
    # that loses a fifth of its packets may lose both
    assert network is not None or "vehicle_status" in names
    z = log.get_dataset("vehicle_local_position").data["z"]
    assert min(z) < -2.0
    if network is None:
        assert receiver.lost == 0
    else:  # lost data packets leave gaps, never broken messages
        assert receiver.lost > 10


def test_a_file_log_and_a_stream_share_the_samples(tmp_path):
    _, data, _, sim = _stream_flight(log_dir=tmp_path / "run")
    files = sorted((tmp_path / "run" / "vehicle-1" / "log").rglob("*.ulg"))
    streamed = tmp_path / "stream.ulg"
    streamed.write_bytes(data)
    file_log = pyulog.ULog(str(files[0]))
    stream = pyulog.ULog(str(streamed))
    f = file_log.get_dataset("vehicle_local_position").data["timestamp"]
    s = stream.get_dataset("vehicle_local_position").data["timestamp"]
    # The stream's samples are the file's, from its start on (one set of subscriptions).
    assert set(s) <= set(f) and len(s) > 300
    # While the stream's header waited for its acks, the logger sampled nothing, for the file
    # either (PX4's logger thread blocks).
    assert max(b - a for a, b in zip(f, f[1:], strict=False)) > 50_000


def test_receiver_skips_to_the_next_message_after_a_gap():
    topic = UlogStreamTopic()
    rec = Recorder(topic)
    writer = MavlinkLogWriter(topic)
    writer.start()
    header = ulog.header(0)
    messages = [ulog.logged_string(ulog.LOG_INFO, k, "x" * (40 + 70 * k)) for k in range(8)]
    writer.write_raw(header, 0.0)
    writer.write(b"".join(messages), 0.0)
    packets = rec.packets()
    whole = UlogReceiver()
    for p in packets + packets[-1:]:  # the last one twice, as a resend: dropped
        whole.feed(p.msg_sequence, len(p.data), p.first_message_offset, p.data)
    published, expected = len(packets) * DATA_LEN, header
    for m in messages:  # the whole messages in what was published
        if len(expected) + len(m) <= published:
            expected += m
    assert whole.ulog() == expected and len(expected) > len(header) + sum(map(len, messages[:5]))
    assert whole.lost == 0
    gap = UlogReceiver()
    for p in packets[:3] + packets[4:]:
        gap.feed(p.msg_sequence, len(p.data), p.first_message_offset, p.data)
    assert gap.lost == 1
    kept, pos, data = [], len(header), gap.ulog()
    while pos < len(data):  # whole messages only, each one of those sent
        size = 3 + struct.unpack_from("<H", data, pos)[0]
        kept.append(data[pos:pos + size])
        pos += size
    assert data.startswith(header) and pos == len(data)
    assert set(kept) < set(messages) and len(kept) >= 3


def test_hostile_logging_traffic_is_refused_or_ignored_and_streaming_still_works():
    """LOGGING_START/STOP with NaN, inf and 3e38 params from many senders, and LOGGING_ACKs for
    sequences never sent, interleaved: no service fails, telemetry flows, and a client that
    then asks properly gets its stream."""
    import random

    rng = random.Random(5)
    hostile = [math.nan, math.inf, -math.inf, 3e38, -3e38, 0.0, 1.0, 0.4, -0.6]
    with Sim(1) as sim:
        api = sim.api(0)
        mav = M.MAVLink(None, 0, 0)
        for k in range(600):
            mav.srcSystem, mav.srcComponent = rng.randrange(1, 256), rng.randrange(0, 256)
            kind = rng.randrange(3)
            if kind == 2:
                msg = mav.logging_ack_encode(1, 1, rng.randrange(0, 65536))
            else:
                command = M.MAV_CMD_LOGGING_START if kind == 0 else M.MAV_CMD_LOGGING_STOP
                msg = mav.command_long_encode(1, rng.choice([0, 1]), command, 0,
                                              *(rng.choice(hostile) for _ in range(7)))
            api.send_bytes(msg.pack(mav))
            if k % 20 == 0:
                sim.advance(0.05)
        before = len(api.messages("ATTITUDE"))
        sim.advance(3.0)  # whatever stream a stranger started times out or runs on
        assert len(api.messages("ATTITUDE")) - before > 100  # telemetry flows
        api.command_long(M.MAV_CMD_LOGGING_STOP)  # whoever holds the stream: it ends
        assert api.start_log_stream() == CommandResult.ACCEPTED
        sim.advance(1.0)
        _, data = api.stop_log_stream()
        assert data.startswith(ulog.MAGIC) and len(data) > 30_000
        assert sum(link.session.stats.handler_errors
                   for link in sim.simulation.links.values()) == 0
