"""The events protocol's messages (common.xml: EVENT 410, CURRENT_EVENT_SEQUENCE 411,
REQUEST_EVENT 412, RESPONSE_EVENT_ERROR 413), which pymavlink 2.4.50's common dialect lacks.

Each is made as mavgen makes a message class (wire order by field size, CRC_EXTRA from the
definition; tests/unit/test_events.py recomputes it) and registered in the common dialect's
``mavlink_map`` (and the development dialect's, which PX4 SITL builds with), so that pymavlink's
parser decodes them with their CRC checked, and the encoder
(codec.py) packs them like any other message. Importing this module registers them.
"""

from __future__ import annotations

import struct
from typing import Any

from pymavlink.dialects.v20 import common as M
from pymavlink.dialects.v20 import development

_SIZE = {"uint32_t": 4, "uint16_t": 2, "uint8_t": 1}
_CODE = {"uint32_t": "I", "uint16_t": "H", "uint8_t": "B"}
Field = tuple[str, str, int]  # (type, name, array length or 0), in the definition's order


def _message(msg_id: int, name: str, crc_extra: int, fields: tuple[Field, ...]
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


U8, U16, U32 = "uint8_t", "uint16_t", "uint32_t"
EVENT = _message(410, "EVENT", 160, (
    (U8, "destination_component", 0), (U8, "destination_system", 0), (U32, "id", 0),
    (U32, "event_time_boot_ms", 0), (U16, "sequence", 0), (U8, "log_levels", 0),
    (U8, "arguments", 40)))
CURRENT_EVENT_SEQUENCE = _message(411, "CURRENT_EVENT_SEQUENCE", 106, (
    (U16, "sequence", 0), (U8, "flags", 0)))
REQUEST_EVENT = _message(412, "REQUEST_EVENT", 33, (
    (U8, "target_system", 0), (U8, "target_component", 0), (U16, "first_sequence", 0),
    (U16, "last_sequence", 0)))
RESPONSE_EVENT_ERROR = _message(413, "RESPONSE_EVENT_ERROR", 77, (
    (U8, "target_system", 0), (U8, "target_component", 0), (U16, "sequence", 0),
    (U16, "sequence_oldest_available", 0), (U8, "reason", 0)))
