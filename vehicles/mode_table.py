"""The flight modes as Commander sees them: how a request to switch to each is answered while
armed, what it needs, whether it can arm (mode_req_prevent_arming), which control-mode flags it
sets, and the mode a failsafe action flies.

After PX4 ``src/modules/commander`` (ModeUtil/mode_requirements.cpp, ModeUtil/control_mode.cpp,
failsafe/failsafe.cpp modeFromAction). ``MODE_TABLE`` has one row per NavState (a test proves it).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from vehicles.failsafe import Action
from vehicles.types import NavState


class SwitchRule(enum.Enum):
    ALLOWED = "allowed"  # ACCEPTED (TEMPORARILY_REJECTED without position if it needs one)
    NEEDS_MANUAL_CONTROL = "needs_manual_control"  # rejected without fresh stick input
    FAILSAFE_ONLY = "failsafe_only"  # entered by the vehicle itself, never by request


class ArmEvent(enum.Enum):
    """Commander events other than mode requests (the coverage test crosses them with modes)."""

    ARM = "arm"
    DISARM = "disarm"
    KILL = "kill"
    AUTO_DISARM = "auto_disarm"


@dataclass(frozen=True)
class ModeSpec:
    name: str
    switch: SwitchRule
    needs_position: bool
    arming_allowed: bool
    needs_mission: bool = False  # a valid mission must be stored
    needs_offboard: bool = False  # an offboard setpoint younger than COM_OF_LOSS_T
    needs_home: bool = False  # mode_req_home_position (Return)
    # vehicle_control_mode (control_mode.cpp): flag_control_manual_enabled, and with it whether
    # the throttle stick sets the thrust (no flag_control_climb_rate_enabled: Manual,
    # Stabilized, Acro) rather than a climb rate (Altitude, Position)
    manual: bool = False
    stick_thrust: bool = False


# What a failsafe action makes the vehicle fly (failsafe.cpp modeFromAction).
ACTION_NAV_STATE: dict[Action, NavState] = {
    Action.HOLD: NavState.AUTO_LOITER,
    Action.RTL: NavState.AUTO_RTL,
    Action.LAND: NavState.AUTO_LAND,
    Action.DESCEND: NavState.DESCEND,
    Action.TERMINATE: NavState.TERMINATION,
    Action.FALLBACK_POSCTRL: NavState.POSCTL,
    Action.FALLBACK_ALTCTRL: NavState.ALTCTL,
    Action.FALLBACK_STABILIZED: NavState.STAB,
}
MODE_TABLE: dict[NavState, ModeSpec] = {
    NavState.MANUAL: ModeSpec("Manual", SwitchRule.NEEDS_MANUAL_CONTROL, False, True,
                              manual=True, stick_thrust=True),
    NavState.ALTCTL: ModeSpec("Altitude", SwitchRule.NEEDS_MANUAL_CONTROL, False, True,
                              manual=True),
    NavState.POSCTL: ModeSpec("Position", SwitchRule.NEEDS_MANUAL_CONTROL, True, True,
                              manual=True),
    NavState.AUTO_MISSION: ModeSpec("Mission", SwitchRule.ALLOWED, True, True,
                                    needs_mission=True),
    NavState.AUTO_LOITER: ModeSpec("Hold", SwitchRule.ALLOWED, True, True),
    NavState.AUTO_RTL: ModeSpec("Return", SwitchRule.ALLOWED, True, False, needs_home=True),
    NavState.POSITION_SLOW: ModeSpec("Position Slow", SwitchRule.NEEDS_MANUAL_CONTROL, True, True,
                                     manual=True),
    NavState.ACRO: ModeSpec("Acro", SwitchRule.NEEDS_MANUAL_CONTROL, False, True,
                            manual=True, stick_thrust=True),
    NavState.DESCEND: ModeSpec("Descend", SwitchRule.FAILSAFE_ONLY, False, False),
    NavState.TERMINATION: ModeSpec("Termination", SwitchRule.FAILSAFE_ONLY, False, False),
    NavState.OFFBOARD: ModeSpec("Offboard", SwitchRule.ALLOWED, True, True,
                                needs_offboard=True),
    NavState.STAB: ModeSpec("Stabilized", SwitchRule.NEEDS_MANUAL_CONTROL, False, True,
                            manual=True, stick_thrust=True),
    NavState.AUTO_TAKEOFF: ModeSpec("Takeoff", SwitchRule.ALLOWED, True, True),
    NavState.AUTO_LAND: ModeSpec("Land", SwitchRule.ALLOWED, True, False),
    NavState.AUTO_FOLLOW_TARGET: ModeSpec("Follow Me", SwitchRule.ALLOWED, True, False),
    NavState.AUTO_PRECLAND: ModeSpec("Precision Land", SwitchRule.ALLOWED, True, False),
    NavState.ORBIT: ModeSpec("Orbit", SwitchRule.ALLOWED, True, False),
}

# COM_RC_OVERRIDE bit 0: sticks take over these modes (Commander: flag_control_auto_enabled).
# Not Orbit nor Follow Me: there the sticks are part of the mode (Orbit's altitude, radius and
# speed; Follow Me's height, distance and angle), and control_mode.cpp clears the auto flag
# ("Follow Target supports RC adjustment").
STICK_OVERRIDE_AUTO = frozenset({NavState.AUTO_MISSION, NavState.AUTO_LOITER, NavState.AUTO_RTL,
                                 NavState.AUTO_TAKEOFF, NavState.AUTO_LAND, NavState.AUTO_PRECLAND,
                                 NavState.DESCEND})

# vehicle_control_mode: the navigation states without flag_multicopter_position_control_enabled,
# and those with it but without flag_control_position_enabled (no horizontal position).
NO_POSITION_CONTROL = frozenset({NavState.MANUAL, NavState.STAB, NavState.ACRO,
                                 NavState.TERMINATION})
NO_POSITION_HOLD = frozenset({NavState.ALTCTL, NavState.DESCEND})
