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
  direct CRC: one struct call for the header, one compiled CRC call (fastcrc) over header and
  payload, one table step for CRC_EXTRA (≈0.5 µs a frame). fastcrc rather than numba: a numba
  function costs more to call from Python (≈0.3 µs) than fastcrc takes (≈0.15 µs). Tests prove
  byte equality with pymavlink for every message of the dialect, signed and unsigned.
"""

from __future__ import annotations

import logging
import math
import struct
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

# fastcrc (a pymavlink dependency, and what pymavlink itself uses) computes the X.25 CRC.
from fastcrc import crc16 as _fastcrc16
from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20 import development

from gateway.mavlink.signing import IFLAG_SIGNED, Signer, Verifier

log = logging.getLogger(__name__)

MAGIC_V2 = 0xFD
LOG_INTERVAL_S = 1.0  # at most one debug line per second of simulated time per decoder

# PROTOCOL_VERSION (300) is not in pymavlink 2.4.50's common dialect; we frame it by hand.
MSG_ID_PROTOCOL_VERSION = 300
CRC_EXTRA_PROTOCOL_VERSION = 217  # computed from the XML definition, see tests
PROTOCOL_VERSION_PAYLOAD = struct.pack("<HHH8s8s", 200, 100, 200, bytes(8), bytes(8))
# COMPONENT_METADATA (397) and COMPONENT_INFORMATION (395) are not in it either: time_boot_ms,
# file CRC(s), URI(s) of char[100]; CRC_EXTRA from their XML definitions (see tests).
MSG_ID_COMPONENT_METADATA = 397
CRC_EXTRA_COMPONENT_METADATA = 182
COMPONENT_METADATA = struct.Struct("<II100s")
MSG_ID_COMPONENT_INFORMATION = 395
CRC_EXTRA_COMPONENT_INFORMATION = 0
COMPONENT_INFORMATION = struct.Struct("<III100s100s")

# magic, len, incompat flags, compat flags, seq, sysid, compid, msgid lo16, msgid hi8
_HEADER = struct.Struct("<BBBBBBBHB")
_CRC = struct.Struct("<H")
_crc_x25 = _fastcrc16.mcrf4xx
_DEVELOPMENT_MAP = development.mavlink_map

INT16_MIN, INT16_MAX = -32768, 32767
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1


def c_int(value: float, lo: int, hi: int) -> int:
    """C's conversion of a float to an integer field, as PX4's streams make it: toward zero,
    clamped (out of range is undefined in C and the field cannot hold it; a setpoint taken from
    a client, such as an altitude of 3e38 m, must not stop the stream), 0 for NaN and inf."""
    if not math.isfinite(value):
        return 0
    return max(lo, min(hi, math.trunc(value)))


_F32 = struct.Struct("<f")
_f32_pack, _f32_unpack = _F32.pack, _F32.unpack


def f32(value: float) -> float:
    """``value`` rounded to float32, as PX4 stores it (finite, within the float32 range)."""
    return _f32_unpack(_f32_pack(value))[0]


def f32_mul(value: float, factor: float) -> float:
    """``value * factor`` as PX4 computes it on a float field: both in float32, the product
    rounded to float32. A C conversion of the product to an integer then sees what PX4 sees
    (0.9f * 100.f is 90, where the double product 90.00000000000001 would ceil to 91)."""
    if not math.isfinite(value) or abs(value) > FLT_MAX:
        return value * factor
    try:
        return _f32_unpack(_f32_pack(_f32_unpack(_f32_pack(value))[0] * factor))[0]
    except OverflowError:  # beyond float32 once multiplied: inf, as float32 arithmetic gives
        return math.copysign(math.inf, value * factor)


def i16(value: float) -> int:
    return c_int(value, INT16_MIN, INT16_MAX)


def i32(value: float) -> int:
    return c_int(value, INT32_MIN, INT32_MAX)


def _crc_table() -> tuple[int, ...]:
    """X.25 (MCRF4XX, reflected 0x1021) one-byte steps: crc' = (crc >> 8) ^ T[(crc ^ b) & 0xFF]."""
    table = []
    for i in range(256):
        c = i
        for _ in range(8):
            c = (c >> 1) ^ 0x8408 if c & 1 else c >> 1
        table.append(c)
    return tuple(table)


def _state_before(byte: int, after: int) -> int:
    """The CRC state that ``byte``'s step takes to ``after``: the step is a bijection (the high
    bytes of the table's entries are all different, so ``after``'s high byte names the entry)."""
    i = next(i for i in range(256) if _CRC_STEP[i] >> 8 == after >> 8)
    return ((after ^ _CRC_STEP[i]) & 0xFF) << 8 | (i ^ byte)


