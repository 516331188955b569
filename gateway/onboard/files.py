"""A vehicle's files as MAVLink FTP serves them (gateway/mavlink/ftp.py's FileRoot): its root
directory (``<state dir or run dir>/vehicle-<sysid>``: the logs under ``log/``, the saved
parameters and plans), like a PX4 SITL instance's rootfs, and PX4's read-only ROMFS
``etc/extras/`` (the component metadata of gateway/onboard/metadata.py) over it.

Rules:
- Paths are relative to the root; a leading "/" and PX4's "/fs/microsd" prefix both mean the
  root. A path that resolves outside the root (``..``, a symlink) is FileProtected.
- Errors follow PX4's MavlinkFTP: a missing file to open, read or list → FailErrno ENOENT
  (which the service sends as FileNotFound, as PX4 does); removing one → FileNotFound; creating
  a directory that exists → FileExists; other OS errors → FailErrno with their errno.
- A listing is PX4 SITL's readdir on Linux: "." and ".." first, then the entries by name; a
  symlink (or anything but a file or a directory) is listed, PX4's way, as a skip entry.
- ``etc``, ``etc/extras`` and its files exist whether or not there is a root directory; they
  are read-only as PX4's ROMFS (changing them → FailErrno EROFS). Without a root directory
  every other path is FileNotFound.
- ``attach_ftp(sim, roots_for)`` gives every link of every vehicle its files (the root is the
  first of ``roots_for(sysid)``) and lets the vehicle answer COMPONENT_METADATA.
"""

from __future__ import annotations

import errno
import os
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

from gateway.mavlink.ftp import (
    ERR_FAIL_ERRNO,
    ERR_FILE_EXISTS,
    ERR_FILE_NOT_FOUND,
    ERR_FILE_PROTECTED,
    FtpError,
)
from gateway.onboard import metadata

PX4_SD_PREFIX = "/fs/microsd"
DOTS = (("S", ".", 0), ("S", "..", 0))  # readdir's "." and "..": PX4 lists them as skip entries


def _errno(exc: OSError) -> FtpError:
    return FtpError(ERR_FAIL_ERRNO, (exc.errno or errno.EIO) & 0xFF)


