"""Parameter persistence: atomic files, defaults not stored, instance ids never taken from file."""

import json

from gateway.sim import persist
from vehicles.params import ParamStore


def test_changes_are_saved_and_reloaded(tmp_path):
    a = ParamStore({"MAV_SYS_ID": 2})
    persist.attach(a, tmp_path, 2)
    assert not persist.params_path(tmp_path, 2).exists()  # nothing changed yet
    a.set("MIS_TAKEOFF_ALT", 6.0)
    a.set("NAV_DLL_ACT", 2)
    doc = json.loads(persist.params_path(tmp_path, 2).read_text())
    assert doc["params"] == {"MIS_TAKEOFF_ALT": 6.0, "NAV_DLL_ACT": 2}

    b = ParamStore({"MAV_SYS_ID": 2})
    persist.attach(b, tmp_path, 2)
    assert b["MIS_TAKEOFF_ALT"] == 6.0 and b["NAV_DLL_ACT"] == 2
    b.set("MIS_TAKEOFF_ALT", 2.5)  # back to the default: no longer stored
    doc = json.loads(persist.params_path(tmp_path, 2).read_text())
    assert doc["params"] == {"NAV_DLL_ACT": 2}


def test_bad_files_and_unknown_names_do_not_stop_the_vehicle(tmp_path):
    path = persist.params_path(tmp_path, 1)
    path.parent.mkdir(parents=True)
    path.write_text("{not json")
    store = ParamStore({"MAV_SYS_ID": 1})
    persist.attach(store, tmp_path, 1)
    assert store["MIS_TAKEOFF_ALT"] == 2.5
    path.write_text(json.dumps({"version": 1, "params": {
        "NO_SUCH_PARAM": 1, "MAV_SYS_ID": 9, "NAV_DLL_ACT": 1.5, "MIS_TAKEOFF_ALT": 4.0}}))
    store = ParamStore({"MAV_SYS_ID": 1})
    persist.attach(store, tmp_path, 1)
    assert store["MAV_SYS_ID"] == 1  # the instance decides, as PX4's rcS
    assert store["NAV_DLL_ACT"] == 0  # not an INT32: default kept
    assert store["MIS_TAKEOFF_ALT"] == 4.0


def test_no_temporary_file_left_behind(tmp_path):
    store = ParamStore({"MAV_SYS_ID": 1})
    persist.attach(store, tmp_path, 1)
    store.set("MPC_XY_CRUISE", 7.0)
    assert sorted(p.name for p in persist.params_path(tmp_path, 1).parent.iterdir()) == \
        ["params.json"]
