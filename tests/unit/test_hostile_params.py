"""PARAM_SET with values PX4 accepts but its modules never expect, sent in flight.

PX4's param_set (src/lib/parameters/parameters.cpp) stores a value of the right type as given: no
check against the metadata's min/max. The modules then compute with it in float arithmetic, where
x/0 is inf and a double beyond float32 is inf. The vehicle flies on what PX4's algorithms make of
it (PositionControl's failsafe setpoint for non-finite setpoints, the hover thrust estimator's
rejected measurements, ...); nothing may raise, and no telemetry message may fail to build.
"""

from __future__ import annotations

import struct

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.testing import Sim, mission_item
from vehicles.params import ParamType
from vehicles.plan_types import MavCmd, PlanResult
from vehicles.types import PX4_SITL_HOME


def geo(n: float, e: float) -> tuple[float, float]:
    g = PX4_SITL_HOME.offset_ned(n, e, 0.0)
    return g.lat_deg, g.lon_deg


def mission():
    return ([mission_item(MavCmd.NAV_TAKEOFF, *geo(0, 0), 10.0)]
            + [mission_item(MavCmd.NAV_WAYPOINT, *geo(n, e), 10.0) for n, e in ((30, 0), (30, 30))]
            + [mission_item(MavCmd.NAV_RETURN_TO_LAUNCH)])


@pytest.mark.parametrize("name, value", [
    ("MPC_JERK_AUTO", 0.0),  # the trajectory's jerk limit divides (was ZeroDivisionError)
    ("MPC_XY_VEL_P_ACC", 0.0),  # PositionControl's anti-windup gain 2 / P (was ZeroDivisionError)
    ("HTE_ACC_GATE", 0.0),  # the hover thrust EKF's test ratio (was ZeroDivisionError)
    ("MPC_XY_VEL_D_ACC", 3e38),  # setpoints beyond float32 in POSITION_TARGET_LOCAL_NED
    ("MPC_Z_VEL_MAX_UP", -3e38),  # (both were counted handler errors every tick)
    ("MPC_XY_VEL_MAX", -3e38),
    ("SIM_BAT_DRAIN", 0.0),  # the simulated battery's charge step dt / drain (ZeroDivisionError)
    ("BAT1_V_CHARGED", 3e38),  # BATTERY_STATUS's cell voltages and charge (failed to build)
    ("BAT1_V_EMPTY", -3e38),
    ("BAT1_N_CELLS", 2**31 - 1),
])
def test_a_hostile_value_px4_stores_never_raises_in_flight(name, value):
    with Sim(1) as sim:
        api = sim.api(0)
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        assert api.upload_mission(mission()) == PlanResult.ACCEPTED
        assert api.arm() == 0 and api.start_mission() == 0
        sim.advance(12.0)  # airborne, on the way to the first waypoint
        cursor = len(api.frames)
        ptype = sim.vehicles[0].params.info(name).type
        wire = struct.unpack("<f", struct.pack("<i", value))[0] if ptype is ParamType.INT32 \
            else value
        api.send(M.MAVLink_param_set_message(1, 1, name.encode(), wire, ptype))
        sim.advance(20.0)
        echo = [m for m in api.messages("PARAM_VALUE", since=cursor) if m.param_id == name]
        assert echo and sim.vehicles[0].params[name] == pytest.approx(value)  # stored as given
        positions = api.messages("GLOBAL_POSITION_INT", since=cursor)
        assert len(positions) >= 20 * 10 * 0.8  # telemetry went on at its rate
        assert sim.simulation.internal_errors == 0


@pytest.mark.parametrize("name, value, corrected, then, text", [
    ("MPC_XY_CRUISE", 15.0, "MPC_XY_CRUISE", 12.0,
     "Cruise speed has been constrained by max speed"),
    ("MPC_XY_VEL_MAX", 4.0, "MPC_XY_CRUISE", 4.0,
     "Cruise speed has been constrained by max speed"),
    ("MPC_TILTMAX_AIR", 10.0, "MPC_TILTMAX_LND", 10.0,
     "Land tilt has been constrained by max tilt"),
    ("MPC_Z_VEL_MAX_UP", 1.0, "MPC_Z_V_AUTO_UP", 1.0,
     "Ascent speed has been constrained by max speed"),
    ("MPC_THR_MAX", 0.5, "MPC_THR_HOVER", 0.5, "Hover thrust has been constrained by min/max"),
])
def test_the_position_controller_pulls_design_parameters_inside_their_limits(
        name, value, corrected, then, text):
    """MulticopterPositionControl::parameters_update: the set value is stored and echoed as
    given; the parameter it now contradicts is committed to the limit (a PARAM_VALUE to every
    client) and a critical text says so (with its event)."""
    with Sim(1) as sim:
        api = sim.api(0)
        sim.advance(1.0)
        cursor = len(api.frames)
        api.send(M.MAVLink_param_set_message(1, 1, name.encode(), value, ParamType.REAL32))
        sim.advance(0.5)
        values = [(m.param_id, m.param_value) for m in api.messages("PARAM_VALUE", since=cursor)]
        assert values[0] == (name, pytest.approx(value))
        assert (corrected, pytest.approx(then)) in values
        assert sim.vehicles[0].params[corrected] == pytest.approx(then)
        texts = [m.text for m in api.messages("STATUSTEXT", since=cursor)]
        assert any(t.startswith(text) for t in texts), texts
        assert sim.simulation.internal_errors == 0
