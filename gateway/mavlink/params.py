"""Parameter protocol server over the vehicle's ParamStore.

Source: PX4 v1.15.2 mavlink_parameters.cpp (MavlinkParametersManager), mavlink_receiver.cpp
(run: the manager's send() every 10 ms); MAVSDK mavlink_parameter_client.cpp; QGC
ParameterManager.cc.
Rules and invariants:
- Every PARAM_VALUE carries param_count = store.count and its dense param_index.
- INT32 values travel BYTEWISE: the int's four bytes sit in the float field. We pack the int
  directly (never through a Python float) so signalling-NaN bit patterns survive.
- PARAM_REQUEST_LIST: `_HASH_CHECK` first (type UINT32, index 65535, value = hash bytes), then
  every index 0..N−1: PARAM_BURST messages (the hash counts as one) per PARAM_TICK_S, as the
  receiver thread calls send() over UDP. A LIST during a running list restarts at 0 without
  the hash. A PARAM_SET of `_HASH_CHECK` (QGC: its cache matches) stops the list when
  MAV_HASH_CHK_EN is set, and is not answered.
- PARAM_SET success: echo on this link (send_param). Every change (this link's, other links',
  the autopilot's) arrives through the store's on_change observer and is sent on every link, as
  each MAVLink instance's send_untransmitted sends a changed, not yet saved parameter: the link
  that set it gets it twice, echo first. (PX4 sends that copy 5–15 ms later, and every
  parameter changed since the last autosave with it; autosave waits 300 ms, and for disarm.)
  A REAL32 NaN or ±inf is stored and echoed as PX4 does; a store PX4 counts as no change (to or
  from NaN) reaches the other links only in their next list or read.
- What PX4 v1.15 refuses it leaves unanswered: PARAM_SET of an unknown name, or with a type
  other than the parameter's (INT32 / REAL32); a read of an unknown name or of an index out of
  range. (PARAM_ERROR came with PX4 1.17.)
"""

from __future__ import annotations

import math
import struct
import weakref

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.link import LinkContext
from vehicles.params import ParamType

HASH_CHECK_NAME = "_HASH_CHECK"
HASH_CHECK_INDEX = 65535  # index −1 as uint16
MAV_PARAM_TYPE_UINT32 = 5
PARAM_BURST = 20  # send(): max_num_to_send over UDP
PARAM_TICK_S = 0.01  # MavlinkReceiver::run calls send() when 10 ms have passed
PARAM_ID_LEN = 16

# PARAM_VALUE wire layout: param_value(4 bytes), param_count u16, param_index u16, id[16], type u8
_PV_INT = struct.Struct("<iHH16sB")
_PV_FLOAT = struct.Struct("<fHH16sB")
_PV_UINT = struct.Struct("<IHH16sB")
_PV = M.MAVLink_param_value_message


def float_bits_to_int32(value: float) -> int:
    return struct.unpack("<i", struct.pack("<f", value))[0]


