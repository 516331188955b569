"""Messages of MAVLink's common.xml that pymavlink 2.4.50's generated dialects lack (common.xml
marks them work in progress, which pymavlink leaves out) but PX4 builds with and sends: the
events protocol (event_messages.py), the ESC reports ESC_INFO (290) and ESC_STATUS (291), which
PX4 SITL with the gz bridge streams by default, TIME_ESTIMATE_TO_TARGET (380) and
LINK_NODE_STATUS (8); and development.xml's SET_VELOCITY_LIMITS (354), which PX4 SITL (built with
the development dialect) takes for Position Slow's limits (registered in both maps too: the
decoder parses with the common dialect's).

``define_message`` makes a class as mavgen makes one (wire order by field size, stable; the
CRC_EXTRA given is mavgen's, tests recompute it from the definition) and registers it in the
common dialect's ``mavlink_map`` and the development dialect's (PX4 SITL's), so that pymavlink's
parser decodes it with its CRC checked and the encoder (codec.py) packs it like any other
message. Importing this module registers the messages below.
"""

from __future__ import annotations

import struct
from typing import Any

from pymavlink.dialects.v20 import common as M
from pymavlink.dialects.v20 import development

_SIZE = {"uint64_t": 8, "int32_t": 4, "uint32_t": 4, "float": 4, "int16_t": 2, "uint16_t": 2,
         "uint8_t": 1}
_CODE = {"uint64_t": "Q", "int32_t": "i", "uint32_t": "I", "float": "f", "int16_t": "h",
         "uint16_t": "H", "uint8_t": "B"}
Field = tuple[str, str, int]  # (type, name, array length or 0), in the definition's order


def define_message(msg_id: int, name: str, crc_extra: int, fields: tuple[Field, ...]
                   ) -> type[M.MAVLink_message]:
    wire = sorted(range(len(fields)), key=lambda i: -_SIZE[fields[i][0]])  # stable, as mavgen
    names = [f[1] for f in fields]
    ordered = [fields[i][1] for i in wire]
    fmt = "<" + "".join(f"{fields[i][2] or ''}{_CODE[fields[i][0]]}" for i in wire)
    arrays = [fields[i][2] for i in wire]
    unpacker = struct.Struct(fmt)

    def __init__(self: Any, *args: Any) -> None:
        M.MAVLink_message.__init__(self, msg_id, name)
        self._fieldnames = names
        self._instance_field, self._instance_offset = None, -1
        for field, value in zip(names, args):
            setattr(self, field, value)

    def pack(self: Any, mav: Any, force_mavlink1: bool = False) -> bytes:
        values: list[Any] = []
        for field, n in zip(ordered, arrays):
            value = getattr(self, field)
            values.extend(value) if n else values.append(value)
        return self._pack(mav, crc_extra, unpacker.pack(*values), force_mavlink1=force_mavlink1)

    cls = type(f"MAVLink_{name.lower()}_message", (M.MAVLink_message,), {
        "id": msg_id, "msgname": name, "fieldnames": names, "ordered_fieldnames": ordered,
        "fieldtypes": [f[0] for f in fields], "fielddisplays_by_name": {},
        "fieldenums_by_name": {}, "fieldunits_by_name": {}, "native_format": bytearray(fmt,
                                                                                     "ascii"),
        "orders": [ordered.index(n) for n in names], "lengths": [n or 1 for n in arrays],
        "array_lengths": arrays, "crc_extra": crc_extra, "unpacker": unpacker,
        "instance_field": None, "instance_offset": -1, "__init__": __init__, "pack": pack})
    M.mavlink_map.setdefault(msg_id, cls)
    development.mavlink_map.setdefault(msg_id, M.mavlink_map[msg_id])  # PX4 SITL's dialect
    return M.mavlink_map[msg_id]

U8, U16, U32, U64 = "uint8_t", "uint16_t", "uint32_t", "uint64_t"
I16, I32, F32 = "int16_t", "int32_t", "float"

# common.xml ESC_INFO / ESC_STATUS, fields in the definition's order.
ESC_INFO = define_message(290, "ESC_INFO", 251, (
    (U8, "index", 0), (U64, "time_usec", 0), (U16, "counter", 0), (U8, "count", 0),
    (U8, "connection_type", 0), (U8, "info", 0), (U16, "failure_flags", 4),
    (U32, "error_count", 4), (I16, "temperature", 4)))
ESC_STATUS = define_message(291, "ESC_STATUS", 10, (
    (U8, "index", 0), (U64, "time_usec", 0), (I32, "rpm", 4), (F32, "voltage", 4),
    (F32, "current", 4)))
TIME_ESTIMATE_TO_TARGET = define_message(380, "TIME_ESTIMATE_TO_TARGET", 232, (
    (I32, "safe_return", 0), (I32, "land", 0), (I32, "mission_next_item", 0),
    (I32, "mission_end", 0), (I32, "commanded_action", 0)))
LINK_NODE_STATUS = define_message(8, "LINK_NODE_STATUS", 117, (
    (U64, "timestamp", 0), (U8, "tx_buf", 0), (U8, "rx_buf", 0), (U32, "tx_rate", 0),
    (U32, "rx_rate", 0), (U16, "rx_parse_err", 0), (U16, "tx_overflows", 0),
    (U16, "rx_overflows", 0), (U32, "messages_sent", 0), (U32, "messages_received", 0),
    (U32, "messages_lost", 0)))
# development.xml SET_VELOCITY_LIMITS (a wip message: no pymavlink class), PX4's velocity_limits.
SET_VELOCITY_LIMITS = define_message(354, "SET_VELOCITY_LIMITS", 210, (
    (U8, "target_system", 0), (U8, "target_component", 0), (F32, "horizontal_speed_limit", 0),
    (F32, "vertical_speed_limit", 0), (F32, "yaw_rate_limit", 0)))
