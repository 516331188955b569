"""Parameter protocol: complete paced list, bytewise INT32, read, set echo + broadcast, errors."""

import math
import struct

import pytest
from pymavlink.dialects.v20 import common as M
from test_mavlink_support import Client, FakeVehicle, make, of_type

from gateway.mavlink.session import LinkKind, Session


def raw_value(msg) -> bytes:
    """PARAM_VALUE.param_value's four wire bytes (exact even for NaN bit patterns)."""
    buf = bytes(msg.get_msgbuf())
    return buf[10:10 + buf[1]].ljust(25, b"\0")[:4]


def test_param_list_complete_and_paced():
    vehicle, session, client = make()
    store = vehicle.params
    got = client.send(M.MAVLink_param_request_list_message(1, 1))
    hash_msg = of_type(got, "PARAM_VALUE")
    assert [(m.param_id, m.param_index, m.param_type, m.param_count) for m in hash_msg] == [
        ("_HASH_CHECK", 65535, 5, store.count)]
    assert struct.unpack("<I", raw_value(hash_msg[0]))[0] == store.hash32()
    values = of_type(client.run_until(1.0), "PARAM_VALUE")
    assert [m.param_index for m in values] == list(range(store.count))
    assert {m.param_count for m in values} == {store.count}
    assert [m.param_id for m in values] == [info.name for info, _ in store.items()]
    for m, (info, value) in zip(values, store.items()):
        assert m.param_type == int(info.type)
        if m.param_type == 6:
            assert struct.unpack("<i", raw_value(m))[0] == value  # bytewise
        else:
            assert struct.unpack("<f", raw_value(m))[0] == value
    assert client.now_s == 1.0
    assert all(len(d) <= 1400 for d in client.datagrams)


def test_param_list_leaves_room_for_telemetry():
    vehicle, session, client = make(LinkKind.GCS)
    client.run_until(0.5)
    client.send(M.MAVLink_param_request_list_message(1, 1))
    got = client.run_until(1.0)
    assert len(of_type(got, "PARAM_VALUE")) == vehicle.params.count
    assert abs(len(of_type(got, "ATTITUDE")) - 25) <= 1  # 50 Hz kept up during the list


def test_second_list_restarts_without_hash():
    vehicle, session, client = make()
    client.send(M.MAVLink_param_request_list_message(1, 1))
    client.run_until(0.05)
    got = client.send(M.MAVLink_param_request_list_message(1, 0))  # component 0: all
    assert of_type(got, "PARAM_VALUE") == []
    values = of_type(client.run_until(2.0), "PARAM_VALUE")
    assert [m.param_index for m in values] == list(range(vehicle.params.count))


def test_param_read_by_name_index_and_hash():
    vehicle, session, client = make()
    store = vehicle.params
    got = client.send(M.MAVLink_param_request_read_message(1, 1, b"MIS_TAKEOFF_ALT", -1))
    (m,) = got
    assert (m.param_id, m.param_type, m.param_index) == ("MIS_TAKEOFF_ALT", 9,
                                                         store.index_of("MIS_TAKEOFF_ALT"))
    assert abs(m.param_value - 2.5) < 1e-6
    (m,) = client.send(M.MAVLink_param_request_read_message(1, 1, b"", 3))
    assert m.param_index == 3 and m.param_id == store.info(3).name
    (m,) = client.send(M.MAVLink_param_request_read_message(1, 1, b"_HASH_CHECK", -1))
    assert m.param_index == 65535 and m.param_type == 5
    (m,) = client.send(M.MAVLink_param_request_read_message(1, 1, b"MAV_SYS_ID", -1))
    assert (m.param_type, struct.unpack("<i", raw_value(m))[0]) == (6, 1)


@pytest.mark.parametrize("name, index", [(b"NO_SUCH_PARAM", -1), (b"", 30000),
                                         (b"MIS_TAKEOFF_ALT", 30000), (b"", 2000)])
def test_param_read_unknown_is_not_answered(name, index):
    """v1.15.2 mavlink_parameters.cpp: send_param(PARAM_INVALID) sends nothing (an index >= 0
    is looked up by index alone, whatever the name). PARAM_ERROR is PX4 1.17's."""
    _, _, client = make()
    assert client.send(M.MAVLink_param_request_read_message(1, 1, name, index)) == []


def _int_as_float(value: int) -> float:
    return struct.unpack("<f", struct.pack("<i", value))[0]


