"""Typed PX4 parameter store: one per vehicle, owned by the autopilot.

Invariants:
- Only PX4's two types exist: INT32 and FLOAT (REAL32). Values are stored as Python int / float
  (floats rounded through float32 so that what is read back equals what went over the wire).
- Indices are dense (0..count-1), stable for the life of the store, in name order as PX4's
  ``param_find`` table is.
- Names come from ``data/px4_params.csv`` (PX4 metadata; see tools/make_param_table.py). A name that
  is not there does not exist: ``set`` refuses it.
- A change is what PX4's param_set_internal calls one (``px4_changed``: for a FLOAT a step of
  more than FLT_EPSILON, so nothing to or from NaN is a change). The value is stored either way.
- Observers registered with ``on_change`` are called after every successful change, so the
  gateway can broadcast PARAM_VALUE and the autopilot can re-read what it caches. A value stored
  that is no change bumps no ``version`` and reaches only ``on_stored`` observers (the storage,
  which PX4 writes with the next autosave). A change made with ``notify=False`` is PX4's
  ``commit_no_notification`` (no parameter_update: no PARAM_VALUE, no logger entry); only
  observers registered with ``quiet=True`` (the storage, which PX4's autosave still writes) see
  it.
- ``VOLATILE``: the parameters PX4's metadata marks ``@volatile`` (the autopilot's own
  bookkeeping); ``hash32`` leaves them out, as PX4's param_hash_check does.
- ``version`` counts the changes: a module that keeps values derived from parameters re-reads
  them when it differs from the one it read them at (PX4 modules' updateParams() on
  parameter_update). ``derived`` is a memo for such values that any change empties.
"""

from __future__ import annotations

import csv
import enum
import functools
import math
import struct
import zlib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from importlib import resources


class ParamType(enum.IntEnum):
    """MAV_PARAM_TYPE values PX4 uses."""

    INT32 = 6
    REAL32 = 9


@dataclass(frozen=True)
class ParamInfo:
    name: str
    type: ParamType
    default: int | float
    min: float | None
    max: float | None
    unit: str
    group: str
    description: str
    reboot_required: bool = False  # PX4's @reboot_required (data/px4_reboot_required.txt)
    # The firmware's default (PARAM_DEFINE / module.yaml: what PX4's parameters.json says) where
    # SITL's start-up sets another with ``param set-default`` (``default``); None: the same.
    firmware_default: int | float | None = None


FLT_EPSILON = 1.1920929e-07


def px4_changed(ptype: ParamType, old: int | float, new: int | float) -> bool:
    """PX4's param_set_internal test for a change: INT32 ``old != new``, FLOAT
    ``fabsf(old - new) > FLT_EPSILON``. A NaN on either side is no change (every comparison
    with NaN is false), nor is inf → inf (inf − inf is NaN)."""
    if ptype is ParamType.INT32:
        return old != new
    return abs(old - new) > FLT_EPSILON


def _same(a: int | float, b: int | float) -> bool:
    """The same stored value (NaN is NaN)."""
    return a == b or (a != a and b != b)


def _f32(value: float) -> float:
    return struct.unpack("<f", struct.pack("<f", float(value)))[0]


def _coerce(ptype: ParamType, value: float) -> int | float:
    """``value`` as the parameter's type; ValueError for what the type cannot hold (NaN or ±inf
    for an INT32, beyond float32 or int32, a fraction for an INT32). A REAL32 holds NaN and ±inf:
    PX4's param_set stores the float32 it is given (src/lib/parameters/parameters.cpp)."""
    if ptype is ParamType.INT32:
        if not math.isfinite(value):
            raise ValueError(f"{value!r} is not an INT32")
        ivalue = int(value)
        if ivalue != value or not -(2**31) <= ivalue < 2**31:
            raise ValueError(f"{value!r} is not an INT32")
        return ivalue
    try:
        return _f32(value)
    except OverflowError:
        raise ValueError(f"{value!r} is out of the REAL32 range") from None


