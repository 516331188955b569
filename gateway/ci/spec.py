"""What one headless flight is: the plan and the conditions it is flown in.

``cornet fly`` builds one :class:`FlightSpec` from its flags, ``cornet sweep`` one per cell and
seed of its grid, and a baseline stores the spec it was flown with (gateway/ci/baseline.py), so
the flight that is compared with it runs under the same conditions unless told otherwise.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gateway.sim.scenario import NetworkConfig


@dataclass(frozen=True)
class FlightSpec:
    """A plan and its flight conditions. ``seed``: the network's seed (it also seeds the sensor
    noise and the wind); None keeps the scenario's. ``scenario`` sets the network unless a
    latency, jitter or loss is given. ``control``: ``mission`` flies the plan as an onboard
    mission (PX4 Mission mode); ``ground`` flies its waypoints with a ground-side controller
    sending offboard velocity setpoints over the network (gateway/ci/ground.py)."""

    plan: str
    latency_ms: float = 0.0
    jitter_ms: float = 0.0
    loss: float = 0.0
    seed: int | None = None
    scenario: str | None = None
    params: dict[str, float] = field(default_factory=dict)
    time_limit_s: float | None = None
    max_deviation_m: float | None = None
    control: str = "mission"

    @property
    def has_link_flags(self) -> bool:
        return bool(self.latency_ms or self.jitter_ms or self.loss)

    def network(self) -> NetworkConfig | None:
        """The network to fly in: None leaves it to the scenario (or an ideal one)."""
        if self.scenario is None or self.has_link_flags:
            if self.has_link_flags or self.seed:
                return NetworkConfig.from_flags(self.latency_ms, self.jitter_ms, self.loss,
                                                self.seed or 0)
            return None
        if self.seed is None:
            return None
        from gateway.sim.scenario import load

        return dataclasses.replace(load(self.scenario).network, seed=self.seed)

    def fly_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of gateway.ci.fly.fly (but ``progress`` and ``log_dir``)."""
        kwargs: dict[str, Any] = {"network": self.network(), "scenario": self.scenario,
                                  "params": dict(self.params),
                                  "max_deviation_m": self.max_deviation_m,
                                  "control": self.control}
        if self.time_limit_s is not None:
            kwargs["time_limit_s"] = self.time_limit_s
        return kwargs

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> FlightSpec:
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in d.items() if k in names})

    def conditions(self, control: bool = True) -> str:
        """``latency 100 ms, loss 0.2, seed 3, MPC_XY_CRUISE=8`` (what differs from the default;
        ``control=False`` leaves out the control, which a sweep states once for every cell)."""
        parts = []
        if self.scenario is not None:
            parts.append(f"scenario {Path(self.scenario).name}")
        if self.latency_ms:
            parts.append(f"latency {self.latency_ms:g} ms")
        if self.jitter_ms:
            parts.append(f"jitter {self.jitter_ms:g} ms")
        if self.loss:
            parts.append(f"loss {self.loss:g}")
        if self.seed is not None:
            parts.append(f"seed {self.seed}")
        parts += [f"{k}={v:g}" for k, v in sorted(self.params.items())]
        if control and self.control != "mission":
            parts.append(f"{self.control} control")
        return ", ".join(parts) or "ideal network"


def plan_digest(plan: Any) -> str:
    """A digest of what a plan asks the vehicle to do (mission, fence, rally items), so that a
    plan saved again or moved still matches its baseline and another plan does not."""
    rows = [[it.mission_type, it.frame, it.command, it.autocontinue,
             *(None if v != v else round(v, 6) for v in (it.param1, it.param2, it.param3,
                                                         it.param4)), it.x, it.y, round(it.z, 3)]
            for it in (*plan.mission, *plan.fence, *plan.rally)]
    return hashlib.sha256(json.dumps(rows).encode()).hexdigest()[:16]
