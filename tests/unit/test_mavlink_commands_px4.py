"""Command answers checked against PX4's own sources: mavlink_receiver.cpp
(handle_message_command_both and the commands it answers itself) and Commander::handle_command."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as M
from test_mavlink_support import Client, FakeVehicle, acks, make

from gateway.mavlink.command_table import SeenComponents
from gateway.mavlink.session import LinkKind, Session

NAN = math.nan
INT32_MAX = 2**31 - 1


def results(msgs):
    return [(a.command, a.result) for a in acks(msgs)]


@pytest.mark.parametrize("command", [M.MAV_CMD_COMPONENT_ARM_DISARM, M.MAV_CMD_REQUEST_MESSAGE,
                                     M.MAV_CMD_DO_SET_MODE, 31000])
@pytest.mark.parametrize("how", ["long", "int"])
@pytest.mark.parametrize("target", [(0, 0), (0, 1), (2, 1), (1, 100), (1, 190)])
def test_a_command_for_another_target_is_answered_failed(command, how, target):
    """MavlinkReceiver::evaluate_target_ok: a command is taken only when its target_system is
    this system's id and target_component this component or 0; handle_message_command_both
    answers any other target (broadcast system 0 too) FAILED when no other MAVLink instance has
    heard that component, and does nothing with it."""
    vehicle, session, client = make()
    vehicle.become_ready()
    if how == "long":
        got = client.command_long(command, 1, 4, 3, target_system=target[0],
                                  target_component=target[1])
    else:
        got = client.send(M.MAVLink_command_int_message(*target, 0, command, 0, 0, 1, 4, 3, 0,
                                                        INT32_MAX, INT32_MAX, NAN))
    assert results(got) == [(command, 4)]
    assert [(a.target_system, a.target_component) for a in acks(got)] == [(245, 190)]
    assert not vehicle.armed and vehicle.nav_state.name == "AUTO_LOITER"
    assert session.stats.rx_other_target == 1


def test_a_command_for_a_component_heard_on_another_link_is_left_to_it():
    """PX4 SITL's GCS and onboard links forward (-f): a command for a component another link
    has heard (Mavlink::component_was_seen) is forwarded there and not answered; broadcast
    system 0 counts as heard once the other link heard anyone."""
    vehicle = FakeVehicle()
    seen = SeenComponents()
    api = Session(vehicle, LinkKind.API, seen=seen)
    gcs = Session(vehicle, LinkKind.GCS, seen=seen)
    c_api, c_gcs = Client(api), Client(gcs, 255, 190)
    assert results(c_api.command_long(M.MAV_CMD_DO_SET_MODE, 1, 4, 3, target_system=1,
                                      target_component=100)) == [(176, 4)]
    assert results(c_api.command_long(M.MAV_CMD_DO_SET_MODE, 1, 4, 3, target_system=0,
                                      target_component=0)) == [(176, 4)]
    c_gcs.send(M.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))  # QGC (255, 190) on the GCS link
    for target in ((255, 190), (255, 0), (0, 0), (0, 1)):
        assert results(c_api.command_long(M.MAV_CMD_DO_SET_MODE, 1, 4, 3,
                                          target_system=target[0],
                                          target_component=target[1])) == [], target
    assert results(c_api.command_long(M.MAV_CMD_DO_SET_MODE, 1, 4, 3, target_system=255,
                                      target_component=1)) == [(176, 4)]
    assert not acks(c_gcs.drain())


@pytest.mark.parametrize("command, answered", [(M.MAV_CMD_DO_SET_MODE, False),
                                               (M.MAV_CMD_COMPONENT_ARM_DISARM, False),
                                               (M.MAV_CMD_REQUEST_MESSAGE, True),
                                               (M.MAV_CMD_GET_MESSAGE_INTERVAL, True)])
def test_a_command_from_the_autopilots_own_ids_is_dropped(command, answered):
    """handle_message_command_both: a command it passes on that comes from its own system and
    component ("ignoring CMD with same SYS/COMP") is dropped unanswered; the ones the MAVLink
    module answers itself are answered whoever sent them."""
    vehicle = FakeVehicle()
    client = Client(Session(vehicle, LinkKind.API), 1, 1)
    got = client.command_long(command, 1, 4, 3)
    assert bool(acks(got)) is answered
    assert not vehicle.armed
    # handle_message_set_mode passes a legacy SET_MODE on from anyone: Commander answers it
    got = client.send(M.MAVLink_set_mode_message(1, 1, (4 << 16) | (3 << 24)))
    assert results(got) == [(176, 0)]


@pytest.mark.parametrize("p5, p6, denied", [
    (2147483648.0, 2147483648.0, True), (2147483520.0, 2147483904.0, True),
    (2147483648.0, 0.0, False), (2147483392.0, 2147483648.0, False)])
def test_command_long_with_int32_max_position_is_denied_whatever_its_target(p5, p6, denied):
    """handle_message_command_long, before the target is looked at: param5 and param6 both
    within nextafterf of (float)INT32_MAX look like a COMMAND_INT sent as COMMAND_LONG, DENIED."""
    _, _, client = make()
    got = client.command_long(M.MAV_CMD_DO_SET_MODE, 1, 4, 3, 0, p5, p6, target_system=2)
    assert results(got) == [(176, 2 if denied else 4)]


def test_command_int_position_is_unset_only_when_x_and_y_both_are_int32_max():
    """handle_message_command_int: x = y = INT32_MAX leave lat/lon NaN; one of them alone is
    read as degE7 like any value."""
    vehicle, _, client = make()
    client.send(M.MAVLink_command_int_message(1, 1, 5, 192, 0, 0, NAN, 1, 0, NAN, INT32_MAX,
                                              85460000, 500.0))
    _, _, lat, lon, alt, _, _ = vehicle.calls[-1]
    assert (lat, lon, alt) == pytest.approx((214.7483647, 8.546, 500.0))


@pytest.mark.parametrize("command", [M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
                                     M.MAV_CMD_REQUEST_PROTOCOL_VERSION])
def test_capability_requests_take_any_system_and_component(command):
    """evaluate_target_ok: REQUEST_AUTOPILOT_CAPABILITIES and REQUEST_PROTOCOL_VERSION accept
    system 0 and ignore the component."""
    _, _, client = make()
    for target in ((0, 0), (0, 100), (1, 100)):
        assert results(client.command_long(command, 1, target_system=target[0],
                                           target_component=target[1])) == [(command, 0)]


@pytest.mark.parametrize("msg_id", [9999, 437, 65535, -1])
def test_request_for_a_message_without_a_stream_is_denied(msg_id):
    """MavlinkReceiver::handle_request_message_command answers ACCEPTED or DENIED, never
    UNSUPPORTED: a message id without a stream (AVAILABLE_MODES_MONITOR, which only the
    AVAILABLE_MODES stream sends, an unknown id; -1 is (uint16_t)roundf(-1) = 65535) is
    DENIED."""
    _, _, client = make()
    assert results(client.command_long(M.MAV_CMD_REQUEST_MESSAGE, msg_id)) == [(512, 2)]


@pytest.mark.parametrize("p1, sent", [(NAN, "HEARTBEAT"), (30.4, "ATTITUDE"),
                                      (65536 + 30, "ATTITUDE")])
def test_request_message_takes_the_id_as_uint16_of_its_rounding(p1, sent):
    """handle_message_command_both: message_id = (uint16_t)roundf(param1); NaN converts to 0
    on x86 (HEARTBEAT), and the id wraps at 16 bits."""
    _, _, client = make()
    got = client.command_long(M.MAV_CMD_REQUEST_MESSAGE, p1)
    assert [m.get_type() for m in got] == [sent, "COMMAND_ACK"] and acks(got)[0].result == 0


@pytest.mark.parametrize("p3, p4, p7", [
    (1, 0, 0), (0, 1, 0), (0, 0, 2), (0.4, 0.4, 0.4), (NAN, NAN, NAN), (math.inf, 0, 0)])
def test_set_message_interval_reads_no_response_target(p3, p4, p7):
    """v1.15.2 MavlinkReceiver: set_message_interval((int)roundf(param1), param2, param3):
    param3 is a data rate, param4 to param7 are not read (PX4 main fails a response target;
    v1.15 does not)."""
    _, session, client = make()
    got = client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, 30, 1e6, p3, p4, 0, 0, p7)
    assert results(got) == [(511, 0)]
    assert session.scheduler.interval_us(30) == 1_000_000


@pytest.mark.parametrize("p1, message_id, interval", [(-0.6, 65535, 0), (-0.4, 0, 1_000_000),
                                                      (29.5, 30, 20_000)])
def test_get_message_interval_rounds_the_id_with_roundf(p1, message_id, interval):
    """get_message_interval((int)roundf(param1)): -0.6 is -1 (no stream: interval 0, sent as
    uint16 65535), not (int)(-0.6 + 0.5f) = 0 (HEARTBEAT)."""
    _, _, client = make(LinkKind.GCS)
    got = client.command_long(M.MAV_CMD_GET_MESSAGE_INTERVAL, p1)
    (reply,) = [m for m in got if m.get_type() == "MESSAGE_INTERVAL"]
    assert (reply.message_id, reply.interval_us) == (message_id, interval)
    assert results(got) == [(510, 0)]


def test_request_message_for_message_interval_is_denied():
    """v1.15.2 has no MESSAGE_INTERVAL stream: REQUEST_MESSAGE(244) is DENIED, nothing sent."""
    _, _, client = make()
    got = client.command_long(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_MESSAGE_INTERVAL, 30)
    assert [m.get_type() for m in got] == ["COMMAND_ACK"] and results(got) == [(512, 2)]


@pytest.mark.parametrize("command, p1, p2, answered", [
    (M.MAV_CMD_REQUEST_STORAGE_INFORMATION, 0, 0, True),
    (M.MAV_CMD_REQUEST_STORAGE_INFORMATION, 1, 5, True),
    (M.MAV_CMD_REQUEST_MESSAGE, 261, 0, True), (M.MAV_CMD_REQUEST_MESSAGE, 261, 1.4, True),
    (M.MAV_CMD_REQUEST_MESSAGE, 261, 2, False)])
def test_storage_information_as_its_stream_answers(command, p1, p2, answered):
    """handle_message_command_both answers REQUEST_STORAGE_INFORMATION as a request for
    STORAGE_INFORMATION with param2 0; the stream answers storage (int)roundf(param2) 0 or 1
    (one storage, available and formatted) and refuses another id (DENIED)."""
    _, _, client = make()
    got = client.command_long(command, p1, p2)
    infos = [m for m in got if m.get_type() == "STORAGE_INFORMATION"]
    assert results(got) == [(command, 0 if answered else 2)]
    assert [(m.storage_id, m.storage_count, m.status) for m in infos] == \
        ([(1, 1, 2)] if answered else [])
    if answered:
        m = infos[0]
        assert m.used_capacity + m.available_capacity == pytest.approx(m.total_capacity)


def test_set_message_interval_rounds_the_id():
    """(int)roundf(param1): 29.6 is ATTITUDE (30)."""
    _, session, client = make()
    assert results(client.command_long(M.MAV_CMD_SET_MESSAGE_INTERVAL, 29.6, 5e5)) == [(511, 0)]
    assert session.scheduler.interval_us(30) == 500_000


# --- COMPONENT_ARM_DISARM: Commander::handle_command ------------------------------------------

@pytest.mark.parametrize("p1, call", [(0.6, "arm"), (1.4, "arm"), (257.0, "arm"), (0.4, "disarm"),
                                      (-0.4, "disarm"), (NAN, "disarm"), (3e38, "disarm")])
def test_arm_disarm_reads_param1_as_int8_of_lroundf(p1, call):
    """arming_action = static_cast<int8_t>(lroundf(param1)): 0.6 and 257 arm, -0.4 disarms;
    NaN and values beyond a long convert to LONG_MIN on x86, whose low byte is 0: disarm."""
    vehicle, _, client = make()
    vehicle.become_ready()
    assert results(client.command_long(400, p1)) == [(400, 0)]
    assert vehicle.calls[-1][0] == call


@pytest.mark.parametrize("p2, forced", [(21196, True), (21196.4, True), (21195.6, True),
                                        (21196.6, False), (NAN, False)])
def test_forced_arm_disarm_is_lroundf_of_param2(p2, forced):
    """forced = (static_cast<int>(lroundf(param2)) == 21196)."""
    vehicle, _, client = make()
    client.command_long(400, 0, p2)
    assert vehicle.calls[-1] == ("disarm", 0.0, forced)


@pytest.fixture(scope="module")
def sim():
    from gateway.testing import Sim

    with Sim(1) as s:
        assert s.run_until(lambda: s.status(0).position_valid, timeout_s=10)
        yield s


def answer(sim, command, *params, source_component=None, wait_s=0.5):
    """COMMAND_LONG from the API client (or another component of it): the ACK's result (None
    without one), and the texts and events (but the health report's) that came with it."""
    api = sim.api(0)
    cursor, latest = len(api.frames), sim.vehicles[0].events.latest
    p = [float(x) for x in params] + [0.0] * (7 - len(params))
    compid = api.mav.srcComponent
    if source_component is not None:
        api.mav.srcComponent = source_component
    try:
        api.send(api.mav.command_long_encode(1, 1, command, 0, *p))
    finally:
        api.mav.srcComponent = compid
    sim.advance(wait_s)
    got = [m.result for m in api.messages("COMMAND_ACK", since=cursor) if m.command == command]
    texts = [m.text for m in api.messages("STATUSTEXT", since=cursor)]
    from vehicles.events import DEFINITIONS

    shown = {d.id for d in DEFINITIONS if d.group == "default"}  # not the health report's
    events = [e for e in sim.vehicles[0].events.after(latest) if e.id in shown]
    return (got[0] if got else None), texts, events


def test_an_arm_action_neither_arm_nor_disarm_is_said_with_its_value(sim):
    """Commander: "Unsupported ARM_DISARM param: %.3f\\t" (critical) and its event, no ACK."""
    from vehicles.events import UNSUPPORTED_ARM_PARAM

    result, texts, events = answer(sim, M.MAV_CMD_COMPONENT_ARM_DISARM, 2)
    assert result is None
    assert texts == ["Unsupported ARM_DISARM param: 2.000\t"]
    assert [e.id for e in events] == [UNSUPPORTED_ARM_PARAM.id]
    assert not sim.status(0).armed
    assert sim.simulation.internal_errors == 0


# --- DO_SET_MODE: Commander::handle_command ---------------------------------------------------

@pytest.mark.parametrize("p1, p2, p3, nav", [
    (1, 3, 1, "POSCTL"),  # POSCTL's sub modes other than SLOW are Position (not Orbit)
    (1, 3, 2, "POSITION_SLOW"),
    (1, 1, 5, "MANUAL"), (1, 2, 9, "ALTCTL"), (1, 5, 3, "ACRO"), (1, 7, 4, "STAB"),
    (1, 6, 7, "OFFBOARD"),  # the other main modes ignore the sub mode
    (1, 4, 0, "AUTO_MISSION"), (1 | 128 | 32, 4, 3, "AUTO_LOITER"), (257, 4, 6, "AUTO_LAND"),
    (4, 0, 0, "AUTO_MISSION"), (64 | 8, 0, 0, "POSCTL"), (64 | 16, 0, 0, "STAB"),
    (64, 0, 0, "MANUAL"),  # without CUSTOM_MODE_ENABLED: the base mode flags
])
def test_set_mode_decodes_as_commander(p1, p2, p3, nav):
    vehicle, _, client = make()
    assert results(client.command_long(176, p1, p2, p3)) == [(176, 0)]
    assert vehicle.calls[-1][0] == "set_nav_state" and vehicle.calls[-1][2].name == nav


@pytest.mark.parametrize("p1, p2, p3", [
    (1, 0, 0), (1, 8, 0), (1, 9, 0), (1, 10, 0), (1, 11, 0), (1, 200, 0),  # no such main mode
    (0, 4, 3), (2, 4, 3), (128, 0, 0),  # no custom mode, no AUTO or MANUAL flag
    (NAN, 4, 3), (math.inf, 4, 3), (3e38, 4, 3),  # (uint8_t) of these is 0 on x86
    (1, NAN, 3),
])
def test_set_mode_without_a_mode_is_accepted_and_changes_nothing(p1, p2, p3):
    """desired_nav_state stays NAVIGATION_STATE_MAX: no transition, and main_ret
    TRANSITION_NOT_CHANGED answers ACCEPTED."""
    vehicle, _, client = make()
    assert results(client.command_long(176, p1, p2, p3)) == [(176, 0)]
    assert vehicle.calls == [] and vehicle.nav_state.name == "AUTO_LOITER"


@pytest.mark.parametrize("p3", [1, 7, 10, 19, 255, NAN, -1])
def test_set_mode_with_an_unknown_auto_sub_mode_is_rejected(p3):
    """AUTO with a sub mode Commander does not switch to: TEMPORARILY_REJECTED (NaN's
    (uint8_t) is 0, which is Mission)."""
    vehicle, _, client = make()
    got = client.command_long(176, 1, 4, p3)
    if math.isnan(p3):
        assert results(got) == [(176, 0)] and vehicle.nav_state.name == "AUTO_MISSION"
    else:
        assert results(got) == [(176, 1)] and vehicle.calls == []


def test_set_mode_to_an_unknown_auto_sub_mode_says_so(sim):
    """"Unsupported auto mode\\t" (critical) and its event (error)."""
    from vehicles.events import UNSUPPORTED_AUTO_MODE

    result, texts, events = answer(sim, M.MAV_CMD_DO_SET_MODE, 1, 4, 1)
    assert result == M.MAV_RESULT_TEMPORARILY_REJECTED
    assert texts == ["Unsupported auto mode\t"]
    assert [e.id for e in events] == [UNSUPPORTED_AUTO_MODE.id]


# --- printRejectMode ----------------------------------------------------------------------------

def test_a_refused_mode_switch_is_said_to_qgc_only(sim):
    """DO_SET_MODE: Commander prints "Switching to <mode> is currently not available\\t" (and
    its event, the mode's custom mode and navigation_mode_t) only for a command from component
    190 (QGC); at most once a second."""
    from vehicles.events import MODE_NOT_AVAILABLE

    sim.advance(1.1)
    api = sim.api(0)
    assert api.arm() == 0  # armed, a mode must be able to run (disarmed, PX4 grants any)
    sim.advance(0.5)  # its text out
    try:
        result, texts, events = answer(sim, M.MAV_CMD_DO_SET_MODE, 1, 6, 0,
                                       source_component=191)
        assert result == M.MAV_RESULT_TEMPORARILY_REJECTED and texts == [] and events == []
        result, texts, events = answer(sim, M.MAV_CMD_DO_SET_MODE, 1, 6, 0)  # Offboard, no sp
        assert result == M.MAV_RESULT_TEMPORARILY_REJECTED
        assert texts == ["Switching to Offboard is currently not available\t"]
        assert [(e.id, e.arguments) for e in events] == [
            (MODE_NOT_AVAILABLE.id, (6 << 16).to_bytes(4, "little") + bytes([7]))]
        result, texts, _ = answer(sim, M.MAV_CMD_DO_SET_MODE, 1, 4, 4)  # Mission: none
        assert result == M.MAV_RESULT_TEMPORARILY_REJECTED and texts == []  # within the second
        sim.advance(1.0)
        _, texts, _ = answer(sim, M.MAV_CMD_DO_SET_MODE, 1, 4, 4)
        assert texts == ["Switching to Mission is currently not available\t"]
        assert sim.status(0).nav_state.name == "AUTO_LOITER"
    finally:
        assert api.disarm() == 0
        sim.advance(0.5)


def test_disarmed_any_mode_a_command_names_is_granted(sim):
    """UserModeIntention::change: always allowed while disarmed, Offboard without setpoints and
    Mission without a mission too; arming in them is what is refused."""
    for custom_main, sub, name in ((6, 0, "OFFBOARD"), (4, 4, "AUTO_MISSION"),
                                   (4, 3, "AUTO_LOITER")):
        result, texts, _ = answer(sim, M.MAV_CMD_DO_SET_MODE, 1, custom_main, sub)
        assert result == M.MAV_RESULT_ACCEPTED and texts == []
        sim.advance(0.1)
        assert sim.status(0).nav_state.name == name
        if name != "AUTO_LOITER":
            assert sim.api(0).arm() == M.MAV_RESULT_TEMPORARILY_REJECTED
            sim.advance(0.5)  # its texts out


def armed_without_position(sim):
    """Armed in Hold, then the GPS off (MAV_CMD_INJECT_FAILURE) until the position is lost."""
    sim.vehicles[0].params.set("SYS_FAILURE_EN", 1)
    assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
    assert sim.api(0).arm() == 0
    assert sim.api(0).command_long(M.MAV_CMD_INJECT_FAILURE, 4, 1, 0) == 0
    assert sim.run_until(lambda: not sim.status(0).position_valid, timeout_s=10)
    sim.advance(0.5)  # "Failsafe activated" (Descend) out


def test_commands_that_switch_modes_say_a_refusal_to_everyone():
    """NAV_TAKEOFF, NAV_LAND, NAV_RETURN_TO_LAUNCH and DO_REPOSITION: printRejectMode whoever
    sends them (here armed without a position estimate, which each mode needs)."""
    from gateway.testing import Sim

    with Sim(1) as sim:
        armed_without_position(sim)
        for command, params, name in (
                (M.MAV_CMD_NAV_TAKEOFF, [NAN] * 7, "Takeoff"),
                (M.MAV_CMD_NAV_LAND, [NAN] * 7, "Land"),
                (M.MAV_CMD_NAV_RETURN_TO_LAUNCH, [], "Return"),
                (M.MAV_CMD_DO_REPOSITION, [-1, 1, 0, NAN, NAN, NAN, NAN], "Hold")):
            sim.vehicles[0].commander._reject_said_s = -math.inf  # one text each
            result, texts, _ = answer(sim, command, *params, source_component=191, wait_s=0.1)
            assert result == M.MAV_RESULT_TEMPORARILY_REJECTED
            assert texts == [f"Switching to {name} is currently not available\t"]
        assert sim.simulation.internal_errors == 0


# --- the others -----------------------------------------------------------------------------------

@pytest.mark.parametrize("p1", [1, 0])
def test_set_home_with_home_disabled_is_denied(p1):
    """Commander: DO_SET_HOME with COM_HOME_EN 0 is DENIED (not TEMPORARILY_REJECTED), before
    anything else is looked at."""
    vehicle, _, client = make()
    vehicle.become_ready()
    vehicle.params.set("COM_HOME_EN", 0)
    assert results(client.command_long(179, p1, 0, 0, NAN, 47.4, 8.5, 500)) == [(179, 2)]
    assert not [c for c in vehicle.calls if c[0] == "set_home"]


@pytest.mark.parametrize("p1, result", [(0, 0), (0.5, 0), (-0.9, 0), (1, 2), (NAN, 2)])
def test_reboot_reads_param1_as_an_int(p1, result):
    """PREFLIGHT_REBOOT_SHUTDOWN: const int param1 = cmd.param1; 0 is ACCEPTED (nothing to
    do)."""
    _, _, client = make()
    assert results(client.command_long(246, p1)) == [(246, result)]


def test_a_refused_orbit_is_said():
    """DO_ORBIT whose switch to Orbit is refused: TEMPORARILY_REJECTED and "Orbit command
    rejected" (critical)."""
    from gateway.testing import Sim

    with Sim(1) as sim:
        armed_without_position(sim)
        result, texts, _ = answer(sim, M.MAV_CMD_DO_ORBIT, 10, 2, 0, NAN, NAN, NAN, NAN,
                                  wait_s=0.1)
        assert result == M.MAV_RESULT_TEMPORARILY_REJECTED
        assert texts == ["Orbit command rejected"]
