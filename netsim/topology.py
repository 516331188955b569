"""Topologies: routers (``netsim.backend.Router``) built from a plain config dict.

A topology says which hops a packet crosses from one node to another; the hop models (by name,
from ``netsim.models``) decide delay and loss. ``make_router(config)`` returns the router and the
fixed node positions (access point, ground radio) for ``EmbeddedBackend(fixed_positions=...)``.
The dict is the scenario file's ``[network]`` table; errors raise ValueError naming the key path
(``network.ap.position_ned_m: expected 3 numbers``).

Nodes (netsim.backend): ``v1`` … vehicles (positions pushed by the simulation), ``gcs``,
``api1`` … (the API client of vehicle i), and the access point, named by ``ap.name``.

Config (every key optional; positions are metres NED in the world frame, origin = home):

    topology    = "direct" | "star" | "adhoc"          default "direct"
    outages     = [{link = PATTERN, start_s = s, duration_s = s}, ...]     all topologies
                  # optional per window: loss = p (0..1, default 1: a blackout; with
                  # latency_s alone 0), latency_s = s (added delay): loss bursts, latency steps
    # direct — every link direction is one hop:
    link        = {model = NAME, ...params}     absent: ideal; present without model: fixed
    # star — the paper's case study I: vehicles on Wi-Fi to an access point, GCS wired to it:
    ap          = {name = "ap", position_ned_m = [0.0, 0.0, -10.0]}
    # adhoc — the GCS has its own radio; vehicles reach it (and each other) directly:
    gcs         = {position_ned_m = [0.0, 0.0, -2.0]}
    # star and adhoc:
    radio       = {model = "wireless", ...params}   vehicle <-> AP (star) / GCS radio (adhoc),
                                                    one instance per vehicle per direction
    wired       = {model = "fixed", latency_s = 0.001, ...}   AP <-> gcs and ground API clients
                                                    (adhoc: GCS radio <-> ground API clients)
    channel     = {model = "queue", rate_bps = ..., queue_packets = ..., half_duplex = false}
                  absent: no shared channel. Present: one instance per radio hub and direction
                  (``half_duplex = true``: one for both directions), shared by all vehicles —
                  the hub's air time, where their packets queue behind each other.
    api_clients = "ground" | "onboard"             default "ground"
                  ground: API clients sit with the GCS (behind the AP / the GCS radio);
                  onboard: a companion computer on the vehicle, linked by ``onboard``
    onboard     = {model = "ideal", ...}           api_i <-> v_i when api_clients = "onboard"
    # every topology: more radios on every vehicle, each with a path of its own to the GCS
    extra_radios = [{name = "lte", radio = {...}, wired = {...}, position_ned_m = [...]}, ...]
                  name: [a-z][a-z0-9_]*, not gcs, api, a vehicle, API client or hub name;
                  radio: hop table as ``radio`` (default wireless), one instance per vehicle
                  per direction; wired: optional hop between its ground station and the GCS;
                  position_ned_m: its ground station (default [0, 0, -10])

A hop table's ``model`` defaults as shown; when it is the default model, the given parameters
are merged over the default ones (``wired = {jitter_s = 0.0005}`` keeps latency_s = 0.001).

Extra radios: vehicle v1's radio "lte" is the node ``v1.lte`` (the gateway pushes it with v1's
position) and its ground station the node ``lte``; its links are named ``v1/lte/up`` and
``v1/lte/down`` (gcs -> v1.lte and back).

Paths (hops in order; ``ch`` = the shared channel hop when configured):
    star    v1 -> gcs   ch(ap rx), radio v1->ap, wired ap->gcs
            gcs -> v1   wired gcs->ap, ch(ap tx), radio ap->v1
            v1 <-> api1 as with gcs (ground) or one ``onboard`` hop (onboard)
            v1 -> v2    ch(ap rx), radio v1->ap, ch(ap tx), radio ap->v2 (the AP relays)
    adhoc   v1 -> gcs   ch(gcs rx), radio v1->gcs;  gcs -> v1  ch(gcs tx), radio gcs->v1
            v1 -> api1  ch(gcs rx), radio v1->gcs, wired gcs->api1 (ground)
            v1 -> v2    radio v1->v2 (direct; no relaying through other vehicles)
    direct  any         link
    any     v1.lte -> gcs   radio v1.lte->lte, [wired lte->gcs]; gcs -> v1.lte the reverse
An onboard API client reaches other nodes through its vehicle (onboard hop, then the vehicle's).
The channel comes before the radio hop in both directions: a frame waits for the medium, then
is sent (and retried). It also keeps the shared queue's arrivals in time order — a queue hop is
served in call order, and behind a radio hop (whose retries can add tens of ms) one slow packet
would hold up every vehicle's packets called after it. Its occupancy is size·8/rate_bps per
frame; the radio's retries are not charged to it.

Outages: ``link`` is an fnmatch pattern matched against the link's name as the gateway names it
(``v1/gcs/up`` = gcs->v1, ``v1/gcs/down`` = v1->gcs, ``v1/api/up``, ``v1/api/down``), against
``src->dst``, and against each end node (``v1`` blacks out every link of v1, its extra radios'
too; ``v*/gcs/*`` every GCS link; ``v1/lte/*`` vehicle 1's radio "lte"). Each matching link
gets one ``outage`` hop, first in its path (the window applies to the send time);
netsim/models/outage.py says what a window with a loss or a latency does.
Note the backend names a path's first hop's random stream after the link, the others
``link/hopN``: adding an outage to a link shifts its other hops' streams.

Keys this module does not own (``seed``, ``backend``, ``sync_period_s``, ``late_policy`` by
default: see ``make_router(ignore=...)``) are skipped.
"""

