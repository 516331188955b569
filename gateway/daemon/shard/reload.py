"""SIGHUP in a sharded run: the configuration file re-read by the coordinator, applied by every
worker at the same sync point.

Hydra's mpiexec dies of SIGHUP and forwards SIGUSR1 to every rank, so the launcher (the process
the user or systemd signals, the parent of mpiexec) turns SIGHUP into SIGUSR1 after creating the
job's reload flag file (``$CORNET_RELOAD_FLAG``: the number of SIGHUPs so far). A rank that gets
SIGUSR1 with a new number reads it as "reload" (rank 0 acts, workers ignore it); otherwise
SIGUSR1 keeps its meaning of one process (each worker logs its links' table).

The coordinator re-reads the file (``reload()``, as one process does), checks that the new
network can be swapped in a sharded run (embedded, no shared channel, same extra radios, same
sync period: the shards' grid of sync points), and sends the network and the wind with the next
grant: every worker, held right after that sync point, rebuilds its links before any later
event — the same reload at the same simulated time on every shard, as in one process.
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Callable
from dataclasses import fields, replace

from gateway.daemon.config import RunConfig
from gateway.daemon.shard.launch import RELOAD_FLAG_VARIABLE, check
from gateway.sim.scenario import ScenarioError

log = logging.getLogger(__name__)


class ReloadFlag:
    """The launcher's count of SIGHUPs (the flag file holds it): a SIGUSR1 that comes with a
    new count means "reload", one without means SIGUSR1. Every rank reads it on its own, and
    nobody removes it, so no rank can miss it."""

    def __init__(self, path: str | None = None) -> None:
        self.path = path if path is not None else os.environ.get(RELOAD_FLAG_VARIABLE)
        self.seen = self._count()

    def _count(self) -> str:
        if not self.path:
            return ""
        with contextlib.suppress(OSError):
            with open(self.path) as f:
                return f.read()
        return ""

    def requested(self) -> bool:
        """Whether the SIGUSR1 just received is a relayed SIGHUP."""
        count = self._count()
        if count == self.seen:
            return False
        self.seen = count
        return True


def prepare(config: RunConfig, load: Callable[[], RunConfig] | None
            ) -> tuple[RunConfig, dict | None]:
    """The file again: the config now running and what the workers must apply (None: nothing;
    every refusal is logged, the running network stays)."""
    if load is None:
        log.warning("SIGHUP: started without --config or --scenario; nothing to re-read")
        return config, None
    running = config.network.summary
    try:
        new = load()
    except ScenarioError as exc:
        log.error("reload failed, keeping the running network (%s): %s", running, exc)
        return config, None
    problem = check(replace(new, shards=config.shards, vehicles=config.vehicles))
    if problem is None and new.network.radios != config.network.radios:
        problem = "the extra radios (names, ports) changed: their links and ports are built at start"
    if problem is None and new.network.sync_period_s != config.network.sync_period_s:
        problem = ("network.sync_period_s changed: the shards keep lockstep on its grid "
                   "(restart to change it)")
    if problem is not None:
        log.error("reload failed, keeping the running network (%s): %s", running, problem)
        return config, None
    for f in fields(RunConfig):
        before, after = getattr(config, f.name), getattr(new, f.name)
        if f.name not in ("network", "wind") and after != before:
            log.warning("reload: %s changed (%s -> %s); it takes effect at the next start",
                        f.name, before, after)
    if new.network == config.network and new.wind == config.wind:
        log.info("reload: the network is unchanged (%s)", running)
        return config, None
    log.info("reload: the network is now %s (was %s), wind %s; every shard at its next sync "
             "point", new.network.summary, running, new.wind)
    return (replace(config, network=new.network, wind=new.wind),
            {"network": new.network, "wind": new.wind})
