"""The parameters PX4's control allocation and the gz bridge's ESC outputs are configured with,
read as the inner loop takes them (vehicles/inner_loop.py ``set_allocation``, ``set_outputs``).

Sources: PX4 v1.15 src/modules/control_allocator (ActuatorEffectivenessRotors::updateParams:
``CA_ROTOR_COUNT`` rotors, at most NUM_ROTORS_MAX, each CA_ROTORn_PX/PY/PZ, the axis
CA_ROTORn_AX/AY/AZ, CA_ROTORn_CT and CA_ROTORn_KM) and src/modules/simulation/gz_bridge
(MixingOutput of the ESC group: SIM_GZ_EC_FUNCn, _MINn, _MAXn, _DISn, SIM_GZ_EC_REV's bit n−1),
with CA_METHOD and the motors' CA_Rn_SLEW (ControlAllocator::parameters_updated).
Both follow every parameter change, as the modules' updateParams do.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from vehicles.inner_loop import MAX_MOTORS

Get = Callable[..., "int | float | None"]
_AXES = ("PX", "PY", "PZ", "AX", "AY", "AZ", "CT", "KM")


def rotor_geometry(get: Get) -> tuple[tuple[float, ...], ...] | None:
    """Each rotor's (PX, PY, PZ, AX, AY, AZ, CT, KM) for CA_ROTOR_COUNT rotors (clamped to
    0..NUM_ROTORS_MAX); None without the parameters."""
    count = get("CA_ROTOR_COUNT")
    if count is None:
        return None
    return tuple(tuple(float(get(f"CA_ROTOR{i}_{axis}", 0.0) or 0.0) for axis in _AXES)
                 for i in range(max(0, min(int(count), MAX_MOTORS))))


def allocation(get: Get) -> tuple[tuple[tuple[float, ...], ...], int, tuple[float, ...]] | None:
    """What ControlAllocator allocates with: ``rotor_geometry``, CA_METHOD and each motor's
    CA_Rn_SLEW (ControlAllocator::parameters_updated; a slew time that is not above
    FLT_EPSILON, or not finite, limits nothing); None without the parameters."""
    geometry = rotor_geometry(get)
    if geometry is None:
        return None
    slews = tuple(float(get(f"CA_R{i}_SLEW", 0.0) or 0.0) for i in range(MAX_MOTORS))
    return geometry, int(get("CA_METHOD", 2) or 0), tuple(
        s if math.isfinite(s) else 0.0 for s in slews)


def esc_outputs(get: Get, outputs: int) -> tuple[tuple[float, ...], ...] | None:
    """The first ``outputs`` ESC outputs' (function, min, max, disarmed, reversed) from the gz
    bridge's SIM_GZ_EC_* parameters, as MixingOutput::updateParams keeps them: in uint16_t
    (a value beyond 0..65535 wraps round), a minimum above the maximum swapped with it; None
    without the parameters."""
    rev = get("SIM_GZ_EC_REV")
    if rev is None:
        return None
    out = []
    for n in range(1, outputs + 1):
        lo, hi = _uint16(get(f"SIM_GZ_EC_MIN{n}")), _uint16(get(f"SIM_GZ_EC_MAX{n}"))
        out.append((float(get(f"SIM_GZ_EC_FUNC{n}", 0) or 0), float(min(lo, hi)),
                    float(max(lo, hi)), float(_uint16(get(f"SIM_GZ_EC_DIS{n}"))),
                    1.0 if int(rev) >> (n - 1) & 1 else 0.0))
    return tuple(out)


def _uint16(value: int | float | None) -> int:
    return int(value or 0) & 0xFFFF