from __future__ import annotations

import fnmatch
import math
import re
from collections.abc import Iterable, Mapping
from typing import Any

from netsim.backend import HopSpec, Mobility, Router, Vec3
from netsim.models import make_model
from netsim.models.base import MAX_DELAY_S

TOPOLOGIES = ("direct", "star", "adhoc")
API_CLIENTS = ("ground", "onboard")
DEFAULT_IGNORED = ("seed", "backend", "sync_period_s", "late_policy")

MAX_POSITION_M = 100_000.0  # a radio 100 km from home is a typo, not a scenario
DEFAULT_AP_POSITION_NED_M: Vec3 = (0.0, 0.0, -10.0)  # a 10 m mast at home
DEFAULT_GCS_POSITION_NED_M: Vec3 = (0.0, 0.0, -2.0)  # a ground radio on a tripod
# (default model, default params) per hop table.
HOP_DEFAULTS: dict[str, tuple[str, dict[str, Any]]] = {
    "link": ("fixed", {}),
    "radio": ("wireless", {}),
    "wired": ("fixed", {"latency_s": 0.001}),
    "channel": ("queue", {}),
    "onboard": ("ideal", {}),
}
EXTRA_RADIO_KEYS = {"name", "radio", "wired", "position_ned_m"}
DEFAULT_EXTRA_RADIO_POSITION_NED_M: Vec3 = (0.0, 0.0, -10.0)  # a ground station's mast at home
KEYS = {
    "direct": {"topology", "outages", "link", "extra_radios"},
    "star": {"topology", "outages", "ap", "radio", "wired", "channel", "api_clients",
             "onboard", "extra_radios"},
    "adhoc": {"topology", "outages", "gcs", "radio", "wired", "channel", "api_clients",
              "onboard", "extra_radios"},
}

_VEHICLE = re.compile(r"v([1-9][0-9]*)\Z")
_API = re.compile(r"api([1-9][0-9]*)\Z")
_RADIO_NAME = re.compile(r"[a-z][a-z0-9_]{0,15}\Z")
_RADIO_NODE = re.compile(r"(v[1-9][0-9]*)\.([a-z][a-z0-9_]*)\Z")  # v1.lte: v1's radio "lte"


class _Hop:
    """A validated hop table: model name and parameters."""

    def __init__(self, model: str, params: dict[str, Any]) -> None:
        self.model = model
        self.params = params

    def spec(self, src: str, dst: str, shared_key: str | None = None) -> HopSpec:
        return HopSpec(self.model, dict(self.params), src, dst, shared_key)