class VehicleFiles:
    def __init__(self, root: Path | None,
                 extras: dict[str, bytes] | Callable[[], dict[str, bytes]] | None = None
                 ) -> None:
        """``extras``: the files of etc/extras, or what makes them at first use."""
        self.root = Path(root) if root is not None else None
        self._extras = extras

    @property
    def extras(self) -> dict[str, bytes]:
        extras = self._extras
        if callable(extras):
            extras = self._extras = extras()
        return extras or {}

    @staticmethod
    def _rel(path: str) -> str:
        if path.startswith(PX4_SD_PREFIX):
            path = path[len(PX4_SD_PREFIX):]
        return "/".join(p for p in path.split("/") if p not in ("", "."))

    def _rom(self, path: str) -> str | None:
        """``""`` for the directories of the ROMFS part, a file name under etc/extras, or None
        for a path outside it."""
        rel = self._rel(path)
        if rel in ("etc", metadata.EXTRAS_DIR):
            return ""
        if rel.startswith(metadata.EXTRAS_DIR + "/"):
            return rel[len(metadata.EXTRAS_DIR) + 1:]
        return None

    def _rom_file(self, path: str) -> bytes | None:
        name = self._rom(path)
        if name is None:
            return None
        if name == "":
            raise FtpError(ERR_FAIL_ERRNO, errno.EISDIR)
        data = self.extras.get(name)
        if data is None:
            raise FtpError(ERR_FAIL_ERRNO, errno.ENOENT)
        return data

    def _read_only(self, path: str) -> None:
        if self._rom(path) is not None:
            raise FtpError(ERR_FAIL_ERRNO, errno.EROFS)

    def _path(self, path: str) -> Path:
        if self.root is None:
            raise FtpError(ERR_FILE_NOT_FOUND)
        rel = self._rel(path)
        root = self.root.resolve()
        full = (root / rel).resolve()
        if full != root and root not in full.parents:
            raise FtpError(ERR_FILE_PROTECTED)
        return full

    def list(self, path: str) -> list[tuple[str, str, int]]:
        """(kind, name, size) as PX4's readdir loop sees them: "." and ".." first, then the
        entries by name; "F" a regular file, "D" a directory, "S" anything else (a symlink)."""
        rel = self._rel(path)
        if rel == "etc":
            return [*DOTS, ("D", "extras", 0)]
        if rel == metadata.EXTRAS_DIR:
            return [*DOTS, *(("F", name, len(data)) for name, data in sorted(self.extras.items()))]
        if self._rom(path) is not None:
            raise FtpError(ERR_FAIL_ERRNO, errno.ENOENT)
        out: list[tuple[str, str, int]] = [*DOTS, ("D", "etc", 0)] if rel == "" else []
        if self.root is None and rel == "":
            return out
        p = self._path(path)
        try:
            with os.scandir(p) as it:
                entries = sorted((e for e in it if not (rel == "" and e.name == "etc")),
                                 key=lambda e: e.name)
        except OSError as exc:
            raise _errno(exc) from None
        if rel != "":
            out.extend(DOTS)
        for entry in entries:
            try:
                if entry.is_file(follow_symlinks=False):
                    out.append(("F", entry.name, entry.stat().st_size))
                elif entry.is_dir(follow_symlinks=False):
                    out.append(("D", entry.name, 0))
                else:
                    out.append(("S", entry.name, 0))
            except OSError:
                out.append(("S", entry.name, 0))
        return out

    def size(self, path: str) -> int:
        data = self._rom_file(path)
        if data is not None:
            return len(data)
        p = self._path(path)
        try:
            if p.is_dir():
                raise FtpError(ERR_FAIL_ERRNO, errno.EISDIR)
            return p.stat().st_size
        except OSError as exc:
            raise _errno(exc) from None

    def read(self, path: str, offset: int, count: int) -> bytes:
        data = self._rom_file(path)
        if data is not None:
            return data[offset:offset + count]
        try:
            with open(self._path(path), "rb") as f:
                f.seek(offset)
                return f.read(count)
        except OSError as exc:
            raise _errno(exc) from None

    def write(self, path: str, offset: int, data: bytes) -> None:
        self._read_only(path)
        try:
            with open(self._path(path), "r+b") as f:
                f.seek(offset)
                f.write(data)
        except OSError as exc:
            raise _errno(exc) from None

    def create(self, path: str, exclusive: bool) -> None:
        self._read_only(path)
        p = self._path(path)
        try:  # open(2) with O_CREAT: a missing folder is ENOENT (FileNotFound), as PX4's
            with open(p, "xb" if exclusive else "wb"):
                pass
        except FileExistsError:
            raise FtpError(ERR_FILE_EXISTS) from None
        except OSError as exc:
            raise _errno(exc) from None

    def remove(self, path: str) -> None:
        self._read_only(path)
        try:
            self._path(path).unlink()
        except FileNotFoundError:
            raise FtpError(ERR_FILE_NOT_FOUND) from None
        except OSError as exc:
            raise _errno(exc) from None

    def mkdir(self, path: str) -> None:
        self._read_only(path)
        try:
            self._path(path).mkdir()
        except FileExistsError:
            raise FtpError(ERR_FILE_EXISTS) from None
        except OSError as exc:
            raise _errno(exc) from None

    def rmdir(self, path: str) -> None:
        self._read_only(path)
        p = self._path(path)
        if self.root is not None and p == self.root.resolve():
            raise FtpError(ERR_FILE_PROTECTED)
        try:
            p.rmdir()
        except FileNotFoundError:
            raise FtpError(ERR_FILE_NOT_FOUND) from None
        except OSError as exc:
            raise _errno(exc) from None

    def rename(self, old: str, new: str) -> None:
        self._read_only(old)
        self._read_only(new)
        try:
            shutil.move(self._path(old), self._path(new))
        except FileNotFoundError:
            raise FtpError(ERR_FILE_NOT_FOUND) from None
        except OSError as exc:
            raise _errno(exc) from None

    def truncate(self, path: str, size: int) -> None:
        self._read_only(path)
        try:
            os.truncate(self._path(path), size)
        except OSError as exc:
            raise _errno(exc) from None

    def crc32(self, path: str) -> int:
        """PX4's crc32part over the file (metadata.mavlink_crc32), chunk by chunk."""
        data = self._rom_file(path)
        if data is not None:
            return metadata.mavlink_crc32(data)
        value = 0
        try:
            with open(self._path(path), "rb") as f:
                while chunk := f.read(65536):
                    value = metadata.mavlink_crc32(chunk, value)
        except OSError as exc:
            raise _errno(exc) from None
        return value


def attach_ftp(sim: Any, roots_for: Callable[[int], list[Path]]) -> None:
    component = metadata.shared()
    for link in sim.links.values():
        session = link.session
        roots = roots_for(session.sysid)
        if roots:
            roots[0].mkdir(parents=True, exist_ok=True)
        session.ftp.root = VehicleFiles(roots[0] if roots else None, lambda: component.files)
        session.commands.component_metadata = component
