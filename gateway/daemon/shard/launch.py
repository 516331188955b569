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
from pathlib import Path

from gateway.daemon.config import RunConfig
from gateway.daemon.sdnotify import socket_address

MPI_RANK_VARIABLES = ("PMI_RANK", "OMPI_COMM_WORLD_RANK", "PMIX_RANK")
MPI_MISSING = "--shards needs MPI (mpi4py and an MPI library): pip install 'cornet[mpi]'"
RELOAD_FLAG_VARIABLE = "CORNET_RELOAD_FLAG"  # the job's reload flag file (shard/reload.py)


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


def launch(shards: int, argv: list[str]) -> int:
    """Run the MPI job as a child, in a session of its own, and relay the signals this process
    gets to mpiexec: SIGINT, SIGTERM and SIGUSR1 as they are (mpiexec forwards them to every
    rank); SIGHUP — of which mpiexec would die — as SIGUSR1 after creating the job's reload flag
    (gateway/daemon/shard/reload.py). The job's exit code (128 + n if it died of signal n).
    Raises ShardError."""
    command = mpiexec_command(shards, argv)
    flag_dir = tempfile.mkdtemp(prefix="cornet-")
    flag = os.path.join(flag_dir, "reload")
    sys.stdout.flush()
    sys.stderr.flush()
    relayed = (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1, signal.SIGHUP)
    job: list[subprocess.Popen] = []
    hups = [0]

    def relay(signum: int, frame: object) -> None:
        if signum == signal.SIGHUP:
            hups[0] += 1
            with open(flag + ".tmp", "w") as f:
                f.write(str(hups[0]))
            os.replace(flag + ".tmp", flag)
            signum = signal.SIGUSR1
        if job:
            with contextlib.suppress(ProcessLookupError):
                job[0].send_signal(signum)

    for sig in relayed:
        signal.signal(sig, relay)
    notify, env = _notify_relay(dict(os.environ))
    try:
        job.append(subprocess.Popen(command, env={**env, RELOAD_FLAG_VARIABLE: flag},
                                    start_new_session=True, preexec_fn=_end_with_parent))
        code = _wait(job[0], notify, os.environ.get("NOTIFY_SOCKET", ""))
    finally:
        for sig in relayed:
            signal.signal(sig, signal.SIG_DFL)
        shutil.rmtree(flag_dir, ignore_errors=True)
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


def _wait(job: subprocess.Popen, notify: socket.socket | None, notify_socket: str) -> int:
    """The job's exit code; meanwhile, the ranks' notifications relayed to systemd."""
    address = socket_address(notify_socket)
    if notify is None or address is None:
        return job.wait()
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as out:
        while True:
            code = job.poll()
            while select.select([notify], [], [], 0.0 if code is not None else 0.2)[0]:
                with contextlib.suppress(OSError):  # the last ones too (STOPPING=1)
                    out.sendto(notify.recv(4096), address)
                if code is None:
                    break
            if code is not None:
                return code


