"""Network backends: what the simulation asks for a link, and how positions reach the network.

A backend turns (source node, destination node) into a one-way link that carries opaque byte
packets on the kernel's clock. Two kinds exist:

- the embedded backend (here): each link is a ``netsim.link.Link`` whose model is the path of
  hop models the topology gives (e.g. vehicle —Wi-Fi— access point —wire— GCS); decisions are
  immediate, so no packet is ever late;
- external backends (ns-3, netsim/ns3/): packets are handed to another simulator once per sync
  period and come back with delivery times; those that come back after their time are *late*
  and handled by the late policy (``drop``, the CORNET paper's rule, or ``deliver``).

Rules:
- Node names are strings: ``v1``, ``v2`` … (vehicles, by MAV_SYS_ID), ``gcs`` (the ground
  station behind the GCS link), ``api1`` … (the API client of each vehicle), ``ap`` … (access
  points, named by the topology).
- Positions are metres NED in one world frame (origin: the world's home), pushed by the
  simulation every sync period with ``update_mobility`` — the physics clock is the reference.
- A backend never looks inside a packet.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from netsim.kernel import Kernel
from netsim.link import Deliver, Link, LinkStats, Tracer
from netsim.models import Drop, LinkModel, make_model

Vec3 = tuple[float, float, float]


class NetLink(Protocol):
    """One direction of one link, as the simulation uses it."""

    name: str
    stats: LinkStats
    deliver: Deliver  # where a delivered packet goes; may be replaced at any time

    def send(self, packet: bytes, meta: Any = None) -> None: ...


class NetworkBackend(Protocol):
    sync_period_s: float

    def make_link(self, name: str, src: str, dst: str, deliver: Deliver) -> NetLink: ...

    def update_mobility(self, now_s: float, positions_ned_m: Mapping[str, Vec3]) -> None: ...

    def close(self) -> None: ...


class Mobility:
    """The positions the network believes in: updated once per sync period, read by models."""

    def __init__(self, fixed: Mapping[str, Vec3] | None = None) -> None:
        self.positions: dict[str, Vec3] = dict(fixed or {})
        self.updated_at_s = float("-inf")

    def update(self, now_s: float, positions: Mapping[str, Vec3]) -> None:
        self.positions.update(positions)
        self.updated_at_s = now_s

    def position(self, node: str) -> Vec3:
        return self.positions[node]

    def distance_m(self, a: str, b: str) -> float:
        pa, pb = self.positions.get(a), self.positions.get(b)
        if pa is None or pb is None:
            return 0.0
        return ((pa[0] - pb[0]) ** 2 + (pa[1] - pb[1]) ** 2 + (pa[2] - pb[2]) ** 2) ** 0.5


class Path:
    """A link model made of hop models in series: delays add up, the first drop wins."""

    def __init__(self, hops: list[LinkModel]) -> None:
        if not hops:
            raise ValueError("a path needs at least one hop")
        self.hops = hops

    def transit(self, size_bytes: int, now_s: float) -> float | Drop:
        total = 0.0
        for hop in self.hops:
            verdict = hop.transit(size_bytes, now_s + total)
            if isinstance(verdict, Drop):
                return verdict
            total += verdict
        return total


@dataclass(frozen=True)
class HopSpec:
    """One hop of a path: a model by name with its parameters, between two nodes."""

    model: str
    params: dict = field(default_factory=dict)
    src: str = ""
    dst: str = ""
    shared_key: str | None = None  # hops with the same key share one model instance (a channel)


# A topology maps (src, dst) to the hops between them.
Router = Callable[[str, str], list[HopSpec]]


def uniform_router(model: str, params: Mapping[str, Any]) -> Router:
    """Every link direction is one hop with the same model (the CLI's --latency/--loss)."""

    def route(src: str, dst: str) -> list[HopSpec]:
        return [HopSpec(model, dict(params), src, dst)]

    return route


class EmbeddedBackend:
    """Links whose models run inside this process, decided at send time."""

    def __init__(self, kernel: Kernel, router: Router, *, seed: int = 0,
                 sync_period_s: float = 0.02, fixed_positions: Mapping[str, Vec3] | None = None,
                 tracer: Tracer | None = None) -> None:
        self.kernel = kernel
        self.router = router
        self.seed = seed
        self.sync_period_s = sync_period_s
        self.mobility = Mobility(fixed_positions)
        self.tracer = tracer
        self.links: dict[str, Link] = {}
        self._shared: dict[str, LinkModel] = {}

    def _hop_model(self, link_name: str, index: int, hop: HopSpec) -> LinkModel:
        params = dict(hop.params)
        if hop.shared_key is not None:
            model = self._shared.get(hop.shared_key)
            if model is None:
                model = make_model(hop.model, params, seed=self.seed,
                                   stream_name=f"medium:{hop.shared_key}",
                                   mobility=self.mobility, src=hop.src, dst=hop.dst)
                self._shared[hop.shared_key] = model
            return model
        # The first hop's stream is named after the link itself, so a one-hop path draws
        # exactly what a plain link of that name would.
        stream = link_name if index == 0 else f"{link_name}/hop{index}"
        return make_model(hop.model, params, seed=self.seed, stream_name=stream,
                          mobility=self.mobility, src=hop.src, dst=hop.dst)

    def make_link(self, name: str, src: str, dst: str, deliver: Deliver) -> Link:
        hops = self.router(src, dst)
        models = [self._hop_model(name, i, hop) for i, hop in enumerate(hops)]
        model = models[0] if len(models) == 1 else Path(models)
        link = Link(self.kernel, model, deliver, name=name, tracer=self.tracer)
        self.links[name] = link
        return link

    def update_mobility(self, now_s: float, positions_ned_m: Mapping[str, Vec3]) -> None:
        self.mobility.update(now_s, positions_ned_m)

    def close(self) -> None:
        pass
