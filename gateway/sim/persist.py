"""Parameters that survive a restart: one small JSON file per vehicle in the state directory.

PX4 saves every parameter change to its parameter file at once; so do we. A file holds only the
values that differ from the defaults (as PX4's does), keyed by name, so a newer parameter table
keeps working with old files. Writes are atomic (temporary file, fsync, rename, fsync of the
directory): after a crash the file is the old or the new one, never half of each.

Layout: ``<state_dir>/vehicle-<sysid>/params.json``.
"""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path

from vehicles.params import ParamStore

log = logging.getLogger(__name__)

FILE_VERSION = 1
# Set from the instance number at every boot, as PX4's rcS does; never taken from the file.
INSTANCE_PARAMS = ("MAV_SYS_ID",)


def params_path(state_dir: Path, sysid: int) -> Path:
    return Path(state_dir) / f"vehicle-{sysid}" / "params.json"


def load_saved(state_dir: Path, sysid: int) -> dict[str, float]:
    """Saved values for one vehicle; unknown names and bad values are skipped with a warning."""
    path = params_path(state_dir, sysid)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        return {}
    except (OSError, ValueError) as exc:
        log.warning("ignoring unreadable parameter file %s: %s", path, exc)
        return {}
    values = doc.get("params", {}) if isinstance(doc, dict) else {}
    out = {}
    for name, value in values.items():
        if name in INSTANCE_PARAMS or not isinstance(value, (int, float)):
            continue
        out[name] = value
    return out


def apply_saved(store: ParamStore, saved: dict[str, float], path: Path) -> None:
    for name, value in saved.items():
        try:
            known = store.set(name, value)
        except ValueError as exc:
            log.warning("%s: %s: %s; keeping the default", path, name, exc)
            continue
        if not known:
            log.warning("%s: no parameter %s any more; ignoring it", path, name)


def write_atomic(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


def save(store: ParamStore, state_dir: Path, sysid: int) -> None:
    changed = {k: v for k, v in store.changed_from_default().items() if k not in INSTANCE_PARAMS}
    doc = {"version": FILE_VERSION, "params": dict(sorted(changed.items()))}
    write_atomic(params_path(state_dir, sysid), json.dumps(doc, indent=1) + "\n")


def attach(store: ParamStore, state_dir: Path, sysid: int) -> None:
    """Load the saved values into ``store`` and save again on every later change."""
    path = params_path(state_dir, sysid)
    apply_saved(store, load_saved(state_dir, sysid), path)

    def on_change(name: str, value: float) -> None:
        if name in INSTANCE_PARAMS:
            return
        try:
            save(store, state_dir, sysid)
        except OSError as exc:  # a full disk must not stop the flight
            log.error("cannot save parameters to %s: %s", path, exc)

    store.on_change(on_change)
