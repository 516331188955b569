"""Start ``cornet run`` as a user does: the one launcher of the daemon for tests, benches, the
pytest plugin and the examples.

A subprocess on a free ``--port-offset`` (gateway/ci/ports.py); ``start_daemon`` returns once the
daemon printed its ``cornet ready`` line. Its output is kept (``stdout_lines``,
``stderr_lines``; ``log_tail`` shows the end of both); ``stop()`` sends SIGTERM, waits, and
returns the exit code (``stop_took_s`` says how long it took).
"""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
import time
import weakref
from collections import deque
from collections.abc import Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING

from gateway.ci.ports import (
    API_CLIENT_PORT,
    GCS_CLIENT_PORT,
    free_port_offset,
    free_tcp_port,  # noqa: F401 (re-exported: tests and examples bind client ports with it)
)

if TYPE_CHECKING:
    from gateway.ci.checks import FlightLogView

__all__ = ["CornetDaemon", "cornet_command", "free_port_offset", "free_tcp_port", "start_daemon"]

READY_TIMEOUT_S = 30.0
STOP_TIMEOUT_S = 10.0
READY_PREFIX = "cornet ready"
# PX4 SITL's vehicle-side ports (px4_ports in gateway/sim/simulation.py) before the offset.
VEHICLE_GCS_PORT = 18570
VEHICLE_API_PORT = 14580
RADIO_PORT_STRIDE = 1000  # extra radio r (1-based): VEHICLE_GCS_PORT + r·stride + i
# Every daemon this process started, while it exists: a test suite can look at all of them
# (e.g. that none of them logged a traceback).
STARTED: weakref.WeakSet[CornetDaemon] = weakref.WeakSet()


def cornet_command() -> list[str]:
    """``cornet`` next to this interpreter (a venv's bin/), else ``python -m gateway.entry``."""
    exe = Path(sys.executable).with_name("cornet")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "gateway.entry"]


def option(args: Sequence[str], name: str) -> str | None:
    """The value of ``name`` in a command line (``--flag V`` or ``--flag=V``), or None."""
    for k, a in enumerate(args):
        if a == name and k + 1 < len(args):
            return args[k + 1]
        if a.startswith(name + "="):
            return a.split("=", 1)[1]
    return None


class CornetDaemon:
    """A running ``cornet run``; see :func:`start_daemon`."""

    def __init__(self, proc: subprocess.Popen, command: list[str], offset: int, vehicles: int,
                 log_dir: Path | None, output_file: Path | None = None) -> None:
        self.proc, self.command, self.offset, self.vehicles = proc, command, offset, vehicles
        self.log_dir = log_dir
        self.output_file = output_file  # every line of stdout and stderr is also written here
        self._file = None if output_file is None else open(output_file, "w")  # noqa: SIM115
        self._file_lock = threading.Lock()
        self.started_at = time.monotonic()
        self.ready_at = float("nan")  # time.monotonic() when the ready line came
        self.ready_line = ""
        self.returncode: int | None = None
        self.stop_took_s = float("nan")
        self.stdout_lines: list[str] = []
        self.stderr_lines: list[str] = []
        self.output: deque[str] = deque(maxlen=200)  # the last lines of stdout and stderr
        self._ready = threading.Event()
        self._threads = [threading.Thread(target=self._pump, args=(s, s is proc.stdout),
                                          name="cornet-daemon-output", daemon=True)
                         for s in (proc.stdout, proc.stderr)]
        for t in self._threads:
            t.start()
        STARTED.add(self)

    def _pump(self, stream: IO[str], is_stdout: bool) -> None:
        lines = self.stdout_lines if is_stdout else self.stderr_lines
        try:
            for line in stream:
                line = line.rstrip()
                lines.append(line)
                self.output.append(line)
                if self._file is not None:
                    with self._file_lock:
                        self._file.write(line + "\n")
                        self._file.flush()
                if is_stdout and not self._ready.is_set() and line.startswith(READY_PREFIX):
                    self.ready_line = line
                    self.ready_at = time.monotonic()
                    self._ready.set()
        except (OSError, ValueError):  # the stream was closed under us
            pass

    # --- where clients connect ------------------------------------------------------------------
    def mavsdk_port(self, index: int = 0) -> int:
        """The UDP port vehicle ``index`` sends its MAVSDK (onboard API) link to."""
        return API_CLIENT_PORT + min(index, 9) + self.offset

    api_port = mavsdk_port

    def mavsdk_url(self, index: int = 0) -> str:
        """For MAVSDK's ``System.connect(system_address=...)``."""
        return f"udpin://0.0.0.0:{self.mavsdk_port(index)}"

    def gcs_port(self) -> int:
        """The UDP port every vehicle sends its GCS link to (QGroundControl's 14550, shifted)."""
        return GCS_CLIENT_PORT + self.offset

    def gcs_url(self) -> str:
        """The GCS link in MAVSDK's form (every vehicle; QGroundControl listens there)."""
        return f"udpin://0.0.0.0:{self.gcs_port()}"

    def pymavlink_url(self, index: int | None = None) -> str:
        """For pymavlink's ``mavlink_connection`` (its own form, ``udpin:HOST:PORT``):
        the GCS link of every vehicle, or with ``index`` that vehicle's API link."""
        port = self.gcs_port() if index is None else self.mavsdk_port(index)
        return f"udpin:0.0.0.0:{port}"

    def vehicle_port(self, index: int, kind: str) -> int:
        """The port vehicle ``index`` binds for its ``"gcs"`` or ``"api"`` link."""
        return (VEHICLE_GCS_PORT if kind == "gcs" else VEHICLE_API_PORT) + index + self.offset

    def radio_port(self, index: int, radio: int = 1) -> int:
        """The port vehicle ``index`` binds for extra radio number ``radio`` (1-based, in the
        scenario's ``extra_radios`` order; gateway/sim/radios.py)."""
        return VEHICLE_GCS_PORT + RADIO_PORT_STRIDE * radio + index + self.offset

    @property
    def run_dir(self) -> Path:
        """This daemon's flight-log directory (``log_dir/run-<date>-<time>``)."""
        if self.log_dir is None:
            raise FileNotFoundError("this daemon was started with log_dir=None")
        from gateway.sim.flightlog import resolve_run_dir

        return resolve_run_dir(self.log_dir)

    def log(self) -> FlightLogView:
        """Its flight logs as they are on disk now (flushed every simulated second; all of it
        once :meth:`stop` returned)."""
        from gateway.ci.checks import FlightLogView

        return FlightLogView(self.run_dir)

    def log_tail(self, n: int = 40) -> str:
        return "\n".join(list(self.output)[-n:])

    def tracebacks(self) -> list[str]:
        """Python tracebacks in the daemon's log so far, each as its text (a daemon under test
        should have none: every failure it expects is a logged line, not a traceback)."""
        found: list[str] = []
        lines = list(self.stderr_lines)
        for k, line in enumerate(lines):
            if line.startswith("Traceback (most recent call last)"):
                end = k + 1
                while end < len(lines) and (lines[end].startswith((" ", "\t")) or not lines[end]):
                    end += 1
                found.append("\n".join(lines[max(0, k - 1):end + 1]))
        return found

    # --- lifetime -------------------------------------------------------------------------------
    def wait_ready(self, timeout_s: float) -> bool:
        deadline = time.monotonic() + timeout_s
        while not self._ready.wait(0.02):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                break
        return self._ready.is_set()

    @property
    def running(self) -> bool:
        return self.proc.poll() is None

    def stop(self, timeout_s: float = STOP_TIMEOUT_S) -> int:
        """SIGTERM (the daemon flushes its logs and exits 0); killed after ``timeout_s``.
        Returns the exit code; calling it again returns the same code."""
        if self.returncode is not None:
            return self.returncode
        t0 = time.monotonic()
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            code = self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
            self.output.append(f"[killed after {timeout_s:g} s without exiting on SIGTERM]")
        self.stop_took_s = time.monotonic() - t0
        for t in self._threads:
            t.join(timeout=5)
        for stream in (self.proc.stdout, self.proc.stderr):
            if stream is not None and not stream.closed:
                stream.close()
        if self._file is not None:
            with self._file_lock:
                self._file.close()
        self.returncode = code
        return code

    def __enter__(self) -> CornetDaemon:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def __repr__(self) -> str:
        state = "running" if self.returncode is None else f"exited {self.returncode}"
        return f"<CornetDaemon port-offset {self.offset}, {self.vehicles} vehicle(s), {state}>"


