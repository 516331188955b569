"""MAVLink framing for one link: a fast MAVLink 2 encoder and a datagram-at-a-time decoder.

Rules and invariants:
- Out: always MAVLink 2, one sequence counter per link (PX4 `MAV_PROTO_VER` 2 in SITL); unsigned
  unless the encoder has a ``Signer`` (signing.py), then every frame is signed.
- In: MAVLink 1 and 2 (pymavlink's v20 parser handles both magics). Without a ``Verifier`` signed
  frames are accepted and their signature ignored (PX4 ≤ 1.16 has no signing); with one, frames it
  rejects are dropped here, before any service sees them, and counted (rx_unsigned,
  rx_bad_signature, rx_replayed); ``rx_frames`` counts only the frames delivered.
- Signing off costs the hot paths nothing: ``Encoder.frame`` is only replaced by its signing twin
  when a signer is given, and ``Decoder.feed`` checks for a verifier once per datagram.
- UDP carries whole frames: every datagram is parsed on its own and the parser is reset after it,
  so a truncated frame can never swallow the start of the next datagram.
- ``Decoder.feed`` never raises: garbage, truncated frames, bad CRC and unknown ids are counted
  and dropped. pymavlink exceptions are caught here, at the boundary, and logged rate-limited.
- The encoder bypasses ``MAVLink_message.pack`` (≈3 µs) with a per-class generated packer and a
  direct CRC (≈1 µs); tests prove byte equality with pymavlink for every message we send.
"""

from __future__ import annotations

import logging
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

# fastcrc (a pymavlink dependency, and what pymavlink itself uses) computes the X.25 CRC.
from fastcrc import crc16 as _fastcrc16
from pymavlink.dialects.v20 import common as mavlink2

from gateway.mavlink.signing import IFLAG_SIGNED, Signer, Verifier


def _crc16(data: bytes) -> int:
    return _fastcrc16.mcrf4xx(data, 0xFFFF)


log = logging.getLogger(__name__)

MAGIC_V2 = 0xFD
MAX_DATAGRAM_BYTES = 1400
LOG_INTERVAL_S = 1.0  # at most one debug line per second of simulated time per decoder

# PROTOCOL_VERSION (300) is not in pymavlink 2.4.50's common dialect; we frame it by hand.
MSG_ID_PROTOCOL_VERSION = 300
CRC_EXTRA_PROTOCOL_VERSION = 217  # computed from the XML definition, see tests
PROTOCOL_VERSION_PAYLOAD = struct.pack("<HHH8s8s", 200, 100, 200, bytes(8), bytes(8))

_HEADER = struct.Struct("<BBBBBBHB")  # len, incompat, compat, seq, sys, comp, msgid lo16, hi8


def _build_packer(cls: type[mavlink2.MAVLink_message]) -> tuple[Callable[..., bytes], tuple]:
    """Compile ``args (constructor order) -> payload bytes`` for one message class.

    pymavlink orders wire fields by type size (``ordered_fieldnames``); ``array_lengths`` is in
    wire order. Char arrays are ``Ns`` (one bytes value), other arrays are flattened.
    """
    names = list(cls.fieldnames)
    parts = []
    defaults: list[Any] = []
    for wire_pos, fname in enumerate(cls.ordered_fieldnames):
        i = names.index(fname)
        n = cls.array_lengths[wire_pos]
        is_char = cls.fieldtypes[i] == "char"
        if n and not is_char:
            parts.append(f"*a[{i}]")
        elif is_char:
            parts.append(f"_b(a[{i}])")
        else:
            parts.append(f"a[{i}]")
    for i, fname in enumerate(names):
        wire_pos = list(cls.ordered_fieldnames).index(fname)
        n = cls.array_lengths[wire_pos]
        if cls.fieldtypes[i] == "char":
            defaults.append(b"")
        elif n:
            defaults.append((0,) * n)
        else:
            defaults.append(0)
    src = f"lambda a: _s({', '.join(parts)})"
    fn = eval(src, {"_s": cls.unpacker.pack, "_b": _as_bytes})  # noqa: S307 - our own template
    return fn, tuple(defaults)


def _as_bytes(v: bytes | str) -> bytes:
    return v.encode("utf-8", "replace") if isinstance(v, str) else v


