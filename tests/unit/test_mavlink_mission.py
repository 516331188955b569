"""Mission protocol server (mission / fence / rally) against the FakeVehicle, in memory.

The lossy tests run a MAVSDK-like client state machine (0.5 s timeouts, 5 retries, plus QGC's
re-send of the last item when the final ACK is missing) over a seeded network that drops 20 %
of the datagrams both ways, on virtual time (MAVSDK's mission_transfer_lossy, STYLE habit 10).
"""

from __future__ import annotations

import dataclasses
import math
import random

import pytest
from pymavlink.dialects.v20 import common as M
from test_mavlink_support import Client, FakeVehicle, make, of_type

from gateway.mavlink import mission
from gateway.mavlink.mission import UploadLock
from gateway.mavlink.session import LinkKind, Session
from vehicles.plan_types import PlanItem, PlanResult, PlanType
from vehicles.types import NavState

LAT, LON = 473977420, 85455940
NAN = math.nan


def wp(seq, lat=LAT, lon=LON, alt=10.0, cmd=16, frame=6, current=0, mission_type=0,
       params=(0.0, 3.0, 0.0, NAN)):
    return PlanItem(seq, frame, cmd, current, 1, *params, lat, lon, alt, mission_type)


def mavsdk_mission() -> list[PlanItem]:
    """MSDK-Py examples/mission.py: 3 fly-through waypoints at 25 m with speed 10, then RTL."""
    items = []
    for k in range(3):
        items.append(wp(len(items), LAT + 1000 * k, LON + 500 * k, 25.0, current=int(k == 0)))
        items.append(PlanItem(len(items), 2, 178, 0, 1, 1.0, 10.0, -1.0, 0.0, 0, 0, NAN))
    items.append(PlanItem(len(items), 2, 20, 0, 1, NAN, NAN, NAN, NAN, 0, 0, NAN))
    return items


def fence_items() -> list[PlanItem]:
    return [PlanItem(i, 0, 5001, 0, 1, 4.0, 0, 0, 0, LAT + dx, LON + dy, 0.0, 1)
            for i, (dx, dy) in enumerate([(0, 0), (5000, 0), (5000, 5000), (0, 5000)])] + [
        PlanItem(4, 0, 5004, 0, 1, 30.0, 0, 0, 0, LAT + 2000, LON + 2000, 0.0, 1)]


def rally_items() -> list[PlanItem]:
    return [PlanItem(i, 3, 5100, 0, 1, 0, 0, 0, 0, LAT + 300 * i, LON, 20.0 + i, 2)
            for i in range(3)]


def int_frames(items: list[PlanItem], plan_type: PlanType, current_seq: int = 0
               ) -> list[PlanItem]:
    """``items`` as PX4 sends them back to MISSION_REQUEST_INT: the int flavour of their
    altitude reference, a fence point always absolute and with autocontinue 0 (a
    mission_fence_point_s keeps neither), and, whatever the plan type, ``current`` on the
    mission's current seq (send_mission_item)."""
    fence = plan_type == PlanType.FENCE
    frames = {0: 5, 3: 5, 5: 5, 6: 5} if fence else {0: 5, 3: 6, 5: 5, 6: 6}
    return [dataclasses.replace(it, frame=frames.get(it.frame, it.frame),
                                current=int(it.seq == current_seq),
                                autocontinue=0 if fence else it.autocontinue) for it in items]


def item_int_msg(item: PlanItem, target=(1, 1)) -> M.MAVLink_mission_item_int_message:
    return M.MAVLink_mission_item_int_message(
        *target, item.seq, item.frame, item.command, item.current, item.autocontinue,
        item.param1, item.param2, item.param3, item.param4, item.x, item.y, item.z,
        item.mission_type)


def same(a: PlanItem, b: PlanItem, xy_tol: int = 0) -> bool:
    """Field-by-field equality with NaN == NaN (float32 on the wire); x/y within xy_tol."""
    for name in PlanItem.__dataclass_fields__:
        x, y = getattr(a, name), getattr(b, name)
        if name in ("x", "y"):
            if abs(x - y) > xy_tol:
                return False
        elif isinstance(x, float) and math.isnan(x):
            if not math.isnan(y):
                return False
        elif isinstance(x, float):
            if abs(x - y) > 1e-4 * max(1.0, abs(x)):
                return False
        elif x != y:
            return False
    return True


def item_from_wire(m, mission_type) -> PlanItem:
    if m.get_type() == "MISSION_ITEM_INT":
        x, y = m.x, m.y
    else:
        scale = 1e7 if m.frame in (0, 3, 5, 6) else 1.0
        x, y = int(round(m.x * scale)), int(round(m.y * scale))
    return PlanItem(m.seq, m.frame, m.command, m.current, m.autocontinue, m.param1, m.param2,
                    m.param3, m.param4, x, y, m.z, m.mission_type)


def upload(client: Client, items, mission_type=0, target=(1, 1)):
    """Perfect-link upload answering every request; returns all messages received."""
    got = client.send(M.MAVLink_mission_count_message(*target, len(items), mission_type))
    out = list(got)
    for _ in range(len(items) + 1):
        reqs = [m for m in got if m.get_type() in ("MISSION_REQUEST_INT", "MISSION_REQUEST")]
        if not reqs:
            break
        got = client.send(item_int_msg(items[reqs[-1].seq], target))
        out += got
    return out


def download(client: Client, mission_type=0, use_int=True, target=(1, 1)):
    got = client.send(M.MAVLink_mission_request_list_message(*target, mission_type))
    count = of_type(got, "MISSION_COUNT")
    assert count and count[0].mission_type == mission_type
    items = []
    cls = M.MAVLink_mission_request_int_message if use_int else M.MAVLink_mission_request_message
    name = "MISSION_ITEM_INT" if use_int else "MISSION_ITEM"
    for seq in range(count[0].count):
        m = of_type(client.send(cls(*target, seq, mission_type)), name)
        assert len(m) == 1 and m[0].seq == seq
        items.append(item_from_wire(m[0], mission_type))
    client.send(M.MAVLink_mission_ack_message(*target, 0, mission_type))
    return items


