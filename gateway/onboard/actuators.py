"""The actuators metadata (COMP_METADATA_TYPE_ACTUATORS) as PX4 v1.15 SITL serves it from
``etc/extras/actuators.json.xz``: what QGroundControl builds its Actuators setup page from.

PX4 generates it at build time (Tools/module_config/generate_actuators_metadata.py) from the
module.yaml of every output driver in the build and of the control allocator, and the output
functions of src/lib/mixer_module/output_functions.yaml. For a gz SITL build that is:

- ``outputs_v1``: the output drivers. gz_bridge's (simulation/gz_bridge/module.yaml, "SIM_GZ":
  shown when SIM_GZ_EN is set; ESCs and servos 1..8, wheels 1..2) then pwm_out_sim's
  (drivers/pwm_out_sim/module_sim.yaml, "SIM": 16 channels with a function each). Per channel the
  parameters ``<prefix>_FUNC${i}`` (the output function), _DIS, _MIN, _MAX, _FAIL and the
  ``<prefix>_REV`` bitmask, ``${i}`` being the channel's param-index;
- ``functions_v1``: the output functions by number (0 Disabled, 101.. Motor 1.., 201.. Servo 1..);
- ``mixer_v1``: control_allocator/module.yaml's actuator types (motor 101..112, servo 201..208,
  the values QGC's actuator-test sliders span) and the airframe configurations selected by
  CA_AIRFRAME. Only the multirotor one (CA_AIRFRAME 0) is given: the only airframe simulated
  here. Its motors are CA_ROTOR_COUNT items with the CA_ROTOR${i}_* geometry, ``${i}`` the
  0-based item index.

QGC shows the geometry (from the CA_ROTOR* parameters), the output groups with each channel's
function, and one test slider per configured function: every distinct non-zero value of a
channel's "function" parameter (4001_gz_x500: SIM_GZ_EC_FUNC1..4 = Motor 1..4); a slider sends
MAV_CMD_ACTUATOR_TEST with 1000 + that function, 1101 for Motor 1 (vehicles/actuator_test.py).

The JSON is written without indentation and with sorted keys, as PX4's generator writes it.
"""

from __future__ import annotations

import json

_PER_CHANNEL = (("Function", "FUNC", "function"), ("Disarmed", "DIS", "disarmed"),
                ("Minimum", "MIN", "min"), ("Maximum", "MAX", "max"),
                ("Failsafe", "FAIL", "failsafe"))


def _rev_range(prefix: str) -> dict[str, object]:
    """The per-channel view of ``<prefix>_REV``: bit param-index - 1 of one bitmask parameter."""
    return {"label": "Rev Range\n(for Servos)", "name": f"{prefix}_REV", "index-offset": -1,
            "show-as": "bitset"}


def _subgroup(prefix: str, channel_label: str, count: int, label: str | None,
              standard: bool = True) -> dict[str, object]:
    """One output_groups entry of a module.yaml: channels 1..count (param-index = channel) and
    the per-channel parameters (the function only, or also the standard_params)."""
    params: list[dict[str, object]] = []
    for text, suffix, function in _PER_CHANNEL if standard else _PER_CHANNEL[:1]:
        param: dict[str, object] = {"label": text, "name": f"{prefix}_{suffix}${{i}}",
                                    "function": function}
        if function == "failsafe":
            param["advanced"] = True
        params.append(param)
    params.append(_rev_range(prefix))
    group: dict[str, object] = {
        "channels": [{"label": f"{channel_label} {n}", "param-index": n}
                     for n in range(1, count + 1)],
        "per-channel-parameters": params}
    if label is not None:
        group["label"] = label
    return group


def outputs() -> list[dict[str, object]]:
    """``outputs_v1``: gz_bridge's output groups, then pwm_out_sim's."""
    gz: dict[str, object] = {
        "label": "SIM_GZ", "show-subgroups-if": "SIM_GZ_EN>=1",
        "parameters": [{"name": "SIM_GZ_EN", "label": "Configure", "function": "enable"}],
        "subgroups": [_subgroup("SIM_GZ_EC", "ESC", 8, "ESCs"),
                      _subgroup("SIM_GZ_SV", "Servo", 8, "Servos"),
                      _subgroup("SIM_GZ_WH", "Wheels", 2, "Wheels")]}
    sim: dict[str, object] = {
        "label": "SIM", "subgroups": [_subgroup("PWM_MAIN", "Channel", 16, None, False)]}
    return [gz, sim]