def _fail(path: str, message: str) -> ValueError:
    return ValueError(f"{path}: {message}")


def _hop(config: Mapping[str, Any], key: str, path: str, *, absent: _Hop | None = None,
         extra: Iterable[str] = ()) -> _Hop | None:
    """Validate hop table ``key`` by building its model once; ``absent`` if the key is."""
    if key not in config:
        return absent
    table = config[key]
    where = f"{path}.{key}"
    if not isinstance(table, Mapping):
        raise _fail(where, f"expected a table {{model = ..., ...}}, got {table!r}")
    default_model, default_params = HOP_DEFAULTS[key]
    model = table.get("model", default_model)
    if not isinstance(model, str):
        raise _fail(f"{where}.model", f"expected a model name, got {model!r}")
    params = {k: v for k, v in table.items() if k != "model" and k not in extra}
    if model == default_model:
        params = {**default_params, **params}
    _check_model(model, params, where)
    return _Hop(model, params)


def _check_model(model: str, params: dict[str, Any], where: str) -> None:
    try:
        make_model(model, dict(params), seed=0, stream_name="check", mobility=Mobility(),
                   src="a", dst="b")
    except ValueError as exc:
        message = str(exc)
        if message.startswith("unknown link model"):
            raise _fail(f"{where}.model", message) from None
        named = [k for k in params if re.search(rf"\b{re.escape(k)}\b", message)]
        raise _fail(f"{where}.{named[0]}" if len(named) == 1 else where, message) from None


def _position(value: Any, where: str) -> Vec3:
    if (not isinstance(value, (list, tuple)) or len(value) != 3
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                       and math.isfinite(x) and abs(x) <= MAX_POSITION_M for x in value)):
        raise _fail(where, f"expected 3 numbers [north, east, down] in metres, each within "
                    f"±{MAX_POSITION_M:g}, got {value!r}")
    return (float(value[0]), float(value[1]), float(value[2]))


def _table(config: Mapping[str, Any], key: str, path: str, known: set[str]) -> Mapping[str, Any]:
    table = config.get(key, {})
    if not isinstance(table, Mapping):
        raise _fail(f"{path}.{key}", f"expected a table, got {table!r}")
    for k in table:
        if k not in known:
            raise _fail(f"{path}.{key}.{k}", f"unknown key (known: {', '.join(sorted(known))})")
    return table


class _Outage:
    def __init__(self, pattern: str, start_s: float, duration_s: float, loss: float = 1.0,
                 latency_s: float = 0.0) -> None:
        self.pattern = pattern
        self.window = ([start_s, duration_s] if loss >= 1.0 and latency_s == 0.0
                       else [start_s, duration_s, loss, latency_s])

    def matches(self, names: tuple[str, ...]) -> bool:
        return any(fnmatch.fnmatchcase(name, self.pattern) for name in names)