_CRC_STEP = _crc_table()
# The CRC covers the frame without its magic: started from the state that the magic's step takes
# to X.25's 0xFFFF, it runs over the frame as built, magic included, in one call.
_CRC_INIT_BEFORE_MAGIC = _state_before(MAGIC_V2, 0xFFFF)


def _build_packer(cls: type[mavlink2.MAVLink_message]
                  ) -> tuple[Callable[..., bytes], Callable[..., bytes]]:
    """Compile ``(*args in constructor order) -> payload bytes`` for one message class.

    A function whose parameters are the fields, each defaulting to zero (omitted trailing
    extension arguments are zeros), handing them to the class's struct in wire order: pymavlink
    orders wire fields by type size (``ordered_fieldnames``; ``array_lengths`` is in wire
    order); char arrays are ``Ns`` (one bytes value), other arrays are flattened. A float beyond
    float32 raises OverflowError, and only then are the arguments converted (``_as_float32``);
    the second function returned is the same without that, raising.
    """
    names = list(cls.fieldnames)
    wire_names = list(cls.ordered_fieldnames)
    env: dict[str, Any] = {"_s": cls.unpacker.pack, "_b": _as_bytes, "_f32": _as_float32}
    parts: list[str] = []
    for wire_pos, fname in enumerate(wire_names):
        i = names.index(fname)
        if cls.fieldtypes[i] == "char":
            parts.append(f"_b(f{i})")
        elif cls.array_lengths[wire_pos]:
            parts.append(f"*f{i}")
        else:
            parts.append(f"f{i}")
    params: list[str] = []
    for i, fname in enumerate(names):
        n = cls.array_lengths[wire_names.index(fname)]
        env[f"_d{i}"] = b"" if cls.fieldtypes[i] == "char" else (0,) * n if n else 0
        params.append(f"f{i}=_d{i}")
    args = ", ".join(f"f{i}" for i in range(len(names)))
    body = f"_s({', '.join(parts)})"
    exec(f"def _raw({', '.join(params)}):\n"  # noqa: S102 - our own template, one compile
         f"    return {body}\n"
         f"def pack({', '.join(params)}):\n"
         f"    try:\n"
         f"        return {body}\n"
         f"    except OverflowError:\n"
         f"        return _raw(*map(_f32, ({args},)))\n", env)
    return env["pack"], env["_raw"]


def _as_bytes(v: bytes | str) -> bytes:
    return v.encode("utf-8", "replace") if isinstance(v, str) else v


FLT_MAX = 3.4028234663852886e38


class Packer:
    """The payload encoder of one message class; ``pack(*args)`` takes the constructor's
    arguments (omitted trailing extensions zero); ``raw(*args)`` likewise, but raises
    OverflowError for a float beyond float32."""

    __slots__ = ("msg_id", "crc_extra", "pack", "raw")

    def __init__(self, cls: type[mavlink2.MAVLink_message]) -> None:
        self.msg_id: int = cls.id
        self.crc_extra: int = cls.crc_extra
        self.pack, self.raw = _build_packer(cls)


_PACKERS: dict[type, Packer] = {}  # generated code only depends on the class: share it


def packer_of(cls: type[mavlink2.MAVLink_message]) -> Packer:
    packer = _PACKERS.get(cls)
    if packer is None:
        packer = _PACKERS[cls] = Packer(cls)
    return packer


def payload_of(cls: type[mavlink2.MAVLink_message]) -> Callable[..., bytes]:
    """``(*args) -> payload`` of ``cls(*args)``, untrimmed, as ``Encoder.pack`` packs it: bound
    once per message by the telemetry builders, which return payloads
    (``Encoder.frame_streams``)."""
    return packer_of(cls).pack


