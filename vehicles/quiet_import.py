"""Import a C extension that prints when it loads, without letting it print.

PyBullet's module initialisation prints "pybullet build time: ..." from C (on standard output in
3.2.5 and 3.2.6, on standard error since): a ``cornet`` command's output must carry only what
the command says (the ready line, ``cornet check``'s summary). Python's ``sys.stdout`` cannot
catch a C printf, so descriptors 1 and 2 point at /dev/null for the import, and C's buffers are
flushed before they are restored."""

from __future__ import annotations

import ctypes
import importlib
import os
import sys
from types import ModuleType


def import_quietly(name: str) -> ModuleType:
    if name in sys.modules:
        return sys.modules[name]
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    try:
        saved = [os.dup(1), os.dup(2)]
    except OSError:  # no such descriptors: nothing to protect
        return importlib.import_module(name)
    libc = ctypes.CDLL(None)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        return importlib.import_module(name)
    finally:
        libc.fflush(None)  # what the import printed leaves C's buffers while they point nowhere
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)
