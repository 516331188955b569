"""The engine program the ns-3 backend drives: where its build is, how its child process is
tied to the daemon, the errors it raises, and the node kinds its network knows by name."""

from __future__ import annotations

import pathlib
import re
import sys

HERE = pathlib.Path(__file__).resolve().parent
BINARY = HERE / "build" / "cornet-ns3"


class Ns3Error(RuntimeError):
    """The engine is missing, refused a request, or was lost with ``strict=True``."""


class Ns3BuildMissing(Ns3Error):
    pass


def build_missing_message(binary: pathlib.Path = BINARY) -> str:
    return (f"ns-3 build missing: {binary} not found; run `make ns3` "
            "(needs libns3-dev, libzmq3-dev, cppzmq-dev, libgsl-dev: `make ns3-deps`)")


def die_with_parent() -> None:
    """In the engine's child process (Linux): SIGTERM it when the daemon dies, so a crash of
    the daemon or a backend that was never closed leaves no engine behind."""
    if sys.platform.startswith("linux"):
        import ctypes
        import signal

        pr_set_pdeathsig = 1
        ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, int(signal.SIGTERM))


def node_kind(name: str) -> str:
    if re.fullmatch(r"v\d+", name):
        return "vehicle"
    if re.fullmatch(r"ap\d*", name):  # "ap", "ap2" — not "api1", an API client
        return "ap"
    return "ground"