def test_param_set_echo_and_broadcast_to_other_links():
    vehicle = FakeVehicle()
    api = Session(vehicle, LinkKind.API)
    gcs = Session(vehicle, LinkKind.GCS)
    c_api, c_gcs = Client(api), Client(gcs, 255, 190)
    got = c_api.send(M.MAVLink_param_set_message(1, 1, b"MIS_TAKEOFF_ALT", 10.0, 9))
    # the echo (send_param), then the change every link sends (send_untransmitted)
    assert [(m.param_id, m.param_value, m.param_type) for m in got] == [
        ("MIS_TAKEOFF_ALT", 10.0, 9)] * 2
    assert vehicle.params["MIS_TAKEOFF_ALT"] == 10.0
    (b,) = c_gcs.drain()
    assert (b.param_id, b.param_value, b.param_count) == ("MIS_TAKEOFF_ALT", 10.0,
                                                          vehicle.params.count)
    # INT32 set bytewise; the echo carries the same bytes
    got = c_gcs.send(M.MAVLink_param_set_message(1, 1, b"NAV_DLL_ACT", _int_as_float(2), 6))
    assert [struct.unpack("<i", raw_value(m))[0] for m in got] == [2, 2]
    assert vehicle.params["NAV_DLL_ACT"] == 2
    assert [m.param_id for m in c_api.drain()] == ["NAV_DLL_ACT"]
    # a change made by the autopilot itself reaches every link
    vehicle.params.set("RTL_RETURN_ALT", 40.0)
    assert [m.param_id for m in c_api.drain()] == ["RTL_RETURN_ALT"]
    assert [m.param_id for m in c_gcs.drain()] == ["RTL_RETURN_ALT"]
    # setting the same value again still echoes (MAVSDK waits for it), no broadcast
    assert len(c_api.send(M.MAVLink_param_set_message(1, 1, b"RTL_RETURN_ALT", 40.0, 9))) == 1
    assert c_gcs.drain() == []


def test_param_set_negative_int_bytewise_is_exact():
    vehicle, session, client = make()
    name = "CAL_ACC0_ID"
    assert vehicle.params.info(name).type == 6
    for value in (-1, -8388607, 2139095041):  # NaN bit patterns, incl. signalling NaN
        raw = struct.pack("<i", value)
        # put the int's bytes in the float field (first on the wire) and frame it
        msg = M.MAVLink_param_set_message(1, 1, name.encode(), 0.0, 6)
        payload = raw + msg.unpacker.pack(0.0, 1, 1, name.encode(), 6)[4:]
        mav = M.MAVLink(None, 245, 190)
        frame = msg._pack(mav, msg.crc_extra, payload)
        session.receive_datagram(frame, 0.0)
        echo = client.drain()[0]
        assert vehicle.params[name] == value
        assert raw_value(echo) == raw


@pytest.mark.parametrize("name, ptype", [(b"NO_SUCH_PARAM", 9), (b"MIS_TAKEOFF_ALT", 6),
                                         (b"MIS_TAKEOFF_ALT", 4), (b"NAV_DLL_ACT", 9),
                                         (b"_HASH_CHECK", 5)])
def test_param_set_refusals_are_not_answered(name, ptype):
    """v1.15.2 mavlink_parameters.cpp: an unknown name ("unknown param") or a type other than
    the parameter's INT32 / REAL32 ("param types mismatch") only print on the console; a set of
    _HASH_CHECK is not answered either. Nothing changes."""
    vehicle, _, client = make()
    before = dict((info.name, value) for info, value in vehicle.params.items())
    assert client.send(M.MAVLink_param_set_message(1, 1, name, 1.0, ptype)) == []
    assert client.send(M.MAVLink_param_set_message(9, 1, b"MIS_TAKEOFF_ALT", 1.0, 9)) == []
    assert dict((info.name, value) for info, value in vehicle.params.items()) == before


def test_param_list_paces_twenty_per_ten_ms_the_hash_counting():
    """MavlinkReceiver::run calls MavlinkParametersManager::send() once 10 ms have passed; over
    UDP it sends up to 20 (max_num_to_send) a call, the _HASH_CHECK being the first."""
    vehicle, _, client = make()
    got = client.send(M.MAVLink_param_request_list_message(1, 1))
    got += client.run_until(0.005)
    values = of_type(got, "PARAM_VALUE")
    assert len(values) == 20 and values[0].param_id == "_HASH_CHECK"
    assert len(of_type(client.run_until(0.015), "PARAM_VALUE")) == 20
    assert len(of_type(client.run_until(0.025), "PARAM_VALUE")) == 20


@pytest.mark.parametrize("hash_check_enabled, stops", [(1, True), (0, False)])
def test_hash_check_set_stops_the_list_only_with_mav_hash_chk_en(hash_check_enabled, stops):
    """PARAM_SET _HASH_CHECK (QGC's cache matches): _send_all_index = -1 only when
    _mavlink->hash_check_enabled() (MAV_HASH_CHK_EN); not answered."""
    vehicle, _, client = make()
    vehicle.params.set("MAV_HASH_CHK_EN", hash_check_enabled)
    client.send(M.MAVLink_param_request_list_message(1, 1))
    client.run_until(0.005)
    assert client.send(M.MAVLink_param_set_message(1, 1, b"_HASH_CHECK", 0.0, 5)) == []
    rest = of_type(client.run_until(2.0), "PARAM_VALUE")
    assert (rest == []) is stops
    if not stops:
        assert rest[-1].param_index == vehicle.params.count - 1