def crc_extra_of(msg_id: int) -> int:
    """CRC_EXTRA of a message of PX4 SITL's dialect (development, with wip_dialect's)."""
    return int(_DEVELOPMENT_MAP[msg_id].crc_extra)


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
        self._incompat = 0
        if signer is not None:
            self._sign = signer.sign
            self._incompat = IFLAG_SIGNED  # the signed flag is in the header, covered by the CRC
            # An instance attribute shadows the method: the unsigned path keeps no branch.
            self.frame = self._frame_signed  # type: ignore[method-assign]

    def frame(self, msg_id: int, crc_extra: int, payload: bytes) -> bytes:
        """One MAVLink 2 frame around an already-packed payload (trailing zeros trimmed)."""
        body = payload.rstrip(b"\0") or payload[:1]  # MAVLink 2 truncation keeps >= 1 byte
        seq = self.seq
        self.seq = (seq + 1) & 0xFF
        out = _HEADER.pack(MAGIC_V2, len(body), self._incompat, 0, seq, self.sysid, self.compid,
                           msg_id & 0xFFFF, msg_id >> 16) + body
        # Header (after the magic) and payload in one C call, then the CRC_EXTRA byte's step.
        crc = _crc_x25(out, _CRC_INIT_BEFORE_MAGIC)
        return out + _CRC.pack((crc >> 8) ^ _CRC_STEP[(crc ^ crc_extra) & 0xFF])

    def frame_streams(self, specs: Iterable[Any], snapshot: Any, out: list[bytes],
                      failed: Callable[[int], None]) -> None:
        """Each stream of ``specs`` (streams.StreamSpec: ``builder``, ``msg_id``, ``crc_extra``,
        the id's header fields ``id_low16`` and ``id_high8``) built from ``snapshot`` and framed
        onto ``out``, in order: ``frame`` inlined into one loop, as a wake-up frames a dozen
        messages. A builder that returns None sends nothing; one that raises is reported to
        ``failed(msg_id)`` and skipped (no sequence number)."""
        seq = self.seq
        sysid, compid, incompat = self.sysid, self.compid, self._incompat
        sign = self._sign if self.signer is not None else None
        now_s = self.now_s
        header, crc_x25, crc_pack, step = _HEADER.pack, _crc_x25, _CRC.pack, _CRC_STEP
        magic, crc_init = MAGIC_V2, _CRC_INIT_BEFORE_MAGIC
        append = out.append
        for spec in specs:
            try:
                payload = spec.builder(self, snapshot)
            except Exception:  # one broken stream must not silence the others
                failed(spec.msg_id)
                continue
            if payload is None:
                continue
            body = payload.rstrip(b"\0") or payload[:1]
            frame = header(magic, len(body), incompat, 0, seq, sysid, compid, spec.id_low16,
                           spec.id_high8) + body
            crc = crc_x25(frame, crc_init)
            frame += crc_pack((crc >> 8) ^ step[(crc ^ spec.crc_extra) & 0xFF])
            seq = (seq + 1) & 0xFF
            append(frame if sign is None else sign(frame, now_s))
        self.seq = seq

    def _frame_signed(self, msg_id: int, crc_extra: int, payload: bytes) -> bytes:
        """``frame`` with the signature block appended."""
        return self._sign(Encoder.frame(self, msg_id, crc_extra, payload), self.now_s)

    def pack(self, cls: type[mavlink2.MAVLink_message], *args: Any) -> bytes:
        """Encode ``cls(*args)``; trailing (extension) arguments may be omitted → zero."""
        p = _PACKERS.get(cls) or packer_of(cls)
        return self.frame(p.msg_id, p.crc_extra, p.pack(*args))


def _as_float32(value: Any) -> Any:
    """``value`` as PX4's float fields hold it: a double beyond the float32 range is ±inf (what
    a C double→float conversion and float32 arithmetic give), e.g. a velocity setpoint computed
    with a gain of 3e38, which PX4 stores as given."""
    if isinstance(value, float) and abs(value) > FLT_MAX:
        return math.copysign(math.inf, value)
    if isinstance(value, (list, tuple)):
        return type(value)(_as_float32(v) for v in value)
    return value


MAX_REMOTE_COMPONENTS = 16  # MavlinkReceiver's sender table


@dataclass
class DecodeStats:
    rx_datagrams: int = 0
    rx_bytes: int = 0
    rx_frames: int = 0  # decoded, known message ids, good CRC (and accepted by the Verifier)
    rx_malformed: int = 0  # bad CRC, garbage bytes, truncated frames, parser errors
    rx_unknown: int = 0  # well-framed but message id not in common.xml
    rx_bad_datagrams: int = 0  # datagrams with anything unusable in them (malformed or unknown)
    rx_lost: int = 0  # frames missing from a sender's sequence numbers (MavlinkReceiver's count)
    rx_counted: int = 0  # frames MavlinkReceiver::update_rx_stats counts (its first 16 senders)
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
        self._seqs: dict[tuple[int, int], int] = {}  # last sequence number per (sysid, compid)

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
                    # MavlinkReceiver::update_rx_stats: per sender (the first 16 only) the gap
                    # to the expected sequence number, one short across the wrap (+255)
                    sender, seq = (m.get_srcSystem(), m.get_srcComponent()), m.get_seq()
                    seqs = self._seqs
                    last = seqs.get(sender)
                    if last is not None:
                        expected = (last + 1) & 0xFF
                        st.rx_lost += seq + 255 - expected if seq < expected else seq - expected
                        st.rx_counted += 1
                        seqs[sender] = seq
                    elif len(seqs) < MAX_REMOTE_COMPONENTS:
                        st.rx_counted += 1
                        seqs[sender] = seq
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


def fixed_name(name: str) -> bytes:
    """PARAM/STATUSTEXT-style char[N] field: ASCII bytes; struct pads with NULs."""
    return name.encode("ascii", "replace")