def mission_acks(msgs):
    return [(m.type, m.mission_type) for m in of_type(msgs, "MISSION_ACK")]


# --- upload / download ----------------------------------------------------------------------

@pytest.mark.parametrize("plan_type, items", [
    (PlanType.MISSION, mavsdk_mission()),
    (PlanType.FENCE, fence_items()),
    (PlanType.RALLY, rally_items()),
], ids=["mission", "fence", "rally"])
def test_upload_download_round_trip(plan_type, items):
    vehicle, session, client = make()
    got = upload(client, items, int(plan_type))
    reqs = of_type(got, "MISSION_REQUEST_INT")
    assert [r.seq for r in reqs] == list(range(len(items)))
    assert all((r.target_system, r.target_component, r.mission_type) == (245, 190, plan_type)
               for r in reqs)
    assert mission_acks(got) == [(0, plan_type)]
    ack = of_type(got, "MISSION_ACK")[0]
    assert (ack.target_system, ack.target_component) == (245, 190)
    assert len(vehicle.plans[plan_type]) == len(items)
    assert all(same(a, b) for a, b in zip(vehicle.plans[plan_type], items))
    back = download(client, int(plan_type))
    expected = int_frames(items, plan_type)
    assert len(back) == len(items) and all(same(a, b) for a, b in zip(back, expected))
    assert session.mission.phase is mission.Phase.IDLE


def test_download_gives_items_back_as_px4_stored_them():
    """PX4 mavlink_mission.cpp parse_mavlink_mission_item keeps per command only some params
    (a waypoint: hold time, acceptance radius, yaw as wrap_2pi(radians(param4)); a takeoff: yaw;
    a timed loiter: time, force-heading and exit flags, radius) and the altitude reference, and
    format_mavlink_mission_item sends that back: frame GLOBAL_RELATIVE_ALT_INT to
    MISSION_REQUEST_INT, GLOBAL_RELATIVE_ALT to a legacy MISSION_REQUEST."""
    vehicle, session, client = make()
    items = [wp(0, cmd=22, frame=3, params=(15.0, 0.0, 0.0, NAN)),
             wp(1, frame=3, params=(2.0, 3.0, 5.0, -90.0)),
             wp(2, cmd=19, frame=6, params=(10.0, 0.5, 4.0, 30.0)),
             PlanItem(3, 2, 178, 0, 1, 1.0, 10.0, -1.0, 0.0, 0, 0, NAN)]
    assert mission_acks(upload(client, items)) == [(0, 0)]
    back = download(client, 0)
    assert [it.frame for it in back] == [6, 6, 6, 2]
    assert [(it.param1, it.param2, it.param3) for it in back] == [
        (0.0, 0.0, 0.0), (2.0, 3.0, 0.0), (10.0, 1.0, 4.0), (1.0, 10.0, -1.0)]
    assert math.isnan(back[0].param4) and back[1].param4 == pytest.approx(270.0)
    assert back[2].param4 == 1.0 and back[3].param4 == 0.0
    legacy = download(client, 0, use_int=False)
    assert [it.frame for it in legacy] == [3, 3, 3, 2]


def test_mavsdk_upload_is_prompt_and_sets_current():
    vehicle, session, client = make()
    got = client.send(M.MAVLink_mission_count_message(1, 190, 7, 0))
    assert [(m.get_type(), m.seq) for m in got] == [("MISSION_REQUEST_INT", 0)]  # no waiting
    got = upload(client, mavsdk_mission(), 0, target=(1, 190))
    assert mission_acks(got) == [(0, 0)]
    set_plan = [c for c in vehicle.calls if c[0] == "set_plan"]
    assert len(set_plan) == 1 and [i.command for i in set_plan[0][3]] == [
        16, 178, 16, 178, 16, 178, 20]
    # MISSION_CURRENT now reports the mission: total 7 (v1.15 leaves mission_state, _mode 0)
    mc = of_type(client.run_until(1.5), "MISSION_CURRENT")[-1]
    assert (mc.seq, mc.total, mc.mission_state, mc.mission_mode) == (0, 7, 0, 0)


def test_legacy_float_client():
    """A client that answers MISSION_REQUEST_INT with MISSION_ACK UNSUPPORTED gets REQUESTs."""
    vehicle, session, client = make()
    items = rally_items()
    got = client.send(M.MAVLink_mission_count_message(1, 1, len(items), 2))
    assert of_type(got, "MISSION_REQUEST_INT")[0].seq == 0
    got = client.send(M.MAVLink_mission_ack_message(1, 1, 3, 2))  # UNSUPPORTED
    assert [(m.get_type(), m.seq) for m in got] == [("MISSION_REQUEST", 0)]
    for it in items:
        assert got[-1].get_type() in ("MISSION_REQUEST", "MISSION_ACK")
        got = client.send(M.MAVLink_mission_item_message(
            1, 1, it.seq, it.frame, it.command, it.current, it.autocontinue, it.param1,
            it.param2, it.param3, it.param4, it.x * 1e-7, it.y * 1e-7, it.z, 2))
    assert mission_acks(got) == [(0, 2)]
    # float32 degrees resolve ~4e-6° at 47° (why MISSION_ITEM_INT exists): ≤ 0.5 m here
    stored = vehicle.plans[PlanType.RALLY]
    assert len(stored) == 3 and all(same(a, b, xy_tol=50) for a, b in zip(stored, items))
    back = download(client, 2, use_int=False)
    expected = [dataclasses.replace(it, current=int(it.seq == 0)) for it in stored]
    assert all(same(a, b, xy_tol=50) for a, b in zip(back, expected))