class Encoder:
    """Frames messages as this link's MAVLink 2 endpoint (sysid, compid, seq).

    With a ``signer`` every frame is signed at simulated time ``now_s``, which the session sets
    on each of its entry points (frames are signed when built, and built in sending order).
    """

    def __init__(self, sysid: int, compid: int, signer: Signer | None = None) -> None:
        self.sysid = sysid
        self.compid = compid
        self.seq = 0
        self.now_s = 0.0
        self.signer = signer
        self._packers: dict[type, tuple[Callable[..., bytes], tuple, int, int]] = {}
        if signer is not None:
            self._sign = signer.sign
            # An instance attribute shadows the method: the unsigned path keeps no branch.
            self.frame = self._frame_signed  # type: ignore[method-assign]

    def frame(self, msg_id: int, crc_extra: int, payload: bytes) -> bytes:
        """One MAVLink 2 frame around an already-packed payload (trailing zeros trimmed)."""
        n = len(payload)
        while n > 1 and payload[n - 1] == 0:
            n -= 1
        body = _HEADER.pack(n, 0, 0, self.seq, self.sysid, self.compid, msg_id & 0xFFFF,
                            msg_id >> 16) + payload[:n]
        self.seq = (self.seq + 1) & 0xFF
        crc = _crc16(body + bytes((crc_extra,)))
        return b"\xfd" + body + crc.to_bytes(2, "little")

    def _frame_signed(self, msg_id: int, crc_extra: int, payload: bytes) -> bytes:
        """``frame`` with the signed flag in the header (it is covered by the CRC) and the
        signature block appended."""
        n = len(payload)
        while n > 1 and payload[n - 1] == 0:
            n -= 1
        body = _HEADER.pack(n, IFLAG_SIGNED, 0, self.seq, self.sysid, self.compid,
                            msg_id & 0xFFFF, msg_id >> 16) + payload[:n]
        self.seq = (self.seq + 1) & 0xFF
        crc = _crc16(body + bytes((crc_extra,)))
        return self._sign(b"\xfd" + body + crc.to_bytes(2, "little"), self.now_s)

    def pack(self, cls: type[mavlink2.MAVLink_message], *args: Any) -> bytes:
        """Encode ``cls(*args)``; trailing (extension) arguments may be omitted → zero."""
        entry = self._packers.get(cls)
        if entry is None:
            fn, defaults = _build_packer(cls)
            entry = (fn, defaults, cls.id, cls.crc_extra)
            self._packers[cls] = entry
        fn, defaults, msg_id, crc_extra = entry
        if len(args) < len(defaults):
            args = args + defaults[len(args):]
        return self.frame(msg_id, crc_extra, fn(args))


@dataclass
class DecodeStats:
    rx_datagrams: int = 0
    rx_bytes: int = 0
    rx_frames: int = 0  # decoded, known message ids, good CRC (and accepted by the Verifier)
    rx_malformed: int = 0  # bad CRC, garbage bytes, truncated frames, parser errors
    rx_unknown: int = 0  # well-framed but message id not in common.xml
    rx_bad_datagrams: int = 0  # datagrams with anything unusable in them (malformed or unknown)
    # signing on (a Verifier), see signing.py. Dropped after decoding, not in rx_frames:
    rx_unsigned: int = 0  # unsigned or MAVLink 1, not on the accept-unsigned list
    rx_bad_signature: int = 0  # signature does not match the key (or no room for a new stream)
    rx_replayed: int = 0  # timestamp not newer than its stream's, or a new stream > 60 s old
    # ...and delivered (in rx_frames):
    rx_signed: int = 0  # valid signature, fresh timestamp


class Decoder:
    """Datagram → list of pymavlink messages. Never raises.

    With a ``verifier`` only the messages it accepts are returned; it counts the others (give it
    the same stats object).
    """

    def __init__(self, stats: DecodeStats, verifier: Verifier | None = None) -> None:
        self._mav = mavlink2.MAVLink(None, 0, 0)
        self._mav.robust_parsing = True
        self.stats = stats
        self.verifier = verifier
        self._next_log_s = -1.0

    def feed(self, data: bytes, now_s: float) -> list[mavlink2.MAVLink_message]:
        st = self.stats
        st.rx_datagrams += 1
        st.rx_bytes += len(data)
        out: list[mavlink2.MAVLink_message] = []
        mav = self._mav
        bad_before = st.rx_malformed + st.rx_unknown
        try:
            msgs = mav.parse_buffer(data) or ()
            for m in msgs:
                if isinstance(m, mavlink2.MAVLink_bad_data):
                    st.rx_malformed += 1
                    self._log(now_s, "bad data: %s", m.reason)
                elif isinstance(m, mavlink2.MAVLink_unknown):
                    st.rx_unknown += 1
                else:
                    st.rx_frames += 1
                    out.append(m)
            if mav.buf_len() > 0:
                st.rx_malformed += 1
                self._log(now_s, "truncated frame: %d bytes left", mav.buf_len())
        except Exception as exc:  # noqa: BLE001 - the boundary: nothing from the wire may escape
            st.rx_malformed += 1
            self._log(now_s, "parser error: %r", exc)
        finally:
            self._reset()
        if st.rx_malformed + st.rx_unknown != bad_before:
            st.rx_bad_datagrams += 1
        if self.verifier is not None and out:
            kept = self.verifier.filter(out, now_s)
            st.rx_frames -= len(out) - len(kept)
            return kept
        return out

    def _reset(self) -> None:
        mav = self._mav
        mav.buf = bytearray()
        mav.buf_index = 0
        mav.expected_length = mavlink2.HEADER_LEN_V1 + 2
        mav.have_prefix_error = False

    def _log(self, now_s: float, fmt: str, *args: Any) -> None:
        if now_s >= self._next_log_s:
            self._next_log_s = now_s + LOG_INTERVAL_S
            log.debug(fmt, *args)


def pack_datagrams(frames: list[bytes], limit: int = MAX_DATAGRAM_BYTES) -> list[bytes]:
    """Concatenate frames into datagrams of at most ``limit`` bytes; a frame is never split."""
    out: list[bytes] = []
    cur: list[bytes] = []
    size = 0
    for f in frames:
        if cur and size + len(f) > limit:
            out.append(b"".join(cur))
            cur, size = [], 0
        cur.append(f)
        size += len(f)
    if cur:
        out.append(b"".join(cur))
    return out


def fixed_name(name: str) -> bytes:
    """PARAM/STATUSTEXT-style char[N] field: ASCII bytes; struct pads with NULs."""
    return name.encode("ascii", "replace")
