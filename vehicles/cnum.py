"""C float arithmetic where Python's raises: for values derived from parameters.

PX4's param_set stores a float32 as given, NaN and ±inf included (src/lib/parameters/
parameters.cpp), and its modules compute with it in C: NaN propagates, comparisons with it are
false, a float→int conversion never traps. Python raises instead (``int(nan)``,
``math.remainder(inf, …)``), so the few places that convert or wrap a parameter-derived value go
through these.

Rules: finite values give exactly what the plain Python expression gives; only non-finite ones
take the C result.
"""

from __future__ import annotations

import math
import struct

INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1


def c_int(value: float, lo: int = INT32_MIN, hi: int = INT32_MAX) -> int:
    """``(int)value``: toward zero, saturated to [lo, hi], NaN → 0 (the flight controller's
    conversion, ARM VCVT; x86 SITL would give INT32_MIN for NaN and ±inf)."""
    if value != value:
        return 0
    if value >= hi:
        return hi
    if value <= lo:
        return lo
    return math.trunc(value)


def c_ceil(value: float) -> int:
    """``(int)ceilf(value)``."""
    return c_int(math.ceil(value)) if math.isfinite(value) else c_int(value)


def c_round(value: float) -> int:
    """``(int)roundf(value)``, as ``int(round(value))`` for finite values."""
    return c_int(round(value)) if math.isfinite(value) else c_int(value)


def wrap_remainder(value: float, period: float) -> float:
    """``math.remainder(value, period)``; NaN where it would raise (value ±inf), as
    matrix::wrap gives NaN for an infinite angle (inf − range·inf)."""
    return math.remainder(value, period) if math.isfinite(value) else math.nan


def f32(value: float) -> float:
    """``value`` rounded to float32, as a C float holds it (beyond its range: ±inf)."""
    try:
        return struct.unpack("<f", struct.pack("<f", value))[0]
    except OverflowError:
        return math.copysign(math.inf, value)
