"""The daemon's status line and the ports of its ready line: shared by one process
(gateway/daemon/app.py) and the coordinator of a sharded run, which imports nothing of the
simulation (gateway/daemon/shard/coordinator.py)."""

from __future__ import annotations

from gateway.daemon.config import RunConfig
from gateway.sim.radios import ports_text

STATUS_PERIOD_S = 10.0


def format_status(sim_t: float, rtf: float, vehicles: int, counters: dict[str, int],
                  extra: str = "") -> str:
    return (f"sim_t={sim_t:.1f}s rtf={rtf:.2f} vehicles={vehicles} {extra}"
            + " ".join(f"{k}={v}" for k, v in counters.items()))


def ports_summary(cfg: RunConfig) -> str:
    """``v1 udp 14540<->14580 ..., v2 ...``: the first four vehicles' ports."""
    text = ", ".join(f"v{i + 1} {ports_text(i, cfg.network.radios, cfg.port_offset)}"
                     for i in range(min(cfg.vehicles, 4)))
    return text + (" ..." if cfg.vehicles > 4 else "")
