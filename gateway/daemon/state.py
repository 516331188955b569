"""What a vehicle keeps across restarts: its parameters (PX4's parameter file) and its mission,
geofence and rally points (PX4's dataman).

Layout: ``<state_dir>/vehicle-<sysid>/params.json`` and ``plans.json``, each with the last good
copy beside it (``*.prev``); with signing on, ``<state_dir>/signing-<first sysid>.json`` keeps the
key's replay state (gateway/mavlink/signing.py: the newest timestamp of every client stream and of
the daemon's own frames), saved once per simulated second while it changes and at stop. One such
file per process: a daemon with ``--shards`` keeps one per shard.

Rules and invariants:
- Parameter values are JSON numbers; a REAL32 NaN or ±inf (PX4 stores them) is the string
  "NaN", "Infinity" or "-Infinity" (``NON_FINITE``; a NaN with other float32 bits
  ``NaN(0x<bits>)``), so the file stays strict JSON and loads back the same value (and hash).
  A value PX4 stores as no change (to or from NaN) is written with the next save.
- Only what a client (or the vehicle itself) changed after boot is kept: never ``--param``
  values, never the speed-scaled link-loss time-outs, never MAV_SYS_ID (the instance decides, as
  PX4's rcS does). A value set back to its default is still kept: the client chose it.
- Boot order: PX4's defaults → the saved values → speed scaling of the time-outs not saved →
  ``--param``. So the same state directory and flags give the same parameters at any speed.
- Writes never run on the event loop: the loop hands a snapshot to one writer thread, which
  waits WRITE_DELAY_S for more changes (a flood of PARAM_SET becomes one write), then writes
  atomically (gateway/sim/files.py). ``close()`` writes what is pending before the daemon exits.
- A file that cannot be read stops the start with StateError naming it; it is never
  overwritten. With ``ignore_unreadable`` the vehicle starts with defaults and the file is
  moved aside to ``NAME.unreadable`` first.
"""

from __future__ import annotations

import json
import logging
import math
import os
import re
import struct
import threading
from collections.abc import Callable, Mapping
from dataclasses import astuple, dataclass, field
from pathlib import Path
from typing import Any

from gateway.mavlink.signing import SigningKey, SigningState
from gateway.sim.files import write_atomic
from vehicles.params import ParamStore, ParamType
from vehicles.plan_types import PlanItem, PlanResult, PlanType
from vehicles.vehicle import Vehicle

log = logging.getLogger(__name__)

FILE_VERSION = 1
INSTANCE_PARAMS = ("MAV_SYS_ID",)
WRITE_DELAY_S = 0.2  # wall seconds a change waits for others before the file is written
CLOSE_TIMEOUT_S = 4.0  # SIGTERM must still stop the daemon within 5 s
PLAN_KEYS = {PlanType.MISSION: "mission", PlanType.FENCE: "fence", PlanType.RALLY: "rally"}
UNREADABLE_SUFFIX = ".unreadable"
NON_FINITE = {"NaN": math.nan, "Infinity": math.inf, "-Infinity": -math.inf}
_NAN_BITS = 0x7FC00000  # the float32 NaN that "NaN" stands for


class StateError(Exception):
    """A state file that cannot be used; the message names it and says what to do."""


def vehicle_dir(state_dir: Path, sysid: int) -> Path:
    return Path(state_dir) / f"vehicle-{sysid}"


def params_path(state_dir: Path, sysid: int) -> Path:
    return vehicle_dir(state_dir, sysid) / "params.json"


def plans_path(state_dir: Path, sysid: int) -> Path:
    return vehicle_dir(state_dir, sysid) / "plans.json"


@dataclass
class Saved:
    """One vehicle's saved state, as read at boot."""

    params: dict[str, float] = field(default_factory=dict)
    plans: dict[PlanType, list[PlanItem]] = field(default_factory=dict)


def _read(path: Path, ignore_unreadable: bool) -> dict[str, Any] | None:
    """The file's document; None if there is none (or it was unreadable and is ignored)."""
    try:
        doc = json.loads(path.read_text())
        if not isinstance(doc, dict) or doc.get("version") != FILE_VERSION:
            raise ValueError(f"not a version-{FILE_VERSION} state file")
        return doc
    except FileNotFoundError:
        return None
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) else str(exc)
        if not ignore_unreadable:
            raise StateError(f"cannot read {path}: {why}; repair or remove it (its last good copy "
                             f"may be {path.name}.prev), or start with --ignore-bad-state to "
                             "start this vehicle with defaults") from None
        aside = path.with_name(path.name + UNREADABLE_SUFFIX)
        os.replace(path, aside)
        log.warning("cannot read %s (%s): starting with defaults; the file is kept as %s",
                    path, why, aside)
        return None


