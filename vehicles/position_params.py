"""MulticopterPositionControl::parameters_update's consistency rules (PX4 v1.15,
src/modules/mc_pos_control/MulticopterPositionControl.cpp), run when a parameter changed.

PX4 stores any value a client sets; the position controller then pulls the design parameters
inside their absolute limits: MPC_XY_CRUISE and MPC_VEL_MANUAL at most MPC_XY_VEL_MAX, the auto
climb and descent speeds at most MPC_Z_VEL_MAX_UP/DN, MPC_TILTMAX_AIR at most 89° and
MPC_TILTMAX_LND at most MPC_TILTMAX_AIR, MPC_THR_HOVER within MPC_THR_MIN..MPC_THR_MAX. Each
correction is committed (clients get the new PARAM_VALUE), said as a critical text ending in a
tab (the text of an event) and sent as that event. Rules run in PX4's order, on the values the
previous ones left; the committed change makes PX4 run them again, which changes nothing more.

Not here: SYS_VEHICLE_RESP's and MPC_XY_VEL_ALL/MPC_Z_VEL_ALL's rewrites (the table has no
MPC_*_VEL_ALL; SYS_VEHICLE_RESP is off by default).
"""

from __future__ import annotations

from vehicles.events import (
    CRUISE_SET,
    DOWN_VEL_SET,
    HOVER_THRUST_SET,
    LAND_TILT_SET,
    MAN_VEL_SET,
    TILT_SET,
    UP_VEL_SET,
    EventDef,
    EventLog,
    Log,
)
from vehicles.params import ParamStore
from vehicles.status_log import StatusLog

MAX_SAFE_TILT_DEG = 89.0  # MulticopterPositionControl.hpp: numerical issues above (tanf)
# (parameter, the limit it may not exceed (a number or a parameter), text, event), in PX4's order
_UPPER_LIMITS = (
    ("MPC_TILTMAX_AIR", MAX_SAFE_TILT_DEG, "Tilt constrained to safe value\t", TILT_SET),
    ("MPC_TILTMAX_LND", "MPC_TILTMAX_AIR", "Land tilt has been constrained by max tilt\t",
     LAND_TILT_SET),
    ("MPC_XY_CRUISE", "MPC_XY_VEL_MAX", "Cruise speed has been constrained by max speed\t",
     CRUISE_SET),
    ("MPC_VEL_MANUAL", "MPC_XY_VEL_MAX", "Manual speed has been constrained by max speed\t",
     MAN_VEL_SET),
    ("MPC_Z_V_AUTO_UP", "MPC_Z_VEL_MAX_UP", "Ascent speed has been constrained by max speed\t",
     UP_VEL_SET),
    ("MPC_Z_V_AUTO_DN", "MPC_Z_VEL_MAX_DN", "Descent speed has been constrained by max speed\t",
     DOWN_VEL_SET),
)


def constrain_params(params: ParamStore, now_s: float, log: StatusLog,
                     events: EventLog | None) -> None:
    """Apply the rules to ``params`` (each correction committed, said and sent)."""
    def commit(name: str, value: float, text: str, event: EventDef, arg: float) -> None:
        params.set(name, value)
        log.critical(now_s, text)
        if events is not None:
            events.send(now_s, event, Log.WARNING, None, "f", arg)

    for name, limit, text, event in _UPPER_LIMITS:
        bound = float(params[limit]) if isinstance(limit, str) else limit
        if float(params[name]) > bound:
            commit(name, bound, text, event, bound)
    hover, low, high = (float(params[n]) for n in ("MPC_THR_HOVER", "MPC_THR_MIN", "MPC_THR_MAX"))
    if hover > high or hover < low:
        # math::constrain(val, min, max): (val < min) ? min : ((val > max) ? max : val)
        value = low if hover < low else high
        commit("MPC_THR_HOVER", value, "Hover thrust has been constrained by min/max\t",
               HOVER_THRUST_SET, value)
