"""Codec: byte-equality with pymavlink, v1/v2/signed input, garbage never escapes."""

import random

import pytest
from pymavlink.dialects.v20 import common as M
from pymavlink.dialects.v20 import development
from pymavlink.generator.mavcrc import x25crc
from test_mavlink_support import FakeVehicle, acks, make

from gateway.mavlink import codec
from gateway.mavlink.codec import (
    CRC_EXTRA_PROTOCOL_VERSION,
    Decoder,
    DecodeStats,
    Encoder,
)
from gateway.mavlink.link import SessionStats
from gateway.mavlink.link_status import TelemetryStatus
from gateway.mavlink.session import LinkKind
from gateway.mavlink.snapshot import LinkTelemetry, Snapshot
from gateway.mavlink.streams import STREAMS
from gateway.mavlink.telemetry_estimator import wind_cov
from vehicles.orbit import OrbitStatus

# Streams that send from the fake vehicle (RC_CHANNELS and DISTANCE_SENSOR never do in SITL).
# (WIND_COV: EKF2 has no wind without drag fusion)
SENDING_STREAMS = [s for s in STREAMS if not s.silent and s.builder is not wind_cov]


def crc_extra(name: str, fields: list[tuple[str, str, int]]) -> int:
    """MAVLink's CRC_EXTRA of a message from its XML fields (in wire order, arrays with n)."""
    crc = x25crc(name.encode() + b" ")
    for ftype, fname, n in fields:
        crc.accumulate_str(ftype + " ")
        crc.accumulate_str(fname + " ")
        if n:
            crc.accumulate([n])
    return (crc.crc & 0xFF) ^ (crc.crc >> 8)


def test_hand_framed_crc_extras_match_the_xml_definitions():
    assert crc_extra("PROTOCOL_VERSION", [
        ("uint16_t", "version", 0), ("uint16_t", "min_version", 0),
        ("uint16_t", "max_version", 0), ("uint8_t", "spec_version_hash", 8),
        ("uint8_t", "library_version_hash", 8)]) == CRC_EXTRA_PROTOCOL_VERSION
    assert crc_extra("COMPONENT_METADATA", [
        ("uint32_t", "time_boot_ms", 0), ("uint32_t", "file_crc", 0),
        ("char", "uri", 100)]) == codec.CRC_EXTRA_COMPONENT_METADATA
    assert crc_extra("COMPONENT_INFORMATION", [
        ("uint32_t", "time_boot_ms", 0), ("uint32_t", "general_metadata_file_crc", 0),
        ("uint32_t", "peripherals_metadata_file_crc", 0), ("char", "general_metadata_uri", 100),
        ("char", "peripherals_metadata_uri", 100)]) == codec.CRC_EXTRA_COMPONENT_INFORMATION


@pytest.mark.parametrize("spec", SENDING_STREAMS, ids=lambda s: str(s.msg_id))
def test_fast_encoder_matches_pymavlink_pack(spec):
    vehicle = FakeVehicle(3)
    vehicle.become_ready()
    vehicle.move_to(3.0, -4.0, -10.0)
    vehicle.orbit_status = OrbitStatus(-20.0, (5.0, 6.0), -12.0)
    vehicle.position_setpoint_ned_m = (3.5, -4.0, -10.0)
    vehicle.global_target_ned_m = (12.5, -3.0, -10.5)
    vehicle.motor_outputs = (512.5, 530.0, 498.25, 505.0)
    snap = Snapshot(vehicle, 12.345, 1.7e9, link=LinkTelemetry(TelemetryStatus(SessionStats())))
    enc = Encoder(3, 1)
    enc.seq = 77
    frame = spec.frame(enc, snap)
    msg = development.MAVLink(None, 0, 0).decode(bytearray(frame))  # CURRENT_MODE too
    mav = M.MAVLink(None, 3, 1)
    mav.seq = 77
    assert msg.pack(mav) == frame
    assert enc.seq == 78


def test_sequence_wraps_per_link():
    enc = Encoder(1, 1)
    seqs = [enc.pack(M.MAVLink_ping_message, 0, 0, 0, 0)[4] for _ in range(300)]
    assert seqs[:3] == [0, 1, 2] and seqs[256] == 0