def test_count_zero_clears_and_clear_all():
    vehicle, session, client = make()
    upload(client, mavsdk_mission())
    upload(client, fence_items(), 1)
    got = client.send(M.MAVLink_mission_count_message(1, 1, 0, 0))
    assert mission_acks(got) == [(0, 0)] and vehicle.plans[PlanType.MISSION] == ()
    got = client.send(M.MAVLink_mission_clear_all_message(1, 1, 1))
    assert mission_acks(got) == [(0, 1)] and vehicle.plans[PlanType.FENCE] == ()
    upload(client, rally_items(), 2)
    got = client.send(M.MAVLink_mission_clear_all_message(1, 1, 255))
    assert mission_acks(got) == [(0, 255)]
    assert all(p == () for p in vehicle.plans.values())
    for t in (0, 1, 2):  # empty plans download as COUNT 0 (QGC's connect sequence)
        got = client.send(M.MAVLink_mission_request_list_message(1, 190, t))
        assert [(m.get_type(), m.count, m.mission_type) for m in got] == [
            ("MISSION_COUNT", 0, t)]
    # handle_mission_request_list: even an empty list is a transfer (SENDLIST) until the ACK
    assert session.mission.phase is mission.Phase.DOWNLOAD
    client.send(M.MAVLink_mission_ack_message(1, 190, 0, 2))
    assert session.mission.phase is mission.Phase.IDLE


def test_unacked_empty_download_times_out_and_blocks_an_upload_until_then():
    """handle_mission_request_list answers an empty plan with MISSION_COUNT 0 and stays in
    SENDLIST: without the client's MISSION_ACK an upload meanwhile gets "WPM: IGN MISSION_COUNT:
    Busy" and MISSION_ERROR, and the transfer ends after MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT
    with "Operation timeout". A new MISSION_REQUEST_LIST finds it complete and starts over."""
    vehicle, session, client = make()
    client.heartbeat()
    got = client.send(M.MAVLink_mission_request_list_message(1, 1, 0))
    assert [(m.get_type(), m.count) for m in got] == [("MISSION_COUNT", 0)]
    got = client.send(M.MAVLink_mission_count_message(1, 1, 1, 0))
    assert mission_acks(got) == [(1, 0)]
    assert [t.text for t in of_type(client.run_until(0.1), "STATUSTEXT")] == [
        "WPM: IGN MISSION_COUNT: Busy\t"]
    got = client.send(M.MAVLink_mission_request_list_message(1, 1, 0))  # starts over
    assert [(m.get_type(), m.count) for m in got] == [("MISSION_COUNT", 0)]
    got = client.run_until(client.now_s + 4.5)
    assert of_type(got, "STATUSTEXT") == []
    client.heartbeat()
    got = client.run_until(client.now_s + 1.0)
    assert [t.text for t in of_type(got, "STATUSTEXT")] == ["Operation timeout\t"]
    assert session.mission.phase is mission.Phase.IDLE
    upload(client, mavsdk_mission())  # idle again: uploads go through


@pytest.mark.parametrize("mission_type, count, result", [
    (0, mission.CAPACITY[PlanType.MISSION] + 1, 4),
    (1, 65, 4), (2, 33, 4), (1, 64, None), (2, 32, None),
    # another type has no capacity (current_max_item_count 0): NO_SPACE, count 0 ACCEPTED
    (7, 3, 4), (7, 0, 0), (255, 2, 4), (255, 0, 0),
])
def test_counts_and_capacity(mission_type, count, result):
    _, session, client = make()
    got = client.send(M.MAVLink_mission_count_message(1, 1, count, mission_type))
    if result is None:
        assert of_type(got, "MISSION_REQUEST_INT") and not of_type(got, "MISSION_ACK")
    else:
        assert mission_acks(got) == [(result, mission_type)]
        assert session.mission.phase is mission.Phase.IDLE


def test_unknown_type_counts_nothing_downloads_empty_and_clears_nothing():
    """mavlink_mission.cpp: a type other than 0/1/2 (255 only for CLEAR_ALL) has item count 0
    ("mission type %u not handled" on PX4's console): MISSION_COUNT 0 and CLEAR_ALL are
    ACCEPTED and change nothing, REQUEST_LIST answers COUNT 0, each with that type."""
    vehicle, session, client = make()
    upload(client, mavsdk_mission())
    for msg in (M.MAVLink_mission_count_message(1, 1, 0, 9),
                M.MAVLink_mission_count_message(1, 1, 0, 255),
                M.MAVLink_mission_clear_all_message(1, 1, 9)):
        got = client.send(msg)
        assert mission_acks(got) == [(0, msg.mission_type)]
    assert len(vehicle.plans[PlanType.MISSION]) == 7
    got = client.send(M.MAVLink_mission_request_list_message(1, 1, 9))
    assert [(m.get_type(), m.count, m.mission_type) for m in got] == [("MISSION_COUNT", 0, 9)]
    assert session.mission.phase is mission.Phase.DOWNLOAD  # SENDLIST until the client's ACK
    client.send(M.MAVLink_mission_ack_message(1, 1, 0, 9))
    assert session.mission.phase is mission.Phase.IDLE


@pytest.mark.parametrize("target, answered", [
    ((1, 1), True), ((1, 0), True), ((1, 190), True), ((0, 1), False), ((2, 1), False),
    ((1, 100), False),
])
def test_target_rules(target, answered):
    _, session, client = make()
    got = client.send(M.MAVLink_mission_request_list_message(*target, 0))
    assert bool(of_type(got, "MISSION_COUNT")) is answered


