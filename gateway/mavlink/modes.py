"""PX4 flight modes on the wire: NavState ↔ (main_mode, sub_mode) ↔ HEARTBEAT custom/base mode.

Source: PX4 px4_custom_mode.h, HEARTBEAT.hpp; Commander's DO_SET_MODE.
- ``custom_mode = (main << 16) | (sub << 24)``; bits 0–15 are zero.
- ``base_mode`` = CUSTOM_MODE_ENABLED (1) plus the per-mode flags of the table, +SAFETY_ARMED (128)
  when armed. pymavlink's ``interpret_px4_mode`` relies on exactly these flags.
- Every NavState has a row (a test proves it). DESCEND is displayed as AUTO.LAND, as PX4 does, so
  the decode direction is the table minus DESCEND.
"""

from __future__ import annotations

import enum

from vehicles.types import NavState

# MAV_MODE_FLAG bits
CUSTOM_MODE_ENABLED = 1
HIL_ENABLED = 32
SAFETY_ARMED = 128
AUTO_ENABLED = 4
GUIDED_ENABLED = 8
STABILIZE_ENABLED = 16
MANUAL_INPUT_ENABLED = 64

BASE_MANUAL = CUSTOM_MODE_ENABLED | MANUAL_INPUT_ENABLED | STABILIZE_ENABLED  # 81
BASE_AUTO = CUSTOM_MODE_ENABLED | AUTO_ENABLED | GUIDED_ENABLED | STABILIZE_ENABLED  # 29
BASE_POSCTL_NO_STICKS = CUSTOM_MODE_ENABLED | STABILIZE_ENABLED  # 17 (offboard, orbit, follow)
BASE_ACRO = CUSTOM_MODE_ENABLED | MANUAL_INPUT_ENABLED  # 65
BASE_TERMINATION = CUSTOM_MODE_ENABLED  # 1


class MainMode(enum.IntEnum):
    MANUAL = 1
    ALTCTL = 2
    POSCTL = 3
    AUTO = 4
    ACRO = 5
    OFFBOARD = 6
    STABILIZED = 7
    RATTITUDE_LEGACY = 8
    SIMPLE = 9
    TERMINATION = 10
    ALTITUDE_CRUISE = 11


class AutoSubMode(enum.IntEnum):
    READY = 1
    TAKEOFF = 2
    LOITER = 3
    MISSION = 4
    RTL = 5
    LAND = 6
    FOLLOW_TARGET = 8
    PRECLAND = 9
    VTOL_TAKEOFF = 10


class PosctlSubMode(enum.IntEnum):
    POSCTL = 0
    ORBIT = 1
    SLOW = 2


# NavState → (main, sub, base_mode flags without SAFETY_ARMED)
MODE_TABLE: dict[NavState, tuple[int, int, int]] = {
    NavState.MANUAL: (MainMode.MANUAL, 0, BASE_MANUAL),
    NavState.ALTCTL: (MainMode.ALTCTL, 0, BASE_MANUAL),
    NavState.POSCTL: (MainMode.POSCTL, PosctlSubMode.POSCTL, BASE_MANUAL),
    NavState.ORBIT: (MainMode.POSCTL, PosctlSubMode.ORBIT, BASE_POSCTL_NO_STICKS),
    NavState.POSITION_SLOW: (MainMode.POSCTL, PosctlSubMode.SLOW, BASE_MANUAL),
    NavState.AUTO_TAKEOFF: (MainMode.AUTO, AutoSubMode.TAKEOFF, BASE_AUTO),
    NavState.AUTO_LOITER: (MainMode.AUTO, AutoSubMode.LOITER, BASE_AUTO),
    NavState.AUTO_MISSION: (MainMode.AUTO, AutoSubMode.MISSION, BASE_AUTO),
    NavState.AUTO_RTL: (MainMode.AUTO, AutoSubMode.RTL, BASE_AUTO),
    NavState.AUTO_LAND: (MainMode.AUTO, AutoSubMode.LAND, BASE_AUTO),
    NavState.DESCEND: (MainMode.AUTO, AutoSubMode.LAND, BASE_AUTO),
    NavState.AUTO_FOLLOW_TARGET: (MainMode.AUTO, AutoSubMode.FOLLOW_TARGET, BASE_POSCTL_NO_STICKS),
    NavState.AUTO_PRECLAND: (MainMode.AUTO, AutoSubMode.PRECLAND, BASE_AUTO),
    NavState.ACRO: (MainMode.ACRO, 0, BASE_ACRO),
    NavState.OFFBOARD: (MainMode.OFFBOARD, 0, BASE_POSCTL_NO_STICKS),
    NavState.STAB: (MainMode.STABILIZED, 0, BASE_MANUAL),
    NavState.TERMINATION: (MainMode.TERMINATION, 0, BASE_TERMINATION),
}

# (main, sub) → NavState for DO_SET_MODE. DESCEND is not selectable; AUTO sub 0 means Mission.
_DECODE: dict[tuple[int, int], NavState] = {
    (main, sub): nav for nav, (main, sub, _) in MODE_TABLE.items() if nav is not NavState.DESCEND
}
_DECODE[(MainMode.AUTO, 0)] = NavState.AUTO_MISSION


def custom_mode_of(nav: NavState) -> int:
    main, sub, _ = MODE_TABLE[nav]
    return (main << 16) | (sub << 24)


def heartbeat_modes(nav: NavState, armed: bool) -> tuple[int, int]:
    """(base_mode, custom_mode) as PX4's HEARTBEAT stream sends them."""
    main, sub, base = MODE_TABLE[nav]
    if armed:
        base |= SAFETY_ARMED
    return base, (main << 16) | (sub << 24)


def decode_custom(main: int, sub: int) -> NavState | None:
    """PX4 custom main/sub → NavState, None if PX4 would reject it."""
    return _DECODE.get((main, sub))


def decode_set_mode(base_mode: int, main: int, sub: int) -> NavState | None:
    """DO_SET_MODE (p1 base, p2 main, p3 sub) / SET_MODE decode as PX4's commander does.

    With CUSTOM_MODE_ENABLED: main/sub. Without it, the legacy base-mode flags: AUTO → Mission,
    MANUAL+GUIDED → Position, MANUAL+STABILIZE → Stabilized, MANUAL → Manual.
    """
    if base_mode & CUSTOM_MODE_ENABLED:
        return decode_custom(main, sub)
    if base_mode & AUTO_ENABLED:
        return NavState.AUTO_MISSION
    if base_mode & MANUAL_INPUT_ENABLED:
        if base_mode & GUIDED_ENABLED:
            return NavState.POSCTL
        if base_mode & STABILIZE_ENABLED:
            return NavState.STAB
        return NavState.MANUAL
    return None


def split_custom_mode(custom_mode: int) -> tuple[int, int]:
    return (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF
