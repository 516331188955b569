"""AVAILABLE_MODES as PX4 v1.15.2 answers MAV_CMD_REQUEST_MESSAGE for it
(streams/AVAILABLE_MODES.hpp request_message and send_single_mode; lib/modes/ui.hpp,
standard_modes.hpp; ModeManagement::getModeStatus; px4_custom_mode.h get_px4_custom_mode), on
a multicopter SITL where no external mode registers."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as M
from pymavlink.dialects.v20 import development
from test_mavlink_support import acks, make, of_type

from gateway.mavlink.available_modes import (
    CAN_SET_NAV_STATES_MASK,
    MODES,
    VALID_NAV_STATES_MASK,
)
from gateway.mavlink.codec import Encoder
from gateway.mavlink.modes import heartbeat_modes
from gateway.mavlink.session import LinkKind
from gateway.testing import Sim
from vehicles.types import NavState

NAN = math.nan
REQUEST_MESSAGE = M.MAV_CMD_REQUEST_MESSAGE
AVAILABLE_MODES = 435
ADV, NUS = 1, 2  # MAV_MODE_PROPERTY_ADVANCED, _NOT_USER_SELECTABLE
NA = "(Mode not available)"

# (standard_mode, custom_mode = main << 16 | sub << 24, properties, mode_name), mode_index 1..25:
# the valid nav states in nav_state order.
EXPECTED = [
    (0, 1 << 16, ADV, "Manual"),                    # 0 MANUAL
    (0, 2 << 16, 0, "Altitude"),                    # 1 ALTCTL: not advanced
    (0, 3 << 16, 0, "Position"),                    # 2 POSCTL: not advanced
    (7, 4 << 16 | 4 << 24, ADV, ""),                # 3 AUTO_MISSION: standard MISSION
    (0, 4 << 16 | 3 << 24, ADV, "Hold"),            # 4 AUTO_LOITER
    (5, 4 << 16 | 5 << 24, ADV, ""),                # 5 AUTO_RTL: standard RETURN_HOME
    (0, 3 << 16 | 2 << 24, ADV, "Position Slow"),   # 6 POSITION_SLOW
    (0, 5 << 16, ADV, "Acro"),                      # 10 ACRO
    (0, 10 << 16, ADV | NUS, "Termination"),        # 13 TERMINATION: never selectable
    (0, 6 << 16, ADV, "Offboard"),                  # 14 OFFBOARD
    (0, 7 << 16, ADV, "Stabilized"),                # 15 STAB
    (9, 4 << 16 | 2 << 24, ADV, ""),                # 17 AUTO_TAKEOFF: standard TAKEOFF
    (8, 4 << 16 | 6 << 24, ADV, ""),                # 18 AUTO_LAND: standard LAND
    (0, 4 << 16 | 8 << 24, ADV, "Follow Target"),   # 19 AUTO_FOLLOW_TARGET
    (0, 4 << 16 | 9 << 24, ADV, "Precision Landing"),  # 20 AUTO_PRECLAND
    (0, 3 << 16 | 1 << 24, ADV, "Orbit"),           # 21 ORBIT
    (0, 4 << 16 | 10 << 24, ADV, "VTOL Takeoff"),   # 22 AUTO_VTOL_TAKEOFF, on a quad too
    *[(0, 4 << 16 | (11 + i) << 24, NUS, NA) for i in range(8)],  # 23..30 EXTERNAL1..8
]


def fields(msgs):
    return [(m.standard_mode, m.custom_mode, m.properties, m.mode_name) for m in msgs]


def test_the_masks_are_getmodestatus_without_external_modes():
    """getValidNavStates (17 internal states, VTOL Takeoff included) plus EXTERNAL1..8, valid
    even unregistered; selectable: all of them but Termination and the unregistered ones."""
    assert VALID_NAV_STATES_MASK == 0x7FFEE47F
    assert CAN_SET_NAV_STATES_MASK == 0x007EC47F
    assert [n for n, _ in MODES] == [0, 1, 2, 3, 4, 5, 6, 10, 13, 14, 15, 17, 18, 19, 20, 21,
                                     22, *range(23, 31)]


def test_the_custom_modes_are_the_heartbeats():
    for nav_state, (_, custom, _, _) in MODES:
        if nav_state in {int(n) for n in NavState}:
            assert custom == heartbeat_modes(NavState(nav_state), False)[1]


@pytest.mark.parametrize("kind", [LinkKind.API, LinkKind.GCS])
@pytest.mark.parametrize("p2", [0, -0.4, 0.49])
def test_param2_zero_sends_every_mode_then_accepts(kind, p2):
    """mode_index = roundf(param2) == 0: one AVAILABLE_MODES per valid nav state, mode_index
    1..25 of number_modes 25, all before the ACK (what QGroundControl's StandardModes asks)."""
    _, _, client = make(kind)
    got = client.command_long(REQUEST_MESSAGE, AVAILABLE_MODES, p2)
    assert [m.get_type() for m in got] == ["AVAILABLE_MODES"] * 25 + ["COMMAND_ACK"]
    modes = got[:-1]
    assert [(m.mode_index, m.number_modes) for m in modes] == [(i, 25) for i in range(1, 26)]
    assert fields(modes) == EXPECTED
    assert [(a.command, a.result) for a in acks(got)] == [(512, 0)]


@pytest.mark.parametrize("p2, index", [(1, 1), (4, 4), (9, 9), (25, 25), (2.4, 2), (24.5, 25),
                                       (0.5, 1)])
def test_param2_n_sends_the_nth_mode(p2, index):
    _, _, client = make()
    got = client.command_long(REQUEST_MESSAGE, AVAILABLE_MODES, p2)
    assert [m.get_type() for m in got] == ["AVAILABLE_MODES", "COMMAND_ACK"]
    assert (got[0].mode_index, got[0].number_modes) == (index, 25)
    assert fields(got[:1]) == [EXPECTED[index - 1]]
    assert acks(got)[0].result == 0


@pytest.mark.parametrize("p2", [26, 25.5, 255, 1e9])
def test_an_index_past_the_last_mode_is_denied(p2):
    """mode_index > number of valid modes: request_message returns false → DENIED."""
    _, _, client = make()
    got = client.command_long(REQUEST_MESSAGE, AVAILABLE_MODES, p2)
    assert [(m.get_type(), m.result) for m in got] == [("COMMAND_ACK", 2)]


@pytest.mark.parametrize("p2", [-1, -0.6, -300, NAN, math.inf, 3e9])
def test_a_negative_index_is_accepted_with_nothing_sent(p2):
    """A negative mode_index (NaN, infinities and values beyond int convert to INT_MIN on x86)
    is <= the mode count, the search for it ends at NAVIGATION_STATE_MAX without a match: no
    mode is sent, yet request_message returns true → ACCEPTED."""
    _, _, client = make()
    got = client.command_long(REQUEST_MESSAGE, AVAILABLE_MODES, p2)
    assert [(m.get_type(), m.result) for m in got] == [("COMMAND_ACK", 0)]


def test_command_int_asks_the_same():
    """handle_message_command_int passes param2 on as COMMAND_LONG's."""
    _, _, client = make()
    got = client.send(M.MAVLink_command_int_message(1, 1, 0, REQUEST_MESSAGE, 0, 0,
                                                    AVAILABLE_MODES, 3, 0, 0, 0, 0, 0))
    assert [m.get_type() for m in got] == ["AVAILABLE_MODES", "COMMAND_ACK"]
    assert got[0].mode_index == 3 and got[0].mode_name == "Position"


def test_the_monitor_is_never_streamed_nor_requestable():
    """The AVAILABLE_MODES stream (0.3 Hz on both links) sends AVAILABLE_MODES_MONITOR only
    after a dynamic update, which never comes without external modes; no stream has
    AVAILABLE_MODES_MONITOR's id, so requesting it is DENIED. MESSAGE_INTERVAL reports the
    stream's configured interval, and SET_MESSAGE_INTERVAL on it is ACCEPTED."""
    for kind in (LinkKind.API, LinkKind.GCS):
        vehicle, _, client = make(kind)
        vehicle.become_ready()
        got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, AVAILABLE_MODES)
        assert got[0].message_id == AVAILABLE_MODES and got[0].interval_us == 3_333_333
        got = client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, AVAILABLE_MODES, 100_000)
        assert [(a.command, a.result) for a in acks(got)] == [(511, 0)]
        got = client.command_long(REQUEST_MESSAGE, 437)
        assert [(m.get_type(), m.result) for m in got] == [("COMMAND_ACK", 2)]
        streamed = client.run_until(20.0)
        assert not of_type(streamed, "AVAILABLE_MODES")
        assert not of_type(streamed, "AVAILABLE_MODES_MONITOR")


def test_the_frames_are_pymavlinks_development_dialect_frames():
    """Byte for byte what pymavlink's development dialect (CRC_EXTRA 134, the v1.15.2 mavlink
    submodule's definition) encodes, trailing zeros of mode_name trimmed."""
    from gateway.mavlink.available_modes import available_modes

    frames = available_modes(Encoder(1, 1), 0)
    assert frames is not None
    mav = development.MAVLink(None, 1, 1)
    for i, (frame, (standard, custom, props, name)) in enumerate(zip(frames, EXPECTED)):
        msg = development.MAVLink_available_modes_message(25, i + 1, standard, custom, props,
                                                          name.encode())
        assert frame == bytes(msg.pack(mav))
        mav.seq = (mav.seq + 1) & 0xFF


def test_a_lockstep_vehicle_lists_its_modes_to_a_request():
    """A pymavlink client asking a running vehicle for every mode gets the 25 before the ACK."""
    with Sim(1, links=(LinkKind.API, LinkKind.GCS)) as sim:
        sim.advance(1.0)
        gcs = sim.gcs()
        assert gcs.command_long(REQUEST_MESSAGE, AVAILABLE_MODES, 0) == 0
        timed = gcs.timed_messages()
        names = [m.get_type() for _, m in timed if m.get_type() in ("AVAILABLE_MODES",
                                                                   "COMMAND_ACK")]
        assert names[-26:] == ["AVAILABLE_MODES"] * 25 + ["COMMAND_ACK"]
        modes = gcs.messages("AVAILABLE_MODES")
        assert [m.mode_index for m in modes] == list(range(1, 26))
        assert fields(modes) == EXPECTED
        sim.advance(10.0)
        assert gcs.messages("AVAILABLE_MODES_MONITOR") == []
