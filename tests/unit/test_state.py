"""What a vehicle keeps across restarts (gateway/daemon/state.py): parameters and plans that
clients changed, written off the event loop, never lost to a bad file, the same at any speed."""

from __future__ import annotations

import json
import math
import struct
from dataclasses import astuple, replace

import pytest

from gateway.daemon import state
from gateway.daemon.app import SPEED_SCALED_PARAMS, Daemon, RunConfig
from gateway.testing import mission_item
from vehicles.params import ParamStore
from vehicles.plan_types import PlanResult, PlanType

HOME = (47.397742, 8.545594)


def boot(tmp_path, speed: float = 1.0, params: dict | None = None, ignore: bool = False,
         vehicles: int = 1) -> Daemon:
    return Daemon(RunConfig(vehicles=vehicles, speed=speed, state_dir=tmp_path,
                            params=dict(params or {}), ignore_bad_state=ignore))


def square() -> list:
    items = [mission_item(22, *HOME, 10)]
    for dn, de in [(20, 0), (20, 20), (0, 20)]:
        items.append(mission_item(16, HOME[0] + dn * 1e-5, HOME[1] + de * 1e-5, 10))
    return [replace(item, seq=k) for k, item in enumerate(items)]


def same_items(a, b) -> bool:
    """Equal item by item (NaN fields included, which == would not call equal)."""
    return [repr(astuple(i)) for i in a] == [repr(astuple(i)) for i in b]


def written(d: Daemon) -> None:
    d.close()  # the writer flushes at close


def test_client_changes_and_plans_survive_a_restart(tmp_path):
    d = boot(tmp_path)
    v = d.sim.vehicles[0]
    v.params.set("MIS_TAKEOFF_ALT", 6.0)
    v.params.set("NAV_DLL_ACT", 2)
    v.params.set("MPC_XY_CRUISE", 6.0)
    v.params.set("MPC_XY_CRUISE", 5.0)  # back to the default, but a client chose it: kept
    assert v.set_plan(0.0, PlanType.MISSION, square()) is PlanResult.ACCEPTED
    written(d)
    doc = json.loads(state.params_path(tmp_path, 1).read_text())
    assert doc["params"] == {"MIS_TAKEOFF_ALT": 6.0, "MPC_XY_CRUISE": 5.0, "NAV_DLL_ACT": 2}
    d2 = boot(tmp_path)
    v2 = d2.sim.vehicles[0]
    assert v2.params["MIS_TAKEOFF_ALT"] == 6.0 and v2.params["NAV_DLL_ACT"] == 2
    assert len(v2.plan(PlanType.MISSION)) == 4
    assert same_items(v2.plan(PlanType.MISSION), v.plan(PlanType.MISSION))
    written(d2)


def test_flight_bookkeeping_committed_without_notification_is_saved(tmp_path):
    """PX4 saves COM_FLIGHT_UUID and the flight time (commit_no_notification still autosaves):
    the next boot counts on from them."""
    d = boot(tmp_path)
    params = d.sim.vehicles[0].params
    params.set("COM_FLIGHT_UUID", 4, notify=False)
    params.set("LND_FLIGHT_T_LO", 123_000_000, notify=False)
    written(d)
    d2 = boot(tmp_path)
    assert d2.sim.vehicles[0].params["COM_FLIGHT_UUID"] == 4
    assert d2.sim.vehicles[0].params["LND_FLIGHT_T_LO"] == 123_000_000
    written(d2)


def test_boot_values_are_not_saved(tmp_path):
    """--param and the speed-scaled time-outs are set at every boot, never written."""
    d = boot(tmp_path, speed=10, params={"MPC_XY_CRUISE": 7.0})
    v = d.sim.vehicles[0]
    assert v.params["MPC_XY_CRUISE"] == 7.0
    assert v.params["COM_DL_LOSS_T"] == 10 * ParamStore()["COM_DL_LOSS_T"]
    v.params.set("MIS_TAKEOFF_ALT", 4.0)
    written(d)
    doc = json.loads(state.params_path(tmp_path, 1).read_text())
    assert doc["params"] == {"MIS_TAKEOFF_ALT": 4.0}


