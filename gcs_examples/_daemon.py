"""`cornet run` as a subprocess on free ports, for the examples that start their own daemon."""

import contextlib
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from gateway.ports import free_port_offset, free_tcp_port  # noqa: F401 (re-exported)

ROOT = Path(__file__).resolve().parent.parent
READY_TIMEOUT_S = 60.0


class CornetDaemon:
    """``cornet run ... --port-offset K`` in its own session; stop() sends SIGTERM and waits."""

    def __init__(self, args: list[str], log_path: Path) -> None:
        self.offset = free_port_offset()
        exe = Path(sys.executable).parent / "cornet"
        cmd = ([str(exe)] if exe.exists() else [sys.executable, "-m", "gateway.cli"])
        self.cmd = cmd + ["run", "--port-offset", str(self.offset), *args]
        self.log_path = log_path
        self._log = open(log_path, "w")
        self.proc = subprocess.Popen(self.cmd, cwd=ROOT, stdout=subprocess.PIPE,
                                     stderr=self._log, text=True, start_new_session=True)
        self._ready = threading.Event()
        threading.Thread(target=self._pump, daemon=True).start()
        deadline = time.monotonic() + READY_TIMEOUT_S
        while not self._ready.wait(0.1):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"daemon not ready: {' '.join(self.cmd)}\n{self.log_tail()}")

    def _pump(self) -> None:
        for line in self.proc.stdout:
            self._log.write(line)
            if "ready" in line:
                self._ready.set()

    @property
    def api_port(self) -> int:
        return 14540 + self.offset

    @property
    def gcs_port(self) -> int:
        return 14550 + self.offset

    def log_tail(self, n: int = 20) -> str:
        self._log.flush()
        with contextlib.suppress(OSError):
            return "\n".join(self.log_path.read_text().splitlines()[-n:])
        return ""

    def stop(self) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            code = self.proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
        self._log.close()
        return code
