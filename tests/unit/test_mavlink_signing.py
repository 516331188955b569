"""MAVLink 2 signing: key files, our signer/verifier against pymavlink's signing, session rules."""

import hashlib
import random

import pytest
from pymavlink.dialects.v20 import common as M
from pymavlink.dialects.v20 import development
from test_mavlink_support import FakeVehicle, acks, make

from gateway.mavlink.codec import Decoder, DecodeStats, Encoder
from gateway.mavlink.link import SessionStats
from gateway.mavlink.link_status import TelemetryStatus
from gateway.mavlink.session import LinkKind, Session
from gateway.mavlink.signing import (
    ACCEPT_UNSIGNED,
    MAVLINK_EPOCH_UNIX_S,
    Signer,
    SigningClock,
    SigningConfig,
    SigningKey,
    SigningState,
    SigningStats,
    Verdict,
    Verifier,
)
from gateway.mavlink.snapshot import LinkTelemetry, Snapshot
from gateway.mavlink.streams import STREAMS
from gateway.mavlink.telemetry_estimator import wind_cov
from vehicles.orbit import OrbitStatus

# Streams that send from the fake vehicle (RC_CHANNELS and DISTANCE_SENSOR never do in SITL).
# (WIND_COV: EKF2 has no wind without drag fusion)
SENDING_STREAMS = [s for s in STREAMS if not s.silent and s.builder is not wind_cov]
KEY = SigningKey(bytes(range(32)))
OTHER_KEY = SigningKey(bytes(range(1, 33)))
EPOCH_UNIX_S = 1_750_000_000.0  # wall-clock time at simulated t = 0
TICKS_PER_S = 100_000


def stamp(t_s: float) -> int:
    """Simulated time t_s as a signing timestamp (10 µs since 2015-01-01)."""
    return round((EPOCH_UNIX_S - MAVLINK_EPOCH_UNIX_S) * TICKS_PER_S) + int(t_s * TICKS_PER_S)


def pym(key: SigningKey | None, timestamp: int, link_id: int = 0, sysid: int = 245,
        compid: int = 190) -> M.MAVLink:
    """A pymavlink endpoint that signs with its own implementation."""
    mav = M.MAVLink(None, sysid, compid)
    if key is not None:
        mav.signing.secret_key = key.secret
        mav.signing.sign_outgoing = True
        mav.signing.link_id = link_id
        mav.signing.timestamp = timestamp
    return mav


def command(mav: M.MAVLink, cmd: int = M.MAV_CMD_COMPONENT_ARM_DISARM, p1: float = 1.0) -> bytes:
    frame = M.MAVLink_command_long_message(1, 1, cmd, 0, p1, 0, 0, 0, 0, 0, 0).pack(mav)
    mav.seq = (mav.seq + 1) & 0xFF
    return frame


def verifier(stats=None) -> Verifier:
    return Verifier(KEY, SigningClock(EPOCH_UNIX_S), stats=stats)


def check(v: Verifier, frame: bytes, now_s: float = 10.0) -> Verdict:
    msg = development.MAVLink(None, 0, 0).decode(bytearray(frame))  # CURRENT_MODE too
    return v.check(frame, msg.get_msgId(), now_s)


def timestamp_of(frame: bytes) -> int:
    return int.from_bytes(frame[-12:-6], "little")


def signing() -> SigningConfig:
    """A fresh key domain (its replay state is shared by every session given it)."""
    return SigningConfig(KEY, EPOCH_UNIX_S)


