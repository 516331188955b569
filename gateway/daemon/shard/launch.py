"""Launching a sharded run: what can run sharded, the split of vehicles, the MPI job."""

from __future__ import annotations

import contextlib
import os
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import traceback
import uuid
from collections.abc import Callable
from pathlib import Path

from gateway.daemon.config import RunConfig
from gateway.daemon.sdnotify import socket_address

MPI_RANK_VARIABLES = ("PMI_RANK", "OMPI_COMM_WORLD_RANK", "PMIX_RANK")
MPI_MISSING = "--shards needs MPI (mpi4py and an MPI library): pip install 'cornet[mpi]'"
RELOAD_FLAG_VARIABLE = "CORNET_RELOAD_FLAG"  # the job's reload flag file (shard/reload.py)
ARMED_DIR_VARIABLE = "CORNET_ARMED_DIR"  # where the ranks say their handlers are in place
POLL_S = 0.05  # how often the launcher looks for held signals to relay


class ShardError(RuntimeError):
    def __init__(self, message: str, code: int = 1) -> None:
        super().__init__(message)
        self.code = code


def split(vehicles: int, shards: int) -> list[tuple[int, int]]:
    """(first vehicle, count) per shard: contiguous blocks, sizes differing by at most one."""
    base, extra = divmod(vehicles, shards)
    out, first = [], 0
    for k in range(shards):
        n = base + (1 if k < extra else 0)
        out.append((first, n))
        first += n
    return out


def check(config: RunConfig) -> str | None:
    """Why ``config`` cannot run sharded, or None."""
    if config.shards < 1:
        return "--shards must be at least 1"
    if config.shards > config.vehicles:
        return f"--shards {config.shards} is more than --vehicles {config.vehicles}"
    if config.shards == 1:
        return None
    if config.network.backend != "embedded":
        return "--shards needs the embedded network (an ns-3 engine runs in one process)"
    if "channel" in config.network.topology:
        return ("--shards: the scenario's network.channel is one medium every vehicle's frames "
                "queue on; it cannot be split across shards (run one process, or drop it)")
    return None


def in_mpi_job(environ: dict[str, str] | None = None) -> bool:
    """Whether this process was started by an MPI launcher (so it is a rank)."""
    env = os.environ if environ is None else environ
    return any(name in env for name in MPI_RANK_VARIABLES)


def abort_job(code: int) -> None:
    """In a rank that cannot start (a flag or file its host refuses, checked by each rank, as
    the ranks may run on other machines): end the whole job with ``code`` (MPI_Abort, which
    mpiexec turns into the end of every rank), rather than exit alone and leave the others
    waiting for it in the job's first exchange."""
    from mpi4py import MPI

    sys.stderr.flush()
    MPI.COMM_WORLD.Abort(code)


def end_job_if_rank(exc: BaseException) -> None:
    """``cornet run`` failing in a rank of an MPI job (a refused flag's SystemExit, code 2; an
    exception, code 1, its traceback printed): ``abort_job``. Elsewhere, or exit code 0:
    nothing."""
    if not in_mpi_job():
        return
    if isinstance(exc, SystemExit):
        if exc.code in (0, None):
            return
        abort_job(exc.code if isinstance(exc.code, int) else 2)
        return
    traceback.print_exception(exc)
    abort_job(1)


def mpiexec_command(shards: int, argv: list[str]) -> list[str]:
    """The MPI job that runs ``cornet <argv>`` with ``shards`` workers on this machine.
    Raises ShardError (code 2) when mpi4py or mpiexec is missing."""
    try:
        import mpi4py  # noqa: F401  (the package only; MPI starts in the ranks)
    except ImportError:
        raise ShardError(MPI_MISSING, 2) from None
    here = str(Path(sys.executable).parent)  # the venv's bin: where the mpich wheel puts it
    mpiexec = shutil.which("mpiexec", path=os.pathsep.join([here, os.environ.get("PATH", "")]))
    if mpiexec is None:
        raise ShardError("--shards needs mpiexec (none next to Python or on PATH): "
                         "pip install 'cornet[mpi]'", 2)
    return [mpiexec, "-n", str(shards + 1), sys.executable, "-m", "gateway.entry", *argv]


def _end_with_parent() -> None:
    """In the child before exec: SIGTERM when the launcher dies, even of SIGKILL (Linux)."""
    with contextlib.suppress(OSError, AttributeError):
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def mark_armed(environ: dict[str, str] | None = None) -> None:
    """In a rank of a job ``launch`` started: its signal handlers are in place (a file of its
    own in ``$CORNET_ARMED_DIR``), so the launcher may relay signals to it from now on."""
    env = os.environ if environ is None else environ
    directory = env.get(ARMED_DIR_VARIABLE)
    if directory:
        with contextlib.suppress(OSError):
            Path(directory, f"rank-{os.getpid()}").touch()


