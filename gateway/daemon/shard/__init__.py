"""Sharded daemon: the vehicles split across the ranks of an MPI job, kept in lockstep.

``cornet run --vehicles N --shards K`` runs one MPI job of K + 1 ranks. Rank 0 is the
coordinator: it prints the ready and status lines, keeps the workers' simulated clocks together
and carries every vehicle's position to every worker, so distance-based network models see all
vehicles. Rank k (1..K) is the worker of shard k - 1: it simulates a contiguous block of
vehicles in its own PyBullet world and event kernel, binds those vehicles' PX4 ports itself and
paces itself on the wall clock — the same ``Daemon`` as one process runs, given
``first_vehicle`` and its share of ``vehicles``.

On one machine ``cornet run --shards K`` runs ``mpiexec -n K+1 <python> -m gateway.entry run
<the same arguments>`` as its child (the mpiexec next to the Python interpreter first: the
``mpich`` wheel's, from ``pip install 'cornet[mpi]'``) and stays its parent: it relays SIGINT,
SIGTERM and SIGUSR1 to mpiexec (which forwards them to every rank), turns SIGHUP — of which
mpiexec dies — into a reload (reload.py), and exits with the job's code. Every rank runs the
same command line; ``cornet run`` started by an MPI launcher (PMI_RANK, OMPI_COMM_WORLD_RANK or
PMIX_RANK in its environment) is a rank, not a launcher. So across machines one runs
``mpiexec -n K+1 -hosts a,b cornet run ... --shards K`` directly (docs/scaling.md).

Messages (MPI point-to-point between rank 0 and each worker; every message one small dict,
pickled by mpi4py; sends are ``isend``, receives are found with ``improbe`` when the sender
rings the receiver's doorbell, a loopback UDP socket (ranks of one host), or at the next poll
(channel.py), so no MPI call ever blocks an event loop — MPICH's blocking calls would spin a
core):

  worker → coordinator
    {"ready": k}                          ports bound, simulation built, simulated t = 0
    {"error": text, "code": 2}            could not start (e.g. a port in use); it exits
    {"sync": t, "positions": {node: (n, e, d)}, "next": t', "bus": [(topic, body), ...]}
                                          reached the sync point t (every sync period of the
                                          network, the CORNET mobility update); its vehicles'
                                          world-frame positions at t; the next sync point t';
                                          with --zmq-pub, what it published since the last one
    {"metrics": [Metric, ...]}            with --metrics-port: its snapshot, every second
    {"finished": t}                       ran every event up to --duration; waits for "stop"
    {"status": {counter: value}, "t": t}  every status period (wall), for the status line
    {"interrupt": true}                   it got SIGINT or SIGTERM: please stop everyone
    {"stopped": {counter: value}, "t": t} after a stop: final counters; then it exits 0
  coordinator → worker
    {"setup": {"boot_unix_s": e, "run_dir": path or None}}
                                          first: the run's provisional epoch (simulated t = 0
                                          on the wall clock: logs, signing) and --log-dir's
                                          run directory
    {"horizon": h, "priority": p, "t": t, "positions": {...}}
                                          every vehicle was at these positions at sync point t;
                                          run up to h = t' (events at h itself only up to
                                          priority p: physics and the mobility update);
                                          the first (t = 0) also "epoch": the wall clock as
                                          it lets time run, the run's epoch from then on
    {"wants_packets": bool}               --zmq-pub: someone subscribes to cornet.packet (or
                                          no longer): build packet events (or stop)
    {"stop": true}

This is a gather and a broadcast per sync point, written as point-to-point messages because
they must not block: a worker keeps simulating (up to its horizon) and serving UDP while its
report travels.

Lockstep rule: a worker is held right after its mobility update of sync point t (the physics
steps of instant t have run, nothing else of that instant). When every worker has reported t,
each gets every vehicle's position at t — its network sees them before any later event, exactly
as one process, which pushes all vehicles' positions at t at once — and the horizon of the next
sync point t + δ (δ = the sync period), where it is held the same way. So no two shards are
ever more than δ apart in simulated time, and a shard that falls behind holds the others (they
slip, as one overloaded process would). With ``--duration S`` the last horizon is S itself, all
of it; each worker reports "finished" and the coordinator stops everyone.

Logs: the coordinator chooses --log-dir's run directory and the epoch; each worker writes its
vehicles' tlogs and onboard logs there, and its part of the files that hold every vehicle
(meta.json, state.csv, packets.trace, --packet-trace FILE) as ``NAME.shard<k>``; once every
worker has stopped, the coordinator merges the parts into the files one process writes
(gateway/sim/logparts.py). Same scenario, seed and --duration with no clients: the same logs
from one process or K shards (tests/e2e/test_shards.py), but for the wall-clock epoch.
--state-dir is per vehicle: each worker keeps its own vehicles.

--zmq-pub, --metrics-port and --web are the coordinator's: one socket, one HTTP server, one
live view for every vehicle, fed by the workers' batches and snapshots (outlets.py; a port in
use: exit 2).

SIGHUP (relayed by the launcher as SIGUSR1 with a new count in the job's reload flag file):
the coordinator re-reads the configuration file and sends its network and wind with the next
grant; every worker swaps them in at that sync point (reload.py). RELOADING=1, then READY=1 once
every shard runs the new network.

Stopping: mpiexec forwards SIGINT and SIGTERM to every rank. The coordinator then sends
"stop" to every worker; a worker that gets the signal asks the coordinator to ("interrupt"),
so one signalled rank is enough. Workers answer with their final counters, the coordinator
logs the stop line, every rank exits 0; a rank whose run has ended ignores the signals that
reach it late (signals.py). A rank that fails unexpectedly aborts the whole job (MPI_Abort).

Limits: the embedded network only (an ns-3 engine belongs to one process), and no shared
channel (``network.channel`` queues every vehicle's frames in one place); vehicles of different
shards never collide (each shard has its own PyBullet world); a reload cannot change the sync
period; the lockstep API (gateway.testing.Sim) is one process.

systemd: rank 0 sends READY, RELOADING, STOPPING, STATUS and the watchdog's pings (while
simulated time advances on every shard) to a socket of the launcher's, which relays them from
the unit's main pid (NotifyAccess=main, as the shipped unit has). Across hosts, started by
mpiexec directly, rank 0 notifies $NOTIFY_SOCKET itself.
"""

