"""Extra radios: more MAVLink instances per vehicle, each on a radio of its own.

A vehicle may carry more than one radio (Wi-Fi telemetry and LTE, say). As PX4 runs one
``mavlink start -u LOCAL -o REMOTE`` instance per radio, every extra radio of the scenario's
``[network] extra_radios`` is one more MAVLink link of every vehicle, in Normal mode (the GCS
link's streams): the same system and component ids and vehicle, but a Session of its own (its
peer, its stream schedule, its message sequence), its own UDP port, and its own path through
the network (netsim/topology.py: node ``v1.lte`` follows vehicle ``v1``; links ``v1/lte/up``
and ``v1/lte/down``, which outage patterns name). A GCS that hears a vehicle over two radios
sees one system on two links (QGC's multi-link, MAVSDK's system by sysid).

Ports (``radio_ports``): PX4 SITL instance i binds 18570+i for its GCS link; extra radio number
r (1-based, in the scenario's order) of vehicle i binds 18570 + 1000·r + i, so up to
MAX_EXTRA_RADIOS radios of 254 vehicles collide neither with each other nor with PX4's
18570+i, 14580+i, 14540..14549 and 14550. It talks first to its ``remote_port`` (default
14550, QGC's; another port makes it a second UDP link of the GCS). ``--port-offset`` shifts
both, as it does PX4's.

A link of a vehicle is named by a *tag*: ``LinkKind.GCS`` and ``LinkKind.API`` for PX4 SITL's
two, the radio's name (a str) for an extra radio.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, NamedTuple

from gateway.mavlink.link import LinkKind
from gateway.sim.values import ScenarioError
from gateway.sim.values import number as _number

# PX4 SITL port scheme (ROMFS px4fmu_common/init.d-posix/px4-rc.mavlink) for instance i.
GCS_LOCAL_BASE = 18570
GCS_REMOTE_PORT = 14550
API_LOCAL_BASE = 14580
API_REMOTE_BASE = 14540
API_REMOTE_MAX = 14549  # PX4 sends instances > 9 to 14549
RADIO_PORT_STRIDE = 1000  # extra radio r binds GCS_LOCAL_BASE + r·stride + i
MAX_EXTRA_RADIOS = 4
MAX_PORT = 65535
GATEWAY_KEYS = ("remote_port",)  # what the gateway keeps of an extra_radios entry

# The name of one of a vehicle's MAVLink links: a LinkKind, or an extra radio's name.
LinkTag = LinkKind | str


class Ports(NamedTuple):
    """UDP ports of one vehicle link: what the vehicle binds and where it talks first."""

    local: int
    remote: int


@dataclass(frozen=True)
class ExtraRadio:
    """What the gateway needs of one extra radio (its hops are the topology's)."""

    name: str  # links v<i>/<name>/up|down, node v<i>.<name>
    number: int  # 1-based place among the extra radios: its port block
    remote_port: int = GCS_REMOTE_PORT  # before --port-offset


def tag_name(tag: LinkTag) -> str:
    """``gcs``, ``api`` or the radio's name: what link names, tlogs and metrics call it."""
    return tag.value if isinstance(tag, LinkKind) else tag


def px4_ports(index: int, kind: LinkKind, offset: int = 0) -> Ports:
    if kind is LinkKind.GCS:
        return Ports(GCS_LOCAL_BASE + index + offset, GCS_REMOTE_PORT + offset)
    return Ports(API_LOCAL_BASE + index + offset,
                 min(API_REMOTE_BASE + index, API_REMOTE_MAX) + offset)


def radio_ports(index: int, radio: ExtraRadio, offset: int = 0) -> Ports:
    return Ports(GCS_LOCAL_BASE + RADIO_PORT_STRIDE * radio.number + index + offset,
                 radio.remote_port + offset)


def link_ports(index: int, tag: LinkTag, radios: Iterable[ExtraRadio],
               offset: int = 0) -> Ports:
    """The ports of vehicle ``index``'s link ``tag``."""
    if isinstance(tag, LinkKind):
        return px4_ports(index, tag, offset)
    for radio in radios:
        if radio.name == tag:
            return radio_ports(index, radio, offset)
    raise KeyError(f"no extra radio {tag!r}")


def ports_text(index: int, radios: Iterable[ExtraRadio], offset: int = 0) -> str:
    """``gcs 18570->14550 api 14580->14540 lte 19570->14550`` for vehicle ``index``."""
    parts = [(kind.value, px4_ports(index, kind, offset)) for kind in LinkKind]
    parts += [(r.name, radio_ports(index, r, offset)) for r in radios]
    return " ".join(f"{name} {p.local}->{p.remote}" for name, p in parts)


def split_entries(entries: Any, path: str) -> tuple[list[Any], tuple[ExtraRadio, ...]]:
    """A scenario's ``extra_radios`` list: (what the topology validates and routes, without
    the gateway's keys; the radios the gateway builds links for). The entries' structure and
    names are the topology's to check (netsim/topology.py), after this."""
    if not isinstance(entries, list):
        return entries, ()  # the topology says what is wrong with it
    if len(entries) > MAX_EXTRA_RADIOS:
        raise ScenarioError(f"{path}: at most {MAX_EXTRA_RADIOS} extra radios, got "
                            f"{len(entries)}")
    network, radios = [], []
    for k, entry in enumerate(entries, start=1):
        if not isinstance(entry, dict):
            network.append(entry)
            continue
        remote = GCS_REMOTE_PORT
        if "remote_port" in entry:
            where = f"{path}[{k - 1}].remote_port"
            remote = int(_number(entry["remote_port"], where, integer=True, minimum=1))
            if remote > MAX_PORT:
                raise ScenarioError(f"{where}: at most {MAX_PORT}, got {remote}")
        network.append({key: v for key, v in entry.items() if key not in GATEWAY_KEYS})
        name = entry.get("name")
        radios.append(ExtraRadio(name if isinstance(name, str) else "", k, remote))
    return network, tuple(radios)


def check_radio_ports(radios: Iterable[ExtraRadio], vehicles: int, port_offset: int,
                      path: str) -> None:
    """Every port the radios use fits, and none is a port the vehicles bind."""
    bound = [(GCS_LOCAL_BASE, "the GCS links"), (API_LOCAL_BASE, "the API links")]
    for r in radios:
        high = radio_ports(vehicles - 1, r, port_offset).local
        if high > MAX_PORT:
            raise ScenarioError(f"{path}: extra radio {r.name!r} with {vehicles} vehicles "
                                f"needs port {high} > {MAX_PORT}; use a smaller offset")
        if r.remote_port + port_offset > MAX_PORT:
            raise ScenarioError(f"{path}: extra radio {r.name!r} talks to "
                                f"{r.remote_port} + {port_offset} > {MAX_PORT}")
        bound.append((GCS_LOCAL_BASE + RADIO_PORT_STRIDE * r.number, f"radio {r.name!r}"))
    for r in radios:
        for base, what in bound:
            if base <= r.remote_port < base + vehicles:
                raise ScenarioError(f"network.extra_radios[{r.number - 1}].remote_port: "
                                    f"{r.remote_port} is a port the vehicles bind ({what}: "
                                    f"{base}+i)")