def load_param_table() -> list[ParamInfo]:
    """The shipped PX4 parameter table, sorted by name."""
    data = resources.files("vehicles").joinpath("data")
    text = data.joinpath("px4_params.csv").read_text()
    reboot = set(data.joinpath("px4_reboot_required.txt").read_text().split())
    infos = []
    for row in csv.DictReader(text.splitlines()):
        ptype = ParamType.INT32 if row["type"] == "INT32" else ParamType.REAL32
        infos.append(
            ParamInfo(
                name=row["name"],
                type=ptype,
                default=_coerce(ptype, float(row["default"])),
                min=float(row["min"]) if row["min"] else None,
                max=float(row["max"]) if row["max"] else None,
                unit=row["unit"],
                group=row["group"],
                description=row["short_desc"],
                reboot_required=row["name"] in reboot,
                firmware_default=(_coerce(ptype, float(row["firmware_default"]))
                                  if row.get("firmware_default") else None),
            )
        )
    infos.sort(key=lambda i: i.name)
    return infos


_TABLE: list[ParamInfo] | None = None


def param_table() -> list[ParamInfo]:
    global _TABLE
    if _TABLE is None:
        _TABLE = load_param_table()
    return _TABLE


# volatile in PX4 v1.15.2's parameter definitions (those of this table): commander_params.c
# (COM_FLIGHT_UUID), land_detector_params.c (LND_FLIGHT_T_HI/_LO), ekf2/module.yaml
# (EKF2_MAG_DECL), the airspeed sensor's params.c (SENS_DPRES_OFF) and sensors/module.yaml's
# calibration offsets, scales and compensations (CAL_ACCn_*OFF/*SCALE, CAL_GYROn_*OFF,
# CAL_MAGn_*OFF/*SCALE/*ODIAG/*COMP, n = 0..3).
VOLATILE = frozenset({
    "COM_FLIGHT_UUID", "LND_FLIGHT_T_HI", "LND_FLIGHT_T_LO", "EKF2_MAG_DECL", "SENS_DPRES_OFF",
    *(f"CAL_ACC{n}_{a}{k}" for n in range(4) for a in "XYZ" for k in ("OFF", "SCALE")),
    *(f"CAL_GYRO{n}_{a}OFF" for n in range(4) for a in "XYZ"),
    *(f"CAL_MAG{n}_{a}{k}" for n in range(4) for a in "XYZ"
      for k in ("OFF", "SCALE", "ODIAG", "COMP"))})


def crc32part(data: bytes, crc: int = 0) -> int:
    """PX4's (and QGC's) ``crc32part``: the CRC-32 polynomial from ``crc`` with no inversion
    before or after, so parts chain. zlib inverts both, hence the inversions around it."""
    return ~zlib.crc32(data, ~crc & 0xFFFFFFFF) & 0xFFFFFFFF


@functools.lru_cache(maxsize=1)
def _shipped() -> tuple[list[ParamInfo], dict[str, int], tuple[int | float, ...],
                        dict[str, int | float]]:
    """The shipped table, its name → index map and its defaults (shared, never changed)."""
    infos = param_table()
    return (infos, {info.name: i for i, info in enumerate(infos)},
            tuple(info.default for info in infos), {info.name: info.default for info in infos})


