"""MAVLink 2 message signing for one link: a key, a signer and a verifier. Sans-IO.

Wire format (https://mavlink.io/en/guide/message_signing.html): a signed frame has incompat
flag 0x01 and 13 more bytes after the CRC: link_id (1), timestamp (6, little-endian, 10 µs units
since 2015-01-01 00:00:00 UTC) and the first 6 bytes of
SHA-256(secret_key + header + payload + CRC + link_id + timestamp).

Rules and invariants:
- Time is an argument. A link's timestamps come from simulated time mapped onto a wall-clock
  epoch the shell passes in (``SigningConfig.epoch_unix_s`` = Unix time at simulated t = 0, and
  ``SigningClock.rebase`` when the shell stamps it again as time starts); nothing here reads a
  clock.
- One ``SigningClock`` per link is shared by its ``Signer`` and ``Verifier``, as the C library
  shares ``signing->timestamp``: outgoing timestamps strictly increase, and an accepted incoming
  timestamp that is ahead of ours pulls ours forward. So after a client with a wall clock ahead
  of simulated time talks to us, our frames are never "older than a minute" to it. (Simulated
  time on the epoch is the wall clock only at 1× speed: faster runs stamp ahead, which receivers
  accept and adopt; a run far slower than real time falls behind until the client's next signed
  frame pulls the link forward.)
- Verification follows the C library's order: signature first, then timestamps, so a forged frame
  cannot move a stream's timestamp. Accepted: a valid signature whose timestamp is newer than the
  last one of its stream (sysid, compid, link_id), or, for a stream not seen yet, not more than
  60 s behind the link's local timestamp. At most ``MAX_STREAMS`` streams (the C library keeps
  16 per link); a new stream beyond that is rejected.
- Replay state is the key's, not one link's: every link signed with one ``SigningConfig`` shares
  its ``SigningState`` (the newest timestamp of each stream, and the newest timestamp sent or
  accepted anywhere). A frame accepted on one vehicle's link is a replay on every other link, and
  a client that talks to several vehicles over one MAVLink link (QGC) is one stream throughout.
  The shell saves the state (``SigningState.to_doc``) and gives it back at the next start
  (``from_doc``): timestamps never go back across restarts, ours or the clients'.
- Counters (on the stats object given to the ``Verifier``): ``rx_unsigned`` (unsigned or
  MAVLink 1 frames rejected), ``rx_bad_signature`` (signature mismatch, or no room for a new
  stream), ``rx_replayed`` (timestamp not newer than the stream's last one, or a new stream more
  than 60 s behind); and ``rx_signed`` for frames accepted with a valid signature, which is what
  tells an authenticated sender from one that only sent frames on the accept-unsigned list.

Unsigned frames we accept (``ACCEPT_UNSIGNED``). PX4's ``accept_unsigned`` callback
(src/modules/mavlink/mavlink_sign_control.cpp) always lets RADIO_STATUS, ADSB_VEHICLE and
COLLISION through; a later version of that file (the one with MavlinkSigningStorage) adds
HEARTBEAT, "required for link discovery/interop". We follow that newest list: HEARTBEAT,
RADIO_STATUS, ADSB_VEHICLE, COLLISION. Of these only HEARTBEAT reaches a service here, so an
unsigned GCS heartbeat still counts as "GCS present" and feeds the data-link-loss timer, exactly
as on PX4. As in the C library, a frame of these types with a bad signature is accepted as well.
Everything else needs a valid signature; MAVLink 1 frames cannot carry one and are rejected like
unsigned ones. PX4's other exceptions (MAV_SIGN_CFG 0 "optional", USB links, no key stored) have
no counterpart: a session has signing either off (``signing=None``: nothing is checked, signed
frames are accepted and their signature ignored, outgoing frames unsigned) or on.

SETUP_SIGNING (256) is refused. PX4 takes a new key from any SETUP_SIGNING that passes the
receiver (i.e. signed with the current key once a key exists; a blank key, which disables
signing, only when signed), persists it in one file shared by all its MAVLink instances and
reloads the other instances. Here the key is fixed by the operator when the daemon starts and
shared by both links of every vehicle; rotating it from one link would leave the other link on
the old key, and nothing would persist it. So a SETUP_SIGNING that passes verification is counted
(``rx_setup_signing_refused``), logged and otherwise ignored; MAVLink has no acknowledgement for
it, so the client learns nothing either way. Unsigned SETUP_SIGNING is just an unsigned frame.

Key files (``SigningKey.load``), first rule that matches wins:
1. exactly 32 bytes: the raw key (e.g. ``head -c 32 /dev/urandom``);
2. otherwise text (UTF-8) with surrounding whitespace stripped; 64 hex digits: the key in hex;
3. otherwise the stripped text is a passphrase and the key is SHA-256 of its UTF-8 bytes, the
   convention of MAVProxy's ``signing setup`` and of QGroundControl's signing key setting.
   A passphrase of exactly 32 characters must be stored with a trailing newline (``echo`` adds
   one), or rule 1 takes it as a raw key.
"""

