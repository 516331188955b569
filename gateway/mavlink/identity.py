"""Who the vehicle says it is: the board's unique ids (PX4 board_get_uuid / board_get_px4_guid),
as AUTOPILOT_VERSION and UTM_GLOBAL_POSITION carry them."""

from __future__ import annotations

UID_BASE = 0x434F524E45540000  # "CORNET\0\0"; + sysid so every vehicle differs


def uid(sysid: int) -> int:
    """AUTOPILOT_VERSION's uid: 64 bits, different for every system id."""
    return (UID_BASE + sysid) & 0xFFFFFFFFFFFFFFFF


def px4_guid(sysid: int) -> list[int]:
    """The board's 18-byte GUID (board_get_px4_guid), as AUTOPILOT_VERSION's uid2 and
    UTM_GLOBAL_POSITION's uas_id carry it: the uid's bytes, zero-padded."""
    return list(uid(sysid).to_bytes(8, "little")) + [0] * 10