class ParamStore:
    """Dense, typed, observable parameter values for one vehicle."""

    def __init__(self, overrides: Mapping[str, float] | None = None,
                 table: Iterable[ParamInfo] | None = None) -> None:
        if table is None:  # the shipped table: its index and defaults are built once
            self._infos, self._index, values, by_name = _shipped()
            self._values: list[int | float] = list(values)
            # The same values by name: the controllers read parameters on every 50 Hz tick.
            self._by_name: dict[str, int | float] = dict(by_name)
        else:
            self._infos = list(table)
            self._index = {info.name: i for i, info in enumerate(self._infos)}
            self._values = [info.default for info in self._infos]
            self._by_name = {i.name: v for i, v in zip(self._infos, self._values)}
        self._observers: list[Callable[[str, int | float], None]] = []
        self._quiet_observers: list[Callable[[str, int | float], None]] = []
        self._stored_observers: list[Callable[[str, int | float], None]] = []
        self.version = 0
        self.derived: dict[object, object] = {}
        self._set_defaults: dict[str, int | float] = {}  # ``set_default``'s, over the table's
        for name, value in (overrides or {}).items():
            if not self.set_default(name, value):
                raise KeyError(f"unknown PX4 parameter {name!r}")

    # --- lookup -------------------------------------------------------------------------------
    def __contains__(self, name: str) -> bool:
        return name in self._index

    def __len__(self) -> int:
        return len(self._infos)

    @property
    def count(self) -> int:
        return len(self._infos)

    def index_of(self, name: str) -> int:
        return self._index[name]

    def info(self, name_or_index: str | int) -> ParamInfo:
        if isinstance(name_or_index, str):
            return self._infos[self._index[name_or_index]]
        return self._infos[name_or_index]

    def __getitem__(self, name: str) -> int | float:
        return self._by_name[name]

    def get(self, name: str, default: float | None = None) -> int | float | None:
        i = self._index.get(name)
        return default if i is None else self._values[i]

    def value_at(self, index: int) -> int | float:
        return self._values[index]

    def items(self) -> Iterable[tuple[ParamInfo, int | float]]:
        return zip(self._infos, self._values)

    # --- change -------------------------------------------------------------------------------
    def set(self, name: str, value: float, notify: bool = True) -> bool:
        """Set a value, coerced to the parameter's type. False if the name does not exist.
        ``notify=False``: PX4's commit_no_notification (module rules)."""
        return self._set(name, value, notify)

    def _set(self, name: str, value: float, notify: bool, reset: bool = False) -> bool:
        i = self._index.get(name)
        if i is None:
            return False
        info = self._infos[i]
        new = _coerce(info.type, value)
        old = self._values[i]
        if px4_changed(info.type, old, new) or (reset and not _same(old, new)):
            self._store(i, name, new)
            self.version += 1
            self.derived.clear()
            for observer in list(self._observers if notify else self._quiet_observers):
                observer(name, new)
        elif not _same(old, new):
            # PX4 stores it all the same, but as no change: no parameter_update (modules keep
            # what they read), no autosave (the next one writes it), nothing to other links.
            self._store(i, name, new)
            for observer in list(self._stored_observers):
                observer(name, new)
        return True

    def _store(self, i: int, name: str, value: int | float) -> None:
        self._values[i] = value
        self._by_name[name] = value

    def set_default(self, name: str, value: float) -> bool:
        """PX4's ``param set-default`` (an airframe's or the launch's values, e.g. the instance's
        MAV_SYS_ID): set the value and make it the one a reset returns to."""
        if not self.set(name, value):
            return False
        self._set_defaults[name] = self._by_name[name]
        return True

    def default_of(self, name: str) -> int | float:
        return self._set_defaults.get(name, self._infos[self._index[name]].default)

    def reset(self, selected: Callable[[str], bool]) -> None:
        """PX4's param_reset_all / _excludes / _specific: every parameter ``selected`` accepts
        back to its default (observers see each change)."""
        for info in self._infos:
            if selected(info.name):
                # param_reset drops the user value and notifies whatever the comparison says
                self._set(info.name, self.default_of(info.name), True, reset=True)

    def on_change(self, observer: Callable[[str, int | float], None], quiet: bool = False
                  ) -> None:
        """``observer(name, value)`` after each change; with ``quiet`` also after the changes
        made without notification."""
        self._observers.append(observer)
        if quiet:
            self._quiet_observers.append(observer)

    def on_stored(self, observer: Callable[[str, int | float], None]) -> None:
        """``observer(name, value)`` after a value was stored that PX4 counts as no change
        (``px4_changed``: a NaN on either side, inf → inf, a step within FLT_EPSILON)."""
        self._stored_observers.append(observer)

    def changed_from_default(self) -> dict[str, int | float]:
        return {
            info.name: value for info, value in zip(self._infos, self._values) if value != info.default
        }

    def hash32(self) -> int:
        """PX4's param_hash_check (``_HASH_CHECK``): crc32part over each parameter's name and
        its four value bytes, in name order, volatile ones left out. QGC computes the same over
        its cache (ParameterManager::_tryCacheHashLoad) to skip a download when they match."""
        crc = 0
        for info, value in zip(self._infos, self._values):
            if info.name in VOLATILE:
                continue
            crc = crc32part(info.name.encode(), crc)
            crc = crc32part(struct.pack("<i" if info.type is ParamType.INT32 else "<f", value),
                            crc)
        return crc
