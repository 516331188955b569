"""AVAILABLE_MODES (development dialect, which PX4 SITL builds with): PX4's list of flight modes,
sent on request.

Source: PX4 v1.15.2 streams/AVAILABLE_MODES.hpp (request_message, send_single_mode, update_data,
send), lib/modes/ui.hpp (getValidNavStates, nav_state_names, isAdvanced),
lib/modes/standard_modes.hpp (getStandardModeFromNavState), Commander's
ModeManagement::getModeStatus (valid_nav_states_mask, can_set_nav_states_mask) and
px4_custom_mode.h (get_px4_custom_mode).
Rules:
- The modes are vehicle_status.valid_nav_states_mask in nav_state order: getValidNavStates' 17
  (VTOL Takeoff too, whatever the airframe) and the eight external modes, which getModeStatus
  marks valid whether registered or not. No external mode registers here, so the list is fixed:
  25 modes, mode_index 1..25.
- Selectable (can_set_nav_states_mask): every valid mode but Termination and the unregistered
  external ones; the others carry NOT_USER_SELECTABLE. isAdvanced: all but Altitude, Position
  and the external modes.
- mode_name only for a non-standard mode: nav_state_names' name, or "(Mode not available)" for
  an external mode nobody registered.
- param2 is read as ``int mode_index = roundf(param2)``: 0 sends every mode, 1..25 that one;
  above 25 nothing is sent and the request is DENIED; below 0 (NaN and values out of range
  convert to INT_MIN on x86) the search finds no index, nothing is sent, and it is ACCEPTED.
- The AVAILABLE_MODES stream (0.3 Hz on both links) sends AVAILABLE_MODES_MONITOR only after a
  dynamic update (an external mode registering, or a change of either mask); here there is
  none, so it never sends (its get_size() stays 0).
"""

from __future__ import annotations

from pymavlink.dialects.v20 import development

from gateway.mavlink.codec import Encoder
from gateway.mavlink.heartbeat import STANDARD_MODES
from gateway.mavlink.snapshot import Snapshot
from vehicles.custom_mode import AutoSubMode, MainMode, custom_mode_of
from vehicles.types import NavState

MSG_ID_AVAILABLE_MODES = development.MAVLINK_MSG_ID_AVAILABLE_MODES
MSG_ID_AVAILABLE_MODES_MONITOR = development.MAVLINK_MSG_ID_AVAILABLE_MODES_MONITOR

# MAV_MODE_PROPERTY bits
MODE_PROPERTY_ADVANCED = 1
MODE_PROPERTY_NOT_USER_SELECTABLE = 2

# vehicle_status nav_state numbers beyond the ones this simulation flies (NavState)
NAVIGATION_STATE_AUTO_VTOL_TAKEOFF = 22
NAVIGATION_STATE_EXTERNAL1 = 23
NAVIGATION_STATE_EXTERNAL8 = 30
EXTERNAL_NAV_STATES = range(NAVIGATION_STATE_EXTERNAL1, NAVIGATION_STATE_EXTERNAL8 + 1)
PX4_CUSTOM_SUB_MODE_EXTERNAL1 = 11

# lib/modes/ui.hpp nav_state_names, indexed by nav_state
NAV_STATE_NAMES = (
    "Manual", "Altitude", "Position", "Mission", "Hold", "Return", "Position Slow",
    "7: unallocated", "8: unallocated", "9: unallocated", "Acro", "11: UNUSED", "Descend",
    "Termination", "Offboard", "Stabilized", "16: UNUSED2", "Takeoff", "Land", "Follow Target",
    "Precision Landing", "Orbit", "VTOL Takeoff", *(f"External {i}" for i in range(1, 9)))

# lib/modes/ui.hpp getValidNavStates: the internal modes every PX4 build lists
_INTERNAL_VALID = (
    NavState.MANUAL, NavState.ALTCTL, NavState.POSCTL, NavState.AUTO_MISSION,
    NavState.AUTO_LOITER, NavState.AUTO_RTL, NavState.POSITION_SLOW, NavState.ACRO,
    NavState.TERMINATION, NavState.OFFBOARD, NavState.STAB, NavState.AUTO_TAKEOFF,
    NavState.AUTO_LAND, NavState.AUTO_FOLLOW_TARGET, NavState.AUTO_PRECLAND, NavState.ORBIT,
    NAVIGATION_STATE_AUTO_VTOL_TAKEOFF)