# --- keys -------------------------------------------------------------------------------------
def test_key_file_formats(tmp_path):
    raw = bytes(range(100, 132))
    (tmp_path / "raw").write_bytes(raw)
    assert SigningKey.load(tmp_path / "raw").secret == raw
    (tmp_path / "hex").write_text(raw.hex().upper() + "\n")
    assert SigningKey.load(tmp_path / "hex").secret == raw
    # MAVProxy `signing setup <passphrase>` / QGC: SHA-256 of the passphrase
    (tmp_path / "pass").write_text("  correct horse battery staple\n")
    assert SigningKey.load(tmp_path / "pass").secret == \
        hashlib.sha256(b"correct horse battery staple").digest()
    (tmp_path / "pass32").write_text("p" * 32 + "\n")  # 33 bytes: a passphrase, not a raw key
    assert SigningKey.load(tmp_path / "pass32") == SigningKey.from_passphrase("p" * 32)
    for bad in (b"", b"\n \n", bytes(range(200, 240))):
        (tmp_path / "bad").write_bytes(bad)
        with pytest.raises(ValueError):
            SigningKey.load(tmp_path / "bad")
    with pytest.raises(ValueError):
        SigningKey(bytes(31))


def test_key_repr_does_not_show_the_secret():
    text = repr(SigningConfig(KEY, EPOCH_UNIX_S)) + repr(KEY) + str(KEY)
    assert KEY.secret.hex() not in text and repr(KEY.secret) not in text
    assert KEY.fingerprint in text


def test_clock_rejects_an_epoch_before_2015():
    with pytest.raises(ValueError):
        SigningClock(0.0)
    assert SigningClock(MAVLINK_EPOCH_UNIX_S + 1.0).of(0.5) == 150_000


# --- our frames vs pymavlink ------------------------------------------------------------------
@pytest.mark.parametrize("spec", SENDING_STREAMS, ids=lambda s: str(s.msg_id))
def test_signed_frames_are_byte_identical_to_pymavlink(spec):
    vehicle = FakeVehicle(3)
    vehicle.become_ready()
    vehicle.move_to(3.0, -4.0, -10.0)
    vehicle.orbit_status = OrbitStatus(-20.0, (5.0, 6.0), -12.0)
    vehicle.global_target_ned_m = (12.5, -3.0, -10.5)
    snap = Snapshot(vehicle, 12.345, 1.7e9, link=LinkTelemetry(TelemetryStatus(SessionStats())))
    enc = Encoder(3, 1, Signer(KEY, 1, SigningClock(EPOCH_UNIX_S)))
    enc.seq, enc.now_s = 77, 12.345
    frame = spec.frame(enc, snap)
    assert frame[2] == 1 and frame[-13] == 1 and timestamp_of(frame) == stamp(12.345)
    msg = development.MAVLink(None, 0, 0).decode(bytearray(frame))  # CURRENT_MODE too
    mav = pym(KEY, stamp(12.345), link_id=1, sysid=3, compid=1)
    mav.seq = 77
    assert msg.pack(mav) == frame


def test_our_frames_pass_pymavlink_with_the_key_and_fail_with_another():
    enc = Encoder(1, 1, Signer(KEY, 0, SigningClock(EPOCH_UNIX_S)))
    frames = []
    for i in range(20):
        enc.now_s = i * 0.01
        frames.append(enc.pack(M.MAVLink_heartbeat_message, 2, 12, 0, 0, 3, 3))
        frames.append(enc.pack(M.MAVLink_attitude_message, i, 0.1, 0.2, 0.3, 0, 0, 0))
    good = M.MAVLink(None, 0, 0)
    good.signing.secret_key = KEY.secret
    msgs = good.parse_buffer(b"".join(frames))
    assert len(msgs) == 40 and all(m.get_signed() for m in msgs)
    assert good.signing.goodsig_count == 40 and good.signing.badsig_count == 0
    wrong = M.MAVLink(None, 0, 0)
    wrong.signing.secret_key = OTHER_KEY.secret
    wrong.robust_parsing = True
    msgs = wrong.parse_buffer(b"".join(frames))
    assert len(msgs) == 40 and all(isinstance(m, M.MAVLink_bad_data) for m in msgs)
    assert wrong.signing.badsig_count == 40