def test_v1_and_signed_v2_frames_are_accepted():
    _, session, client = make()
    v1 = M.MAVLink(None, 245, 190)
    frame_v1 = M.MAVLink_command_long_message(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0, 148,
                                              0, 0, 0, 0, 0, 0).pack(v1, force_mavlink1=True)
    assert frame_v1[0] == 0xFE
    session.receive_datagram(frame_v1, 0.0)
    assert [m.result for m in acks(client.drain())] == [0]
    signer = M.MAVLink(None, 245, 190)
    signer.signing.secret_key = bytes(range(32))
    signer.signing.sign_outgoing = True
    signer.signing.link_id = 1
    signer.signing.timestamp = 1
    frame_signed = M.MAVLink_command_long_message(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0, 148,
                                                  0, 0, 0, 0, 0, 0).pack(signer)
    assert frame_signed[2] & 1  # MAVLINK_IFLAG_SIGNED
    session.receive_datagram(frame_signed, 0.0)
    assert [m.result for m in acks(client.drain())] == [0]
    assert session.stats.rx_malformed == 0


def test_truncated_frame_does_not_eat_the_next_datagram():
    stats = DecodeStats()
    dec = Decoder(stats)
    good = M.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(M.MAVLink(None, 255, 190))
    assert dec.feed(good[:-3], 0.0) == []
    assert [m.get_type() for m in dec.feed(good, 0.0)] == ["HEARTBEAT"]
    assert stats.rx_malformed == 1 and stats.rx_frames == 1


def test_garbage_never_raises_and_is_counted():
    rng = random.Random(20240611)
    vehicle, session, client = make(LinkKind.GCS)
    mav = M.MAVLink(None, 245, 190)
    good = [M.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(mav),
            M.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0).pack(mav),
            M.MAVLink_param_set_message(1, 1, b"MIS_TAKEOFF_ALT", 7.0, 9).pack(mav),
            M.MAVLink_param_request_read_message(1, 1, b"NOPE", -1).pack(mav)]
    n = 100_000
    for i in range(n):
        kind = i % 5
        if kind == 0:
            data = rng.randbytes(rng.randrange(0, 300))
        elif kind == 1:
            g = rng.choice(good)
            data = g[:rng.randrange(0, len(g))]
        elif kind == 2:  # bad CRC
            g = bytearray(rng.choice(good))
            g[-1] ^= 1 + rng.randrange(255)
            data = bytes(g)
        elif kind == 3:  # random magic + header + body
            data = bytes([rng.choice((0xFD, 0xFE))]) + rng.randbytes(rng.randrange(0, 280))
        else:  # unknown msg id, well framed
            data = b"\xfd\x01\x00\x00\x00\xf5\xbe\x39\x30\x00\x00\x00\x00"  # id 12345
        session.receive_datagram(data, i * 1e-3)
        session.datagrams_to_send(i * 1e-3)
    st = session.stats
    assert st.rx_datagrams == n
    assert st.rx_malformed + st.rx_unknown >= n * 0.6
    assert st.rx_unknown > 0
    # a valid command afterwards still works
    client.now_s = 101.0
    vehicle.become_ready()
    got = client.command_long(M.MAV_CMD_REQUEST_MESSAGE, 148)
    assert [m.get_type() for m in got] == ["AUTOPILOT_VERSION", "COMMAND_ACK"]


def test_other_sysid_frames_are_counted_not_handled():
    """A command for system 7 is answered FAILED (mavlink_receiver.cpp) but not carried out;
    other messages for it are dropped."""
    vehicle, session, client = make()
    got = client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1, target_system=7)
    assert [(m.get_type(), m.result) for m in got] == [("COMMAND_ACK", 4)]
    assert session.stats.rx_other_target == 1 and vehicle.calls == []
    got = client.send(M.MAVLink_param_set_message(7, 1, b"MIS_TAKEOFF_ALT", 1.0, 9))
    assert got == [] and session.stats.rx_other_target == 2


def test_a_float_beyond_float32_is_sent_as_infinity_as_a_c_float_holds_it():
    """A setpoint computed from a parameter PX4 stores as given (a gain of 3e38) can exceed
    float32: PX4's float fields hold ±inf there; struct.pack would raise OverflowError."""
    enc = codec.Encoder(1, 1)
    frame = enc.pack(M.MAVLink_position_target_local_ned_message, 1, 1, 0, 1e39, -1e39, 2.0,
                     0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    msg = M.MAVLink(None).decode(bytearray(frame))
    assert (msg.x, msg.y, msg.z) == (float("inf"), float("-inf"), 2.0)
