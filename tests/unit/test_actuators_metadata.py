"""The actuators metadata (COMP_METADATA_TYPE_ACTUATORS) as PX4 v1.15 gz SITL serves it: the
structure of generate_actuators_metadata.py's actuators.json (gz_bridge's and pwm_out_sim's
outputs, output_functions.yaml's functions, control_allocator's multirotor mixer); every
parameter it names exists in the table; with the table's defaults (4001_gz_x500) QGC's Actuators
page finds motors 1..4 to test and four rotors of the x500's geometry."""

from __future__ import annotations

import json
import lzma
import re

import pytest

from gateway.onboard import metadata
from vehicles.airframe import X500
from vehicles.params import ParamType, param_table

TABLE = {i.name: i for i in param_table()}


@pytest.fixture(scope="module")
def doc() -> dict:
    return json.loads(lzma.decompress(metadata.build().files["actuators.json.xz"]))


def holds(condition: str) -> bool:
    """QGC's condition on a parameter ("NAME==v", "NAME>=v"; one not there is false), with the
    table's defaults."""
    m = re.fullmatch(r"(\w+)(==|!=|>=|<=|>|<)(-?\d+)", condition)
    assert m, condition
    name, op, value = m.group(1), m.group(2), int(m.group(3))
    if name not in TABLE:
        return False
    current = TABLE[name].default
    return {"==": current == value, "!=": current != value, ">=": current >= value,
            "<=": current <= value, ">": current > value, "<": current < value}[op]


def named(template: str, index: int) -> str:
    return template.replace("${i}", str(index))


def channel_params(doc: dict):
    """(group label, subgroup, channel, per-channel parameter, its name for the channel)."""
    for group in doc["outputs_v1"]:
        for sub in group["subgroups"]:
            for channel in sub["channels"]:
                for param in sub["per-channel-parameters"]:
                    index = channel["param-index"] + param.get("index-offset", 0)
                    yield group, sub, channel, param, named(param["name"], index)


def test_the_file_has_px4s_structure(doc):
    assert doc["version"] == 1
    assert set(doc) == {"version", "outputs_v1", "functions_v1", "mixer_v1"}
    gz, sim = doc["outputs_v1"]
    assert gz["label"] == "SIM_GZ" and gz["show-subgroups-if"] == "SIM_GZ_EN>=1"
    assert gz["parameters"] == [{"name": "SIM_GZ_EN", "label": "Configure", "function": "enable"}]
    assert [(s["label"], len(s["channels"])) for s in gz["subgroups"]] == [
        ("ESCs", 8), ("Servos", 8), ("Wheels", 2)]
    escs = gz["subgroups"][0]
    assert escs["channels"][0] == {"label": "ESC 1", "param-index": 1}
    assert escs["channels"][-1] == {"label": "ESC 8", "param-index": 8}
    assert gz["subgroups"][2]["channels"][1] == {"label": "Wheels 2", "param-index": 2}
    assert escs["per-channel-parameters"] == [
        {"label": "Function", "name": "SIM_GZ_EC_FUNC${i}", "function": "function"},
        {"label": "Disarmed", "name": "SIM_GZ_EC_DIS${i}", "function": "disarmed"},
        {"label": "Minimum", "name": "SIM_GZ_EC_MIN${i}", "function": "min"},
        {"label": "Maximum", "name": "SIM_GZ_EC_MAX${i}", "function": "max"},
        {"label": "Failsafe", "name": "SIM_GZ_EC_FAIL${i}", "function": "failsafe",
         "advanced": True},
        {"label": "Rev Range\n(for Servos)", "name": "SIM_GZ_EC_REV", "index-offset": -1,
         "show-as": "bitset"}]
    assert sim["label"] == "SIM" and "show-subgroups-if" not in sim
    [channels] = sim["subgroups"]
    assert "label" not in channels and len(channels["channels"]) == 16
    assert channels["channels"][15] == {"label": "Channel 16", "param-index": 16}
    assert [p["name"] for p in channels["per-channel-parameters"]] == [
        "PWM_MAIN_FUNC${i}", "PWM_MAIN_REV"]

    functions = doc["functions_v1"]
    assert functions["0"] == {"label": "Disabled"}
    assert functions["101"] == {"label": "Motor 1"} and functions["112"] == {"label": "Motor 12"}
    assert "113" not in functions and functions["208"] == {"label": "Servo 8"}
    assert functions["306"] == {"label": "Peripheral via Actuator Set 6"}
    assert functions["412"] == {"label": "RC AUX 6"}
    assert functions["440"] == {"label": "Landing Gear Wheel"}
    assert functions["2000"] == {
        "label": "Camera Trigger", "exclude-from-actuator-testing": True,
        "note": {"condition": "TRIG_MODE==0",
                 "text": "Camera triggering needs to be enabled and configured via TRIG_* "
                         "parameters."}}
    assert len(functions) == 3 + 12 + 8 + 6 + 7 + 6 + 5 + 3

    mixer = doc["mixer_v1"]
    assert mixer["rules"] == []
    motor = mixer["actuator-types"]["motor"]
    assert (motor["function-min"], motor["function-max"]) == (101, 112)
    assert motor["values"] == {"min": 0, "max": 1, "default-is-nan": True}
    assert mixer["actuator-types"]["DEFAULT"] == {"values": {"min": -1, "max": 1, "default": -1}}
    [multirotor] = mixer["config"]
    assert multirotor["option"] == "CA_AIRFRAME==0" and multirotor["type"] == "multirotor"
    [motors] = multirotor["actuators"]
    assert motors["count"] == "CA_ROTOR_COUNT" and motors["group-label"] == "Motors"
    assert [p["function"] for p in motors["per-item-parameters"]] == [
        "posx", "posy", "posz", "spin-dir", "axisx", "axisy", "axisz"]