def test_pymavlink_signed_frames_pass_our_verifier():
    stats = SigningStats()
    v = verifier(stats)
    mav = pym(KEY, stamp(9.0), link_id=3)
    for i in range(10):
        assert check(v, command(mav), now_s=10.0 + i) is Verdict.ACCEPTED
    assert v.streams == {(245, 190, 3): stamp(9.0) + 9}
    assert stats == SigningStats()  # check() counts nothing; filter() does


def test_outgoing_timestamps_strictly_increase_per_link():
    clock = SigningClock(EPOCH_UNIX_S)
    enc = Encoder(1, 1, Signer(KEY, 0, clock))
    enc.now_s = 5.0
    burst = [timestamp_of(enc.pack(M.MAVLink_ping_message, 0, 0, 0, 0)) for _ in range(5)]
    assert burst == [stamp(5.0) + i for i in range(5)]
    enc.now_s = 4.0  # time never goes back on the wire, even if asked to
    assert timestamp_of(enc.pack(M.MAVLink_ping_message, 0, 0, 0, 0)) == stamp(5.0) + 5
    enc.now_s = 6.0
    assert timestamp_of(enc.pack(M.MAVLink_ping_message, 0, 0, 0, 0)) == stamp(6.0)


# --- verifier rules ---------------------------------------------------------------------------
def test_replay_is_rejected():
    v = verifier()
    frame = command(pym(KEY, stamp(10.0)))
    assert check(v, frame) is Verdict.ACCEPTED
    assert check(v, frame) is Verdict.REPLAYED
    later = pym(KEY, stamp(10.0) - 5)  # same stream, older timestamp
    assert check(v, command(later)) is Verdict.REPLAYED


def test_new_stream_may_be_up_to_a_minute_old():
    v = verifier()
    assert check(v, command(pym(KEY, stamp(100.0 - 61))), now_s=100.0) is Verdict.STALE
    assert check(v, command(pym(KEY, stamp(100.0 - 59))), now_s=100.0) is Verdict.ACCEPTED
    # another stream (other link id) is judged on its own
    assert check(v, command(pym(KEY, stamp(100.0 - 61), link_id=2)), now_s=100.0) is Verdict.STALE


def test_wrong_key_and_tampering_are_bad_signatures():
    v = verifier()
    assert check(v, command(pym(OTHER_KEY, stamp(10.0)))) is Verdict.BAD_SIGNATURE
    frame = bytearray(command(pym(KEY, stamp(10.0))))
    frame[-1] ^= 0x40
    assert check(v, bytes(frame)) is Verdict.BAD_SIGNATURE
    assert v.streams == {}


def test_a_forged_future_timestamp_does_not_lock_the_stream_out():
    # pymavlink updates a stream's timestamp before it checks the signature; we must not.
    v = verifier()
    forged = bytearray(command(pym(KEY, stamp(10.0) + 10**9)))
    forged[-1] ^= 1
    assert check(v, bytes(forged)) is Verdict.BAD_SIGNATURE
    assert check(v, command(pym(KEY, stamp(10.0)))) is Verdict.ACCEPTED


def test_unsigned_frames_and_the_accept_list():
    v = verifier()
    plain = pym(None, 0)
    assert check(v, command(plain)) is Verdict.UNSIGNED
    v1 = M.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0).pack(
        plain, force_mavlink1=True)
    assert check(v, v1) is Verdict.UNSIGNED
    hb = M.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(plain)
    assert check(v, hb) is Verdict.ALLOWED_UNSIGNED
    radio = M.MAVLink_radio_status_message(200, 180, 90, 10, 10, 0, 0).pack(plain)
    assert check(v, radio) is Verdict.ALLOWED_UNSIGNED
    badly_signed_hb = M.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(pym(OTHER_KEY, 1))
    assert check(v, badly_signed_hb) is Verdict.ALLOWED_UNSIGNED  # as the C library does
    assert ACCEPT_UNSIGNED == {M.MAVLINK_MSG_ID_HEARTBEAT, M.MAVLINK_MSG_ID_RADIO_STATUS,
                               M.MAVLINK_MSG_ID_ADSB_VEHICLE, M.MAVLINK_MSG_ID_COLLISION}