def start_daemon(*args: str, vehicles: int | None = None, log_dir: str | Path | None = None,
                 ready_timeout_s: float = READY_TIMEOUT_S, attempts: int = 3,
                 env: dict[str, str] | None = None, port_offset: int | None = None,
                 cwd: str | Path | None = None, output_file: str | Path | None = None
                 ) -> CornetDaemon:
    """Start ``cornet run [--vehicles N] --port-offset K [--log-dir DIR] ARGS`` and wait for its
    ``ready`` line. ``vehicles``: also read from ``args`` (``--vehicles``); default 1 (or what
    the ``--scenario`` says). ``port_offset``: use this one (the caller bound client ports
    there); otherwise a free one, and another if a port is taken in the meantime.
    ``output_file``: the daemon's output is also written there, line by line."""
    argv = [str(a) for a in args]
    if option(argv, "--port-offset") is not None:
        raise ValueError("start_daemon picks --port-offset itself (or pass port_offset=)")
    given = option(argv, "--vehicles")
    if given is not None and vehicles is not None and int(given) != vehicles:
        raise ValueError(f"vehicles={vehicles} but --vehicles {given}")
    n = int(given) if given is not None else vehicles
    extra = [] if n is None or given is not None else ["--vehicles", str(n)]
    if log_dir is not None:
        if option(argv, "--log-dir") is not None:
            raise ValueError("--log-dir given twice")
        Path(log_dir).mkdir(parents=True, exist_ok=True)
        extra += ["--log-dir", str(log_dir)]
    else:
        log_dir = option(argv, "--log-dir")
    tried: list[int] = []
    for _ in range(1 if port_offset is not None else attempts):
        offset = port_offset if port_offset is not None else free_port_offset(n or 1, skip=tried)
        tried.append(offset)
        cmd = cornet_command() + ["run", *extra, "--port-offset", str(offset), *argv]
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                env=env, stdin=subprocess.DEVNULL, cwd=cwd)
        daemon = CornetDaemon(proc, cmd, offset, n or 1,
                              None if log_dir is None else Path(log_dir),
                              None if output_file is None else Path(output_file))
        if daemon.wait_ready(ready_timeout_s):
            return daemon
        exited_at_start = not daemon.running
        daemon.stop()
        if "already in use" not in daemon.log_tail():
            break
    if exited_at_start:
        raise RuntimeError(f"cornet run exited with code {daemon.returncode} before it was ready: "
                           f"{' '.join(cmd)}\n{daemon.log_tail()}")
    raise RuntimeError(f"cornet run was not ready within {ready_timeout_s:g} s "
                       f"(stopped; exit code {daemon.returncode}): {' '.join(cmd)}\n"
                       f"{daemon.log_tail()}")