def _outages(config: Mapping[str, Any], path: str) -> list[_Outage]:
    entries = config.get("outages", [])
    if not isinstance(entries, (list, tuple)):
        raise _fail(f"{path}.outages", f"expected a list of tables, got {entries!r}")
    out = []
    for i, entry in enumerate(entries):
        where = f"{path}.outages[{i}]"
        if not isinstance(entry, Mapping):
            raise _fail(where, f"expected {{link, start_s, duration_s}}, got {entry!r}")
        for k in entry:
            if k not in ("link", "start_s", "duration_s", "loss", "latency_s"):
                raise _fail(f"{where}.{k}", "unknown key (known: duration_s, latency_s, link, "
                                            "loss, start_s)")
        for k in ("link", "start_s", "duration_s"):
            if k not in entry:
                raise _fail(f"{where}.{k}", "missing")
        link, start, duration = entry["link"], entry["start_s"], entry["duration_s"]
        if not isinstance(link, str) or not link:
            raise _fail(f"{where}.link", f"expected a link name or pattern, got {link!r}")
        if (not isinstance(start, (int, float)) or isinstance(start, bool)
                or not (math.isfinite(start) and start >= 0)):
            raise _fail(f"{where}.start_s", f"expected seconds >= 0, got {start!r}")
        if (not isinstance(duration, (int, float)) or isinstance(duration, bool)
                or not duration > 0):
            raise _fail(f"{where}.duration_s", f"expected seconds > 0, got {duration!r}")
        loss = entry.get("loss", 0.0 if "latency_s" in entry else 1.0)
        latency = entry.get("latency_s", 0.0)
        if (not isinstance(loss, (int, float)) or isinstance(loss, bool)
                or not 0.0 <= loss <= 1.0):
            raise _fail(f"{where}.loss", f"expected a probability 0..1, got {loss!r}")
        if (not isinstance(latency, (int, float)) or isinstance(latency, bool)
                or not 0.0 <= latency <= MAX_DELAY_S):
            raise _fail(f"{where}.latency_s", f"expected seconds 0..{MAX_DELAY_S:g}, "
                                              f"got {latency!r}")
        out.append(_Outage(link, float(start), float(duration), float(loss), float(latency)))
    return out


def link_names(src: str, dst: str) -> tuple[str, ...]:
    """The names an outage pattern is matched against for the link src -> dst."""
    names = [f"{src}->{dst}", src, dst]
    for vehicle, client, direction in ((src, dst, "down"), (dst, src, "up")):
        radio = _RADIO_NODE.match(vehicle)
        if radio is not None:  # an extra radio: its own link names, and its vehicle's node
            names.append(radio.group(1))
            if client == "gcs":
                names.insert(0, f"{radio.group(1)}/{radio.group(2)}/{direction}")
            continue
        m = _VEHICLE.match(vehicle)
        if m is None:
            continue
        if client == "gcs":
            names.insert(0, f"{vehicle}/gcs/{direction}")
        elif client == f"api{m.group(1)}":
            names.insert(0, f"{vehicle}/api/{direction}")
    return tuple(names)


def _with_outages(route: Router, outages: list[_Outage]) -> Router:
    if not outages:
        return route

    def routed(src: str, dst: str) -> list[HopSpec]:
        hops = route(src, dst)
        names = link_names(src, dst)
        windows = [o.window for o in outages if o.matches(names)]
        if windows:
            hops = [HopSpec("outage", {"windows_s": windows}, src, dst), *hops]
        return hops

    return routed


