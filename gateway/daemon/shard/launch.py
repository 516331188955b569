"""Launching a sharded run: what can run sharded, the split of vehicles, the MPI job."""

from __future__ import annotations

import os
import shutil
import signal
import sys
from pathlib import Path

from gateway.daemon.app import RunConfig

MPI_RANK_VARIABLES = ("PMI_RANK", "OMPI_COMM_WORLD_RANK", "PMIX_RANK")
MPI_MISSING = "--shards needs MPI (mpi4py and an MPI library): pip install 'cornet[mpi]'"
UNSUPPORTED_WITH_SHARDS: tuple[str, ...] = ()  # every --flag of one process works sharded


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
    for key in UNSUPPORTED_WITH_SHARDS:
        if getattr(config, key) is not None:
            return f"--{key.replace('_', '-')} is not supported with --shards > 1 yet"
    return None


def in_mpi_job(environ: dict[str, str] | None = None) -> bool:
    """Whether this process was started by an MPI launcher (so it is a rank)."""
    env = os.environ if environ is None else environ
    return any(name in env for name in MPI_RANK_VARIABLES)


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
    return [mpiexec, "-n", str(shards + 1), sys.executable, "-m", "gateway.cli", *argv]


def launch(shards: int, argv: list[str]) -> None:
    """Replace this process with the MPI job (signals sent to this pid reach mpiexec, which
    forwards SIGINT/SIGTERM to every rank; its exit code is the job's; SIGHUP is ignored).
    Raises ShardError."""
    command = mpiexec_command(shards, argv)
    # Hydra's mpiexec dies of SIGHUP, taking the job with it; reloading is not supported
    # sharded, so the job ignores it (an ignored signal stays ignored across exec).
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(command[0], command)