from __future__ import annotations

import asyncio
import logging
import sys
from collections.abc import Callable
from dataclasses import replace

from gateway.daemon.config import RunConfig
from gateway.daemon.shard.channel import Channel
from gateway.daemon.shard.launch import (
    ShardError,
    check,
    in_mpi_job,
    launch,
    mpiexec_command,
    split,
)

__all__ = ["Channel", "ShardError", "check", "in_mpi_job", "launch", "mpiexec_command",
           "serve_rank", "split"]

log = logging.getLogger(__name__)


def serve_rank(config: RunConfig, log_level: str,
               reload: Callable[[], RunConfig] | None = None) -> int:
    """This process's part of the MPI job: the coordinator on rank 0, a worker elsewhere.
    ``reload`` re-reads the configuration file on SIGHUP (rank 0: reload.py)."""
    import mpi4py

    mpi4py.rc.thread_level = "single"  # one thread per rank talks MPI
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    rank, size = comm.Get_rank(), comm.Get_size()
    k = config.shards
    if size != k + 1:
        if rank == 0:
            raise ShardError(f"--shards {k} needs an MPI job of {k + 1} ranks (a coordinator "
                             f"and {k} workers), not {size}", 2)
        return 2
    channel = Channel(comm)
    channel.open_doorbells()
    try:
        if rank == 0:  # imports nothing of the simulation: the workers' start-up is theirs
            from gateway.daemon.shard.coordinator import coordinate

            return asyncio.run(coordinate(config, channel, reload=reload))
        from gateway.daemon.shard.worker import work

        first, n = split(config.vehicles, k)[rank - 1]
        logging.basicConfig(
            level=log_level.upper(), stream=sys.stderr, force=True,
            format=f"%(asctime)s %(levelname)s shard {rank - 1} %(name)s: %(message)s")
        shard_config = replace(config, vehicles=n, first_vehicle=first, shards=1)
        return asyncio.run(work(shard_config, rank - 1, channel))
    except ShardError:
        raise
    except KeyboardInterrupt:  # mpiexec's Ctrl-C before this rank's handlers were in place
        log.error("rank %d interrupted while starting; ending the MPI job", rank)
        sys.stderr.flush()
        comm.Abort(130)
        raise
    except BaseException:
        log.exception("rank %d failed; ending the MPI job", rank)
        sys.stderr.flush()
        comm.Abort(1)
        raise