def test_out_of_order_duplicate_and_partial_items():
    vehicle, session, client = make()
    items = mavsdk_mission()
    client.send(M.MAVLink_mission_count_message(1, 1, len(items), 0))
    assert client.send(item_int_msg(items[2])) == []  # ahead of time: ignored
    got = client.send(item_int_msg(items[0]))
    assert [(m.get_type(), m.seq) for m in got] == [("MISSION_REQUEST_INT", 1)]
    assert client.send(item_int_msg(items[0])) == []  # duplicate: ignored
    got = client.run_until(0.3)  # the retry re-requests the expected item
    assert [m.seq for m in of_type(got, "MISSION_REQUEST_INT")] == [1]
    for it in items[1:-1]:
        client.send(item_int_msg(it))
    assert not [c for c in vehicle.calls if c[0] == "set_plan"]  # nothing stored half-way
    assert vehicle.plans[PlanType.MISSION] == ()
    got = client.send(item_int_msg(items[-1]))
    assert mission_acks(got) == [(0, 0)]
    # our ACK was lost → the client repeats the last item → same ACK again, nothing re-stored
    got = client.send(item_int_msg(items[-1]))
    assert mission_acks(got) == [(0, 0)]
    assert len([c for c in vehicle.calls if c[0] == "set_plan"]) == 1
    # any other item with no transfer → ERROR
    got = client.send(item_int_msg(items[1]))
    assert mission_acks(got) == [(1, 0)]


def test_vehicle_rejection_is_the_ack():
    vehicle, _, client = make()
    vehicle.plan_result = PlanResult.UNSUPPORTED_FRAME
    got = upload(client, rally_items(), 2)
    assert mission_acks(got) == [(2, 2)] and vehicle.plans[PlanType.RALLY] == ()


def acks_to(msgs):
    """(type, mission_type, target) of each MISSION_ACK."""
    return [(m.type, m.mission_type, (m.target_system, m.target_component))
            for m in of_type(msgs, "MISSION_ACK")]


def test_item_of_wrong_type_and_items_from_anyone():
    """handle_mission_item_both: an item of another mission type is answered ERROR (with the
    transfer's type, to the partner); the item expected is taken from any sender; a COUNT in the
    middle of the upload is "WPM: REJ. CMD: Busy" and ERROR to the partner, not the sender."""
    vehicle, session, client = make()
    items = fence_items()
    client.send(M.MAVLink_mission_count_message(1, 1, len(items), 1))
    got = client.send(item_int_msg(wp(0)))  # mission_type 0 during a fence upload
    assert acks_to(got) == [(1, 1, (245, 190))]
    other = Client(session, sysid=255, compid=190)
    got = other.send(item_int_msg(items[0]))
    assert [(m.get_type(), m.seq, m.target_system) for m in got] == [
        ("MISSION_REQUEST_INT", 1, 245)]
    got = other.send(M.MAVLink_mission_count_message(1, 1, 2, 0))
    assert acks_to(got) == [(1, 1, (245, 190))]
    assert session.mission.phase is mission.Phase.UPLOAD and session.mission.seq == 1
    for it in items[1:]:
        got = client.send(item_int_msg(it))
    assert acks_to(got) == [(0, 1, (245, 190))]
    assert vehicle.plans[PlanType.FENCE] == tuple(items)


def test_acks_go_to_the_transfer_partner():
    """send_mission_ack always targets _transfer_partner_sysid/compid with _mission_type: only
    an upload (COUNT > 0) or a download that starts takes the sender as the partner, so a
    CLEAR_ALL, a COUNT 0 or a NO_SPACE answer goes to the last partner (0/0 before any), and a
    busy refusal to the partner of the transfer under way."""
    vehicle, session, client = make()
    gcs = Client(session, sysid=255, compid=190)
    got = gcs.send(M.MAVLink_mission_clear_all_message(1, 1, 0))
    assert acks_to(got) == [(0, 0, (0, 0))]
    got = gcs.send(M.MAVLink_mission_count_message(1, 1, 0, 1))
    assert acks_to(got) == [(0, 1, (0, 0))]
    upload(client, rally_items(), 2)  # the API client is the partner now
    got = gcs.send(M.MAVLink_mission_count_message(1, 1, 10_000, 0))
    assert acks_to(got) == [(4, 0, (245, 190))]
    got = gcs.send(M.MAVLink_mission_clear_all_message(1, 1, 1))
    assert acks_to(got) == [(0, 1, (245, 190))]
    got = gcs.send(item_int_msg(wp(0, mission_type=1)))  # no transfer
    assert acks_to(got) == [(1, 1, (245, 190))]
    gcs.send(M.MAVLink_mission_request_list_message(1, 1, 2))  # the GCS downloads
    got = client.send(M.MAVLink_mission_count_message(1, 1, 3, 0))
    assert acks_to(got) == [(1, 2, (255, 190))]  # "WPM: IGN MISSION_COUNT: Busy"
    got = client.send(item_int_msg(wp(0, mission_type=2)))
    assert acks_to(got) == [(1, 2, (255, 190))]  # "IGN MISSION_ITEM: Busy"


def test_retry_and_timeout_on_virtual_time():
    vehicle, session, client = make()
    client.heartbeat()
    items = mavsdk_mission()
    client.send(M.MAVLink_mission_count_message(1, 1, len(items), 0))
    client.send(item_int_msg(items[0]))
    t0 = client.now_s
    got = client.run_until(t0 + 4.0)
    client.heartbeat()  # keep the GCS "present" so the text is sent
    got += client.run_until(t0 + 6.0)
    reqs = of_type(got, "MISSION_REQUEST_INT")
    assert all(r.seq == 1 for r in reqs)
    assert len(reqs) == int(mission.TIMEOUT_S / mission.RETRY_S) - 1
    texts = [t.text for t in of_type(got, "STATUSTEXT")]
    assert texts == ["Operation timeout\t"]
    assert session.mission.phase is mission.Phase.IDLE
    assert vehicle.plans[PlanType.MISSION] == () and not [
        c for c in vehicle.calls if c[0] == "set_plan"]
    # a repeated COUNT before any item re-requests seq 0 (our first request got lost)
    client.send(M.MAVLink_mission_count_message(1, 1, len(items), 0))
    got = client.send(M.MAVLink_mission_count_message(1, 1, len(items), 0))
    assert [(m.get_type(), m.seq) for m in got] == [("MISSION_REQUEST_INT", 0)]


def test_download_errors_and_timeout():
    vehicle, session, client = make()
    client.heartbeat()
    upload(client, mavsdk_mission())
    got = client.send(M.MAVLink_mission_request_list_message(1, 1, 0))
    assert of_type(got, "MISSION_COUNT")[0].count == 7
    client.send(M.MAVLink_mission_request_int_message(1, 1, 0, 0))
    got = client.send(M.MAVLink_mission_request_int_message(1, 1, 0, 0))  # repeat is fine
    assert of_type(got, "MISSION_ITEM_INT")[0].seq == 0
    got = client.send(M.MAVLink_mission_request_int_message(1, 1, 5, 0))  # skipping ahead
    assert mission_acks(got) == [(1, 0)] and session.mission.phase is mission.Phase.IDLE
    assert [t.text for t in of_type(client.run_until(0.1), "STATUSTEXT")] == [
        "WPM: REJ. CMD: Req. WP was unexpected\t"]
    client.send(M.MAVLink_mission_request_list_message(1, 1, 0))
    client.run_until(client.now_s + 4.0)  # the client went away
    client.heartbeat()
    got = client.run_until(client.now_s + 1.5)
    assert [t.text for t in of_type(got, "STATUSTEXT")] == ["Operation timeout\t"]
    assert session.mission.phase is mission.Phase.IDLE
    # upload while downloading on the same link → ERROR (PX4 "IGN MISSION_COUNT: Busy")
    client.send(M.MAVLink_mission_request_list_message(1, 1, 0))
    got = client.send(M.MAVLink_mission_count_message(1, 1, 1, 0))
    assert mission_acks(got) == [(1, 0)]


def test_concurrent_upload_on_another_link_is_refused():
    vehicle = FakeVehicle()
    uploads = UploadLock()  # the vehicle's, shared by its links (as the Simulation wires it)
    s1 = Session(vehicle, LinkKind.API, uploads=uploads)
    s2 = Session(vehicle, LinkKind.GCS, uploads=uploads)
    c1, c2 = Client(s1), Client(s2, sysid=255, compid=190)
    items = mavsdk_mission()
    c1.send(M.MAVLink_mission_count_message(1, 1, len(items), 0))
    c1.send(item_int_msg(items[0]))
    # _transfer_in_progress: ERROR to this link's last partner (none yet) with its last type
    got = c2.send(M.MAVLink_mission_count_message(1, 1, 3, 2))
    assert acks_to(got) == [(1, 0, (0, 0))]
    assert download(c2, 0) == []  # downloads on the other link still work (old, empty plan)
    for it in items[1:]:
        got = c1.send(item_int_msg(it))
    assert mission_acks(got) == [(0, 0)]
    got = upload(c2, rally_items(), 2)  # free again
    assert mission_acks(got) == [(0, 2)]


def test_stale_upload_owner_does_not_block_forever():
    vehicle = FakeVehicle()
    uploads = UploadLock()  # the vehicle's, shared by its links (as the Simulation wires it)
    s1 = Session(vehicle, LinkKind.API, uploads=uploads)
    s2 = Session(vehicle, LinkKind.GCS, uploads=uploads)
    c1, c2 = Client(s1), Client(s2, sysid=255, compid=190)
    c1.send(M.MAVLink_mission_count_message(1, 1, 3, 0))
    del s1, c1  # that link is gone without ever timing out its transfer
    c2.now_s = mission.TIMEOUT_S + 0.1
    got = upload(c2, rally_items(), 2)
    assert mission_acks(got) == [(0, 2)]


# --- set current / MISSION_CURRENT / MISSION_ITEM_REACHED -------------------------------------

def test_set_current_is_answered_by_the_stream_only():
    """handle_mission_set_current → update_active_mission: the static _current_seq takes the
    new item at once and nothing is sent; MISSION_CURRENT with it comes with the 1 Hz stream,
    on every link."""
    vehicle = FakeVehicle()
    uploads = UploadLock()
    s1 = Session(vehicle, LinkKind.API, uploads=uploads)
    s2 = Session(vehicle, LinkKind.GCS, uploads=uploads)
    client, other = Client(s1), Client(s2, sysid=255, compid=190)
    client.heartbeat()
    got = client.send(M.MAVLink_mission_set_current_message(1, 1, 0))
    assert of_type(got, "MISSION_CURRENT") == []
    assert [t.text for t in of_type(client.run_until(0.1), "STATUSTEXT")] == [
        "WPM: WP CURR CMD: Not in list\t"]
    upload(client, mavsdk_mission())
    other.run_until(client.now_s)
    got = client.send(M.MAVLink_mission_set_current_message(1, 1, 4))
    assert of_type(got, "MISSION_CURRENT") == [] and vehicle.current_seq == 4
    for c in (client, other):
        t0 = c.now_s
        got = of_type(c.run_until(t0 + 1.05), "MISSION_CURRENT")
        assert [m.seq for m in got] == [4]  # the stream's copy, nothing sooner
        assert c.now_s - t0 > 0.0


def test_mission_current_stream_and_change_sent_once_for_the_vehicle():
    vehicle = FakeVehicle()
    uploads = UploadLock()  # the vehicle's, shared by its links (as the Simulation wires it)
    s1 = Session(vehicle, LinkKind.API, uploads=uploads)
    s2 = Session(vehicle, LinkKind.GCS, uploads=uploads)
    c1, c2 = Client(s1), Client(s2)
    mc = of_type(c1.run_until(0.5), "MISSION_CURRENT")
    assert [(m.seq, m.total, m.mission_state) for m in mc] == [(0, 65535, 0)]
    upload(c1, mavsdk_mission())
    c2.run_until(0.9)
    vehicle.nav_state = NavState.AUTO_MISSION
    vehicle.current_seq = 2  # the navigator moved on
    got = of_type(c1.run_until(0.95), "MISSION_CURRENT")
    assert [(m.seq, m.total, m.mission_state, m.mission_mode) for m in got] == [(2, 7, 0, 0)]
    # the static _current_seq: the first link to see the change sends it, the others have it
    # from their 1 Hz stream
    assert of_type(c2.run_until(0.95), "MISSION_CURRENT") == []
    got = of_type(c2.run_until(2.0), "MISSION_CURRENT")
    assert got and all(m.seq == 2 for m in got)
    mc = of_type(c1.run_until(10.0), "MISSION_CURRENT")
    assert 8 <= len(mc) <= 10  # 1 Hz


def test_item_reached_then_ten_repeats():
    vehicle, session, client = make()
    upload(client, mavsdk_mission())
    client.run_until(0.5)
    vehicle.nav_state = NavState.AUTO_MISSION
    vehicle.reach(0)
    got = client.run_until(0.6)
    assert [m.seq for m in of_type(got, "MISSION_ITEM_REACHED")] == [0]
    assert [m.seq for m in of_type(got, "MISSION_CURRENT")] == [1]
    got = client.run_until(20.0)
    reached = of_type(got, "MISSION_ITEM_REACHED")
    assert [m.seq for m in reached] == [0] * mission.REACHED_REPEATS
    # a new reach restarts the repeats with the new seq (the last item reached: MAVSDK's
    # is_mission_finished, as MISSION_CURRENT's mission_state is 0 in v1.15)
    vehicle.reach(6)
    vehicle.mission_finished = True
    got = client.run_until(22.5)
    assert [m.seq for m in of_type(got, "MISSION_ITEM_REACHED")] == [6, 6, 6]
    assert of_type(got, "MISSION_CURRENT")[-1].mission_state == 0


def test_the_same_item_reached_again_is_sent_only_after_a_reset():
    """send: MISSION_ITEM_REACHED only when seq_reached changes; the navigator's seq_reached = -1
    (activation, new current item) stops the repeats and makes the next reach news again."""
    vehicle, session, client = make()
    upload(client, mavsdk_mission())
    client.run_until(0.5)
    vehicle.nav_state = NavState.AUTO_MISSION
    vehicle.reach(2)
    assert [m.seq for m in of_type(client.run_until(0.6), "MISSION_ITEM_REACHED")] == [2]
    vehicle.reach(2)  # a DO_JUMP back to item 2: no news, only the 1 Hz repeat
    assert of_type(client.run_until(1.2), "MISSION_ITEM_REACHED") == []
    assert [m.seq for m in of_type(client.run_until(1.6), "MISSION_ITEM_REACHED")] == [2]
    vehicle.reached_resets += 1  # e.g. paused and resumed
    assert of_type(client.run_until(5.0), "MISSION_ITEM_REACHED") == []
    vehicle.reach(2)
    assert [m.seq for m in of_type(client.run_until(5.1), "MISSION_ITEM_REACHED")] == [2]


@pytest.mark.parametrize("count", [2, 10_000])
def test_a_mission_count_does_not_stop_the_reached_repeats(count):
    """PX4 1.15.2's handle_mission_count does not reset the last reached item (newer PX4 does):
    the repeats go on through an upload until the navigator puts seq_reached back to -1 for the
    new mission once it is stored."""
    vehicle, session, client = make()
    upload(client, mavsdk_mission())
    client.run_until(0.5)
    vehicle.nav_state = NavState.AUTO_MISSION
    vehicle.reach(0)
    got = client.run_until(2.6)
    assert [m.seq for m in of_type(got, "MISSION_ITEM_REACHED")] == [0, 0, 0]
    client.send(M.MAVLink_mission_count_message(1, 1, count, 0))
    got = client.run_until(4.6)
    assert [m.seq for m in of_type(got, "MISSION_ITEM_REACHED")] == [0, 0]
    if count == 2:
        client.send(item_int_msg(wp(0)))
        assert mission_acks(client.send(item_int_msg(wp(1)))) == [(0, 0)]
        assert of_type(client.run_until(9.0), "MISSION_ITEM_REACHED") == []


# --- lossy network ------------------------------------------------------------------------------

class LossyLink:
    """Client ↔ Session with seeded datagram loss both ways, on virtual time."""

    def __init__(self, session: Session, seed: int, loss: float = 0.2) -> None:
        self.rng = random.Random(seed)
        self.loss = loss
        self.session = session
        self.client = Client(session)
        self.now_s = 0.0
        self.dropped = 0

    def send(self, msg) -> None:
        data = self.client.encode(msg)
        if self.rng.random() < self.loss:
            self.dropped += 1
            return
        self.session.receive_datagram(data, self.now_s)

    def step(self, dt_s: float = 0.01) -> list:
        """Advance time, run due timers, return what survived the downlink."""
        self.now_s += dt_s
        t = self.session.get_timer()
        if t is not None and t <= self.now_s:
            self.session.handle_timer(self.now_s)
        got = []
        for d in self.session.datagrams_to_send(self.now_s):
            if self.rng.random() < self.loss:
                self.dropped += 1
                continue
            got.extend(self.client.rx.parse_buffer(d) or [])
        return got


TIMEOUT_S, RETRIES = 0.5, 5  # MAVSDK mission transfer client


def lossy_upload(link: LossyLink, items, mission_type) -> int | None:
    """MAVSDK-like upload (+ QGC's resend of the last item); result code or None on timeout."""
    link.send(M.MAVLink_mission_count_message(1, 1, len(items), mission_type))
    deadline, retries, last = link.now_s + TIMEOUT_S, 0, None
    while True:
        for m in link.step():
            kind = m.get_type()
            if kind == "MISSION_REQUEST_INT" and m.mission_type == mission_type:
                last = items[m.seq]
                link.send(item_int_msg(last))
                deadline, retries = link.now_s + TIMEOUT_S, 0
            elif kind == "MISSION_ACK" and m.mission_type == mission_type:
                return m.type
        if link.now_s >= deadline:
            retries += 1
            if retries > RETRIES:
                return None
            if last is None:
                link.send(M.MAVLink_mission_count_message(1, 1, len(items), mission_type))
            else:
                link.send(item_int_msg(last))
            deadline = link.now_s + TIMEOUT_S


def lossy_download(link: LossyLink, mission_type) -> list[PlanItem] | None:
    def ask(seq):
        if seq is None:
            link.send(M.MAVLink_mission_request_list_message(1, 1, mission_type))
        else:
            link.send(M.MAVLink_mission_request_int_message(1, 1, seq, mission_type))

    want, count, items = None, None, []
    ask(want)
    deadline, retries = link.now_s + TIMEOUT_S, 0
    while True:
        progressed = False
        for m in link.step():
            if m.get_type() == "MISSION_COUNT" and want is None:
                count, progressed = m.count, True
                want = 0
            elif m.get_type() == "MISSION_ITEM_INT" and m.seq == want:
                items.append(item_from_wire(m, mission_type))
                want, progressed = want + 1, True
        if count is not None and want == count:
            link.send(M.MAVLink_mission_ack_message(1, 1, 0, mission_type))
            return items
        if progressed:
            ask(want)
            deadline, retries = link.now_s + TIMEOUT_S, 0
        elif link.now_s >= deadline:
            retries += 1
            if retries > RETRIES:
                return None
            ask(want)
            deadline = link.now_s + TIMEOUT_S


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_lossy_upload_and_download(seed):
    vehicle = FakeVehicle()
    session = Session(vehicle, LinkKind.API)
    for msg_id in list(session.scheduler._interval_us):  # quiet link: only mission traffic
        session.scheduler.set_interval(msg_id, -1, 0.0)
    link = LossyLink(session, seed)
    old_plan = tuple(wp(n, current=int(n == 0)) for n in range(3))
    vehicle.plans[PlanType.MISSION] = old_plan
    items = [dataclasses.replace(it, seq=n, current=int(n == 0))
             for n, it in enumerate(mavsdk_mission() * 3)]

    def plan_ok():
        plan = vehicle.plans[PlanType.MISSION]
        return plan == old_plan or (
            len(plan) == len(items) and all(same(a, b) for a, b in zip(plan, items)))

    result = None
    for _attempt in range(10):  # the user retries a failed upload, as MAVSDK callers do
        result = lossy_upload(link, items, 0)
        assert plan_ok(), f"seed {seed}: half-written plan"
        if result == 0:
            break
        link.step(mission.TIMEOUT_S + 0.1)  # let the server give a broken transfer up
    assert result == 0, f"seed {seed}: upload never succeeded"
    assert all(len(c[3]) == len(items) for c in vehicle.calls if c[0] == "set_plan")
    assert all(same(a, b) for a, b in zip(vehicle.plans[PlanType.MISSION], items))
    assert link.dropped > 0
    back = None
    for _attempt in range(10):
        back = lossy_download(link, 0)
        if back is not None:
            break
        link.step(mission.TIMEOUT_S + 0.1)
    assert back is not None and len(back) == len(items), f"seed {seed}"
    assert all(same(a, b) for a, b in zip(back, items)), f"seed {seed}"


def test_float_item_in_an_int_frame_is_unsupported_frame():
    """PX4 mavlink_mission.cpp parse_mavlink_mission_item takes MAV_FRAME_GLOBAL_INT and
    GLOBAL_RELATIVE_ALT_INT only in int mode, and a legacy MISSION_ITEM puts it in float mode:
    MAV_MISSION_UNSUPPORTED_FRAME, nothing stored."""
    vehicle, session, client = make()
    client.send(M.MAVLink_mission_count_message(1, 1, 1, 0))
    got = client.send(M.MAVLink_mission_item_message(
        1, 1, 0, 6, 16, 1, 1, 0.0, 0.0, 0.0, NAN, LAT * 1e-7, LON * 1e-7, 10.0, 0))
    assert mission_acks(got) == [(2, 0)]
    assert not [c for c in vehicle.calls if c[0] == "set_plan"]
    assert session.mission.phase is mission.Phase.IDLE
    got = client.send(M.MAVLink_mission_count_message(1, 1, 1, 0))  # the same in GLOBAL_RELATIVE_ALT
    got = client.send(M.MAVLink_mission_item_message(
        1, 1, 0, 3, 16, 1, 1, 0.0, 0.0, 0.0, NAN, LAT * 1e-7, LON * 1e-7, 10.0, 0))
    assert mission_acks(got) == [(0, 0)]


# --- per-item verdicts, fence and rally items (PX4 1.15 handle_mission_item_both) ------------

def texts_of(msgs, client=None):
    """The STATUSTEXTs in ``msgs`` and, given the client, those the 20 Hz stream sends next."""
    more = client.run_until(client.now_s + 0.1) if client is not None else []
    return [t.text for t in of_type(list(msgs) + more, "STATUSTEXT")]