def test_preflight_storage_resets_as_px4s_commander_worker():
    """MAV_CMD_PREFLIGHT_STORAGE: 2 (QGC's "Reset all to firmware's defaults") puts every
    parameter back to its default but the flight-time counters; the instance's MAV_SYS_ID and
    other launch values are defaults (``set-default``) and stay; each change is broadcast. 3
    resets only the sensor calibrations; armed: TEMPORARILY_REJECTED; 0/1 (load, save):
    ACCEPTED; another action: no answer."""
    from gateway.testing import Sim

    storage = M.MAV_CMD_PREFLIGHT_STORAGE
    with Sim(2, params={"MPC_XY_CRUISE": 7.0}) as sim:
        sim.advance(1.0)
        api = sim.api(1)
        params = sim.vehicles[1].params
        for name, value in (("MIS_TAKEOFF_ALT", 4.0), ("LND_FLIGHT_T_HI", 3),
                            ("CAL_ACC0_XOFF", 0.5), ("NAV_DLL_ACT", 2)):
            assert params.set(name, value)
        assert api.command_long(storage, 3) == 0
        assert params["CAL_ACC0_XOFF"] == 0.0 and params["MIS_TAKEOFF_ALT"] == 4.0
        since = len(api.frames)
        assert api.command_long(storage, 2) == 0
        sim.advance(0.1)
        assert params["MIS_TAKEOFF_ALT"] == 2.5 and params["NAV_DLL_ACT"] == 0
        assert params["LND_FLIGHT_T_HI"] == 3  # PX4's exclude list
        assert params["MAV_SYS_ID"] == 2 and params["MPC_XY_CRUISE"] == 7.0  # launch values
        sent = {m.param_id for m in api.messages("PARAM_VALUE", since)}
        assert {"MIS_TAKEOFF_ALT", "NAV_DLL_ACT"} <= sent and "MAV_SYS_ID" not in sent
        assert api.command_long(storage, 1) == 0 and api.command_long(storage, 0) == 0
        assert api.command_long(storage, 7, retries=0) is None  # PX4 answers nothing
        assert api.arm() == 0
        assert api.command_long(storage, 2) == 1


def qgc_cache_crc(values: dict[str, tuple[int, float]], volatile: set[str]) -> int:
    """QGC's ParameterManager::_tryCacheHashLoad: QGC::crc32 (table CRC-32, no inversion)
    over each cached parameter's name and four value bytes, in the cache map's (name) order,
    the parameters its metadata marks volatile left out."""
    table = []
    for n in range(256):
        c = n
        for _ in range(8):
            c = (c >> 1) ^ 0xEDB88320 if c & 1 else c >> 1
        table.append(c)
    crc = 0
    for name in sorted(values):
        if name in volatile:
            continue
        ptype, value = values[name]
        for byte in name.encode() + struct.pack("<i" if ptype == 6 else "<f", value):
            crc = table[(crc ^ byte) & 0xFF] ^ (crc >> 8)
    return crc


def test_qgc_cache_matches_the_hash_across_flights_and_bookkeeping_is_not_broadcast():
    """QGC keeps the parameters of the last connection and asks for none when _HASH_CHECK
    equals the CRC it computes over them: ours is PX4's param_hash_check, which leaves out
    the volatile parameters (metadata "volatile": true), so a flight — which counts
    COM_FLIGHT_UUID and LND_FLIGHT_T_HI/_LO up without notification (no PARAM_VALUE) — does
    not cost the next connection a download. A parameter a user sets changes the hash."""
    import json
    import lzma

    from gateway.onboard.metadata import shared
    from gateway.testing import Sim

    doc = json.loads(lzma.decompress(shared().files["parameters.json.xz"]))
    volatile = {p["name"] for p in doc["parameters"] if p.get("volatile")}
    assert {"COM_FLIGHT_UUID", "LND_FLIGHT_T_HI", "LND_FLIGHT_T_LO"} <= volatile
    with Sim() as sim:
        assert sim.run_until(lambda: sim.status(0).position_valid, timeout_s=10)
        api = sim.api(0)
        since = len(api.frames)
        api.send(M.MAVLink_param_request_list_message(1, 1))
        sim.advance(2.0)
        listed = api.messages("PARAM_VALUE", since)
        hash_before = struct.unpack("<I", raw_value(listed[0]))[0]
        cache = {m.param_id: (m.param_type, struct.unpack("<i" if m.param_type == 6 else "<f",
                                                          raw_value(m))[0])
                 for m in listed[1:]}
        assert qgc_cache_crc(cache, volatile) == hash_before
        since = len(api.frames)
        assert api.arm() == 0 and api.takeoff() == 0
        assert sim.run_until(lambda: sim.status(0).nav_state.name == "AUTO_LOITER", timeout_s=30)
        assert api.land() == 0
        assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=60)
        params = sim.vehicles[0].params
        assert params["COM_FLIGHT_UUID"] == 1 and params["LND_FLIGHT_T_LO"] > 0
        broadcast = {m.param_id for m in api.messages("PARAM_VALUE", since)}
        assert not broadcast & volatile
        api.send(M.MAVLink_param_request_read_message(1, 1, b"_HASH_CHECK", -1))
        sim.advance(0.1)
        assert struct.unpack("<I", raw_value(api.messages("PARAM_VALUE")[-1]))[0] == hash_before
        params.set("MPC_XY_CRUISE", 7.0)
        assert params.hash32() != hash_before


