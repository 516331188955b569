"""QGroundControl .params files: per-vehicle parameters for `cornet run --param-file [N:]FILE`
and a scenario's vehicles.param_files."""

import pytest

from gateway.sim import param_files
from gateway.sim.scenario import load
from gateway.sim.values import ScenarioError

# As QGC's "Save to file" writes it (ParameterManager::writeParametersToStream).
QGC_FILE = """\
# Onboard parameters for Vehicle 2
#
# Stack: PX4 Pro
# Vehicle: Multi-Rotor
# Version: 1.15.0 dev
# Git Revision: 0000000000000000
#
# Vehicle-Id Component-Id Name Value Type
2\t1\tMAV_SYS_ID\t2\t6
2\t1\tMIS_TAKEOFF_ALT\t7.500000000000000000\t9
2\t1\tNAV_DLL_ACT\t2\t6
"""


def write(tmp_path, text, name="v.params"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_lines_go_to_the_vehicle_of_their_id_and_mav_sys_id_is_kept(tmp_path):
    path = write(tmp_path, QGC_FILE)
    assert param_files.read(str(path), vehicles=3) == {
        2: {"MIS_TAKEOFF_ALT": 7.5, "NAV_DLL_ACT": 2.0}}


def test_n_colon_loads_the_file_into_vehicle_n(tmp_path):
    path = write(tmp_path, QGC_FILE)
    assert param_files.read(f"3:{path}", vehicles=3) == {
        3: {"MIS_TAKEOFF_ALT": 7.5, "NAV_DLL_ACT": 2.0}}


def test_later_files_win(tmp_path):
    a = write(tmp_path, "1\t1\tMIS_TAKEOFF_ALT\t4\t9\n", "a.params")
    b = write(tmp_path, "1\t1\tMIS_TAKEOFF_ALT\t6\t9\n", "b.params")
    assert param_files.merge([str(a), str(b)], vehicles=1) == {1: {"MIS_TAKEOFF_ALT": 6.0}}


@pytest.mark.parametrize("text, words", [
    ("1\t1\tNOT_A_PX4_PARAM\t1\t9\n", "no PX4 parameter named 'NOT_A_PX4_PARAM'"),
    ("1\t1\tMIS_TAKEOFF_ALT\t7\n", "expected 5 tab-separated fields"),
    ("1\t1\tMIS_TAKEOFF_ALT\tseven\t9\n", "'seven' is not a valid REAL32 value"),
    ("1\t1\tNAV_DLL_ACT\t2\t9\n", "NAV_DLL_ACT is INT32 (type 6), the file says type 9"),
    ("1\t154\tMIS_TAKEOFF_ALT\t7\t9\n", "component 154"),
    ("5\t1\tMIS_TAKEOFF_ALT\t7\t9\n", "vehicle 5 does not exist"),
])
def test_mistakes_name_the_file_and_line(tmp_path, text, words):
    path = write(tmp_path, "# a comment\n" + text)
    with pytest.raises(ScenarioError) as exc:
        param_files.read(str(path), vehicles=2)
    assert f"{path}:2" in str(exc.value) and words in str(exc.value)


def test_a_vehicle_number_that_does_not_exist(tmp_path):
    path = write(tmp_path, QGC_FILE)
    with pytest.raises(ScenarioError, match="vehicle 4 does not exist"):
        param_files.read(f"4:{path}", vehicles=3)


def test_a_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read"):
        param_files.read(str(tmp_path / "nope.params"), vehicles=1)


def test_a_scenario_names_files_relative_to_itself(tmp_path):
    write(tmp_path, QGC_FILE, "second.params")
    scenario = tmp_path / "s.toml"
    scenario.write_text('[vehicles]\ncount = 2\nparam_files = ["1:second.params"]\n'
                        '[network]\ntopology = "direct"\nlink = {model = "ideal"}\n')
    s = load(scenario)
    assert s.vehicle_params == {1: {"MIS_TAKEOFF_ALT": 7.5, "NAV_DLL_ACT": 2.0}}