def test_a_refused_item_ends_the_upload_at_that_item():
    """parse_mavlink_mission_item's refusal is ACKed at the item, after "IGN MISSION_ITEM:
    Invalid item", and the transfer is over: no further request, the old plan stays."""
    vehicle, session, client = make()
    client.heartbeat()
    upload(client, mavsdk_mission())
    items = mavsdk_mission()
    items[1] = PlanItem(1, 2, 12345, 0, 1, 0, 0, 0, 0, 0, 0, 0.0)  # unknown command
    client.send(M.MAVLink_mission_count_message(1, 1, len(items), 0))
    client.send(item_int_msg(items[0]))
    got = client.send(item_int_msg(items[1]))
    assert mission_acks(got) == [(3, 0)]  # MAV_MISSION_UNSUPPORTED
    assert texts_of(got, client) == ["IGN MISSION_ITEM: Invalid item\t"]
    assert not of_type(got, "MISSION_REQUEST_INT")
    assert session.mission.phase is mission.Phase.IDLE
    assert all(same(a, b) for a, b in zip(vehicle.plans[PlanType.MISSION], mavsdk_mission(),
                                          strict=True))


def test_fence_vertex_count_below_three_is_error_at_the_item_without_text():
    """The fence's own check ("Fence: too few vertices", console only): MAV_MISSION_ERROR at
    that vertex, no STATUSTEXT. Only each vertex's own (uint16_t)(param1 + 0.5f) counts."""
    vehicle, session, client = make()
    client.heartbeat()
    items = fence_items()
    items[2] = dataclasses.replace(items[2], param1=2.4)
    client.send(M.MAVLink_mission_count_message(1, 1, len(items), 1))
    client.send(item_int_msg(items[0]))
    client.send(item_int_msg(items[1]))
    got = client.send(item_int_msg(items[2]))
    assert mission_acks(got) == [(1, 1)] and texts_of(got, client) == []
    assert not of_type(got, "MISSION_REQUEST_INT") and vehicle.plans[PlanType.FENCE] == ()
    # A 4-vertex polygon cut to 2 items, a NaN circle and a waypoint are all stored.
    odd = fence_items()[:2] + [
        PlanItem(2, 0, 5003, 0, 1, NAN, 0, 0, 0, LAT, LON, 0.0, 1),
        PlanItem(3, 6, 16, 0, 1, 1.5, 3.0, 0, 45.0, LAT, LON, 10.0, 1)]
    got = upload(client, odd, 1)
    assert mission_acks(got) == [(0, 1)]
    assert all(same(a, b) for a, b in zip(vehicle.plans[PlanType.FENCE], odd, strict=True))


def test_after_a_refused_item_the_item_before_it_is_acked_accepted():
    """Outside a transfer PX4 answers an item with seq == _transfer_seq - 1 ACCEPTED ("assume
    this is a duplicate"), also when the transfer stopped at a refused item; another seq is
    "IGN MISSION_ITEM: No transfer" and ERROR."""
    vehicle, session, client = make()
    client.heartbeat()
    items = rally_items()
    bad = PlanItem(1, 2, 5100, 0, 1, 0, 0, 0, 0, 0, 0, 0.0, 2)  # rally point in frame 2
    client.send(M.MAVLink_mission_count_message(1, 1, len(items), 2))
    client.send(item_int_msg(items[0]))
    got = client.send(item_int_msg(bad))
    assert mission_acks(got) == [(3, 2)]
    assert texts_of(got, client) == ["IGN MISSION_ITEM: Invalid item\t"]
    got = client.send(item_int_msg(items[0]))
    assert mission_acks(got) == [(0, 2)] and texts_of(got, client) == []
    got = client.send(item_int_msg(bad))
    assert mission_acks(got) == [(1, 2)]
    assert texts_of(got, client) == ["IGN MISSION_ITEM: No transfer\t"]
    assert vehicle.plans[PlanType.RALLY] == ()


def test_fence_download_gives_back_what_a_fence_point_keeps():
    """send_mission_item reads a mission_fence_point_s back: autocontinue 0, a global frame
    always absolute, only param1 where the command has one (a waypoint's hold time shares its
    place with the circle radius), a MAV_FRAME_MISSION item's param1 and z but no x/y; and the
    mission's current seq is flagged current in a fence or rally download too."""
    vehicle, session, client = make()
    items = [PlanItem(0, 6, 16, 0, 1, 1.5, 3.0, 0.5, 45.0, LAT, LON, 10.0, 1),
             PlanItem(1, 3, 5003, 1, 1, 25.0, 7.0, 0, 0, LAT, LON, 3.0, 1),
             PlanItem(2, 2, 178, 0, 1, 1.0, 10.0, -1.0, 0.0, 11, 12, 7.0, 1),
             PlanItem(3, 2, 177, 0, 1, 1.0, 2.0, 0.0, 0.0, 0, 0, 0.0, 1)]
    assert mission_acks(upload(client, items, 1)) == [(0, 1)]
    back = download(client, 1)
    assert back == [
        PlanItem(0, 5, 16, 1, 0, 1.5, 0.0, 0.0, 0.0, LAT, LON, 10.0, 1),
        PlanItem(1, 5, 5003, 0, 0, 25.0, 0.0, 0.0, 0.0, LAT, LON, 3.0, 1),
        PlanItem(2, 2, 178, 0, 0, 1.0, 0.0, 0.0, 0.0, 0, 0, 7.0, 1),
        PlanItem(3, 2, 177, 0, 0, 0.0, 0.0, 0.0, 0.0, 0, 0, 0.0, 1)]
    assert mission_acks(upload(client, rally_items(), 2)) == [(0, 2)]
    assert [it.current for it in download(client, 2)] == [1, 0, 0]