def test_stream_table_is_bounded():
    v = Verifier(KEY, SigningClock(EPOCH_UNIX_S, SigningState(max_streams=4)))
    verdicts = [check(v, command(pym(KEY, stamp(10.0), sysid=s))) for s in range(1, 7)]
    assert verdicts == [Verdict.ACCEPTED] * 4 + [Verdict.TOO_MANY_STREAMS] * 2


def test_decoder_drops_and_counts_rejected_frames():
    stats = DecodeStats()
    dec = Decoder(stats, Verifier(KEY, SigningClock(EPOCH_UNIX_S), stats=stats))
    signed = pym(KEY, stamp(10.0))
    good = command(signed)
    datagram = b"".join([good, command(pym(None, 0)), command(pym(OTHER_KEY, stamp(10.0))),
                         good, command(signed)])
    got = dec.feed(datagram, 10.0)
    assert [m.get_msgbuf() for m in got] == [bytearray(good), bytearray(datagram[-len(good):])]
    assert (stats.rx_frames, stats.rx_signed, stats.rx_unsigned, stats.rx_bad_signature,
            stats.rx_replayed) == (2, 2, 1, 1, 1)


def test_accepted_timestamps_pull_the_link_clock_forward():
    # A client whose clock is ahead of simulated time: our replies must not look old to it.
    clock = SigningClock(EPOCH_UNIX_S)
    v = Verifier(KEY, clock)
    enc = Encoder(1, 1, Signer(KEY, 0, clock))
    ahead = stamp(10.0) + 3600 * TICKS_PER_S
    assert check(v, command(pym(KEY, ahead)), now_s=10.0) is Verdict.ACCEPTED
    enc.now_s = 10.0
    assert timestamp_of(enc.pack(M.MAVLink_ping_message, 0, 0, 0, 0)) == ahead + 1


def test_garbage_with_signing_on_never_raises():
    rng = random.Random(20250611)
    stats = DecodeStats()
    dec = Decoder(stats, Verifier(KEY, SigningClock(EPOCH_UNIX_S), stats=stats))
    mav = pym(KEY, stamp(1.0))
    good = [command(mav) for _ in range(4)]
    for i in range(5000):
        g = bytearray(rng.choice(good))
        if i % 3 == 0:
            g[rng.randrange(len(g))] ^= 1 + rng.randrange(255)
        elif i % 3 == 1:
            g = g[:rng.randrange(len(g))]
        dec.feed(bytes(g), 1.0 + i * 1e-3)
    assert stats.rx_datagrams == 5000 and stats.rx_signed <= 4


# --- session ----------------------------------------------------------------------------------
def test_signed_client_arms_the_vehicle_and_every_reply_is_signed():
    vehicle, session, client = make(signing=signing())
    vehicle.become_ready()
    client.now_s = 10.0
    client.sign_with(KEY.secret, stamp(10.0))
    got = client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert [a.result for a in acks(got)] == [M.MAV_RESULT_ACCEPTED]
    assert vehicle.armed and vehicle.calls[0][0] == "arm"
    telemetry_msgs = client.run_until(12.0)  # the client drops anything unsigned or badly signed
    assert {"HEARTBEAT", "ATTITUDE", "GLOBAL_POSITION_INT"} <= {m.get_type() for m in
                                                                telemetry_msgs}
    assert all(m.get_signed() and m.get_link_id() == 1 for m in got + telemetry_msgs)
    assert all(d[2] & 1 for d in client.datagrams)
    st = session.stats
    assert (st.rx_signed, st.rx_unsigned, st.rx_bad_signature, st.rx_replayed) == (1, 0, 0, 0)