class _Relay:
    """The launcher's signals, relayed to the job (mpiexec forwards them to every rank) once
    every rank is armed (``mark_armed``). A rank still starting has Python's default handlers,
    or none yet: a SIGINT there ends it in a KeyboardInterrupt or Python's "Fatal Python
    error" while initialising, a SIGUSR1 or SIGTERM kills it, and mpiexec reports the job as
    failed. So a signal that comes before that is held and relayed as soon as every rank is
    armed, in the order it came; a second SIGINT or SIGTERM while one is held is relayed at
    once with everything held (the user insists: a rank that hangs while starting is ended).
    SIGHUP, of which mpiexec would die, is relayed as SIGUSR1 after the job's reload flag
    counts it (gateway/daemon/shard/reload.py)."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1, signal.SIGHUP)

    def __init__(self, ranks: int, flag: str, armed_dir: str) -> None:
        self.ranks = ranks
        self.flag = flag
        self.armed_dir = armed_dir
        self.job: subprocess.Popen | None = None
        self.held: list[int] = []
        self.hups = 0
        self._all_armed = False

    def install(self) -> None:
        for sig in self.SIGNALS:
            signal.signal(sig, self._on_signal)

    def uninstall(self) -> None:
        for sig in self.SIGNALS:
            signal.signal(sig, signal.SIG_DFL)

    def armed(self) -> bool:
        if not self._all_armed:
            with contextlib.suppress(OSError):
                self._all_armed = len(os.listdir(self.armed_dir)) >= self.ranks
        return self._all_armed

    def _on_signal(self, signum: int, frame: object) -> None:
        insists = signum in (signal.SIGINT, signal.SIGTERM) and any(
            s in (signal.SIGINT, signal.SIGTERM) for s in self.held)
        self.held.append(signum)
        if insists or self.armed():
            self.release()

    def poll(self) -> None:
        """Held signals relayed if every rank is armed now (called while the job runs)."""
        if self.held and self.armed():
            self.release()

    def release(self) -> None:
        held, self.held = self.held, []
        for signum in held:
            if signum == signal.SIGHUP:
                self.hups += 1
                with open(self.flag + ".tmp", "w") as f:
                    f.write(str(self.hups))
                os.replace(self.flag + ".tmp", self.flag)
                signum = signal.SIGUSR1
            if self.job is not None:
                with contextlib.suppress(ProcessLookupError):
                    self.job.send_signal(signum)


def launch(shards: int, argv: list[str]) -> int:
    """Run the MPI job as a child, in a session of its own, and relay the signals this process
    gets to mpiexec (``_Relay``): SIGINT, SIGTERM and SIGUSR1 as they are (mpiexec forwards
    them to every rank); SIGHUP as SIGUSR1 with the job's reload flag. The job's exit code
    (128 + n if it died of signal n). Raises ShardError."""
    command = mpiexec_command(shards, argv)
    job_dir = tempfile.mkdtemp(prefix="cornet-")
    flag = os.path.join(job_dir, "reload")
    armed_dir = os.path.join(job_dir, "armed")
    os.mkdir(armed_dir)
    sys.stdout.flush()
    sys.stderr.flush()
    relay = _Relay(shards + 1, flag, armed_dir)
    relay.install()
    notify, env = _notify_relay(dict(os.environ))
    try:
        relay.job = subprocess.Popen(
            command, env={**env, RELOAD_FLAG_VARIABLE: flag, ARMED_DIR_VARIABLE: armed_dir},
            start_new_session=True, preexec_fn=_end_with_parent)
        relay.poll()  # a signal that came before the job existed
        code = _wait(relay.job, relay.poll, notify, os.environ.get("NOTIFY_SOCKET", ""))
    finally:
        relay.uninstall()
        shutil.rmtree(job_dir, ignore_errors=True)
        if notify is not None:
            notify.close()
    return code if code >= 0 else 128 - code


def _notify_relay(environ: dict[str, str]) -> tuple[socket.socket | None, dict[str, str]]:
    """Under systemd ($NOTIFY_SOCKET): a socket of the launcher's that the ranks notify instead
    (rank 0's READY, RELOADING, STOPPING, WATCHDOG), relayed by the launcher — the unit's main
    pid, so NotifyAccess=main holds; and the job's environment. The watchdog's WATCHDOG_PID is
    the launcher's: rank 0 feeds it through the relay."""
    address = socket_address(environ.get("NOTIFY_SOCKET", ""))
    if address is None:
        return None, environ
    relay = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    name = f"cornet-notify-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    relay.bind("\0" + name)
    env = {**environ, "NOTIFY_SOCKET": "@" + name}
    env.pop("WATCHDOG_PID", None)
    return relay, env


def _wait(job: subprocess.Popen, poll: Callable[[], None], notify: socket.socket | None,
          notify_socket: str) -> int:
    """The job's exit code; meanwhile ``poll()`` every POLL_S, and the ranks' notifications
    relayed to systemd."""
    address = socket_address(notify_socket)
    if notify is None or address is None:
        while True:
            try:
                return job.wait(POLL_S)
            except subprocess.TimeoutExpired:
                poll()
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as out:
        while True:
            code = job.poll()
            while select.select([notify], [], [], 0.0 if code is not None else POLL_S)[0]:
                with contextlib.suppress(OSError):  # the last ones too (STOPPING=1)
                    out.sendto(notify.recv(4096), address)
                if code is None:
                    break
            if code is not None:
                return code
            poll()
