"""PARAM_SET of NaN, +inf and −inf into every REAL32 parameter CORNET's modules read.

PX4's param_set (src/lib/parameters/parameters.cpp, param_set_internal) stores the float32 it is
given; mavlink_parameters.cpp echoes it. A step to ±inf is a change (parameter_update: the modules
re-read); to or from NaN it is none (fabsf(old − new) > FLT_EPSILON is false), so the modules take
it with the next parameter_update. PX4's modules then compute in float arithmetic: NaN
propagates, comparisons with it are false. Nothing may raise, stall or stop telemetry, and the
vehicle must still take a land and a (forced) disarm.
"""

from __future__ import annotations

import math
import pathlib
import re
import struct

import pytest
from pymavlink.dialects.v20 import common as M
from test_hostile_params import geo

from gateway.testing import Sim, mission_item
from vehicles.params import ParamStore, ParamType
from vehicles.plan_types import MavCmd, PlanResult

ROOT = pathlib.Path(__file__).resolve().parents[2]
FORCE_DISARM = 21196  # MAV_CMD_COMPONENT_ARM_DISARM param2: disarm even in the air
POKE = "SYS_AUTOSTART"  # read by no module: a change of it is just a parameter_update
CHUNK = 12


def read_real32_params() -> list[str]:
    """Every REAL32 parameter named in vehicles/ and gateway/ (literal names, and the rate
    controller's MC_<axis>RATE_<gain> family)."""
    store = ParamStore()
    names = set()
    for root in ("vehicles", "gateway"):
        for path in (ROOT / root).rglob("*.py"):
            names.update(re.findall(r"[\"']([A-Z][A-Z0-9_]{2,15})[\"']", path.read_text()))
    names.update(f"MC_{a}RATE_{g}" for a in ("ROLL", "PITCH", "YAW") for g in "PID")
    return sorted(n for n in names if n in store and store.info(n).type is ParamType.REAL32)


NAMES = read_real32_params()


def test_the_list_covers_the_known_consumers():
    assert len(NAMES) > 100
    for name in ("RTL_RETURN_ALT", "MPC_YAWRAUTO_MAX", "BAT1_V_EMPTY", "SIM_BAT_MIN_PCT",
                 "MPC_THR_MIN", "MC_ROLLRATE_P", "MIS_TAKEOFF_ALT"):
        assert name in NAMES


def mission():
    return ([mission_item(MavCmd.NAV_TAKEOFF, *geo(0, 0), 10.0)]
            + [mission_item(MavCmd.NAV_WAYPOINT, *geo(n, e), 10.0) for n, e in ((30, 0), (30, 30))]
            + [mission_item(MavCmd.NAV_LAND, *geo(0, 0), 0.0)])


def set_param(sim: Sim, name: str, value: float) -> None:
    sim.api(0).send(M.MAVLink_param_set_message(1, 1, name.encode(), value, ParamType.REAL32))


def poke(sim: Sim) -> None:
    """A change of another parameter: PX4's next parameter_update, which makes the modules read
    the values stored as no change (NaN) too."""
    store = sim.vehicles[0].params
    value = 4001 if store[POKE] != 4001 else 4002
    wire = struct.unpack("<f", struct.pack("<i", value))[0]  # INT32 travels bytewise
    sim.api(0).send(M.MAVLink_param_set_message(1, 1, POKE.encode(), wire, ParamType.INT32))


def same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def check_window(sim: Sim, cursor: int, seconds: float) -> None:
    sim.advance(seconds)
    assert sim.simulation.internal_errors == 0
    for link in sim.simulation.links.values():
        assert link.session.stats.handler_errors == 0
    positions = sim.api(0).messages("GLOBAL_POSITION_INT", since=cursor)
    assert len(positions) >= seconds * 10 * 0.8  # telemetry still at its rate


def airborne(sim: Sim) -> bool:
    return sim.status(0).armed and -sim.state(0).position_ned_m[2] > 3.0


def take_off(sim: Sim) -> None:
    api = sim.api(0)
    if not sim.status(0).armed:
        api.arm()
    api.takeoff()
    sim.run_until(lambda: airborne(sim), timeout_s=15)


@pytest.mark.parametrize("phase", ["before_arming", "in_flight"])
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf], ids=["nan", "inf", "-inf"])
def test_a_non_finite_real32_never_raises(phase, value):
    with Sim(1) as sim:
        api = sim.api(0)
        store = sim.vehicles[0].params
        defaults = {name: store[name] for name in NAMES}
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        assert api.upload_mission(mission()) == PlanResult.ACCEPTED
        for start in range(0, len(NAMES), CHUNK):
            chunk = NAMES[start:start + CHUNK]
            if phase == "in_flight" and not airborne(sim):
                take_off(sim)
            cursor = len(api.frames)
            for name in chunk:
                set_param(sim, name, value)
            poke(sim)
            if phase == "before_arming":
                check_window(sim, cursor, 1.0)
                api.arm()  # accepted or denied: either is PX4's answer
                api.takeoff()
            check_window(sim, cursor, 4.0 if phase == "before_arming" else 2.0)
            if phase == "in_flight":  # the navigator's modes read most of the rest
                api.return_to_launch()
                check_window(sim, cursor, 2.0)
                api.start_mission()
                check_window(sim, cursor, 2.0)
            for name in chunk:  # stored and echoed as given (a module may correct it after)
                echo = [m for m in api.messages("PARAM_VALUE", since=cursor)
                        if m.param_id == name]
                assert echo and same(echo[0].param_value, value)
            cursor = len(api.frames)
            for name in chunk:
                set_param(sim, name, defaults[name])
            poke(sim)
            check_window(sim, cursor, 1.0)
            if phase == "before_arming" and sim.status(0).armed:
                api.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 0, FORCE_DISARM)
        # with every value non-finite at once, the vehicle still lands and disarms
        if phase == "in_flight" and not airborne(sim):
            take_off(sim)
        cursor = len(api.frames)
        for name in NAMES:
            set_param(sim, name, value)
        poke(sim)
        check_window(sim, cursor, 3.0)
        assert api.land() is not None
        check_window(sim, cursor, 3.0)
        if sim.status(0).armed:
            assert api.command_long(M.MAV_CMD_COMPONENT_ARM_DISARM, 0, FORCE_DISARM) == \
                M.MAV_RESULT_ACCEPTED
        assert not sim.status(0).armed
        check_window(sim, cursor, 1.0)