def _plan_items(value: Any, plan_type: PlanType, path: Path) -> list[PlanItem]:
    if not isinstance(value, list):
        raise StateError(f"{path}: {PLAN_KEYS[plan_type]} is not a list of items")
    items = []
    for raw in value:
        try:
            item = PlanItem(*raw)
        except TypeError:
            raise StateError(f"{path}: a {PLAN_KEYS[plan_type]} item is not an item: {raw!r}") \
                from None
        if item.mission_type != plan_type:
            raise StateError(f"{path}: a {PLAN_KEYS[plan_type]} item has mission type "
                             f"{item.mission_type}")
        items.append(item)
    return items


def load(state_dir: Path, sysid: int, ignore_unreadable: bool = False) -> Saved:
    """Vehicle ``sysid``'s saved state. Raises StateError for a file that cannot be read."""
    saved = Saved()
    path = params_path(state_dir, sysid)
    doc = _read(path, ignore_unreadable)
    if doc is not None:
        values = doc.get("params", {})
        if not isinstance(values, dict):
            raise StateError(f"{path}: 'params' is not a table of names and values")
        for name, value in values.items():
            if name in INSTANCE_PARAMS:
                continue
            value = _param_value(value) if isinstance(value, str) else value
            if not isinstance(value, (int, float)) or isinstance(value, bool):
                log.warning("%s: %s = %r is not a number; keeping the default", path, name,
                            value)
                continue
            saved.params[str(name)] = value
    path = plans_path(state_dir, sysid)
    doc = _read(path, ignore_unreadable)
    if doc is not None:
        for plan_type, key in PLAN_KEYS.items():
            if key in doc:
                saved.plans[plan_type] = _plan_items(doc[key], plan_type, path)
    return saved


def apply_params(store: ParamStore, values: Mapping[str, float], path: Path) -> None:
    for name, value in values.items():
        try:
            known = store.set(name, value)
        except ValueError as exc:
            log.warning("%s: %s: %s; keeping the default", path, name, exc)
            continue
        if not known:
            log.warning("%s: no parameter %s any more; ignoring it", path, name)


def scaled_value(store: ParamStore, name: str, factor: float) -> float:
    """PX4's rcS multiplies the link-loss time-outs by PX4_SIM_SPEED_FACTOR; an INT32 stays an
    integer (rounded, and at least 1 s)."""
    info = store.info(name)
    value = info.default * factor
    if info.type is ParamType.INT32:
        return max(1, round(value))
    return value


class StateWriter:
    """One thread that writes state files, coalescing changes that come in bursts."""

    def __init__(self, delay_s: float = WRITE_DELAY_S) -> None:
        self.delay_s = delay_s
        self.writes = 0
        self.coalesced = 0  # changes that joined a write already pending
        self.errors = 0
        self._cond = threading.Condition()
        self._pending: dict[Path, Callable[[], str]] = {}
        self._busy = False
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="cornet-state", daemon=True)
        self._thread.start()

    def submit(self, path: Path, render: Callable[[], str]) -> None:
        """Write ``render()`` to ``path`` soon. ``render`` runs on the writer thread: it must
        read only a snapshot taken by the caller."""
        with self._cond:
            if path in self._pending:
                self.coalesced += 1
            self._pending[path] = render
            self._cond.notify()

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._pending and not self._closed:
                    self._cond.wait()
                if not self._pending:
                    return
                if not self._closed:
                    self._cond.wait(self.delay_s)  # more changes may come: one write for all
                batch, self._pending = self._pending, {}
                self._busy = True
            for path, render in batch.items():
                try:
                    write_atomic(path, render(), keep_previous=True)
                    self.writes += 1
                except OSError as exc:  # a full disk must not stop the flight
                    self.errors += 1
                    log.error("cannot save %s: %s", path, exc)
            with self._cond:
                self._busy = False
                self._cond.notify_all()

    def flush(self, timeout_s: float = CLOSE_TIMEOUT_S) -> bool:
        """Wait until everything submitted so far is on disk; False on time-out."""
        with self._cond:
            self._cond.notify_all()
            return self._cond.wait_for(lambda: not self._pending and not self._busy, timeout_s)

    def close(self, timeout_s: float = CLOSE_TIMEOUT_S) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._thread.join(timeout_s)
        if self._thread.is_alive():
            log.error("state files not all written within %.0f s", timeout_s)