# ModeManagement::getModeStatus: the external modes are valid, and selectable once registered
VALID_NAV_STATES_MASK = sum(1 << n for n in (*_INTERNAL_VALID, *EXTERNAL_NAV_STATES))
CAN_SET_NAV_STATES_MASK = (VALID_NAV_STATES_MASK & ~(1 << NavState.TERMINATION)
                           & ~sum(1 << n for n in EXTERNAL_NAV_STATES))
# ui.hpp isAdvanced: the modes it does not call advanced
_NOT_ADVANCED = frozenset({NavState.ALTCTL, NavState.POSCTL, *EXTERNAL_NAV_STATES})


def px4_custom_mode(nav_state: int) -> int:
    """get_px4_custom_mode, for the nav states NavState lacks too: VTOL Takeoff is AUTO with
    sub mode VTOL_TAKEOFF, External n AUTO with sub mode EXTERNALn."""
    if nav_state == NAVIGATION_STATE_AUTO_VTOL_TAKEOFF:
        return (MainMode.AUTO << 16) | (AutoSubMode.VTOL_TAKEOFF << 24)
    if nav_state in EXTERNAL_NAV_STATES:
        sub = PX4_CUSTOM_SUB_MODE_EXTERNAL1 + nav_state - NAVIGATION_STATE_EXTERNAL1
        return (MainMode.AUTO << 16) | (sub << 24)
    return custom_mode_of(NavState(nav_state))


_NAV_STATES = frozenset(int(n) for n in NavState)


def _mode_fields(nav_state: int) -> tuple[int, int, int, bytes]:
    """send_single_mode: (standard_mode, custom_mode, properties, mode_name)."""
    standard = STANDARD_MODES.get(NavState(nav_state), 0) if nav_state in _NAV_STATES else 0
    selectable = bool(CAN_SET_NAV_STATES_MASK & (1 << nav_state))
    properties = 0 if nav_state in _NOT_ADVANCED else MODE_PROPERTY_ADVANCED
    name = ""
    if standard == 0:
        if nav_state in EXTERNAL_NAV_STATES:
            # registered external modes carry their registered name; none registers here
            name = "" if selectable else "(Mode not available)"
        else:
            name = NAV_STATE_NAMES[nav_state]
    if not selectable:
        properties |= MODE_PROPERTY_NOT_USER_SELECTABLE
    return standard, px4_custom_mode(nav_state), properties, name.encode()[:34]


# The valid modes in nav_state order (mode_index - 1): (nav_state, fields)
MODES: tuple[tuple[int, tuple[int, int, int, bytes]], ...] = tuple(
    (n, _mode_fields(n)) for n in range(len(NAV_STATE_NAMES)) if VALID_NAV_STATES_MASK & (1 << n))


def available_modes(enc: Encoder, mode_index: int) -> list[bytes] | None:
    """MavlinkStreamAvailableModes::request_message for ``mode_index`` (roundf(param2) as an
    int): the frames to send, or None when the request fails (DENIED)."""
    total = len(MODES)
    if mode_index == 0:
        indices = range(1, total + 1)
    elif mode_index <= total:
        indices = range(mode_index, mode_index + 1) if mode_index > 0 else range(0)
    else:
        return None
    out = []
    for index in indices:
        _, (standard, custom, properties, name) = MODES[index - 1]
        out.append(enc.pack(development.MAVLink_available_modes_message, total, index, standard,
                            custom, properties, name))
    return out


def available_modes_monitor(enc: Encoder, s: Snapshot) -> bytes | None:
    """The stream's send(): AVAILABLE_MODES_MONITOR only after a dynamic update, which never
    comes here (no external mode registers and both masks are fixed)."""
    return None
