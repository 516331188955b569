"""DO_JUMP through the wire in lockstep (gateway.testing.Sim), as PX4 1.15 flies it
(navigator mission_base.cpp goToNextItem / getNonJumpItem, mission.cpp setActiveMissionItems)."""

import numpy as np

from gateway.testing import mission_item
from tests.unit import lockstep_support
from tests.unit.lockstep_support import geo
from vehicles.plan_types import MavCmd, MissionState, PlanResult

sim = lockstep_support.sim  # the fixture: one vehicle, its position estimate valid

# The mission's state as the vehicle knows it (PX4 v1.15's MISSION_CURRENT leaves mission_state 0)
ACTIVE, COMPLETE = MissionState.ACTIVE, MissionState.COMPLETE


def state(sim):
    return sim.vehicles[0].mission_status.state
READ_FAILED = "Waypoint could not be read.\t"


def jump(target: float, repeats: float):
    return mission_item(MavCmd.DO_JUMP, params=(target, repeats, 0.0, 0.0))


NAN = float("nan")
WP0 = mission_item(MavCmd.NAV_WAYPOINT, *geo(12, 0), 6.0)
WP1 = mission_item(MavCmd.NAV_WAYPOINT, *geo(12, 12), 6.0)
WP2 = mission_item(MavCmd.NAV_WAYPOINT, *geo(0, 12), 6.0)


def fly(sim, items, mark=0, timeout_s=90.0):
    """Upload (when ``items``), start, and fly until the mission is complete; the
    MISSION_ITEM_REACHED seqs, the MISSION_CURRENT seqs and the texts from ``mark`` on."""
    api = sim.api(0)
    if items:
        assert api.upload_mission(items) == PlanResult.ACCEPTED
        assert api.arm() == 0 and api.start_mission() == 0

    assert sim.run_until(lambda: state(sim) is COMPLETE, timeout_s=timeout_s)
    sim.advance(2.5)  # the 1 Hz MISSION_CURRENT stream after the finish
    reached = [m.seq for m in api.messages("MISSION_ITEM_REACHED", since=mark)]
    current = [m.seq for m in api.messages("MISSION_CURRENT", since=mark)]
    texts = [m.text for m in api.messages("STATUSTEXT", since=mark)]
    return reached, current, texts


def jump_items(api, mark=0):
    """The DO_JUMP items the vehicle sent unasked (mavlink_mission.cpp send: after each jump)."""
    return [(m.seq, m.command, m.param1, m.param2, m.target_system, m.target_component)
            for m in api.messages("MISSION_ITEM_INT", since=mark)]


def dedup(seqs):
    return [s for i, s in enumerate(seqs) if i == 0 or seqs[i - 1] != s]


def test_exhausted_jump_at_the_end_finishes_at_the_last_flown_item(sim):
    """[WP, WP, DO_JUMP 0 x1]: the jump is taken once, never current nor reached (the link
    sends its item instead); then
    stepping past it reads the item after the last ("Waypoint could not be read.", once per
    look-ahead of the two items flown again and once moving on) and the mission finishes at
    item 1, without resetting the jump: a restart at item 0 does not jump again."""
    api = sim.api(0)
    reached, current, texts = fly(sim, [WP0, WP1, jump(0, 1)])
    assert dedup(reached) == [0, 1, 0, 1]
    assert 2 not in current and dedup(current)[-4:] == [0, 1, 0, 1]
    assert texts.count(READ_FAILED) == 3
    assert texts.index(READ_FAILED) < texts.index("Mission finished, loitering\t")
    m = api.last("MISSION_CURRENT")
    assert (m.seq, m.total, m.mission_state, state(sim)) == (1, 3, 0, COMPLETE)
    # the jump taken: its item, as uploaded, to the client that uploaded the mission
    me = (api.mav.srcSystem, api.mav.srcComponent)
    assert jump_items(api) == [(2, MavCmd.DO_JUMP, 0.0, 1.0, *me)]

    mark = len(api.frames)
    api.send(api.mav.mission_set_current_encode(api.target, 1, 0))
    assert sim.run_until(lambda: state(sim) is ACTIVE, timeout_s=3)
    reached, _current, texts = fly(sim, None, mark)
    # (after the 1 Hz repeats of item 1's MISSION_ITEM_REACHED) the jump's count stayed used up
    assert dedup(reached)[dedup(reached).index(0):] == [0, 1]
    assert texts.count(READ_FAILED) == 3  # at 0's and 1's look-ahead, and moving on from 1
    assert jump_items(api, mark) == []


def test_jump_outside_the_mission_finishes_it(sim):
    """[WP, DO_JUMP 7 x2, WP]: a jump to an index outside the mission has no next item: the
    mission finishes at item 0 (PX4 says "Do Jump mission index is out of bounds." only on its
    console) and item 2 is never flown."""
    api = sim.api(0)
    reached, current, texts = fly(sim, [WP0, jump(7, 2), WP2])
    assert dedup(reached) == [0] and set(current) == {0}
    assert "Mission finished, loitering\t" in texts and READ_FAILED not in texts
    m = api.last("MISSION_CURRENT")
    assert (m.seq, state(sim)) == (0, COMPLETE)


def test_jump_in_the_middle_repeats_and_reports_only_flown_items(sim):
    """[WP, WP, DO_JUMP 0 x1, WP]: after the repeat the exhausted jump is stepped over to item
    3, the last: the mission completes there and nothing reads past the end."""
    api = sim.api(0)
    reached, current, texts = fly(sim, [WP0, WP1, jump(0, 1), WP2])
    assert dedup(reached) == [0, 1, 0, 1, 3]
    assert [i[0] for i in jump_items(api)] == [2]
    assert 2 not in current and READ_FAILED not in texts


def download_jump(sim, seq):
    """param1, param2 of item ``seq`` as a download gives it back (MISSION_ITEM_INT)."""
    api = sim.api(0)
    mark = len(api.frames)
    api.send(api.mav.mission_request_list_encode(api.target, 1, 0))
    sim.advance(0.1)
    for i in range(seq + 1):  # in order, as PX4 requires
        api.send(api.mav.mission_request_int_encode(api.target, 1, i, 0))
        sim.advance(0.1)
    api.send(api.mav.mission_ack_encode(api.target, 1, 0, 0))
    back = api.messages("MISSION_ITEM_INT", since=mark)[-1]
    assert (back.seq, back.command) == (seq, MavCmd.DO_JUMP)
    return back.param1, back.param2


def test_jump_index_and_repeats_are_stored_as_int16_and_uint16(sim):
    """mavlink_mission.cpp parse_mavlink_mission_item keeps DO_JUMP's param1 in an int16_t and
    param2 in a uint16_t (navigation.h mission_item_s), and format_mavlink_mission_item sends
    those back. On x86-64 SITL the float goes through an int32 and keeps its low 16 bits: -1
    repeats are 65535 (as good as for ever), 65537 repeats are 1, index 65536 is item 0."""
    api = sim.api(0)
    assert api.upload_mission([WP0, WP1, jump(0, -1.0)]) == PlanResult.ACCEPTED
    assert download_jump(sim, 2) == (0.0, 65535.0)
    mark = len(api.frames)
    reached, _current, _texts = fly(sim, [WP0, WP1, jump(65536.0, 65537.0), WP2], mark)
    assert dedup(reached) == [0, 1, 0, 1, 3]
    assert [i[:4] for i in jump_items(api, mark)] == [(2, MavCmd.DO_JUMP, 0.0, 1.0)]
    assert download_jump(sim, 2) == (0.0, 1.0)


def test_reached_is_sent_only_when_the_reached_item_changes(sim):
    """mavlink_mission.cpp send: MISSION_ITEM_REACHED goes out when mission_result.seq_reached
    changes. [WP, WP holding 0.5 s, DO_JUMP 1 x2]: item 1 is reached three times in a row, half
    a second apart; the jump back to it changes nothing, so it is sent once (then its 10
    repeats at 1 Hz)."""
    api = sim.api(0)
    hold = mission_item(MavCmd.NAV_WAYPOINT, *geo(12, 12), 6.0, params=(0.5, 0.0, 0.0, NAN))
    reached, _current, _texts = fly(sim, [WP0, hold, jump(1, 2)])
    times = [t for t, m in api.timed_messages("MISSION_ITEM_REACHED") if m.seq == 1]
    assert dedup(reached) == [0, 1]
    # the first one and its repeats at >= 1 s intervals, no extra sends for the second and
    # third reach of item 1
    assert all(b - a > 0.9 for a, b in zip(times, times[1:]))


def test_set_current_onto_a_jump_makes_the_jump_the_current_item(sim):
    """MISSION_SET_CURRENT (mavlink_mission.cpp update_active_mission) puts the new index into
    the mission topic as it is; the navigator loads that item without resolving it
    (MissionBase::loadCurrentMissionItem): the DO_JUMP is the current item, has no position
    setpoint (the vehicle holds where it is) and is never reached, and no jump is counted.
    MISSION_START with the index already current changes nothing (set_current_mission_index
    returns at once); from another current item it resolves the jump (goToItem)."""
    api = sim.api(0)
    assert api.upload_mission([WP0, WP1, jump(0, 3), WP2]) == PlanResult.ACCEPTED
    assert api.arm() == 0 and api.start_mission() == 0
    assert sim.run_until(lambda: 0 in [m.seq for m in api.messages("MISSION_ITEM_REACHED")],
                         timeout_s=40)
    mark = len(api.frames)
    api.send(api.mav.mission_set_current_encode(api.target, 1, 2))
    sim.advance(8.0)
    current = [m.seq for m in api.messages("MISSION_CURRENT", since=mark)]
    assert current and set(current[1:]) == {2}
    assert state(sim) is ACTIVE
    assert [m.seq for m in api.messages("MISSION_ITEM_REACHED", since=mark)
            if m.seq != 0] == []
    assert jump_items(api, mark) == []
    assert float(np.linalg.norm(sim.state(0).velocity_ned_mps)) < 0.3  # holding, not flying on
    # MISSION_START with that index is navigator_main.cpp's set_current_mission_index: the
    # current index already, so nothing happens
    mark = len(api.frames)
    assert api.command_long(300, 2, 0) == 0
    sim.advance(3.0)
    assert jump_items(api, mark) == [] and api.last("MISSION_CURRENT").seq == 2
    assert float(np.linalg.norm(sim.state(0).velocity_ned_mps)) < 0.3
    # from another current item, goToItem resolves the jump (and counts it)
    api.send(api.mav.mission_set_current_encode(api.target, 1, 3))
    assert api.command_long(300, 2, 0) == 0
    assert sim.run_until(lambda: jump_items(api, mark), timeout_s=3)
    assert [i[0] for i in jump_items(api, mark)] == [2]
    assert sim.run_until(lambda: 0 in [m.seq for m in api.messages("MISSION_ITEM_REACHED",
                                                                   since=mark)], timeout_s=20)