def test_gcs_link_signs_with_link_id_0():
    _, _, client = make(LinkKind.GCS, signing=signing())
    client.sign_with(KEY.secret, stamp(0.0))
    assert {m.get_link_id() for m in client.run_until(1.5)} == {0}


def test_unsigned_client_cannot_arm():
    vehicle, session, client = make(signing=signing())
    vehicle.become_ready()
    client.now_s = 10.0
    client.rx.signing.secret_key = KEY.secret  # it can still read (and check) our telemetry
    assert client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1) == []
    assert not vehicle.armed and vehicle.calls == []
    st = session.stats
    assert (st.rx_unsigned, st.rx_frames, st.rx_unhandled) == (1, 0, 0)


def test_wrong_key_client_cannot_arm():
    vehicle, session, client = make(signing=signing())
    vehicle.become_ready()
    client.now_s = 10.0
    client.sign_with(OTHER_KEY.secret, stamp(10.0))
    assert client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1) == []
    assert vehicle.calls == [] and session.stats.rx_bad_signature == 1


def test_replayed_command_reaches_the_vehicle_once():
    vehicle, session, client = make(signing=signing())
    vehicle.become_ready()
    client.now_s = 10.0
    client.sign_with(KEY.secret, stamp(10.0))
    frame = client.encode(M.MAVLink_command_long_message(
        1, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0))
    session.receive_datagram(frame, 10.0)
    session.receive_datagram(frame, 10.5)
    assert [c[0] for c in vehicle.calls] == ["arm"] and session.stats.rx_replayed == 1


def test_unsigned_gcs_heartbeat_is_accepted_as_on_px4():
    vehicle, session, client = make(signing=signing())
    client.now_s = 3.0
    client.heartbeat()
    assert vehicle.gcs_heartbeats == [3.0] and session.stats.rx_unsigned == 0


def test_setup_signing_is_refused():
    vehicle, session, client = make(signing=signing())
    client.now_s = 10.0
    setup = M.MAVLink_setup_signing_message(1, 1, OTHER_KEY.secret, stamp(10.0))
    client.send(setup)  # unsigned: just an unsigned frame
    assert session.stats.rx_unsigned == 1 and session.stats.rx_setup_signing_refused == 0
    client.sign_with(KEY.secret, stamp(10.0))
    client.send(setup)
    assert session.stats.rx_setup_signing_refused == 1
    # the key did not change: frames signed with the old key still pass
    client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert vehicle.calls and session.stats.rx_bad_signature == 0


def test_signing_off_behaves_as_before():
    vehicle, session, client = make()
    vehicle.become_ready()
    assert client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)  # unsigned: accepted
    client.sign_with(OTHER_KEY.secret, 1)  # any signature is ignored
    client.rx.signing.secret_key = None
    assert acks(client.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 0))
    client.send(M.MAVLink_setup_signing_message(1, 1, KEY.secret, 1))
    msgs = client.run_until(2.0)
    assert msgs and not any(m.get_signed() for m in msgs)
    assert all(d[2] == 0 for d in client.datagrams)
    st = session.stats
    assert (st.rx_unsigned, st.rx_bad_signature, st.rx_replayed, st.rx_signed,
            st.rx_setup_signing_refused, st.rx_unhandled) == (0, 0, 0, 0, 0, 1)
    assert session.encoder.signer is None and "frame" not in vars(session.encoder)


