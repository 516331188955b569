"""Byte identity of our MAVLink 2 framing with pymavlink's ``pack()``, on random field values.

For every message of the common dialect (a superset of what the daemon streams and replies),
Hypothesis draws field values at the edges of their wire types (NaN, ±inf, subnormals, integer
extremes, strings with and without NUL padding, full and empty arrays, all-zero payloads that
MAVLink 2 truncates to one byte) and a sequence number; ``Encoder.pack`` must give exactly the
bytes ``MAVLink_message.pack`` gives for the same seq, sysid and compid, unsigned and signed.
"""

import struct

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as M
from pymavlink.dialects.v20 import development as D

from gateway.mavlink.codec import Encoder
from gateway.mavlink.signing import MAVLINK_EPOCH_UNIX_S, Signer, SigningClock, SigningKey
from gateway.mavlink.streams import STREAMS

KEY = SigningKey(bytes(range(7, 39)))
EPOCH_UNIX_S = 1_750_000_000.0
TICKS_PER_S = 100_000

INT_RANGES = {
    "int8_t": (-(1 << 7), (1 << 7) - 1), "uint8_t": (0, (1 << 8) - 1),
    "int16_t": (-(1 << 15), (1 << 15) - 1), "uint16_t": (0, (1 << 16) - 1),
    "int32_t": (-(1 << 31), (1 << 31) - 1), "uint32_t": (0, (1 << 32) - 1),
    "int64_t": (-(1 << 63), (1 << 63) - 1), "uint64_t": (0, (1 << 64) - 1),
    "uint8_t_mavlink_version": (0, 255),
}

# and CURRENT_MODE, AVAILABLE_MODES (and its stream's AVAILABLE_MODES_MONITOR), which PX4 SITL
# sends from its development dialect
CLASSES = sorted([*M.mavlink_map.values(), D.MAVLink_current_mode_message,
                  D.MAVLink_available_modes_message, D.MAVLink_available_modes_monitor_message],
                 key=lambda cls: cls.id)
STREAMED_IDS = {spec.msg_id for spec in STREAMS}


def _scalar(ftype: str) -> st.SearchStrategy:
    if ftype == "float":
        return st.one_of(st.floats(width=32), st.sampled_from([0.0, -0.0, 1e-45, 3.4e38]))
    if ftype == "double":
        return st.one_of(st.floats(), st.sampled_from([0.0, -0.0, 5e-324, 1.7e308]))
    lo, hi = INT_RANGES[ftype]
    return st.one_of(st.integers(lo, hi), st.sampled_from([lo, hi, 0]))


def _field(cls: type[M.MAVLink_message], i: int) -> st.SearchStrategy:
    name, ftype = cls.fieldnames[i], cls.fieldtypes[i]
    n = cls.array_lengths[list(cls.ordered_fieldnames).index(name)]
    if ftype == "char":
        # struct pads with NULs; a full-length string has none; NULs inside are kept as sent.
        return st.binary(max_size=max(n, 1)).map(lambda b: b.rstrip(b"\0") if len(b) % 2 else b)
    if n:
        return st.one_of(st.lists(_scalar(ftype), min_size=n, max_size=n),
                         st.just([0] * n if ftype not in ("float", "double") else [0.0] * n))
    return _scalar(ftype)


def _args(cls: type[M.MAVLink_message]) -> st.SearchStrategy:
    fields = [_field(cls, i) for i in range(len(cls.fieldnames))]
    zeros = st.tuples(*(st.just(_zero(cls, i)) for i in range(len(cls.fieldnames))))
    return st.one_of(st.tuples(*fields), zeros)  # all zeros: truncated to one payload byte


def _zero(cls: type[M.MAVLink_message], i: int) -> object:
    n = cls.array_lengths[list(cls.ordered_fieldnames).index(cls.fieldnames[i])]
    if cls.fieldtypes[i] == "char":
        return b""
    return [0] * n if n else 0


def _reference(cls, args, seq, sysid, compid, signed, now_s, link_id) -> bytes:
    mav = M.MAVLink(None, sysid, compid)
    mav.seq = seq
    if signed:
        mav.signing.secret_key = KEY.secret
        mav.signing.sign_outgoing = True
        mav.signing.link_id = link_id
        mav.signing.timestamp = (round((EPOCH_UNIX_S - MAVLINK_EPOCH_UNIX_S) * TICKS_PER_S)
                                 + int(now_s * TICKS_PER_S))
    return cls(*args).pack(mav)


@pytest.mark.parametrize("cls", CLASSES, ids=lambda cls: cls.msgname)
@settings(max_examples=15, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data(), seq=st.integers(0, 255), sysid=st.integers(1, 255),
       compid=st.integers(0, 255), signed=st.booleans(),
       now_s=st.floats(0.0, 1e6), link_id=st.integers(0, 255))
def test_encoder_is_byte_identical_to_pymavlink(cls, data, seq, sysid, compid, signed, now_s,
                                               link_id):
    args = data.draw(_args(cls))
    try:
        want = _reference(cls, args, seq, sysid, compid, signed, now_s, link_id)
    except (struct.error, OverflowError):  # pymavlink cannot pack it either (float32 overflow)
        with pytest.raises((struct.error, OverflowError)):
            Encoder(sysid, compid).pack(cls, *args)
        return
    signer = Signer(KEY, link_id, SigningClock(EPOCH_UNIX_S)) if signed else None
    enc = Encoder(sysid, compid, signer)
    enc.seq, enc.now_s = seq, now_s
    assert enc.pack(cls, *args) == want
    assert enc.seq == (seq + 1) & 0xFF


def test_every_streamed_message_is_covered():
    assert STREAMED_IDS <= {cls.id for cls in CLASSES}
