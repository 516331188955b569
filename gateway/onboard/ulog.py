"""ULog, PX4's log format, written sans-IO: every function returns the bytes of one part.

Source: the ULog file format (PX4 docs, "ULog File Format"; PX4 src/modules/logger/messages.h).
Rules:
- A file is the 16-byte header, the definitions section (flag bits first, then formats, info,
  parameters, default parameters 'Q' when the flag bits say so) and the data section
  (subscriptions 'A', data 'D', logged strings 'L', parameter changes 'P', sync 'S'). Every
  message is ``uint16 size, uint8 type, payload`` (little endian).
- Formats are packed as declared: no implicit padding; the first field of every logged topic is
  ``uint64_t timestamp`` (µs). A format may end in PX4's generated ``uint8_t[n] _paddingK``
  fields (the struct's alignment to 8 bytes): the format names them but a record leaves them
  out, as PX4's logger writes a topic's o_size_no_padding bytes (pyulog accepts both).
- Types: int8_t … uint64_t, float, double, bool, char, arrays ``type[n]``, and nested formats
  (a field whose type is another format's name, as PX4's position_setpoint_triplet has
  ``position_setpoint current``), whose fields are packed in its place.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping, Sequence
from functools import partial

Fields = Sequence[tuple[str, str]]  # (type, name) pairs
MAGIC = b"ULog\x01\x12\x35"
VERSION = 1
SYNC_MAGIC = bytes((0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12))
CODES = {"int8_t": "b", "uint8_t": "B", "int16_t": "h", "uint16_t": "H", "int32_t": "i",
         "uint32_t": "I", "int64_t": "q", "uint64_t": "Q", "float": "f", "double": "d",
         "bool": "?", "char": "c"}
# Logged string levels (syslog, as ASCII digits).
LOG_EMERG, LOG_ALERT, LOG_CRIT, LOG_ERR, LOG_WARNING, LOG_NOTICE, LOG_INFO, LOG_DEBUG = (
    ord(str(i)) for i in range(8))


def _message(kind: bytes, payload: bytes) -> bytes:
    if len(payload) > 0xFFFF:
        raise ValueError(f"ULog message {kind!r} too long ({len(payload)} bytes)")
    return struct.pack("<HB", len(payload), kind[0]) + payload


def header(timestamp_us: int) -> bytes:
    return MAGIC + bytes((VERSION,)) + struct.pack("<Q", timestamp_us)


COMPAT_DEFAULT_PARAMETERS = 1  # compat_flags[0]: the file has 'Q' (default parameter) messages
DEFAULT_SYSTEM, DEFAULT_CURRENT_SETUP = 1, 2  # ulog_parameter_default_type_t bits


def flag_bits(compat0: int = 0) -> bytes:
    """'B': compat_flags[0] = ``compat0``, no incompatible flags, no appended data."""
    return _message(b"B", bytes((compat0,)) + bytes(15) + struct.pack("<3Q", 0, 0, 0))


def field_code(type_name: str, nested: Mapping[str, Fields] | None = None) -> str:
    """``float[3]`` → ``3f``; a nested format's name (in ``nested``) → its fields' codes."""
    base, _, rest = type_name.partition("[")
    if base not in CODES:
        assert nested is not None, f"no format {base}"
        return "".join(field_code(t, nested) for t, _ in nested[base]) * (
            int(rest[:-1]) if rest else 1)
    code = CODES[base]
    return f"{int(rest[:-1])}{code}" if rest else code


def struct_of(fields: Fields, nested: Mapping[str, Fields] | None = None) -> struct.Struct:
    """The record of ``fields`` packed as declared, a nested format's fields in its place, the
    trailing padding left out (module rules)."""
    end = len(fields)
    while end and fields[end - 1][1].startswith("_padding"):
        end -= 1
    return struct.Struct("<" + "".join(field_code(t, nested) for t, _ in fields[:end]))


def format_message(name: str, fields: Fields) -> bytes:
    """'F': ``name:type field;type field;…``."""
    text = name + ":" + "".join(f"{t} {n};" for t, n in fields)
    return _message(b"F", text.encode())


def _key_value(key: str, value: bytes) -> bytes:
    k = key.encode()
    return bytes((len(k),)) + k + value


def info(name: str, value: str | int, unsigned: bool = False) -> bytes:
    """'I': a string as ``char[len] name``, an integer as ``int32_t name`` (``unsigned``:
    ``uint32_t name``)."""
    if isinstance(value, str):
        raw = value.encode()
        return _message(b"I", _key_value(f"char[{len(raw)}] {name}", raw))
    if unsigned:
        return _message(b"I", _key_value(f"uint32_t {name}", struct.pack("<I", value)))
    return _message(b"I", _key_value(f"int32_t {name}", struct.pack("<i", value)))


def info_multiple(name: str, data: bytes, chunk: int = 4096) -> list[bytes]:
    """'M': ``uint8_t[n] name`` in chunks, each after the first marked continued."""
    return [_message(b"M", bytes((i > 0,)) + _key_value(f"uint8_t[{len(part)}] {name}", part))
            for i, part in enumerate(data[k:k + chunk] for k in range(0, len(data), chunk))]


def parameter(name: str, value: float, is_int: bool) -> bytes:
    """'P': ``int32_t NAME`` or ``float NAME`` (in either section)."""
    if is_int:
        return _message(b"P", _key_value(f"int32_t {name}", struct.pack("<i", int(value))))
    return _message(b"P", _key_value(f"float {name}", struct.pack("<f", float(value))))


def parameter_default(name: str, value: float, is_int: bool, default_types: int) -> bytes:
    """'Q': a parameter's default (``default_types``: DEFAULT_SYSTEM, DEFAULT_CURRENT_SETUP or
    both), as ``int32_t NAME`` or ``float NAME``."""
    raw = struct.pack("<i", int(value)) if is_int else struct.pack("<f", float(value))
    key = f"{'int32_t' if is_int else 'float'} {name}"
    return _message(b"Q", bytes((default_types,)) + _key_value(key, raw))


def add_logged(msg_id: int, name: str, multi_id: int = 0) -> bytes:
    """'A': subscribe ``msg_id`` to the format ``name`` (instance ``multi_id``)."""
    return _message(b"A", struct.pack("<BH", multi_id, msg_id) + name.encode())


def data(msg_id: int, payload: bytes) -> bytes:
    return _message(b"D", struct.pack("<H", msg_id) + payload)


def data_prefix(msg_id: int, payload_size: int) -> bytes:
    """What ``data(msg_id, payload)`` puts before a payload of ``payload_size`` bytes: a topic's
    records all have its struct's size, so the prefix is computed once per topic."""
    return struct.pack("<HBH", payload_size + 2, ord("D"), msg_id)


def data_packer(msg_id: int, record: struct.Struct) -> Callable[..., bytes]:
    """``data(msg_id, record.pack(*values))`` as one call of the values: the message's header
    (``data_prefix``, the same for every record of a topic) packed with the record."""
    whole = struct.Struct("<HBH" + record.format.removeprefix("<"))
    return partial(whole.pack, record.size + 2, ord("D"), msg_id)


def logged_string(level: int, timestamp_us: int, text: str) -> bytes:
    """'L': a message as the console printed it (STATUSTEXT's text)."""
    return _message(b"L", struct.pack("<BQ", level, timestamp_us) + text.encode()[:2000])


def sync() -> bytes:
    return _message(b"S", SYNC_MAGIC)