# output_functions.yaml (v1.15): name → number, or (first number, count) for numbered ones.
_FUNCTIONS: tuple[tuple[str, int | tuple[int, int]], ...] = (
    ("Disabled", 0), ("Constant Min", 1), ("Constant Max", 2), ("Motor", (101, 12)),
    ("Servo", (201, 8)), ("Peripheral via Actuator Set", (301, 6)), ("Landing Gear", 400),
    ("Parachute", 401), ("RC Roll", 402), ("RC Pitch", 403), ("RC Throttle", 404),
    ("RC Yaw", 405), ("RC Flaps", 406), ("RC AUX", (407, 6)), ("Gimbal Roll", 420),
    ("Gimbal Pitch", 421), ("Gimbal Yaw", 422), ("Gripper", 430), ("Landing Gear Wheel", 440))

# The functions of other modules' inputs (camera trigger, camera capture, PPS capture): not
# actuators, so not tested; QGC shows the note while the condition holds.
_INPUT_FUNCTIONS = (
    (2000, "Camera Trigger", "TRIG_MODE==0",
     "Camera triggering needs to be enabled and configured via TRIG_* parameters."),
    (2032, "Camera Capture", "CAM_CAP_FBACK==0",
     "Camera feedback needs to be enabled and configured via CAM_CAP_* parameters."),
    (2064, "PPS Input", "PPS_CAP_ENABLE==0",
     "PPS needs to be enabled via PPS_CAP_ENABLE parameter."))


def functions() -> dict[int, dict[str, object]]:
    """``functions_v1``: every output function by number (JSON turns the keys into strings)."""
    out: dict[int, dict[str, object]] = {}
    for label, number in _FUNCTIONS:
        if isinstance(number, int):
            out[number] = {"label": label}
        else:
            first, count = number
            out.update({first + k: {"label": f"{label} {k + 1}"} for k in range(count)})
    for number, label, condition, text in _INPUT_FUNCTIONS:
        out[number] = {"label": label, "exclude-from-actuator-testing": True,
                       "note": {"condition": condition, "text": text}}
    return out


def _item(name: str, label: str, **extra: object) -> dict[str, object]:
    return {"name": name, "label": label, **extra}


def mixer() -> dict[str, object]:
    """``mixer_v1``: control_allocator/module.yaml's actuator types and its multirotor airframe
    (CA_AIRFRAME 0: CA_ROTOR_COUNT motors with position, spin direction and thrust axis)."""
    motor_params = [
        _item("CA_R_REV", "Bidirectional", **{"show-as": "bitset", "index-offset": 0,
                                               "advanced": True}),
        _item("CA_R${i}_SLEW", "Slew Rate", **{"index-offset": 0, "advanced": True})]
    types = {
        "motor": {"label-index-offset": 1, "function-min": 101, "function-max": 112,
                  "values": {"min": 0, "max": 1, "default-is-nan": True},
                  "per-item-parameters": motor_params},
        "servo": {"label-index-offset": 1, "function-min": 201, "function-max": 208,
                  "values": {"min": -1, "max": 1, "default": 0},
                  "per-item-parameters": [_item("CA_SV${i}_SLEW", "Slew Rate",
                                                **{"index-offset": 0, "advanced": True})]},
        "DEFAULT": {"values": {"min": -1, "max": 1, "default": -1}}}
    rotor = [
        {"label": "Position X", "function": "posx", "name": "CA_ROTOR${i}_PX", "index-offset": 0},
        {"label": "Position Y", "function": "posy", "name": "CA_ROTOR${i}_PY", "index-offset": 0},
        {"label": "Position Z", "function": "posz", "name": "CA_ROTOR${i}_PZ", "advanced": True,
         "index-offset": 0},
        _item("CA_ROTOR${i}_KM", "Direction CCW", function="spin-dir",
              **{"show-as": "true-if-positive"}),
        _item("CA_ROTOR${i}_AX", "Axis X", function="axisx", advanced=True),
        _item("CA_ROTOR${i}_AY", "Axis Y", function="axisy", advanced=True),
        _item("CA_ROTOR${i}_AZ", "Axis Z", function="axisz", advanced=True)]
    multirotor = {
        "option": "CA_AIRFRAME==0", "type": "multirotor", "title": "Multirotor",
        "help-url": "https://docs.px4.io/main/en/config/actuators.html",
        "actuators": [{"actuator-type": "motor", "required": True, "group-label": "Motors",
                       "count": "CA_ROTOR_COUNT", "parameters": [],
                       "per-item-parameters": rotor}]}
    return {"actuator-types": types, "config": [multirotor], "rules": []}


def actuators_json() -> bytes:
    """actuators.json: version 1 with the outputs, the functions and the mixer."""
    doc = {"version": 1, "outputs_v1": outputs(), "functions_v1": functions(),
           "mixer_v1": mixer()}
    return json.dumps(doc, sort_keys=True).encode()