def test_param_messages_to_system_0_are_not_for_the_autopilot():
    """mavlink_parameters.cpp takes PARAM_SET, PARAM_REQUEST_READ and PARAM_REQUEST_LIST only
    when target_system is its own (component its own or 0): a PARAM_SET to system 0 must not
    change the parameter of every vehicle on the network."""
    vehicle, session, client = make()
    before = vehicle.params["MPC_XY_VEL_MAX"]
    got = client.send(M.MAVLink_param_set_message(0, 1, b"MPC_XY_VEL_MAX", 3.0,
                                                  M.MAV_PARAM_TYPE_REAL32))
    got += client.send(M.MAVLink_param_request_read_message(0, 1, b"MPC_XY_VEL_MAX", -1))
    got += client.send(M.MAVLink_param_request_list_message(0, 0))
    got += client.run_until(1.0)
    assert vehicle.params["MPC_XY_VEL_MAX"] == before
    assert of_type(got, "PARAM_VALUE") == [] and of_type(got, "PARAM_ERROR") == []


def test_param_set_non_finite_real32_is_stored_and_echoed_as_px4():
    """parameters.cpp param_set_internal stores the float as given; the change test is
    fabsf(old - new) > FLT_EPSILON, false to or from NaN (and inf -> inf): no parameter_update,
    so only the PARAM_SET's own echo (mavlink_parameters.cpp send_param) carries it."""
    vehicle = FakeVehicle()
    store = vehicle.params
    api, gcs = Session(vehicle, LinkKind.API), Session(vehicle, LinkKind.GCS)
    c_api, c_gcs = Client(api), Client(gcs, 255, 190)
    nan, inf = float("nan"), float("inf")

    def set_alt(value: float) -> float:
        version = store.version
        echo, *again = c_api.send(M.MAVLink_param_set_message(1, 1, b"RTL_RETURN_ALT", value, 9))
        assert echo.param_id == "RTL_RETURN_ALT"
        # a change is sent again after the echo, as on every link; no change: the echo alone
        assert len(again) == (store.version != version)
        return echo.param_value

    version = store.version
    assert math.isnan(set_alt(nan)) and math.isnan(store["RTL_RETURN_ALT"])
    assert c_gcs.drain() == [] and store.version == version  # no change: no parameter_update
    assert set_alt(inf) == inf and c_gcs.drain() == []  # NaN -> inf: still no change
    assert set_alt(-inf) == -inf  # inf -> -inf: a change, broadcast
    assert [(m.param_id, m.param_value) for m in c_gcs.drain()] == [("RTL_RETURN_ALT", -inf)]
    assert store.version == version + 1
    assert set_alt(-inf) == -inf and c_gcs.drain() == []  # -inf -> -inf: inf - inf is NaN
    assert set_alt(30.0) == 30.0 and len(c_gcs.drain()) == 1  # -inf -> 30: a change
    assert set_alt(nan) != set_alt(30.0)  # NaN -> 30: stored, no change
    assert store["RTL_RETURN_ALT"] == 30.0 and c_gcs.drain() == []
    # a step within FLT_EPSILON (absolute: one float32 step at 0.5) is stored, no change either
    assert set_alt(0.5) == 0.5 and len(c_gcs.drain()) == 1
    next_up = struct.unpack("<f", struct.pack("<i", struct.unpack("<i", struct.pack("<f", 0.5))[0]
                                              + 1))[0]
    assert set_alt(next_up) == next_up and c_gcs.drain() == []
    # param_reset notifies whatever the comparison says
    set_alt(nan)
    store.reset(lambda name: name == "RTL_RETURN_ALT")
    assert [m.param_id for m in c_gcs.drain()] == ["RTL_RETURN_ALT"]
    assert store["RTL_RETURN_ALT"] == store.default_of("RTL_RETURN_ALT")
    # an INT32 has no NaN: its four bytes are an int (see the bytewise test above)