from __future__ import annotations

import enum
import hashlib
import hmac
import logging
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, Protocol

from pymavlink.dialects.v20 import common as mavlink2

__all__ = [
    "ACCEPT_UNSIGNED",
    "MAVLINK_EPOCH_UNIX_S",
    "SigningClock",
    "SigningConfig",
    "SigningKey",
    "SigningStats",
    "Signer",
    "Verdict",
    "Verifier",
]

log = logging.getLogger(__name__)

IFLAG_SIGNED = 0x01
SIGNATURE_LEN = 13  # link_id 1 + timestamp 6 + signature 6
KEY_LEN = 32
MAVLINK_EPOCH_UNIX_S = 1_420_070_400  # 2015-01-01 00:00:00 UTC
TICKS_PER_S = 100_000  # timestamp unit: 10 µs
NEW_STREAM_MAX_AGE_TICKS = 60 * TICKS_PER_S  # spec: a new stream may be up to one minute behind
MAX_STREAMS = 64
TIMESTAMP_MAX = (1 << 48) - 1
LOG_INTERVAL_S = 1.0

ACCEPT_UNSIGNED = frozenset({
    mavlink2.MAVLINK_MSG_ID_HEARTBEAT,
    mavlink2.MAVLINK_MSG_ID_RADIO_STATUS,
    mavlink2.MAVLINK_MSG_ID_ADSB_VEHICLE,
    mavlink2.MAVLINK_MSG_ID_COLLISION,
})


@dataclass(frozen=True)
class SigningKey:
    """A 32-byte MAVLink signing secret. ``repr`` shows a fingerprint, never the key."""

    secret: bytes = field(repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.secret, bytes) or len(self.secret) != KEY_LEN:
            raise ValueError(f"a MAVLink signing key is {KEY_LEN} bytes")

    def __repr__(self) -> str:
        return f"SigningKey(fingerprint={self.fingerprint})"

    @property
    def fingerprint(self) -> str:
        """8 hex digits of SHA-256(key): lets an operator compare keys without showing them."""
        return hashlib.sha256(self.secret).hexdigest()[:8]

    @classmethod
    def from_passphrase(cls, passphrase: str) -> SigningKey:
        if not passphrase:
            raise ValueError("empty signing passphrase")
        return cls(hashlib.sha256(passphrase.encode("utf-8")).digest())

    @classmethod
    def from_hex(cls, text: str) -> SigningKey:
        return cls(bytes.fromhex(text))

    @classmethod
    def parse(cls, data: bytes) -> SigningKey:
        """A key from a key file's bytes (rules in the module docstring)."""
        if len(data) == KEY_LEN:
            return cls(data)
        try:
            text = data.decode("utf-8").strip()
        except UnicodeDecodeError:
            raise ValueError(f"a key file holds {KEY_LEN} raw bytes, {2 * KEY_LEN} hex digits "
                             f"or a UTF-8 passphrase; got {len(data)} bytes of binary") from None
        if len(text) == 2 * KEY_LEN and all(c in "0123456789abcdefABCDEF" for c in text):
            return cls.from_hex(text)
        if not text:
            raise ValueError("the signing key file is empty")
        return cls.from_passphrase(text)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> SigningKey:
        with open(path, "rb") as f:
            return cls.parse(f.read())