def test_the_file_is_one_line_with_sorted_keys():
    """json.dump without indent, keys sorted; the functions keyed by number (in number order)."""
    raw = lzma.decompress(metadata.build().files["actuators.json.xz"])
    assert b"\n" not in raw
    doc = json.loads(raw)
    doc["functions_v1"] = {int(k): v for k, v in doc["functions_v1"].items()}
    assert raw == json.dumps(doc, sort_keys=True).encode()


def test_every_parameter_it_names_is_in_the_table(doc):
    names = set()
    for group, _, _, _, name in channel_params(doc):
        names.add(name)
        names.update(p["name"] for p in group.get("parameters", []))
    mixer = doc["mixer_v1"]
    rotors = int(TABLE["CA_ROTOR_COUNT"].default)
    counts = {"motor": range(rotors), "servo": range(8)}
    for kind, spec in mixer["actuator-types"].items():
        for param in spec.get("per-item-parameters", []):
            names.update(named(param["name"], i + param.get("index-offset", 0))
                         for i in counts[kind])
    for config in mixer["config"]:
        for actuator in config["actuators"]:
            for param in actuator["per-item-parameters"]:
                names.update(named(param["name"], i + param.get("index-offset", 0))
                             for i in range(rotors))
    assert len(names) > 100
    assert names <= set(TABLE), sorted(names - set(TABLE))
    # what a condition or a count reads is an INT32
    for name in ("SIM_GZ_EN", "CA_AIRFRAME", "CA_ROTOR_COUNT"):
        assert TABLE[name].type is ParamType.INT32, name
    assert holds(doc["outputs_v1"][0]["show-subgroups-if"])
    assert [holds(c["option"]) for c in mixer["config"]] == [True]


def test_qgc_tests_motors_1_to_4_of_the_x500(doc):
    """QGC's actuator-test sliders: one per distinct non-zero value of a channel's "function"
    parameter (groups shown: SIM_GZ_EN set), each a motor within the motor type's range."""
    configured = []
    for group, _, _, param, name in channel_params(doc):
        shown = group.get("show-subgroups-if")
        if param.get("function") == "function" and (shown is None or holds(shown)):
            value = int(TABLE[name].default)
            if value:
                configured.append(value)
    assert sorted(set(configured)) == configured == [101, 102, 103, 104]
    motor = doc["mixer_v1"]["actuator-types"]["motor"]
    assert all(motor["function-min"] <= f <= motor["function-max"] for f in configured)
    assert [doc["functions_v1"][str(f)]["label"] for f in configured] == [
        "Motor 1", "Motor 2", "Motor 3", "Motor 4"]


def test_the_geometry_qgc_draws_is_the_x500s():
    """CA_ROTOR_COUNT rotors at CA_ROTORn_PX/PY with direction by the sign of _KM: the
    allocation geometry of 4001_gz_x500 (vehicles/airframe.py)."""
    rotors = int(TABLE["CA_ROTOR_COUNT"].default)
    got = tuple((TABLE[f"CA_ROTOR{i}_PX"].default, TABLE[f"CA_ROTOR{i}_PY"].default,
                 TABLE[f"CA_ROTOR{i}_KM"].default) for i in range(rotors))
    assert [v for rotor in got for v in rotor] == pytest.approx(
        [v for rotor in X500.allocation_rotors for v in rotor], abs=1e-6)
    assert all(TABLE[f"CA_ROTOR{i}_AZ"].default == -1.0 for i in range(rotors))


def test_the_general_file_names_it_with_the_crc_of_its_xz_bytes():
    built = metadata.build()
    general = json.loads(lzma.decompress(built.files["component_general.json.xz"]))
    by_type = {t["type"]: t for t in general["metadataTypes"]}
    assert set(by_type) == {1, 4, 5}
    assert by_type[5]["uri"] == "mftp://etc/extras/actuators.json.xz"
    for kind, name in ((1, "parameters"), (4, "all_events"), (5, "actuators")):
        assert by_type[kind]["fileCrc"] == metadata.mavlink_crc32(built.files[f"{name}.json.xz"])
    assert built.general_crc == metadata.mavlink_crc32(
        lzma.decompress(built.files["component_general.json.xz"]))
