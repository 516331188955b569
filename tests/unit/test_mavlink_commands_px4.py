"""Command answers checked against PX4's own sources: mavlink_receiver.cpp
(handle_message_command_both and the commands it answers itself) and Commander::handle_command."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as M
from test_mavlink_support import acks, make

NAN = math.nan
INT32_MAX = 2**31 - 1


def results(msgs):
    return [(a.command, a.result) for a in acks(msgs)]


@pytest.mark.parametrize("command", [M.MAV_CMD_COMPONENT_ARM_DISARM, M.MAV_CMD_REQUEST_MESSAGE,
                                     M.MAV_CMD_DO_SET_MODE, 31000])
@pytest.mark.parametrize("how", ["long", "int"])
def test_a_command_to_system_0_is_ignored(command, how):
    """MavlinkReceiver::evaluate_target_ok: a command is taken only when its target_system is
    this system's id (and target_component this component or 0); broadcast (system 0) is
    ignored without an ACK, however it is sent."""
    vehicle, _, client = make()
    vehicle.become_ready()
    if how == "long":
        got = client.command_long(command, 1, 4, 3, target_system=0, target_component=0)
    else:
        got = client.send(M.MAVLink_command_int_message(0, 0, 0, command, 0, 0, 1, 4, 3, 0,
                                                        INT32_MAX, INT32_MAX, NAN))
    assert results(got) == []
    assert not vehicle.armed and vehicle.nav_state.name == "AUTO_LOITER"


@pytest.mark.parametrize("command", [M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
                                     M.MAV_CMD_REQUEST_PROTOCOL_VERSION])
def test_capability_requests_take_any_system_and_component(command):
    """evaluate_target_ok: REQUEST_AUTOPILOT_CAPABILITIES and REQUEST_PROTOCOL_VERSION accept
    system 0 and ignore the component."""
    _, _, client = make()
    for target in ((0, 0), (0, 100), (1, 100)):
        assert results(client.command_long(command, 1, target_system=target[0],
                                           target_component=target[1])) == [(command, 0)]
