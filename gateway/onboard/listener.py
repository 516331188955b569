"""What PX4's ``listener <topic>`` prints of one message: uORB's orb_print_message_internal
(platforms/common/uORB/uORB.cpp), over the fields CORNET logs of the topic (topic.py).

Rules, as orb_print_message_internal has them:
- ``_padding*`` fields are not printed;
- each field ``    name: value``; an array ``[a, b, …]``; floats ``%.5f``, doubles ``%.6f``,
  bools True/False, integers as they are;
- ``timestamp`` (a uint64_t) is followed by `` (S seconds ago)`` unless it is 0, and
  ``timestamp_sample`` by `` (N us before timestamp)``; a non-zero
  integer whose name contains "flags" by its bits, `` (0b1010'0001)``; a float[4] named ``q`` or
  ``q_*`` by its Euler angles, `` (Roll: 1.0 deg, Pitch: 2.0 deg, Yaw: 3.0 deg)``;
- a nested message (a field of a nested format's type) ``  name (type):`` and its fields below,
  an array of them ``  name[i] (type):`` per element.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

from gateway.onboard.topic import Fields
from vehicles.types import q_euler_rad

_INT_BITS = {"uint8_t": 8, "uint16_t": 16, "uint32_t": 32, "uint64_t": 64}


def print_message(fields: Fields, values: Iterator[Any], now_us: int,
                  nested: Mapping[str, Fields]) -> str:
    """The lines of one message whose ``fields`` take ``values`` in order (an array's
    elements one by one, a nested message's fields in its place)."""
    out: list[str] = []
    stamp = 0  # this message's timestamp, once printed
    for ftype, name in fields:
        base, _, size = ftype.partition("[")
        count = int(size[:-1]) if size else 1
        if base in nested:
            for i in range(count):
                out.append(f"  {name}[{i}] ({base}):\n" if size else f"  {name} ({base}):\n")
                out.append(print_message(nested[base], values, now_us, nested))
            continue
        if name.startswith("_padding"):  # never printed; a record carries no trailing one
            for _ in range(count):
                next(values, None)
            continue
        items = [next(values) for _ in range(count)]
        text = "[" + ", ".join(_scalar(base, v) for v in items) + "]" if size \
            else _scalar(base, items[0])
        if name == "timestamp" and base == "uint64_t" and not size:
            stamp = int(items[0])
        out.append(f"    {name}: {text}{_note(base, name, items, now_us, stamp)}\n")
    return "".join(out)


def _scalar(ctype: str, v: Any) -> str:
    if ctype == "bool":
        return "True" if v else "False"
    if ctype in ("float", "double"):
        v = float(v)
        if not math.isfinite(v):
            return str(v).lower()
        return f"{v:.6f}" if ctype == "double" else f"{v:.5f}"
    return str(int(v))


def _note(ctype: str, name: str, items: Sequence[Any], now_us: int, stamp: int) -> str:
    if len(items) == 1:
        v = items[0]
        if ctype == "uint64_t" and name == "timestamp":
            return f" ({(now_us - int(v)) / 1e6:.6f} seconds ago)" if v else ""
        if ctype == "uint64_t" and name == "timestamp_sample":
            return f" ({stamp - int(v)} us before timestamp)" if stamp and v else ""
        if "flags" in name and ctype in _INT_BITS and int(v):
            bits = format(int(v), "b")
            # a ' between nibbles, counted from the low bit
            return " (0b" + "".join(b + ("'" if (len(bits) - 1 - k) % 4 == 0 and
                                           k < len(bits) - 1 else "")
                                     for k, b in enumerate(bits)) + ")"
    elif len(items) == 4 and ctype == "float" and (name == "q" or name.startswith("q_")):
        roll, pitch, yaw = (math.degrees(a) for a in q_euler_rad(tuple(items)))
        return f" (Roll: {roll:.1f} deg, Pitch: {pitch:.1f} deg, Yaw: {yaw:.1f} deg)"
    return ""
