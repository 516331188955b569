"""A vehicle's files as MAVLink FTP serves them (gateway/mavlink/ftp.py's FileRoot): its root
directory (``<state dir or run dir>/vehicle-<sysid>``: the logs under ``log/``, the saved
parameters and plans), like a PX4 SITL instance's rootfs.

Rules:
- Paths are relative to the root; a leading "/" and PX4's "/fs/microsd" prefix both mean the
  root. A path that resolves outside the root (``..``, a symlink) is FileProtected.
- Errors follow PX4's MavlinkFTP: a missing file to open, read or list → FailErrno ENOENT;
  removing one → FileNotFound; creating a directory that exists → FileExists; other OS errors
  → FailErrno with their errno.
- ``attach_ftp(sim, roots_for)`` gives every link of every vehicle its root (the first of
  ``roots_for(sysid)``); with none, FTP answers FileNotFound.
"""

from __future__ import annotations

import errno
import os
import shutil
import zlib
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

PX4_SD_PREFIX = "/fs/microsd"


def _errno(exc: OSError) -> FtpError:
    return FtpError(ERR_FAIL_ERRNO, (exc.errno or errno.EIO) & 0xFF)


class VehicleFiles:
    def __init__(self, root: Path) -> None:
        self.root = Path(root)

    def _path(self, path: str) -> Path:
        if path.startswith(PX4_SD_PREFIX):
            path = path[len(PX4_SD_PREFIX):]
        rel = path.lstrip("/")
        root = self.root.resolve()
        full = (root / rel).resolve()
        if full != root and root not in full.parents:
            raise FtpError(ERR_FILE_PROTECTED)
        return full

    def list(self, path: str) -> list[tuple[bool, str, int]]:
        p = self._path(path)
        try:
            names = sorted(os.listdir(p))
        except OSError as exc:
            raise _errno(exc) from None
        out = []
        for name in names:
            try:
                st = (p / name).stat()
            except OSError:
                continue
            is_dir = (p / name).is_dir()
            out.append((is_dir, name, 0 if is_dir else st.st_size))
        return out

    def size(self, path: str) -> int:
        p = self._path(path)
        try:
            if p.is_dir():
                raise FtpError(ERR_FAIL_ERRNO, errno.EISDIR)
            return p.stat().st_size
        except OSError as exc:
            raise _errno(exc) from None

    def read(self, path: str, offset: int, count: int) -> bytes:
        try:
            with open(self._path(path), "rb") as f:
                f.seek(offset)
                return f.read(count)
        except OSError as exc:
            raise _errno(exc) from None

    def write(self, path: str, offset: int, data: bytes) -> None:
        try:
            with open(self._path(path), "r+b") as f:
                f.seek(offset)
                f.write(data)
        except OSError as exc:
            raise _errno(exc) from None

    def create(self, path: str, exclusive: bool) -> None:
        p = self._path(path)
        try:
            p.parent.mkdir(parents=True, exist_ok=True)
            with open(p, "xb" if exclusive else "wb"):
                pass
        except FileExistsError:
            raise FtpError(ERR_FILE_EXISTS) from None
        except OSError as exc:
            raise _errno(exc) from None

    def remove(self, path: str) -> None:
        try:
            self._path(path).unlink()
        except FileNotFoundError:
            raise FtpError(ERR_FILE_NOT_FOUND) from None
        except OSError as exc:
            raise _errno(exc) from None

    def mkdir(self, path: str) -> None:
        try:
            self._path(path).mkdir()
        except FileExistsError:
            raise FtpError(ERR_FILE_EXISTS) from None
        except OSError as exc:
            raise _errno(exc) from None

    def rmdir(self, path: str) -> None:
        p = self._path(path)
        if p == self.root.resolve():
            raise FtpError(ERR_FILE_PROTECTED)
        try:
            p.rmdir()
        except FileNotFoundError:
            raise FtpError(ERR_FILE_NOT_FOUND) from None
        except OSError as exc:
            raise _errno(exc) from None

    def rename(self, old: str, new: str) -> None:
        try:
            shutil.move(self._path(old), self._path(new))
        except FileNotFoundError:
            raise FtpError(ERR_FILE_NOT_FOUND) from None
        except OSError as exc:
            raise _errno(exc) from None

    def truncate(self, path: str, size: int) -> None:
        try:
            os.truncate(self._path(path), size)
        except OSError as exc:
            raise _errno(exc) from None

    def crc32(self, path: str) -> int:
        """PX4's crc32part (and MAVSDK's): the CRC-32 polynomial starting at 0, no final XOR.
        zlib's crc32 inverts before and after, so start it at ~0 and invert its result."""
        value = 0xFFFFFFFF
        try:
            with open(self._path(path), "rb") as f:
                while chunk := f.read(65536):
                    value = zlib.crc32(chunk, value)
        except OSError as exc:
            raise _errno(exc) from None
        return ~value & 0xFFFFFFFF


def attach_ftp(sim: Any, roots_for: Callable[[int], list[Path]]) -> None:
    for link in sim.links.values():
        session = link.session
        roots = roots_for(session.sysid)
        if roots:
            roots[0].mkdir(parents=True, exist_ok=True)
            session.ftp.root = VehicleFiles(roots[0])
