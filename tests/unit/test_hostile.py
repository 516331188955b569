"""Well-formed messages with hostile values, replayed through a lockstep vehicle: each gets
PX4's refusal (or a stricter one where PX4's answer would make telemetry non-finite), never a
traceback, a skipped telemetry tick or a vehicle that stops answering."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as M

from gateway.testing import Sim, mission_item
from vehicles.plan_types import PlanResult

HOME = (47.397742, 8.545594)
HOSTILE = [1e9, 3e38, math.inf, -math.inf, math.nan]


@pytest.fixture(scope="module")
def sim():
    with Sim(1) as s:
        assert s.run_until(lambda: s.status(0).position_valid, timeout_s=10)
        yield s


def telemetry_flows(sim: Sim, seconds: float = 1.0) -> bool:
    """GLOBAL_POSITION_INT keeps coming at its rate and every ATTITUDE is finite."""
    api = sim.api(0)
    cursor = len(api.frames)
    sim.advance(seconds)
    positions = api.messages("GLOBAL_POSITION_INT", since=cursor)
    attitudes = api.messages("ATTITUDE", since=cursor)
    finite = all(math.isfinite(a.roll) and math.isfinite(a.yaw) for a in attitudes)
    return len(positions) >= 10 * seconds * 0.8 and finite


@pytest.mark.parametrize("alt", HOSTILE)
@pytest.mark.parametrize("how", ["long", "int"])
def test_set_home_with_a_hostile_altitude_is_denied_and_telemetry_goes_on(sim, alt, how):
    api = sim.api(0)
    errors = sim.simulation.internal_errors
    home_before = sim.vehicles[0].home
    if how == "long":
        result = api.command_long(M.MAV_CMD_DO_SET_HOME, 0, 0, 0, math.nan, *HOME, alt)
    else:
        cursor = len(api.frames)
        api.send(api.mav.command_int_encode(1, 1, M.MAV_FRAME_GLOBAL, M.MAV_CMD_DO_SET_HOME, 0, 0,
                                            0, 0, 0, math.nan, int(HOME[0] * 1e7),
                                            int(HOME[1] * 1e7), alt))
        sim.advance(0.2)
        acks = [m for m in api.messages("COMMAND_ACK", since=cursor)
                if m.command == M.MAV_CMD_DO_SET_HOME]
        result = acks[-1].result if acks else None
    assert result == M.MAV_RESULT_DENIED
    assert sim.vehicles[0].home == home_before
    assert telemetry_flows(sim)
    assert sim.simulation.internal_errors == errors


@pytest.mark.parametrize("value", [math.inf, -math.inf, math.nan, 3e38])
def test_a_non_finite_base_mode_asks_for_no_mode(sim, value):
    """Commander reads DO_SET_MODE's param1 as (uint8_t)param1, which x86 makes 0 for these: no
    custom mode and no mode flag, so nothing is asked for: ACCEPTED, the mode stays."""
    errors = sim.simulation.internal_errors
    before = sim.status(0).nav_state
    assert sim.api(0).command_long(M.MAV_CMD_DO_SET_MODE, value, 4, 4) == M.MAV_RESULT_ACCEPTED
    assert sim.status(0).nav_state is before
    assert telemetry_flows(sim)
    assert sim.simulation.internal_errors == errors


@pytest.mark.parametrize("lat, lon", [(math.nan, HOME[1]), (HOME[0], math.inf), (91.0, HOME[1]),
                                      (HOME[0], 181.0)])
def test_set_home_with_a_hostile_position_is_denied(sim, lat, lon):
    result = sim.api(0).command_long(M.MAV_CMD_DO_SET_HOME, 0, 0, 0, math.nan, lat, lon, 500.0)
    assert result == M.MAV_RESULT_DENIED
    assert telemetry_flows(sim, 0.5)


@pytest.mark.parametrize("bad", ["z_nan", "z_inf", "z_huge"])
def test_mission_items_with_non_finite_or_absurd_values_are_refused(sim, bad):
    z = {"z_nan": math.nan, "z_inf": math.inf, "z_huge": 3e38}[bad]
    items = [mission_item(22, *HOME, 10), mission_item(16, HOME[0] + 1e-4, HOME[1], z)]
    result = sim.api(0).upload_mission(items)
    assert result is not None and result != PlanResult.ACCEPTED
    assert telemetry_flows(sim, 0.5)


def test_mission_start_with_a_nan_first_item_is_denied_and_does_not_arm(sim):
    """Commander.cpp VEHICLE_CMD_MISSION_START: param1 must be finite, >= -1 and < the count."""
    api = sim.api(0)
    items = [mission_item(22, *HOME, 10), mission_item(16, HOME[0] + 1e-4, HOME[1], 10)]
    assert api.upload_mission(items) == PlanResult.ACCEPTED
    for first in (math.nan, math.inf, -2.0, 2.0):
        assert api.command_long(M.MAV_CMD_MISSION_START, first, first) == M.MAV_RESULT_DENIED
        assert not sim.status(0).armed


def test_the_vehicle_still_flies_after_all_of_it(sim):
    api = sim.api(0)
    assert api.arm() == M.MAV_RESULT_ACCEPTED
    assert api.takeoff() == M.MAV_RESULT_ACCEPTED
    assert sim.run_until(lambda: sim.state(0).position_ned_m[2] < -2.0, timeout_s=20)
    assert api.land() == M.MAV_RESULT_ACCEPTED
    assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=40)
    assert sim.simulation.internal_errors == 0


@pytest.mark.parametrize("value", [math.inf, -math.inf, math.nan])
def test_a_non_finite_message_interval_id_is_answered_as_px4_does(sim, value):
    """Found by bench/fuzz_campaign.py. MavlinkReceiver casts param1 with (int)roundf(param1),
    which is INT_MIN on x86 for NaN and ±inf: no stream has that id, so PX4 answers ACCEPTED and
    MESSAGE_INTERVAL(message_id 0 as uint16, interval 0)."""
    errors = sim.simulation.internal_errors
    api = sim.api(0)
    since = len(api.frames)
    assert api.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, value) == M.MAV_RESULT_ACCEPTED
    (reply,) = api.messages("MESSAGE_INTERVAL", since=since)
    assert (reply.message_id, reply.interval_us) == (0, 0)
    assert telemetry_flows(sim)
    assert sim.simulation.internal_errors == errors


@pytest.mark.parametrize("value", [math.nan, math.inf, 30.5, 31.4])
def test_request_message_interval_is_denied_whatever_param2(sim, value):
    """REQUEST_MESSAGE(MESSAGE_INTERVAL): v1.15.2 has no MESSAGE_INTERVAL stream, so
    handle_request_message_command finds nothing to send and answers DENIED, whatever id
    param2 asks about; telemetry goes on."""
    api = sim.api(0)
    since = len(api.frames)
    assert api.command_long(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_MESSAGE_INTERVAL,
                            value) == M.MAV_RESULT_DENIED
    assert api.messages("MESSAGE_INTERVAL", since=since) == []
    assert telemetry_flows(sim)
