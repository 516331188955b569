"""Files that must never be half-written: write a temporary file, fsync, rename, fsync the
directory. After a crash the file is the old one or the new one, never a mix. With
``keep_previous`` the old one stays beside it as ``NAME.prev`` (the last good copy)."""

from __future__ import annotations

import os
from pathlib import Path

PREVIOUS_SUFFIX = ".prev"


def previous_path(path: Path) -> Path:
    return path.with_name(path.name + PREVIOUS_SUFFIX)


def _fsync_dir(directory: Path) -> None:
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _write_synced(path: Path, data: bytes) -> None:
    with open(path, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())


def write_atomic(path: Path, text: str, *, keep_previous: bool = False) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if keep_previous and path.exists():
        # A copy, not a rename: ``path`` itself is never missing, even for an instant.
        prev_tmp = path.with_name(path.name + PREVIOUS_SUFFIX + ".tmp")
        _write_synced(prev_tmp, path.read_bytes())
        os.replace(prev_tmp, previous_path(path))
    tmp = path.with_name(path.name + ".tmp")
    _write_synced(tmp, text.encode())
    os.replace(tmp, path)
    _fsync_dir(path.parent)