class SigningState:
    """The replay-protection state of one key (module rules): the newest timestamp of every
    stream (sysid, compid, link_id) and the newest timestamp sent or accepted on any link."""

    def __init__(self, max_streams: int = MAX_STREAMS) -> None:
        self.max_streams = max_streams
        self.streams: dict[tuple[int, int, int], int] = {}
        self.newest = 0
        self.changed = False  # since the last to_doc()

    def to_doc(self) -> dict[str, object]:
        """A JSON-able snapshot (clears ``changed``)."""
        self.changed = False
        return {"newest": self.newest,
                "streams": [[s, c, link, ts] for (s, c, link), ts in sorted(self.streams.items())]}

    @classmethod
    def from_doc(cls, doc: object, max_streams: int = MAX_STREAMS) -> SigningState:
        """Raises ValueError when ``doc`` is not what ``to_doc`` wrote."""
        state = cls(max_streams)
        if not isinstance(doc, dict):
            raise ValueError("not a table")
        newest, streams = doc.get("newest", 0), doc.get("streams", [])
        if not isinstance(newest, int) or not 0 <= newest <= TIMESTAMP_MAX:
            raise ValueError("'newest' is not a signing timestamp")
        if not isinstance(streams, list):
            raise ValueError("'streams' is not a list")
        for row in streams[-max_streams:]:
            if (not isinstance(row, list) or len(row) != 4
                    or not all(isinstance(v, int) and not isinstance(v, bool) for v in row)
                    or not all(0 <= v <= 255 for v in row[:3]) or not 0 <= row[3] <= TIMESTAMP_MAX):
                raise ValueError(f"a stream is not [sysid, compid, link_id, timestamp]: {row!r}")
            state.streams[(row[0], row[1], row[2])] = row[3]
        state.newest = max([newest, *state.streams.values()])
        return state


@dataclass(frozen=True)
class SigningConfig:
    """What a Session needs to sign and verify: the key, the wall-clock time (Unix seconds) at
    simulated t = 0 as the sessions are built (``Session.set_epoch`` moves their clocks), the
    message ids accepted unsigned, and the key's replay state shared by every session given
    this config."""

    key: SigningKey
    epoch_unix_s: float
    accept_unsigned: frozenset[int] = ACCEPT_UNSIGNED
    state: SigningState = field(default_factory=SigningState, compare=False)


class SigningClock:
    """The local signing timestamp of one link (the C library's ``signing->timestamp``)."""

    def __init__(self, epoch_unix_s: float, shared: SigningState | None = None) -> None:
        """``shared``: the key's state; the link starts at its newest timestamp and moves it."""
        if not math.isfinite(epoch_unix_s) or epoch_unix_s < MAVLINK_EPOCH_UNIX_S:
            raise ValueError("the signing epoch must be a Unix time after 2015-01-01")
        self._base = round((epoch_unix_s - MAVLINK_EPOCH_UNIX_S) * TICKS_PER_S)
        self.shared = shared if shared is not None else SigningState()
        self.timestamp = self.shared.newest  # newest timestamp sent or accepted on this link

    def rebase(self, epoch_unix_s: float) -> None:
        """Simulated t = 0 is ``epoch_unix_s`` from now on (the shell learns it once time
        starts); timestamps already sent or accepted stay the floor."""
        if not math.isfinite(epoch_unix_s) or epoch_unix_s < MAVLINK_EPOCH_UNIX_S:
            raise ValueError("the signing epoch must be a Unix time after 2015-01-01")
        self._base = round((epoch_unix_s - MAVLINK_EPOCH_UNIX_S) * TICKS_PER_S)

    def advance(self, ts: int) -> None:
        """``ts`` was sent or accepted on this link (newer than ``timestamp``)."""
        self.timestamp = ts
        shared = self.shared
        if ts > shared.newest:
            shared.newest = ts
            shared.changed = True

    def of(self, now_s: float) -> int:
        """Simulated time ``now_s`` in signing ticks (no state)."""
        return self._base + int(now_s * TICKS_PER_S)

    def local(self, now_s: float) -> int:
        """The link's local timestamp: the clock, or the newest timestamp seen if ahead."""
        ts = self.of(now_s)
        return ts if ts > self.timestamp else self.timestamp


class Signer:
    """Appends signature blocks to outgoing frames of one link."""

    def __init__(self, key: SigningKey, link_id: int, clock: SigningClock) -> None:
        if not 0 <= link_id <= 255:
            raise ValueError("link_id is one byte")
        self._secret = key.secret
        self._link = bytes((link_id,))
        self.link_id = link_id
        self.clock = clock

    def sign(self, frame: bytes, now_s: float) -> bytes:
        """``frame``: a whole MAVLink 2 frame with IFLAG_SIGNED set and its CRC computed.

        The timestamp is ``now_s`` on the link's clock, or one tick past the newest timestamp of
        the link if that is not older: strictly increasing per link.
        """
        clock = self.clock
        ts = clock.of(now_s)
        if ts <= clock.timestamp:
            ts = clock.timestamp + 1
        clock.advance(ts)
        tail = self._link + (ts & TIMESTAMP_MAX).to_bytes(6, "little")
        return frame + tail + hashlib.sha256(self._secret + frame + tail).digest()[:6]


