"""Component metadata as PX4 serves it: the files behind COMPONENT_METADATA (and the older
COMPONENT_INFORMATION), read over MAVLink FTP from ``etc/extras/`` — how QGC and MAVSDK's
component_metadata plugin learn every parameter's description, units, range and group, the
events and the actuators.

PX4 builds them into its ROMFS (src/lib/component_information, src/lib/parameters/px4params
jsonout.py) and answers MAV_CMD_REQUEST_MESSAGE(COMPONENT_METADATA) with
``mftp://etc/extras/component_general.json.xz`` and that file's CRC
(mavlink/streams/COMPONENT_METADATA.hpp, generate_crc.py: over the uncompressed file). Here:

- ``parameters.json``: version 1, one entry per parameter of the vehicle's table with PX4's
  schema keys (name, type "Int32"/"Float", default, group, category, shortDesc, units, min, max,
  rebootRequired); the default is the firmware's (the PARAM_DEFINE's), not the one SITL's
  start-up sets (``param set-default``: what the vehicle boots with and resets to), so QGC
  shows, say, CA_ROTOR_COUNT's default as 0 and the x500's 4 as a change, as with PX4 SITL,
  sorted keys, indent 2, as jsonout.py writes it;
- ``all_events.json``: the events metadata (libevents' schema, below);
- ``actuators.json``: the actuators metadata, QGC's Actuators page (gateway/onboard/actuators.py);
- ``component_general.json``: version 1, ``metadataTypes`` = the parameter, events and actuators
  types (COMP_METADATA_TYPE_PARAMETER, _EVENTS, _ACTUATORS), each with its mftp URI and
  ``fileCrc``, the MAVLink CRC-32 of the served ``.json.xz`` file: PX4's
  generate_component_general.py reads the compressed files the build passes it (``--type
  1,parameters.json.xz,...``);
- all served xz-compressed (``*.json.xz``) like PX4's ROMFS; read-only (PX4's ROMFS is).

``ComponentMetadata`` is built once per process (the table is the same for every vehicle) and
holds the files as bytes: nothing is written to disk.
"""

from __future__ import annotations

import json
import lzma
from dataclasses import dataclass

from gateway.mavlink.modes import custom_mode_of
from gateway.onboard.actuators import actuators_json
from vehicles.events import (
    ARM_REASON_TEXT,
    COMPONENT_AUTOPILOT,
    DEFINITIONS,
    NAVIGATION_MODE,
    NAVIGATION_MODE_UNKNOWN,
    ArmReason,
)
from vehicles.failsafe import ACTION_TEXT, CAUSE_TEXT, Action, Cause
from vehicles.health_checks import HEALTH_COMPONENTS, MODE_GROUPS
from vehicles.params import VOLATILE, ParamInfo, ParamType, crc32part, param_table

EXTRAS_DIR = "etc/extras"
GENERAL_URI = f"mftp://{EXTRAS_DIR}/component_general.json.xz"
PARAMETERS_URI = f"mftp://{EXTRAS_DIR}/parameters.json.xz"
EVENTS_URI = f"mftp://{EXTRAS_DIR}/all_events.json.xz"
ACTUATORS_URI = f"mftp://{EXTRAS_DIR}/actuators.json.xz"
COMP_METADATA_TYPE_PARAMETER = 1
COMP_METADATA_TYPE_EVENTS = 4
COMP_METADATA_TYPE_ACTUATORS = 5


def mavlink_crc32(data: bytes, crc: int = 0) -> int:
    """MAVLink's CRC-32 as PX4 computes it (crc32part, its generators, MAVSDK): the CRC-32
    polynomial starting at 0 with no final XOR; ``crc`` continues an earlier part."""
    return crc32part(data, crc)


def _typed(info: ParamInfo, value: float) -> int | float:
    return int(value) if info.type is ParamType.INT32 else float(value)


def parameter_entry(info: ParamInfo) -> dict[str, object]:
    entry: dict[str, object] = {
        "name": info.name,
        "type": "Int32" if info.type is ParamType.INT32 else "Float",
        "default": _typed(info, info.default if info.firmware_default is None
                          else info.firmware_default),
        "group": info.group or "Miscellaneous",
        "category": "Standard",
    }
    if info.name in VOLATILE:  # jsonout.py: "volatile" and the @category (system)
        entry["volatile"] = True
        entry["category"] = "System"
    if info.description:
        entry["shortDesc"] = info.description
    if info.unit:
        entry["units"] = info.unit
    if info.min is not None:
        entry["min"] = _typed(info, info.min)
    if info.max is not None:
        entry["max"] = _typed(info, info.max)
    if info.reboot_required:  # QGC: "requires a reboot to take effect" after a change
        entry["rebootRequired"] = True
    return entry


def parameters_json(table: list[ParamInfo]) -> bytes:
    doc = {"version": 1, "parameters": [parameter_entry(i) for i in table]}
    return json.dumps(doc, indent=2, sort_keys=True).encode()