def make_router(config: Mapping[str, Any], *, path: str = "network",
                ignore: Iterable[str] = DEFAULT_IGNORED) -> tuple[Router, dict[str, Vec3]]:
    """Build the router and the fixed node positions described by ``config``."""
    if not isinstance(config, Mapping):
        raise _fail(path, f"expected a table, got {config!r}")
    ignored = set(ignore)
    config = {k: v for k, v in config.items() if k not in ignored}
    kind = config.get("topology", "direct")
    if kind not in TOPOLOGIES:
        raise _fail(f"{path}.topology", f"expected one of {', '.join(TOPOLOGIES)}, got {kind!r}")
    for key in config:
        if key not in KEYS[kind]:
            raise _fail(f"{path}.{key}", f"unknown key for topology {kind!r} "
                                         f"(known: {', '.join(sorted(KEYS[kind]))})")
    outages = _outages(config, path)
    if kind == "direct":
        link = _hop(config, "link", path, absent=_Hop("ideal", {}))
        assert link is not None

        def direct(src: str, dst: str) -> list[HopSpec]:
            return [link.spec(src, dst)]

        radios, radio_positions = _extra_radios(config, path, taken=set())
        return _with_outages(_with_radios(direct, radios), outages), radio_positions

    if kind == "star":
        ap = _table(config, "ap", path, {"name", "position_ned_m"})
        hub = ap.get("name", "ap")
        if not isinstance(hub, str) or not hub or _VEHICLE.match(hub) or _API.match(hub) \
                or hub == "gcs":
            raise _fail(f"{path}.ap.name", f"expected a node name not taken by vehicles, "
                                           f"gcs or API clients, got {hub!r}")
        hub_position = _position(ap.get("position_ned_m", DEFAULT_AP_POSITION_NED_M),
                                 f"{path}.ap.position_ned_m")
    else:
        gcs = _table(config, "gcs", path, {"position_ned_m"})
        hub = "gcs"
        hub_position = _position(gcs.get("position_ned_m", DEFAULT_GCS_POSITION_NED_M),
                                 f"{path}.gcs.position_ned_m")
    api_clients = config.get("api_clients", "ground")
    if api_clients not in API_CLIENTS:
        raise _fail(f"{path}.api_clients", f"expected 'ground' or 'onboard', got {api_clients!r}")
    defaults = {k: _Hop(m, dict(p)) for k, (m, p) in HOP_DEFAULTS.items()}
    radio = _hop(config, "radio", path, absent=defaults["radio"])
    wired = _hop(config, "wired", path, absent=defaults["wired"])
    onboard = _hop(config, "onboard", path, absent=defaults["onboard"])
    channel = _hop(config, "channel", path, extra=("half_duplex",))
    half_duplex = False
    if channel is not None:
        half_duplex = config["channel"].get("half_duplex", False)
        if not isinstance(half_duplex, bool):
            raise _fail(f"{path}.channel.half_duplex", f"expected true or false, "
                                                       f"got {half_duplex!r}")
    assert radio is not None and wired is not None and onboard is not None
    route = _HubRouter(hub, adhoc=kind == "adhoc", onboard_api=api_clients == "onboard",
                       radio=radio, wired=wired, onboard=onboard, channel=channel,
                       half_duplex=half_duplex)
    radios, radio_positions = _extra_radios(config, path, taken={hub})
    return (_with_outages(_with_radios(route, radios), outages),
            {hub: hub_position, **radio_positions})


class _ExtraRadio:
    """One extra radio of every vehicle: its hops to and from its ground station."""

    def __init__(self, name: str, radio: _Hop, wired: _Hop | None) -> None:
        self.name = name
        self.radio = radio
        self.wired = wired

    def up(self, src: str, dst: str) -> list[HopSpec]:  # a ground node -> vN.<name>
        hops = [self.radio.spec(self.name, dst)]
        return hops if self.wired is None else [self.wired.spec(src, self.name), *hops]

    def down(self, src: str, dst: str) -> list[HopSpec]:  # vN.<name> -> a ground node
        hops = [self.radio.spec(src, self.name)]
        return hops if self.wired is None else [*hops, self.wired.spec(self.name, dst)]


def _extra_radios(config: Mapping[str, Any], path: str,
                  taken: set[str]) -> tuple[dict[str, _ExtraRadio], dict[str, Vec3]]:
    """``extra_radios``: validated, by name, and their ground stations' positions."""
    entries = config.get("extra_radios", [])
    if not isinstance(entries, (list, tuple)):
        raise _fail(f"{path}.extra_radios", f"expected a list of tables, got {entries!r}")
    radios: dict[str, _ExtraRadio] = {}
    positions: dict[str, Vec3] = {}
    for k, entry in enumerate(entries):
        where = f"{path}.extra_radios[{k}]"
        if not isinstance(entry, Mapping):
            raise _fail(where, f"expected a table {{name = ..., radio = {{...}}}}, got {entry!r}")
        for key in entry:
            if key not in EXTRA_RADIO_KEYS:
                raise _fail(f"{where}.{key}",
                            f"unknown key (known: {', '.join(sorted(EXTRA_RADIO_KEYS))})")
        name = entry.get("name")
        if name is None:
            raise _fail(f"{where}.name", "missing")
        if (not isinstance(name, str) or not _RADIO_NAME.match(name) or _VEHICLE.match(name)
                or _API.match(name) or name in ("gcs", "api") or name in taken):
            raise _fail(f"{where}.name", f"expected a name of lower-case letters, digits and _ "
                                         f"(at most 16, not gcs, api, a vehicle, an API client "
                                         f"or a hub), got {name!r}")
        if name in radios:
            raise _fail(f"{where}.name", f"{name!r} is already an extra radio")
        model, params = HOP_DEFAULTS["radio"]
        radio = _hop(entry, "radio", where, absent=_Hop(model, dict(params)))
        assert radio is not None
        wired = _hop(entry, "wired", where)
        radios[name] = _ExtraRadio(name, radio, wired)
        positions[name] = _position(entry.get("position_ned_m",
                                              DEFAULT_EXTRA_RADIO_POSITION_NED_M),
                                    f"{where}.position_ned_m")
    return radios, positions