class ParamService:
    """Uses the vehicle's params, the encoder, send, sysid and other_target."""

    def __init__(self, ctx: LinkContext) -> None:
        self.encoder = ctx.encoder
        self.send = ctx.send
        self.sysid = ctx.sysid
        self.other_target = ctx.other_target
        self.store = ctx.vehicle.params
        self._list_next: int | None = None  # next index of a running list transfer
        self._burst_used = 0  # of the next burst: the hash, sent on the request
        # When ``handle_timer`` has work next (the list transfer's next burst); inf: none.
        self.due_s = math.inf
        self._own_set: str | None = None  # name being set by this link (echo sent explicitly)
        self._own_changed = False  # and that set changed it
        ref = weakref.ref(self)

        def observer(name: str, value: int | float) -> None:
            svc = ref()
            if svc is not None:
                svc._on_change(name)

        self.store.on_change(observer)

    # --- timer --------------------------------------------------------------------------------
    def get_timer(self) -> float:
        return self.due_s

    def handle_timer(self, now_s: float) -> None:
        if self._list_next is None or now_s < self.due_s:
            return
        count = self.store.count
        end = min(self._list_next + PARAM_BURST - self._burst_used, count)
        self._burst_used = 0
        for i in range(self._list_next, end):
            self.send(self.param_value(i))
        if end >= count:
            self._list_next, self.due_s = None, math.inf
        else:
            self._list_next, self.due_s = end, now_s + PARAM_TICK_S

    # --- inbound ------------------------------------------------------------------------------
    def on_request_list(self, msg: M.MAVLink_param_request_list_message, now_s: float) -> None:
        if not self._for_us(msg):
            return
        if self._list_next is None:
            self.send(self.hash_check())
            self._burst_used = 1
        self._list_next, self.due_s = 0, now_s

    def on_request_read(self, msg: M.MAVLink_param_request_read_message, now_s: float) -> None:
        if not self._for_us(msg):
            return
        if msg.param_index < 0:
            name = msg.param_id
            if name == HASH_CHECK_NAME:
                self.send(self.hash_check())
            elif name in self.store:
                self.send(self.param_value(self.store.index_of(name)))
        elif msg.param_index < self.store.count:
            self.send(self.param_value(msg.param_index))

    def on_set(self, msg: M.MAVLink_param_set_message, now_s: float) -> None:
        if not self._for_us(msg):
            return
        name = msg.param_id
        if name == HASH_CHECK_NAME:
            # QGC: its cache matches, stop streaming the list (if hash checks are on).
            if int(self.store.get("MAV_HASH_CHK_EN", 1) or 0):
                self._list_next, self.due_s = None, math.inf
            return
        if name not in self.store:
            return  # PX4_ERR("unknown param") on the console only
        index = self.store.index_of(name)
        if msg.param_type != self.store.info(index).type:
            return  # "param types mismatch": INT32 for INT32, REAL32 for REAL32, else silent
        if msg.param_type == ParamType.INT32:
            value: float = float_bits_to_int32_raw(msg)
        else:
            value = msg.param_value
        # mavlink_parameters.cpp: param_set, then send_param whatever it did. A float32 is
        # stored as given (NaN and ±inf too); to or from NaN it is no change (no
        # parameter_update), so only this echo carries it, not the other links. A change is
        # sent again after the echo, as on every link (send_untransmitted).
        self._own_set, self._own_changed = name, False
        try:
            self.store.set(name, value)
        finally:
            self._own_set = None
        self.send(self.param_value(index))
        if self._own_changed:
            self.send(self.param_value(index))

    def _for_us(self, msg: M.MAVLink_message) -> bool:
        # mavlink_parameters.cpp: target_system must be ours (0 is not taken: a broadcast write
        # would change every vehicle's parameter), the component ours or MAV_COMP_ID_ALL.
        if msg.target_system == self.sysid and msg.target_component in (0, 1):
            return True
        self.other_target()
        return False

    def _on_change(self, name: str) -> None:
        if name == self._own_set:
            self._own_changed = True  # sent after the echo
        else:
            self.send(self.param_value(self.store.index_of(name)))

    # --- outbound -----------------------------------------------------------------------------
    def param_value(self, index: int) -> bytes:
        info = self.store.info(index)
        value = self.store.value_at(index)
        pid = info.name.encode("ascii")
        if info.type is ParamType.INT32:
            payload = _PV_INT.pack(int(value), self.store.count, index, pid, ParamType.INT32)
        else:
            payload = _PV_FLOAT.pack(value, self.store.count, index, pid, ParamType.REAL32)
        return self.encoder.frame(_PV.id, _PV.crc_extra, payload)

    def hash_check(self) -> bytes:
        payload = _PV_UINT.pack(self.store.hash32(), self.store.count, HASH_CHECK_INDEX,
                                HASH_CHECK_NAME.encode(), MAV_PARAM_TYPE_UINT32)
        return self.encoder.frame(_PV.id, _PV.crc_extra, payload)


def float_bits_to_int32_raw(msg: M.MAVLink_param_set_message) -> int:
    """The int32 a client put bytewise into PARAM_SET.param_value, read from the raw frame.

    Re-packing the decoded float would quieten signalling-NaN patterns, so read payload bytes
    0..3 (param_value is first on the wire) from the frame; pad if MAVLink 2 trimmed zeros.
    (pymavlink's ``msg._payload`` uses the v1 header length, so it is wrong for v2 frames.)
    """
    buf = getattr(msg, "_msgbuf", None)
    if buf:
        header_len = 10 if buf[0] == 0xFD else 6
        raw = bytes(buf[header_len:header_len + min(4, buf[1])]).ljust(4, b"\0")
        return struct.unpack("<i", raw)[0]
    return float_bits_to_int32(msg.param_value)