def events_json() -> bytes:
    """all_events.json as libevents reads it: the px4 namespace (component 1) with every event
    a vehicle here sends (vehicles/events.py DEFINITIONS, keyed by the 24-bit sub id), the two
    enums the health report uses, those of the arming, failsafe and mode-refusal events, the
    navigation mode groups (a group's HEARTBEAT custom_mode) and the health_and_arming_check
    protocol."""
    groups: dict[str, dict[str, dict[str, object]]] = {}
    for d in DEFINITIONS:
        event: dict[str, object] = {"name": d.name, "message": d.message}
        if d.description:
            event["description"] = d.description
        if d.type:
            event["type"] = d.type
        if d.arguments:
            event["arguments"] = [{"type": t, "name": n} for t, n in d.arguments]
        groups.setdefault(d.group, {"events": {}})["events"][str(d.id & 0xFFFFFF)] = event
    modes = {str(1 << int(nav)): {"name": name, "description": label}
             for nav, (name, label) in MODE_GROUPS.items()}
    components = {str(1 << i): {"name": name, "description": label}
                  for i, (name, label) in enumerate(HEALTH_COMPONENTS)}
    reasons = {str(int(r)): {"name": r.name.lower(), "description": ARM_REASON_TEXT[r]}
               for r in ArmReason}
    actions = {str(int(a)): {"name": a.name.lower(), "description": ACTION_TEXT[a]}
               for a in Action}
    causes = {str(int(c)): {"name": c.name.lower(), "description": CAUSE_TEXT[c]} for c in Cause}
    nav_modes = {str(value): {"name": nav.name.lower(), "description": label}
                 for nav, (value, label, _) in NAVIGATION_MODE.items()}
    nav_modes[str(NAVIGATION_MODE_UNKNOWN)] = {"name": "unknown", "description": "[Unknown]"}
    px4 = {
        "namespace": "px4",
        "enums": {
            "navigation_mode_group_t": {"type": "uint32_t", "is_bitfield": True,
                                        "description": "Navigation/flight mode group bits. "
                                        "All modes within a group share the same arming checks. "
                                        "For now we directly map group == mode.",
                                        "entries": modes},
            "health_component_t": {"type": "uint32_t", "is_bitfield": True,
                                   "description": "Bitfield for subsystems & components",
                                   "entries": components},
            "arm_disarm_reason_t": {"type": "uint8_t", "description": "Reason for arming/disarming",
                                    "entries": reasons},
            "failsafe_action_t": {"type": "uint8_t", "description": "failsafe action",
                                  "entries": actions},
            "failsafe_cause_t": {"type": "uint8_t", "description": "Cause for entering failsafe",
                                 "entries": causes},
            "navigation_mode_t": {"type": "uint8_t", "description": "Flight mode",
                                  "entries": nav_modes}},
        "event_groups": groups,
        "navigation_mode_groups": {"groups": {str(int(nav)): [custom_mode_of(nav)]
                                              for nav in MODE_GROUPS}},
        "supported_protocols": ["health_and_arming_check"]}
    return json.dumps({"version": 2, "components": {str(COMPONENT_AUTOPILOT): px4}},
                      indent=2, sort_keys=True).encode()


def general_json(parameters_xz: bytes, events_xz: bytes, actuators_xz: bytes) -> bytes:
    """component_general.json naming the three served files, each with the CRC of its
    compressed bytes (generate_component_general.py's ``fileCrc``)."""
    doc = {"version": 1, "metadataTypes": [
        {"type": kind, "uri": uri, "fileCrc": mavlink_crc32(data)}
        for kind, uri, data in ((COMP_METADATA_TYPE_PARAMETER, PARAMETERS_URI, parameters_xz),
                                (COMP_METADATA_TYPE_EVENTS, EVENTS_URI, events_xz),
                                (COMP_METADATA_TYPE_ACTUATORS, ACTUATORS_URI, actuators_xz))]}
    return json.dumps(doc).encode()


@dataclass(frozen=True)
class ComponentMetadata:
    """The served files (name under etc/extras → xz bytes) and what COMPONENT_METADATA says."""

    files: dict[str, bytes]
    general_crc: int
    uri: str = GENERAL_URI


def _xz(data: bytes) -> bytes:
    return lzma.compress(data, format=lzma.FORMAT_XZ)


def build(table: list[ParamInfo] | None = None) -> ComponentMetadata:
    parameters = _xz(parameters_json(param_table() if table is None else table))
    events = _xz(events_json())
    actuators = _xz(actuators_json())
    general = general_json(parameters, events, actuators)
    return ComponentMetadata(
        files={"component_general.json.xz": _xz(general), "parameters.json.xz": parameters,
               "all_events.json.xz": events, "actuators.json.xz": actuators},
        general_crc=mavlink_crc32(general))


class SharedMetadata:
    """The metadata of the shipped parameter table, one per process, built when a client
    first asks for it (COMPONENT_METADATA, or a file under etc/extras): building and
    compressing it takes ~0.1 s, which would otherwise delay the daemon's first HEARTBEAT."""

    uri = GENERAL_URI

    def __init__(self) -> None:
        self._built: ComponentMetadata | None = None

    def _get(self) -> ComponentMetadata:
        if self._built is None:
            self._built = build()
        return self._built

    @property
    def files(self) -> dict[str, bytes]:
        return self._get().files

    @property
    def general_crc(self) -> int:
        return self._get().general_crc


_SHARED = SharedMetadata()


def shared() -> SharedMetadata:
    """The metadata of the shipped parameter table (built at first use)."""
    return _SHARED