@pytest.mark.parametrize("speed", [0.5, 1.0, 1.25, 10.0])
@pytest.mark.parametrize("dir_state", ["new", "reused", "truncated", "garbage"])
def test_restart_matrix(tmp_path, speed, dir_state):
    """Any positive speed × a new, reused, truncated or garbage state directory: starts with
    exactly the saved parameters and mission, or refuses with one line naming the file."""
    defaults = ParamStore()
    if dir_state != "new":
        first = boot(tmp_path, speed=1.0)
        first.sim.vehicles[0].params.set("MIS_TAKEOFF_ALT", 7.5)
        first.sim.vehicles[0].params.set("COM_DL_LOSS_T", 20)
        first.sim.vehicles[0].set_plan(0.0, PlanType.MISSION, square())
        written(first)
    path = state.params_path(tmp_path, 1)
    if dir_state == "truncated":
        text = path.read_text()
        path.write_text(text[: len(text) // 2])
    elif dir_state == "garbage":
        path.write_bytes(b"\x00\xff garbage \x89PNG")
    before = path.read_bytes() if path.exists() else None
    if dir_state in ("truncated", "garbage"):
        with pytest.raises(state.StateError, match=str(path)):
            boot(tmp_path, speed=speed)
        assert path.read_bytes() == before  # never overwritten
        return
    d = boot(tmp_path, speed=speed)
    v = d.sim.vehicles[0]
    if dir_state == "reused":
        assert v.params["MIS_TAKEOFF_ALT"] == 7.5
        assert v.params["COM_DL_LOSS_T"] == 20  # the client's value, not scaled again
        assert same_items(v.plan(PlanType.MISSION), square())
    else:
        assert v.params["MIS_TAKEOFF_ALT"] == defaults["MIS_TAKEOFF_ALT"]
        expected = max(1, round(defaults["COM_DL_LOSS_T"] * speed))
        assert v.params["COM_DL_LOSS_T"] == (expected if speed != 1.0 else defaults["COM_DL_LOSS_T"])
        assert v.plan(PlanType.MISSION) == ()
    for name in SPEED_SCALED_PARAMS:
        assert math.isfinite(v.params[name])
    written(d)
    again = boot(tmp_path, speed=speed)  # the same directory, the same speed: the same values
    assert dict(again.sim.vehicles[0].params.changed_from_default()) == \
        dict(v.params.changed_from_default())
    written(again)


def test_unreadable_file_with_the_flag_starts_with_defaults_and_keeps_the_file(tmp_path):
    path = state.params_path(tmp_path, 1)
    path.parent.mkdir(parents=True)
    path.write_text("{not json")
    d = boot(tmp_path, ignore=True)
    assert d.sim.vehicles[0].params["MIS_TAKEOFF_ALT"] == ParamStore()["MIS_TAKEOFF_ALT"]
    assert path.with_name("params.json.unreadable").read_text() == "{not json"
    written(d)


def test_bad_values_and_unknown_names_in_a_readable_file(tmp_path):
    path = state.params_path(tmp_path, 1)
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps({"version": 1, "params": {
        "NO_SUCH_PARAM": 1, "MAV_SYS_ID": 9, "NAV_DLL_ACT": 1.5, "MIS_TAKEOFF_ALT": 4.0}}))
    d = boot(tmp_path)
    p = d.sim.vehicles[0].params
    assert p["MAV_SYS_ID"] == 1  # the instance decides, as PX4's rcS
    assert p["NAV_DLL_ACT"] == 0  # not an INT32: default kept
    assert p["MIS_TAKEOFF_ALT"] == 4.0
    written(d)


def test_a_flood_of_changes_is_coalesced_off_the_loop(tmp_path):
    writer = state.StateWriter(delay_s=0.05)
    kept = state.VehicleState(writer, tmp_path, 3, state.Saved())
    for k in range(2000):
        kept.on_param("MPC_XY_CRUISE", float(k % 10))
    writer.close()
    assert writer.writes < 20 and writer.coalesced > 1900
    doc = json.loads(state.params_path(tmp_path, 3).read_text())
    assert doc["params"] == {"MPC_XY_CRUISE": 9.0}


def test_files_are_replaced_atomically_with_the_last_good_copy(tmp_path):
    d = boot(tmp_path)
    v = d.sim.vehicles[0]
    v.params.set("MIS_TAKEOFF_ALT", 3.0)
    assert d._state_writer is not None and d._state_writer.flush()
    v.params.set("MIS_TAKEOFF_ALT", 4.0)
    written(d)
    folder = state.params_path(tmp_path, 1).parent
    assert sorted(p.name for p in folder.iterdir()) == ["params.json", "params.json.prev"]
    prev = json.loads((folder / "params.json.prev").read_text())
    assert prev["params"] == {"MIS_TAKEOFF_ALT": 3.0}


# --- signing: the key's replay state is kept like parameters ------------------------------------
def signed_boot(tmp_path, key, ignore: bool = False) -> Daemon:
    return Daemon(RunConfig(vehicles=2, state_dir=tmp_path, signing_key=key,
                            ignore_bad_state=ignore))


def test_signing_replay_state_is_kept_across_a_restart(tmp_path):
    from gateway.mavlink.signing import SigningKey

    key = SigningKey(bytes(range(32)))
    d = signed_boot(tmp_path, key)
    shared = d.sim.links[(0, next(iter(d.sim.link_kinds)))].session.signing.state
    assert all(link.session.signing.state is shared for link in d.sim.links.values())
    shared.streams[(245, 190, 0)] = 123_456_789
    shared.newest = 987_654_321
    shared.changed = True
    written(d)
    doc = json.loads((tmp_path / "signing-1.json").read_text())
    assert doc["key"] == key.fingerprint and doc["streams"] == [[245, 190, 0, 123_456_789]]
    again = signed_boot(tmp_path, key)
    kept = again.sim.links[(1, next(iter(again.sim.link_kinds)))].session.signing.state
    assert kept.streams == {(245, 190, 0): 123_456_789} and kept.newest == 987_654_321
    again.close()
    other = signed_boot(tmp_path, SigningKey(bytes(range(1, 33))))  # another key starts afresh
    fresh = other.sim.links[(0, next(iter(other.sim.link_kinds)))].session.signing.state
    assert fresh.streams == {}
    other.close()


def test_an_unreadable_signing_state_stops_the_start(tmp_path):
    from gateway.mavlink.signing import SigningKey

    key = SigningKey(bytes(range(32)))
    (tmp_path / "signing-1.json").write_text('{"version": 1, "key": "%s", "streams": 5}'
                                             % key.fingerprint)
    with pytest.raises(state.StateError, match="signing-1.json"):
        signed_boot(tmp_path, key)
    (tmp_path / "signing-1.json").write_text("{trunc")
    with pytest.raises(state.StateError, match="signing-1.json"):
        signed_boot(tmp_path, key)
    d = signed_boot(tmp_path, key, ignore=True)
    assert (tmp_path / "signing-1.json.unreadable").exists()
    d.close()


def test_non_finite_values_round_trip_as_strict_json(tmp_path):
    """PX4 stores a REAL32 NaN or ±inf and its autosave exports it; the file stays strict JSON
    and the next boot has the same values. A NaN is stored as no change (no autosave of its
    own): it is written with the next save."""
    d = boot(tmp_path)
    params = d.sim.vehicles[0].params
    params.set("MPC_XY_CRUISE", math.inf)
    params.set("MIS_TAKEOFF_ALT", -math.inf)
    params.set("RTL_RETURN_ALT", math.nan)
    minus_nan = struct.unpack("<f", struct.pack("<I", 0xFFC00001))[0]
    params.set("MPC_Z_P", minus_nan)
    params.set("NAV_DLL_ACT", 2)  # the next save
    written(d)
    text = state.params_path(tmp_path, 1).read_text()
    doc = json.loads(text, parse_constant=lambda c: pytest.fail(f"bare {c} in {text}"))
    assert doc["params"] == {"MIS_TAKEOFF_ALT": "-Infinity", "MPC_XY_CRUISE": "Infinity",
                             "MPC_Z_P": "NaN(0xffc00001)", "NAV_DLL_ACT": 2,
                             "RTL_RETURN_ALT": "NaN"}
    d2 = boot(tmp_path)
    p = d2.sim.vehicles[0].params
    assert p["MPC_XY_CRUISE"] == math.inf and p["MIS_TAKEOFF_ALT"] == -math.inf
    assert math.isnan(p["RTL_RETURN_ALT"]) and p["NAV_DLL_ACT"] == 2
    assert struct.pack("<f", p["MPC_Z_P"]) == struct.pack("<I", 0xFFC00001)
    assert p.hash32() == params.hash32()  # QGC's cache still matches
    written(d2)


def test_non_finite_spellings_in_a_file(tmp_path):
    """Bare NaN/Infinity tokens (what Python's json writes) load too; an INT32 cannot hold
    them, nor can any parameter hold another string: the default is kept."""
    path = state.params_path(tmp_path, 1)
    path.parent.mkdir(parents=True)
    path.write_text('{"version": 1, "params": {"MPC_XY_CRUISE": Infinity, "MIS_TAKEOFF_ALT": NaN,'
                    ' "NAV_DLL_ACT": "NaN", "RTL_RETURN_ALT": "nan", "MPC_Z_P": "Infinity"}}')
    d = boot(tmp_path)
    p = d.sim.vehicles[0].params
    defaults = ParamStore()
    assert p["MPC_XY_CRUISE"] == math.inf and math.isnan(p["MIS_TAKEOFF_ALT"])
    assert p["MPC_Z_P"] == math.inf
    assert p["NAV_DLL_ACT"] == defaults["NAV_DLL_ACT"]
    assert p["RTL_RETURN_ALT"] == defaults["RTL_RETURN_ALT"]
    written(d)
