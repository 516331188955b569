"""Start ``cornet run`` as a user does: a subprocess, ports shifted to a free offset."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field

from gateway.ports import free_port_offset, free_tcp_port  # noqa: F401 (re-exported)

READY_TIMEOUT_S = 30.0
STOP_TIMEOUT_S = 2.0


@dataclass
class Daemon:
    proc: subprocess.Popen
    offset: int
    vehicles: int
    ready_line: str
    stderr_lines: list[str] = field(default_factory=list)
    threads: list[threading.Thread] = field(default_factory=list)

    def api_port(self, index: int = 0) -> int:
        return 14540 + min(index, 9) + self.offset

    def gcs_port(self) -> int:
        return 14550 + self.offset

    def vehicle_port(self, index: int, kind: str) -> int:
        return (18570 if kind == "gcs" else 14580) + index + self.offset

    def stop(self) -> tuple[int, float]:
        """SIGTERM; returns (exit code, seconds it took)."""
        t0 = time.monotonic()
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            code = self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
        took = time.monotonic() - t0
        for t in self.threads:
            t.join(timeout=5)
        for stream in (self.proc.stdout, self.proc.stderr):
            if stream is not None and not stream.closed:
                stream.close()
        return code, took

    def log_tail(self, n: int = 40) -> str:
        return "\n".join(self.stderr_lines[-n:])


def cornet_command() -> list[str]:
    exe = os.path.join(os.path.dirname(sys.executable), "cornet")
    return [exe] if os.path.exists(exe) else [sys.executable, "-m", "gateway.cli"]


def start_daemon(*args: str, vehicles: int = 1) -> Daemon:
    offset = free_port_offset(vehicles)
    cmd = cornet_command() + ["run", "--vehicles", str(vehicles), "--port-offset", str(offset),
                              *args]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    daemon = Daemon(proc, offset, vehicles, "")

    def pump_stderr() -> None:
        for line in proc.stderr:
            daemon.stderr_lines.append(line.rstrip())

    ready = []

    def pump_stdout() -> None:
        for line in proc.stdout:
            if not ready and "ready" in line:
                ready.append(line.strip())

    daemon.threads = [threading.Thread(target=pump_stderr, daemon=True),
                      threading.Thread(target=pump_stdout, daemon=True)]
    for t in daemon.threads:
        t.start()
    deadline = time.monotonic() + READY_TIMEOUT_S
    while not ready and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    if not ready:
        daemon.stop()
        raise RuntimeError(f"daemon not ready: {' '.join(cmd)}\n{daemon.log_tail()}")
    daemon.ready_line = ready[0]
    return daemon
