"""The engine program the ns-3 backend drives: where its build is, its child process and the
REQ socket to it (``EngineProcess``), the errors it raises, and the node kinds its network
knows by name.

Rules:
- The bridge's REQ socket binds an ``ipc://`` endpoint in a private temporary directory; the
  engine, started with that endpoint as its only argument, connects a REP socket. The child dies
  with its parent (Linux), and never sees the user's NS_LOG.
- ``request`` waits up to a timeout of wall seconds in slices, noticing a dead engine early;
  ``send_nowait``/``poll``/``read_reply`` are the same exchange without waiting. A reply that is
  an error, or of another protocol version, raises Ns3Error.
- ``release`` stops the process and frees the socket and directory; it is idempotent.
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile
from typing import Any

import zmq

HERE = pathlib.Path(__file__).resolve().parent
BINARY = HERE / "build" / "cornet-ns3"
PROTOCOL_VERSION = 1
POLL_SLICE_MS = 50  # a blocking request waits in slices, to notice a dead engine early


class Ns3Error(RuntimeError):
    """The engine is missing, refused a request, or was lost with ``strict=True``."""


class Ns3BuildMissing(Ns3Error):
    pass


NS3_DEBS = "libns3-dev libzmq3-dev cppzmq-dev libgsl-dev pkg-config g++"


def build_missing_message(binary: pathlib.Path = BINARY) -> str:
    """Where the build is missing and how to make it, in a checkout (`make ns3`) and in an
    installed package alike: the sources and their Makefile are next to this module."""
    return (f"ns-3 build missing: {binary} not found; build it with `make -C {HERE}` (`make ns3` "
            f"in a checkout), after Debian's ns-3 3.37 development files: `apt-get install "
            f"{NS3_DEBS}` (`make ns3-deps`)")


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
    if re.fullmatch(r"enb\d*", name):  # an LTE base station
        return "enb"
    return "ground"


class EngineProcess:
    """One engine child process and the socket to it (module rules)."""

    def __init__(self, engine: str, binary: pathlib.Path) -> None:
        self.engine = engine
        self._proc: subprocess.Popen | None = None
        self._released = False
        self._tmpdir = tempfile.mkdtemp(prefix="cornet-ns3-")
        self._ctx = zmq.Context()
        self._sock = self._ctx.socket(zmq.REQ)
        self._sock.setsockopt(zmq.LINGER, 0)
        # After a timeout we never send on this socket again, but these keep REQ usable.
        self._sock.setsockopt(zmq.REQ_RELAXED, 1)
        self._sock.setsockopt(zmq.REQ_CORRELATE, 1)
        self.endpoint = f"ipc://{self._tmpdir}/engine.sock"
        try:
            self._sock.bind(self.endpoint)
            self._spawn(binary)
        except BaseException:
            self.release()
            raise

    def _command(self, binary: pathlib.Path) -> list[str]:
        if self.engine == "reference":
            return [sys.executable, "-m", "netsim.ns3.reference_engine", self.endpoint]
        if not binary.is_file():
            raise Ns3BuildMissing(build_missing_message(binary))
        return [str(binary), self.endpoint]

    def _spawn(self, binary: pathlib.Path) -> None:
        env = dict(os.environ)
        # ns-3 reads NS_LOG in static constructors, before main: a user's NS_LOG=* would flood
        # stderr with every component's log and slow each cycle by orders of magnitude.
        env.pop("NS_LOG", None)
        root = str(HERE.parent.parent)
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [root, env.get("PYTHONPATH")]))
        self._proc = subprocess.Popen(self._command(binary), env=env, stdin=subprocess.DEVNULL,
                                      stdout=subprocess.DEVNULL, preexec_fn=die_with_parent)

    def running(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    def gone(self) -> str | None:
        if self._proc is not None and self._proc.poll() is not None:
            return f"engine process exited with code {self._proc.returncode}"
        return None

    def request(self, message: dict[str, Any], timeout_s: float) -> dict[str, Any] | None:
        """Send and wait up to ``timeout_s`` wall seconds; None if the engine died or hung."""
        # Blocking send: the engine process may not have connected yet (a REQ socket with no
        # peer holds the message); a timeout here means it never did.
        self._sock.setsockopt(zmq.SNDTIMEO, max(1, int(timeout_s * 1e3)))
        try:
            self._sock.send(json.dumps(message).encode())
        except zmq.Again:
            return None
        waited_ms = 0
        while waited_ms < timeout_s * 1e3:
            if self._sock.poll(POLL_SLICE_MS):
                return self.read_reply()
            waited_ms += POLL_SLICE_MS
            if self.gone():
                return None
        return None

    def send_nowait(self, message: dict[str, Any]) -> bool:
        """Send without waiting; False when no engine is connected any more."""
        try:
            self._sock.send(json.dumps(message).encode(), zmq.NOBLOCK)
        except zmq.Again:
            return False
        return True

    def poll(self, timeout_ms: int) -> bool:
        """Wait up to ``timeout_ms`` for a reply to be readable."""
        return bool(self._sock.poll(timeout_ms))

    def read_reply(self) -> dict[str, Any]:
        reply = json.loads(self._sock.recv())
        if reply.get("op") == "error":
            raise Ns3Error(f"{self.engine} engine refused a request: {reply.get('error')}")
        if reply.get("v") != PROTOCOL_VERSION:
            raise Ns3Error(f"{self.engine} engine speaks protocol {reply.get('v')}, "
                           f"not {PROTOCOL_VERSION}")
        return reply

    def stop(self) -> None:
        proc = self._proc
        if proc is None or proc.poll() is not None:
            return
        proc.terminate()
        try:
            proc.wait(timeout=2.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()

    def release(self) -> None:
        if self._released:
            return
        self._released = True
        self.stop()
        if self._proc is not None and self._proc.poll() is None:
            self._proc.wait()
        self._sock.close(linger=0)
        self._ctx.term()
        shutil.rmtree(self._tmpdir, ignore_errors=True)