class VehicleState:
    """Keeps one vehicle's files in step with its parameters and plans."""

    def __init__(self, writer: StateWriter, state_dir: Path, sysid: int, saved: Saved) -> None:
        self._writer = writer
        self._params_path = params_path(state_dir, sysid)
        self._plans_path = plans_path(state_dir, sysid)
        self.params = dict(saved.params)  # what clients set, over all boots
        self.plans = {t: tuple(items) for t, items in saved.plans.items()}

    def on_param(self, name: str, value: float) -> None:
        if name in INSTANCE_PARAMS:
            return
        self.params[name] = value
        snapshot = dict(self.params)
        self._writer.submit(self._params_path, lambda: _dump({"params": {
            k: _param_json(v) for k, v in sorted(snapshot.items())}}))

    def on_param_stored(self, name: str, value: float) -> None:
        """A value PX4 stores as no change (param_set_internal: to or from NaN): no autosave of
        its own; the next save writes it with the rest."""
        if name not in INSTANCE_PARAMS:
            self.params[name] = value

    def on_plan(self, plan_type: PlanType, items: tuple[PlanItem, ...]) -> None:
        if plan_type not in PLAN_KEYS:
            return
        self.plans[plan_type] = items
        snapshot = dict(self.plans)
        self._writer.submit(self._plans_path, lambda: _dump({
            PLAN_KEYS[t]: [list(astuple(item)) for item in snapshot[t]]
            for t in PLAN_KEYS if t in snapshot}))


def signing_path(state_dir: Path, first_sysid: int) -> Path:
    return state_dir / f"signing-{first_sysid}.json"


def load_signing(state_dir: Path, first_sysid: int, key: SigningKey,
                 ignore_unreadable: bool = False) -> SigningState:
    """The replay state saved for ``key`` (a fresh one for a new or another key)."""
    path = signing_path(state_dir, first_sysid)
    doc = _read(path, ignore_unreadable)
    if doc is None:
        return SigningState()
    if doc.get("key") != key.fingerprint:
        log.info("%s belongs to another signing key: starting its replay state afresh", path)
        return SigningState()
    try:
        return SigningState.from_doc(doc)
    except ValueError as exc:
        raise StateError(f"{path}: {exc}; repair or remove it") from None


class SigningKeeper:
    """Loads the key's replay state, then saves it while it changes (call ``save`` periodically
    and at stop)."""

    def __init__(self, writer: StateWriter, state_dir: Path, first_sysid: int, key: SigningKey,
                 ignore_unreadable: bool = False) -> None:
        self._writer = writer
        self._path = signing_path(state_dir, first_sysid)
        self._key = key.fingerprint
        self.state = load_signing(state_dir, first_sysid, key, ignore_unreadable)

    def save(self, now_s: float = 0.0) -> None:
        if self.state.changed:
            doc = {"key": self._key, **self.state.to_doc()}
            self._writer.submit(self._path, lambda: _dump(doc))


def _param_json(value: float) -> float | str:
    if math.isfinite(value):
        return value
    if math.isnan(value):  # another NaN than the usual one keeps its float32 bits
        bits = struct.unpack("<I", struct.pack("<f", value))[0]
        return "NaN" if bits == _NAN_BITS else f"NaN(0x{bits:08x})"
    return "Infinity" if value > 0 else "-Infinity"


def _param_value(text: str) -> float | str:
    """A parameter value written as a string: NON_FINITE or ``NaN(0x<float32 bits>)``; else the
    string itself (not a number)."""
    if text in NON_FINITE:
        return NON_FINITE[text]
    m = re.fullmatch(r"NaN\(0x([0-9a-f]{8})\)", text)
    if m:
        value = struct.unpack("<f", struct.pack("<I", int(m.group(1), 16)))[0]
        if math.isnan(value):
            return value
    return text


def _dump(doc: dict[str, Any]) -> str:
    return json.dumps({"version": FILE_VERSION, **doc}, indent=1) + "\n"


def restore_plans(vehicle: Vehicle, kept: VehicleState) -> None:
    """Give ``vehicle`` its saved plans, then keep every later change of them."""
    for plan_type, items in kept.plans.items():
        result = vehicle.set_plan(0.0, plan_type, items)
        if result is not PlanResult.ACCEPTED:
            log.warning("vehicle %d: saved %s refused (%s); not restored", vehicle.index + 1,
                        plan_type.name.lower(), result.name)

    def on_change(plan_type: PlanType) -> None:
        kept.on_plan(plan_type, vehicle.plan(plan_type))

    vehicle.autopilot.plans.on_change(on_change)