def _with_radios(route: Router, radios: Mapping[str, _ExtraRadio]) -> Router:
    """Links from and to ``vN.<radio>`` take that radio's hops; the rest ``route``'s."""
    if not radios:
        return route

    def routed(src: str, dst: str) -> list[HopSpec]:
        for node, other, direction in ((src, dst, "down"), (dst, src, "up")):
            m = _RADIO_NODE.match(node)
            if m is None:
                continue
            radio = radios.get(m.group(2))
            if radio is None:
                raise ValueError(f"unknown node {node!r}: no extra radio {m.group(2)!r}")
            if _RADIO_NODE.match(other) or _VEHICLE.match(other) or other in radios:
                raise ValueError(f"extra radio {node!r} reaches ground nodes only, "
                                 f"not {other!r}")
            return radio.down(src, dst) if direction == "down" else radio.up(src, dst)
        return route(src, dst)

    return routed


class _HubRouter:
    """Star (hub = the AP) and ad hoc (hub = the GCS's radio) paths; see the module doc."""

    def __init__(self, hub: str, *, adhoc: bool, onboard_api: bool, radio: _Hop, wired: _Hop,
                 onboard: _Hop, channel: _Hop | None, half_duplex: bool) -> None:
        self.hub = hub
        self.adhoc = adhoc
        self.onboard_api = onboard_api
        self.radio = radio
        self.wired = wired
        self.onboard = onboard
        self.channel = channel
        self.rx_key = f"{hub}/channel" if half_duplex else f"{hub}/channel/rx"
        self.tx_key = f"{hub}/channel" if half_duplex else f"{hub}/channel/tx"

    def _check(self, node: str) -> None:
        if node == self.hub or node == "gcs" or _VEHICLE.match(node) or _API.match(node):
            return
        raise ValueError(f"{'adhoc' if self.adhoc else 'star'} topology: unknown node {node!r}")

    def _carrier(self, node: str) -> str | None:
        """The vehicle an onboard API client rides on, else None."""
        m = _API.match(node)
        return f"v{m.group(1)}" if m and self.onboard_api else None

    def _to_hub(self, node: str) -> list[HopSpec]:
        if node == self.hub:
            return []
        carrier = self._carrier(node)
        if carrier is not None:
            return [self.onboard.spec(node, carrier), *self._to_hub(carrier)]
        if _VEHICLE.match(node):
            hops = [self.radio.spec(node, self.hub)]
            if self.channel is not None:
                hops.insert(0, self.channel.spec(node, self.hub, self.rx_key))
            return hops
        return [self.wired.spec(node, self.hub)]

    def _from_hub(self, node: str) -> list[HopSpec]:
        if node == self.hub:
            return []
        carrier = self._carrier(node)
        if carrier is not None:
            return [*self._from_hub(carrier), self.onboard.spec(carrier, node)]
        if _VEHICLE.match(node):
            hops = [self.radio.spec(self.hub, node)]
            if self.channel is not None:
                hops.insert(0, self.channel.spec(self.hub, node, self.tx_key))
            return hops
        return [self.wired.spec(self.hub, node)]

    def __call__(self, src: str, dst: str) -> list[HopSpec]:
        self._check(src)
        self._check(dst)
        if src == dst:
            raise ValueError(f"no path from {src!r} to itself")
        if self._carrier(src) == dst or self._carrier(dst) == src:
            return [self.onboard.spec(src, dst)]
        if self.adhoc and _VEHICLE.match(src) and _VEHICLE.match(dst):
            return [self.radio.spec(src, dst)]
        return self._to_hub(src) + self._from_hub(dst)
