"""PX4's custom mode of each navigation state (commander/px4_custom_mode.h, get_px4_custom_mode):
what HEARTBEAT's custom_mode carries, and what Commander's events name a mode by.

- ``custom_mode = (main << 16) | (sub << 24)``; bits 0-15 are zero.
- DESCEND shows as AUTO.LAND, as PX4 shows it.
"""

from __future__ import annotations

import enum

from vehicles.types import NavState


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


# NavState → (main mode, sub mode)
MAIN_SUB: dict[NavState, tuple[int, int]] = {
    NavState.MANUAL: (MainMode.MANUAL, 0),
    NavState.ALTCTL: (MainMode.ALTCTL, 0),
    NavState.POSCTL: (MainMode.POSCTL, PosctlSubMode.POSCTL),
    NavState.ORBIT: (MainMode.POSCTL, PosctlSubMode.ORBIT),
    NavState.POSITION_SLOW: (MainMode.POSCTL, PosctlSubMode.SLOW),
    NavState.AUTO_TAKEOFF: (MainMode.AUTO, AutoSubMode.TAKEOFF),
    NavState.AUTO_LOITER: (MainMode.AUTO, AutoSubMode.LOITER),
    NavState.AUTO_MISSION: (MainMode.AUTO, AutoSubMode.MISSION),
    NavState.AUTO_RTL: (MainMode.AUTO, AutoSubMode.RTL),
    NavState.AUTO_LAND: (MainMode.AUTO, AutoSubMode.LAND),
    NavState.DESCEND: (MainMode.AUTO, AutoSubMode.LAND),
    NavState.AUTO_FOLLOW_TARGET: (MainMode.AUTO, AutoSubMode.FOLLOW_TARGET),
    NavState.AUTO_PRECLAND: (MainMode.AUTO, AutoSubMode.PRECLAND),
    NavState.ACRO: (MainMode.ACRO, 0),
    NavState.OFFBOARD: (MainMode.OFFBOARD, 0),
    NavState.STAB: (MainMode.STABILIZED, 0),
    NavState.TERMINATION: (MainMode.TERMINATION, 0),
}


def custom_mode_of(nav: NavState) -> int:
    main, sub = MAIN_SUB[nav]
    return (main << 16) | (sub << 24)
