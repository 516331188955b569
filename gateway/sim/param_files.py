"""Per-vehicle parameter files in QGroundControl's ``.params`` format (what QGC's "Save to file"
writes and "Load from file" reads): ``#`` comment lines, then one tab-separated line per
parameter, ``Vehicle-Id Component-Id Name Value Type`` (type: MAV_PARAM_TYPE, 6 INT32, 9 REAL32).

``cornet run --param-file FILE`` gives each line to the vehicle of its Vehicle-Id column, as
QGC loads a file into the vehicle it was saved from; ``--param-file N:FILE`` gives every line to
vehicle N (system id N), whatever the column says: one vehicle's saved file loaded into another.
MAV_SYS_ID lines are skipped (a vehicle keeps its own id); lines of other components than the
autopilot (component 1) are refused.
"""

from __future__ import annotations

import re
from pathlib import Path

from gateway.sim.values import ScenarioError
from vehicles.params import ParamStore, ParamType

AUTOPILOT_COMPONENT = 1
KEPT = ("MAV_SYS_ID",)  # a vehicle's identity is its instance's (PX4 SITL: 1 + instance)
_TYPES = {int(t): t for t in ParamType}


def split_spec(spec: str) -> tuple[int | None, str]:
    """``N:FILE`` or ``FILE`` (a path with a colon and no number before it stays a path)."""
    m = re.fullmatch(r"(\d+):(.+)", spec)
    return (int(m.group(1)), m.group(2)) if m else (None, spec)


def read(spec: str, vehicles: int, base_dir: Path | None = None,
         where: str = "--param-file") -> dict[int, dict[str, float]]:
    """The values of one ``[N:]FILE``, by system id. Raises ScenarioError naming the file and
    line, or the vehicle number, that is wrong."""
    sysid, name = split_spec(spec)
    path = Path(name)
    if base_dir is not None and not path.is_absolute():
        path = base_dir / path
    if sysid is not None and not 1 <= sysid <= vehicles:
        raise ScenarioError(f"{where} {spec}: vehicle {sysid} does not exist (vehicles 1.."
                            f"{vehicles})")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise ScenarioError(f"{where} {path}: cannot read ({reason})") from None
    store = ParamStore()
    out: dict[int, dict[str, float]] = {}
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        at = f"{where} {path}:{number}"
        fields = line.split("\t") if "\t" in line else line.split()
        if len(fields) != 5:
            raise ScenarioError(f"{at}: expected 5 tab-separated fields (vehicle id, component "
                                f"id, name, value, type), got {len(fields)}")
        vid_text, comp_text, pname, value_text, type_text = (f.strip() for f in fields)
        try:
            vid, comp, ptype = int(vid_text), int(comp_text), int(type_text)
        except ValueError:
            raise ScenarioError(f"{at}: vehicle id, component id and type must be "
                                "integers") from None
        if comp != AUTOPILOT_COMPONENT:
            raise ScenarioError(f"{at}: component {comp}: only the autopilot's (1) parameters "
                                "can be set")
        if pname not in store:
            raise ScenarioError(f"{at}: no PX4 parameter named {pname!r}")
        if pname in KEPT:
            continue
        target = sysid if sysid is not None else vid
        if not 1 <= target <= vehicles:
            raise ScenarioError(f"{at}: vehicle {target} does not exist (vehicles 1..{vehicles}); "
                                f"load the file into another with {where} N:{path}")
        info = store.info(pname)
        if _TYPES.get(ptype) is not info.type:
            raise ScenarioError(f"{at}: {pname} is {info.type.name} (type {int(info.type)}), "
                                f"the file says type {ptype}")
        try:
            value = float(value_text)
            store.set(pname, value)
        except ValueError:
            raise ScenarioError(f"{at}: {value_text!r} is not a valid {info.type.name} value for "
                                f"{pname}") from None
        out.setdefault(target, {})[pname] = value
    return out


def merge(specs: list[str], vehicles: int, base_dir: Path | None = None,
          where: str = "--param-file") -> dict[int, dict[str, float]]:
    """Several files in order: a later file's value of a parameter wins."""
    out: dict[int, dict[str, float]] = {}
    for spec in specs:
        for sysid, values in read(spec, vehicles, base_dir, where).items():
            out.setdefault(sysid, {}).update(values)
    return out