def test_only_a_validly_signed_frame_moves_the_peer():
    """An unsigned HEARTBEAT is accepted (as on PX4) but must not redirect the replies; nor may
    a HEARTBEAT with a bad signature (accepted the same way), nor a signed frame for another
    system."""
    vehicle, session, _ = make(signing=signing())
    signed = pym(KEY, stamp(10.0))
    session.receive_datagram(command(signed, M.MAV_CMD_REQUEST_PROTOCOL_VERSION), 10.0, "client")
    assert session.peer == "client"
    heartbeat = M.MAVLink_heartbeat_message(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)
    session.receive_datagram(heartbeat.pack(pym(None, 0)), 10.1, "unsigned")
    session.receive_datagram(heartbeat.pack(pym(OTHER_KEY, stamp(10.0))), 10.2, "forged")
    other = M.MAVLink_command_long_message(42, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0).pack(signed)
    session.receive_datagram(other, 10.3, "elsewhere")
    assert session.peer == "client"
    assert vehicle.gcs_heartbeats == [10.1, 10.2]  # both heartbeats were taken
    assert session.stats.rx_signed == 2
    session.receive_datagram(heartbeat.pack(signed), 10.4, "moved")
    assert session.peer == "moved"


# --- the key's replay state: shared by every link, kept across restarts ---------------------------
def test_a_frame_accepted_on_one_vehicle_is_a_replay_on_every_other():
    config = signing()
    v1 = FakeVehicle(1)
    v2 = FakeVehicle(2)
    s1 = Session(v1, LinkKind.API, signing=config)
    s2 = Session(v2, LinkKind.API, signing=config)
    for v in (v1, v2):
        v.become_ready()
    mav = pym(KEY, stamp(10.0))
    # Broadcast target (legacy SET_MODE to system 0, which Commander takes): both vehicles would
    # act on it.
    frame = M.MAVLink_set_mode_message(0, 1, 4 << 16 | 4 << 24).pack(mav)
    s1.receive_datagram(frame, 10.0)
    s2.receive_datagram(frame, 10.0)
    assert [c[0] for c in v1.calls] == ["set_nav_state"] and v2.calls == []
    assert s2.stats.rx_replayed == 1


def test_one_client_link_to_several_vehicles_is_one_stream():
    """QGC signs every vehicle's traffic on one link: its timestamps rise across vehicles."""
    config = signing()
    sessions = {i: Session(FakeVehicle(i), LinkKind.GCS, signing=config) for i in (1, 2, 3)}
    mav = pym(KEY, stamp(10.0))
    for k in range(6):
        for sysid, s in sessions.items():
            frame = M.MAVLink_param_request_read_message(sysid, 1, b"MAV_SYS_ID", -1).pack(mav)
            s.receive_datagram(frame, 10.0 + k * 0.01)
    assert all(s.stats.rx_signed == 6 and s.stats.rx_replayed == 0 for s in sessions.values())
    assert len(config.state.streams) == 1


def test_replay_state_survives_a_restart_and_our_timestamps_never_go_back():
    before = signing()
    _, session, _ = make(signing=before)
    mav = pym(KEY, stamp(50.0))
    frame = command(mav)
    session.receive_datagram(frame, 50.0)
    ours = [timestamp_of(f) for f in session.datagrams_to_send(50.0)]
    doc = before.state.to_doc()
    assert not before.state.changed
    # The next start: an earlier epoch (a run at 10x stamped far ahead of the wall clock).
    after = SigningConfig(KEY, EPOCH_UNIX_S - 3600.0, state=SigningState.from_doc(doc))
    vehicle, session, _ = make(signing=after)
    vehicle.become_ready()
    session.receive_datagram(frame, 0.0)
    assert vehicle.calls == [] and session.stats.rx_replayed == 1
    session.receive_datagram(command(mav), 0.0)  # the client's next frame is fine
    assert [c[0] for c in vehicle.calls] == ["arm"]
    newer = [timestamp_of(f) for f in session.datagrams_to_send(0.1)]
    assert newer and min(newer) > max(ours + [timestamp_of(frame)])


@pytest.mark.parametrize("doc", [[], {"newest": -1}, {"newest": 1.5}, {"streams": {}},
                                 {"streams": [[1, 2, 3]]}, {"streams": [[1, 2, 300, 5]]},
                                 {"streams": [[1, 2, 3, True]]}])
def test_a_bad_replay_state_is_refused(doc):
    with pytest.raises(ValueError):
        SigningState.from_doc(doc)
