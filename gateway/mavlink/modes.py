"""PX4 flight modes on the wire: NavState ↔ (main_mode, sub_mode) ↔ HEARTBEAT custom/base mode.

Source: PX4 px4_custom_mode.h (vehicles/custom_mode.py), HEARTBEAT.hpp; Commander's DO_SET_MODE.
- ``custom_mode = (main << 16) | (sub << 24)``; bits 0–15 are zero.
- ``base_mode`` = CUSTOM_MODE_ENABLED (1) plus the per-mode flags of the table, +SAFETY_ARMED (128)
  when armed. pymavlink's ``interpret_px4_mode`` relies on exactly these flags.
- Every NavState has a row (a test proves it). DESCEND is displayed as AUTO.LAND, as PX4 does.
- DO_SET_MODE decodes as Commander does (``decode_set_mode``), not as the table's inverse: it
  ignores most sub modes, and main modes it does not know ask for no mode at all.
"""

from __future__ import annotations

import enum

from vehicles.custom_mode import (  # noqa: F401 - the modes' names, for the gateway
    MAIN_SUB,
    AutoSubMode,
    MainMode,
    PosctlSubMode,
    custom_mode_of,
)
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


# The base mode flags of each navigation state (without SAFETY_ARMED)
_BASE: dict[NavState, int] = {
    NavState.MANUAL: BASE_MANUAL, NavState.ALTCTL: BASE_MANUAL, NavState.POSCTL: BASE_MANUAL,
    NavState.ORBIT: BASE_POSCTL_NO_STICKS, NavState.POSITION_SLOW: BASE_MANUAL,
    NavState.AUTO_TAKEOFF: BASE_AUTO, NavState.AUTO_LOITER: BASE_AUTO,
    NavState.AUTO_MISSION: BASE_AUTO, NavState.AUTO_RTL: BASE_AUTO, NavState.AUTO_LAND: BASE_AUTO,
    NavState.DESCEND: BASE_AUTO, NavState.AUTO_FOLLOW_TARGET: BASE_POSCTL_NO_STICKS,
    NavState.AUTO_PRECLAND: BASE_AUTO, NavState.ACRO: BASE_ACRO,
    NavState.OFFBOARD: BASE_POSCTL_NO_STICKS, NavState.STAB: BASE_MANUAL,
    NavState.TERMINATION: BASE_TERMINATION,
}
# NavState → (main, sub, base_mode flags without SAFETY_ARMED)
MODE_TABLE: dict[NavState, tuple[int, int, int]] = {
    nav: (main, sub, _BASE[nav]) for nav, (main, sub) in MAIN_SUB.items()}

def heartbeat_modes(nav: NavState, armed: bool) -> tuple[int, int]:
    """(base_mode, custom_mode) as PX4's HEARTBEAT stream sends them."""
    main, sub, base = MODE_TABLE[nav]
    if armed:
        base |= SAFETY_ARMED
    return base, (main << 16) | (sub << 24)


# DO_SET_MODE's AUTO sub modes Commander switches to (the EXTERNALn ones are refused: no external
# mode registers here); sub mode 0 is Mission.
_AUTO_SUB: dict[int, NavState] = {
    AutoSubMode.LOITER: NavState.AUTO_LOITER, AutoSubMode.MISSION: NavState.AUTO_MISSION,
    AutoSubMode.RTL: NavState.AUTO_RTL, AutoSubMode.TAKEOFF: NavState.AUTO_TAKEOFF,
    AutoSubMode.LAND: NavState.AUTO_LAND, AutoSubMode.FOLLOW_TARGET: NavState.AUTO_FOLLOW_TARGET,
    AutoSubMode.PRECLAND: NavState.AUTO_PRECLAND, 0: NavState.AUTO_MISSION}
# The main modes whose sub mode Commander ignores
_MAIN: dict[int, NavState] = {
    MainMode.MANUAL: NavState.MANUAL, MainMode.ALTCTL: NavState.ALTCTL,
    MainMode.ACRO: NavState.ACRO, MainMode.STABILIZED: NavState.STAB,
    MainMode.OFFBOARD: NavState.OFFBOARD}
EXTERNAL_SUB_MODES = range(11, 19)  # PX4_CUSTOM_SUB_MODE_EXTERNAL1..8


class SetModeRefusal(enum.Enum):
    UNSUPPORTED_AUTO = "unsupported auto mode"  # said, TEMPORARILY_REJECTED
    NOT_AVAILABLE = "not available"  # an external mode: TEMPORARILY_REJECTED


def decode_set_mode(base_mode: int, main: int, sub: int) -> NavState | SetModeRefusal | None:
    """DO_SET_MODE (p1 base, p2 main, p3 sub, each a uint8) / SET_MODE as Commander's
    handle_command decodes them; None: no mode asked for (ACCEPTED, nothing changes).

    With CUSTOM_MODE_ENABLED: MANUAL, ALTCTL, ACRO, STABILIZED and OFFBOARD whatever the sub mode;
    POSCTL is Position Slow with sub mode SLOW, else Position (its ORBIT sub mode too); AUTO by
    its sub mode; any other main mode is none. Without it, the legacy base-mode flags: AUTO →
    Mission, MANUAL+GUIDED → Position, MANUAL+STABILIZE → Stabilized, MANUAL → Manual.
    """
    if base_mode & CUSTOM_MODE_ENABLED:
        if main == MainMode.POSCTL:
            return NavState.POSITION_SLOW if sub == PosctlSubMode.SLOW else NavState.POSCTL
        if main == MainMode.AUTO:
            if sub in EXTERNAL_SUB_MODES:
                return SetModeRefusal.NOT_AVAILABLE
            return _AUTO_SUB.get(sub, SetModeRefusal.UNSUPPORTED_AUTO)
        return _MAIN.get(main)
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