class Verdict(enum.Enum):
    ACCEPTED = "accepted"  # valid signature, fresh timestamp
    ALLOWED_UNSIGNED = "allowed_unsigned"  # unsigned or badly signed, but on the accept list
    UNSIGNED = "unsigned"
    BAD_SIGNATURE = "bad_signature"
    REPLAYED = "replayed"  # timestamp not newer than the stream's last
    STALE = "stale"  # new stream more than 60 s behind the local timestamp
    TOO_MANY_STREAMS = "too_many_streams"


class SigningCounters(Protocol):
    rx_unsigned: int
    rx_bad_signature: int
    rx_replayed: int
    rx_signed: int


@dataclass
class SigningStats:
    rx_unsigned: int = 0
    rx_bad_signature: int = 0
    rx_replayed: int = 0
    rx_signed: int = 0


_COUNTER = {
    Verdict.UNSIGNED: "rx_unsigned",
    Verdict.BAD_SIGNATURE: "rx_bad_signature",
    Verdict.TOO_MANY_STREAMS: "rx_bad_signature",
    Verdict.REPLAYED: "rx_replayed",
    Verdict.STALE: "rx_replayed",
}


class Verifier:
    """Checks incoming frames of one link; keeps the newest timestamp of every stream."""

    def __init__(self, key: SigningKey, clock: SigningClock,
                 accept_unsigned: Iterable[int] = ACCEPT_UNSIGNED,
                 stats: SigningCounters | None = None) -> None:
        """The streams are the clock's shared state (the key's, module rules)."""
        self._secret = key.secret
        self.clock = clock
        self.accept_unsigned = frozenset(accept_unsigned)
        self.stats: SigningCounters = stats if stats is not None else SigningStats()
        self.shared = clock.shared
        self.streams = clock.shared.streams  # (sysid, compid, link_id) → newest timestamp
        self._next_log_s = -math.inf

    def check(self, frame: bytes | bytearray, msg_id: int, now_s: float) -> Verdict:
        """The verdict on one whole frame (CRC already checked); updates stream state only when
        the frame is accepted with a valid signature. Counts nothing (``filter`` does)."""
        if frame[0] != 0xFD or not frame[2] & IFLAG_SIGNED:
            return Verdict.ALLOWED_UNSIGNED if msg_id in self.accept_unsigned else Verdict.UNSIGNED
        verdict = self._check_signed(frame, now_s)
        if verdict is not Verdict.ACCEPTED and msg_id in self.accept_unsigned:
            return Verdict.ALLOWED_UNSIGNED  # the C library asks the callback after a failure too
        return verdict

    def _check_signed(self, frame: bytes | bytearray, now_s: float) -> Verdict:
        if len(frame) < 12 + SIGNATURE_LEN:  # header 10 + CRC 2 + signature block
            return Verdict.BAD_SIGNATURE
        expected = hashlib.sha256(self._secret + frame[:-6]).digest()[:6]
        if not hmac.compare_digest(expected, frame[-6:]):
            return Verdict.BAD_SIGNATURE
        ts = int.from_bytes(frame[-12:-6], "little")
        stream = (frame[5], frame[6], frame[-13])
        last = self.streams.get(stream)
        if last is None:
            if len(self.streams) >= self.shared.max_streams:
                return Verdict.TOO_MANY_STREAMS
            if ts + NEW_STREAM_MAX_AGE_TICKS < self.clock.local(now_s):
                return Verdict.STALE
        elif ts <= last:
            return Verdict.REPLAYED
        self.streams[stream] = ts
        self.shared.changed = True
        if ts > self.clock.timestamp:
            self.clock.advance(ts)
        return Verdict.ACCEPTED

    def filter(self, msgs: list[Any], now_s: float) -> list[Any]:
        """The decoded pymavlink messages of one datagram that pass; rejections are counted.
        Those accepted with a valid signature answer ``get_signed()`` True."""
        out = []
        for m in msgs:
            frame = m.get_msgbuf()
            verdict = self.check(frame, m.get_msgId(), now_s)
            if verdict is Verdict.ACCEPTED:
                self.stats.rx_signed += 1
                # Marked as pymavlink's own parser marks a frame it verified: get_signed() is
                # True only for a valid signature (not for an unsigned frame let through).
                m._signed = True
                m._link_id = frame[-13]
                out.append(m)
                continue
            if verdict is Verdict.ALLOWED_UNSIGNED:
                out.append(m)
                continue
            name = _COUNTER[verdict]
            setattr(self.stats, name, getattr(self.stats, name) + 1)
            if now_s >= self._next_log_s:
                self._next_log_s = now_s + LOG_INTERVAL_S
                log.debug("signing: dropped %s from %d/%d: %s", m.get_type(), m.get_srcSystem(),
                          m.get_srcComponent(), verdict.value)
        return out
