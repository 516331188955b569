"""The ns-3 backend: links whose packets cross a network simulated by another process.

``Ns3Backend`` implements ``netsim.backend.NetworkBackend``. It starts an engine process
(``cornet-ns3``, the C++ ns-3 program, or the pure-Python reference engine) and drives it over ZMQ
REQ/REP with the protocol of README.md.

Rules and invariants:
- The physics clock is the reference (CORNET): the engine answers every packet with a delivery
  time or a drop.
- Exact time: a conservative next-event exchange on the kernel's horizon (netsim/kernel.py). A
  packet enters ns-3 at its send time and arrives on the kernel at ns-3's delivery time: no
  pipeline. Invariants: ns-3's clock N never passes the kernel's; every packet sent before N is
  in ns-3; every delivery up to N is on the kernel. With nothing in flight the kernel runs
  freely; a send sets the horizon to its time plus ``LOOKAHEAD_S`` (no datagram crosses ns-3
  faster); while packets are in flight the horizon is N. Crossing it, the bridge sends the
  waiting packets and positions and asks the engine to run to the kernel's next event time but
  stop at its first delivery (``stop_at_delivery``), so every delivery is scheduled at its own
  time before the kernel gets there. The mobility ticker only refreshes positions (sent with
  the next exchange).
- Lockstep (``realtime=False``): each exchange waits for the reply (up to ``timeout_s`` of wall
  time): nothing is ever late; runs are deterministic.
- Real time (``realtime=True``): the physics waits at most one sync period of wall time for an
  exchange (the time the pipeline would give the engine). A reply that takes longer is read
  later, without waiting (at the next crossing or mobility tick), while the physics goes on; a
  delivery whose time has passed by then is *late*: policy ``drop`` counts it in
  ``dropped["late"]`` (the paper's rule), ``deliver`` delivers it now and counts it in
  ``late_delivered``. When exchanges keep missing the wait (``PIPELINE_AFTER_LATE``,
  ``PIPELINE_LATE_SHARE``), ns-3 cannot keep up at exact time: the backend says so once and
  switches to the pipeline.
- The pipeline (real time, after that switch): a cycle runs at each ``update_mobility`` call
  (every ``sync_period_s``): the packets sent since the previous cycle go to the engine with
  their send times and the current positions, shifted by ``pipeline_s`` = two sync periods
  (the engine then has one whole period of wall time to answer; the physics never waits). End-
  to-end latency = ns-3 latency + ``pipeline_s``; ``net_latency_*`` in the link stats is ns-3's
  own part. The hang timeout is measured in simulated seconds (≈ wall seconds there).
- An engine that dies, hangs past ``timeout_s`` or cannot start is *lost*: logged once, every
  packet in flight or sent afterwards is dropped with reason ``backend``, the physics keeps
  running. ``strict=True`` raises ``Ns3Error`` instead. The engine is not restarted.
- Every link direction keeps ``sent == delivered + sum(dropped) + in_flight``.
- Node kinds come from names: ``v<N>`` vehicle, ``ap…`` access point, ``enb…`` LTE eNB, anything
  else a ground node (wired to the AP in the ``ap`` topology, a radio in ``adhoc``, a remote host
  behind the PGW in ``lte``). All links must be made before the first cycle, which starts the
  engine's network (init + warm-up, blocking once). ``lte``: cells.py follows the serving cells.
"""

from __future__ import annotations

import logging
import math
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import zmq

from netsim.backend import Vec3
from netsim.kernel import PRIORITY_NETWORK, Kernel
from netsim.link import Deliver, LinkStats, Tracer
from netsim.models import Drop
from netsim.ns3.cells import Cells
from netsim.ns3.engine import BINARY, PROTOCOL_VERSION, EngineProcess, Ns3Error, node_kind
from netsim.ns3.engine import Ns3BuildMissing as Ns3BuildMissing  # re-exported (cli, tests)
from netsim.ns3.engine import build_missing_message as build_missing_message
from netsim.ns3.schema import check_tables

log = logging.getLogger("netsim.ns3")

# No datagram crosses ns-3 faster than this (an 802.11 preamble alone is 16-192 µs; a wired hop
# adds its delay): the lockstep exchange's lookahead after a send.
LOOKAHEAD_S = 1e-6
# ns-3 reports times in whole nanoseconds (9 decimals); the kernel's floats are not rounded.
TIME_RESOLUTION_S = 1e-9
# Real time at exact time: the physics waits at most one sync period of wall time for an
# exchange (what the pipeline gives the engine per cycle); a reply that takes longer is read
# later (its deliveries may be late). Once PIPELINE_AFTER_LATE exchanges have missed it and
# they are more than PIPELINE_LATE_SHARE of all, ns-3 cannot keep up at exact time and the
# backend switches to the pipeline (two sync periods, logged once).
PIPELINE_AFTER_LATE, PIPELINE_LATE_SHARE = 10, 0.2

ENGINES = ("ns3", "reference")
LATE_POLICIES = ("drop", "deliver")
DROP_BACKEND = "backend"  # the engine was lost: its cycle's packets never came back
CONFIG_KEYS = {"engine", "binary", "topology", "routing", "nodes", "wifi", "propagation",
               "wired", "lte", "warmup_s", "drop_after_s", "timeout_s", "init_timeout_s",
               "reference"}
ROUTINGS = ("none", "olsr", "aodv")  # the adhoc topology's: one hop, or ns-3's OLSR / AODV


def check_config(config: Mapping[str, Any]) -> None:
    """What can be checked without the engine; ValueError names the key."""
    unknown = set(config) - CONFIG_KEYS
    if unknown:
        raise ValueError(f"ns-3 backend: unknown config keys {sorted(unknown)} "
                         f"(known: {sorted(CONFIG_KEYS)})")
    routing = config.get("routing", "none")
    if routing not in ROUTINGS:
        raise ValueError(f"routing: must be one of {', '.join(ROUTINGS)}, not {routing!r}")
    if routing != "none" and config.get("topology", "adhoc") != "adhoc":
        raise ValueError(f"routing: {routing!r} needs topology = \"adhoc\"")
    check_tables(config)  # and the lte keys


@dataclass
class Ns3LinkStats(LinkStats):
    """LinkStats plus ns-3's own share of the latency (without the pipeline delay)."""

    net_latency_sum_s: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        out = super().as_dict()
        mean = self.net_latency_sum_s / self.delivered if self.delivered else 0.0
        out["net_latency_mean_ms"] = round(mean * 1e3, 3)
        return out


class Ns3Link:
    """One direction of one link; packets wait in the backend for the next cycle."""

    def __init__(self, backend: Ns3Backend, name: str, src: str, dst: str,
                 deliver: Deliver) -> None:
        self.name = name
        self.src = src
        self.dst = dst
        # Typed as the interface's LinkStats: a reloaded network may hand these counters on.
        self.stats: LinkStats = Ns3LinkStats()
        self._backend = backend
        self.deliver = deliver

    def send(self, packet: bytes, meta: Any = None) -> None:
        self._backend._send(self, packet, meta)


@dataclass
class _Packet:
    id: int
    link: Ns3Link
    packet: bytes
    meta: Any
    sent_at_s: float
    inject_at_s: float = 0.0
    net_latency_s: float = 0.0  # ns-3's delivery time - injection time


class Ns3Backend:
    def __init__(self, kernel: Kernel, config: Mapping[str, Any] | None = None, *,
                 seed: int = 0, sync_period_s: float = 0.02, late_policy: str = "drop",
                 realtime: bool = False, strict: bool = False,
                 tracer: Tracer | None = None) -> None:
        config = dict(config or {})
        check_config(config)
        if late_policy not in LATE_POLICIES:
            raise ValueError(f"late_policy must be one of {LATE_POLICIES}, not {late_policy!r}")
        if not sync_period_s > 0:
            raise ValueError("sync_period_s must be positive")
        self.engine = config.get("engine", "ns3")
        if self.engine not in ENGINES:
            raise ValueError(f"ns-3 backend: engine must be one of {ENGINES}, not {self.engine!r}")
        self.kernel = kernel
        self.config = config
        self.seed = seed
        self.sync_period_s = sync_period_s
        self.late_policy = late_policy
        self.realtime = realtime
        self.strict = strict
        self.tracer = tracer
        self.passive_ground = realtime  # deliveries to ground nodes never stop a step (start())
        self.exact = True  # real time falls back to the pipeline when ns-3 cannot keep up
        self.pipeline_s = 0.0
        self.exchanges = 0  # exact time: engine round trips
        self.exchanges_late = 0  # real time: replies that missed their wait
        self.timeout_s = float(config.get("timeout_s", 5.0))
        self.init_timeout_s = float(config.get("init_timeout_s", 30.0))
        self.links: dict[str, Ns3Link] = {}
        self.nodes: dict[str, str] = {}  # name -> kind, in order of appearance
        self.positions: dict[str, Vec3] = {}
        for name, spec in (config.get("nodes") or {}).items():
            self.nodes[name] = spec.get("kind", node_kind(name))
            if "position" in spec:
                x, y, z = (float(v) for v in spec["position"])
                self.positions[name] = (x, y, z)
        if config.get("topology", "adhoc") == "ap" and not any(
                k == "ap" for k in self.nodes.values()):
            self.nodes["ap"] = "ap"
        if config.get("topology") == "lte" and "enb" not in self.nodes.values():
            self.nodes["enb1"] = "enb"
        self.cells = Cells()  # the lte topology: serving cells and handovers
        # Engine-side state.
        self.started = False
        self.lost: str | None = None  # why the engine was lost, once it is
        self.cycles = 0
        self.cycles_lost = 0
        self.replies_late = 0  # real time: replies read one or more cycles after their request
        self.ready_reply: dict[str, Any] = {}
        self._next_id = 0
        self._outbox: list[_Packet] = []
        self._in_flight: dict[int, _Packet] = {}
        self._engine_until_s = 0.0
        self._positions_sent: dict[str, Vec3] = {}  # what the engine has
        self._awaiting_since_s: float | None = None  # real time: a request is out
        self._process = EngineProcess(self.engine, pathlib.Path(config.get("binary", BINARY)))
        self.endpoint = self._process.endpoint

    # -- NetworkBackend ---------------------------------------------------------------------

    def make_link(self, name: str, src: str, dst: str, deliver: Deliver) -> Ns3Link:
        if name in self.links:
            raise ValueError(f"link {name!r} exists")
        for node in (src, dst):
            if node not in self.nodes:
                if self.started:
                    raise ValueError(f"node {node!r} is unknown to the running engine: make "
                                     "every link before the first sync cycle")
                self.nodes[node] = node_kind(node)
        link = Ns3Link(self, name, src, dst, deliver)
        self.links[name] = link
        return link

    def update_mobility(self, now_s: float, positions_ned_m: Mapping[str, Vec3]) -> None:
        self.positions.update({k: (float(v[0]), float(v[1]), float(v[2]))
                               for k, v in positions_ned_m.items()})
        if self.lost is not None:
            self._drop_all(DROP_BACKEND)
            return
        if not self.started:
            self.start()
            if self.lost is not None:
                return
        if not self.exact:
            self._cycle_realtime()
        elif self.realtime and self._poll_reply() and (self._in_flight or self._outbox):
            self.kernel.horizon = min(self.kernel.horizon, self.kernel.now)
        # Exact time: the positions go with the next exchange (``_exchange``).

    def close(self) -> None:
        if self._process.running() and self.lost is None and self._awaiting_since_s is None:
            try:
                self._process.request({"v": PROTOCOL_VERSION, "op": "close"}, 2.0)
            except (zmq.ZMQError, Ns3Error):
                pass
        self._process.release()

    # -- cycles -----------------------------------------------------------------------------

    def start(self, positions_ned_m: Mapping[str, Vec3] | None = None) -> None:
        """Init the engine's network and run its warm-up (once, blocking, before the first
        cycle: the simulation's first ``update_mobility`` calls it if nobody did), with nodes
        at ``positions_ned_m`` (e.g. the vehicles' spawn points): the warm-up's beacons,
        association and routing see where they are."""
        if self.started:
            return
        self.started = True
        for name, (x, y, z) in (positions_ned_m or {}).items():
            self.positions[name] = (float(x), float(y), float(z))
        # In real time the ground nodes' clients are outside the simulation (UDP sockets): a
        # delivery to them cannot make anything send at its own simulated time, so the engine
        # need not stop for it (their datagrams enter at the kernel's time, never behind it).
        nodes = [{"name": name, "kind": kind,
                  "position": list(self.positions.get(name, (0.0, 0.0, 0.0))),
                  "passive": self.passive_ground and kind == "ground"}
                 for name, kind in self.nodes.items()]
        self._positions_sent = dict(self.positions)
        message = {"v": PROTOCOL_VERSION, "op": "init", "seed": self.seed, "nodes": nodes,
                   "topology": self.config.get("topology", "adhoc")}
        for key in ("routing", "wifi", "propagation", "wired", "lte", "warmup_s", "drop_after_s",
                    "reference"):
            if key in self.config:
                message[key] = self.config[key]
        reply = self._process.request(message, self.init_timeout_s)
        if reply is None:
            self._lose(self._process.gone() or
                       f"no reply to init within {self.init_timeout_s} s")
            return
        self.ready_reply = reply
        self.cells.ready(reply)
        self._engine_until_s = self.kernel.now
        if self.exact:
            self.kernel.on_horizon = self._exchange
            if self._outbox:
                self.kernel.horizon = min(self.kernel.horizon,
                                          self._outbox[0].sent_at_s + LOOKAHEAD_S)
        if reply.get("unassociated"):
            log.warning("ns-3: stations not associated (attached) after the warm-up (out of "
                        "range?): %s", ", ".join(reply["unassociated"]))

    def _step_request(self, until: float | None = None) -> dict[str, Any]:
        now = self.kernel.now
        if until is None:
            until = now + self.pipeline_s
        # A late reply (real time) may have left the engine past the kernel's next event.
        until = max(until, self._engine_until_s)
        packets = []
        for p in self._outbox:
            p.inject_at_s = max(p.sent_at_s + self.pipeline_s, self._engine_until_s)
            self._in_flight[p.id] = p
            packets.append({"id": p.id, "src": p.link.src, "dst": p.link.dst,
                            "size": len(p.packet), "send_time_s": round(p.inject_at_s, 9)})
        self._outbox = []
        self._engine_until_s = until
        self.cycles += 1
        moved = {k: list(v) for k, v in self.positions.items()
                 if self._positions_sent.get(k) != v}  # only what changed since the last step
        self._positions_sent.update(self.positions)
        return {"v": PROTOCOL_VERSION, "op": "step", "until_s": round(until, 9),
                "positions": moved, "packets": packets}

    def _exchange(self, t: float) -> None:
        """Exact time: the kernel is about to pass its horizon towards ``t`` (module rules)."""
        kernel = self.kernel
        if self.lost is not None:
            kernel.horizon = math.inf
            self._drop_all(DROP_BACKEND)
            return
        if not self.started:
            self.start()
            if self.lost is not None:
                kernel.horizon = math.inf
                return
        if self.realtime and not self._poll_reply():
            kernel.horizon = math.inf  # ns-3 is behind: the physics goes on
            return
        if not self.exact:  # switched to the pipeline while a reply was out
            return
        request = self._step_request(until=t)
        request["stop_at_delivery"] = True
        self.exchanges += 1
        if not self.realtime:
            reply = self._process.request(request, self.timeout_s)
            if reply is None:
                kernel.horizon = math.inf
                self._lose(self._process.gone() or f"no reply within {self.timeout_s} s")
                return
        else:
            if not self._process.send_nowait(request):  # no engine connected any more
                self._lose(self._process.gone() or "engine disconnected")
                return
            if not self._process.poll(max(1, round(self.sync_period_s * 1e3))):
                self._awaiting_since_s = kernel.now
                self.exchanges_late += 1
                self.replies_late += 1
                kernel.horizon = math.inf
                self._maybe_pipeline()
                return
            reply = self._process.read_reply()
        self._after_reply(reply, t)

    def _after_reply(self, reply: dict[str, Any], t: float | None) -> None:
        """Deliveries scheduled; the horizon where the engine stopped (``t``: the time it was
        asked to reach; None for a late reply in real time)."""
        kernel = self.kernel
        reached = float(reply["now_s"])
        self._engine_until_s = reached
        self._apply(reply)
        if reply.get("in_flight", 0) == 0 and not self._outbox:
            kernel.horizon = math.inf
        elif t is None:
            kernel.horizon = kernel.now  # exchange again before the next event
        elif reached >= round(t, 9) - TIME_RESOLUTION_S / 2:
            kernel.horizon = t  # ns-3 got there (to its nanosecond)
        else:
            kernel.horizon = reached  # stopped at a delivery, now on the kernel

    def _poll_reply(self) -> bool:
        """Real time: read a reply still out if it has come (True: none is out now)."""
        if self._awaiting_since_s is None:
            return True
        if self._process.poll(0):
            self._awaiting_since_s = None
            reply = self._process.read_reply()
            if self.exact:
                self._after_reply(reply, None)
            else:
                self._apply(reply)
            return True
        gone = self._process.gone()
        if gone or self.kernel.now - self._awaiting_since_s > self.timeout_s:
            self._lose(gone or f"no reply within {self.timeout_s} s")
        return False

    def _maybe_pipeline(self) -> None:
        """Real time: too many exchanges missed their wait — ns-3 cannot keep up at exact
        time; from now on the pipeline of two sync periods (module rules)."""
        if self.exchanges_late < PIPELINE_AFTER_LATE or \
                self.exchanges_late <= PIPELINE_LATE_SHARE * self.exchanges:
            return
        self.exact = False
        self.pipeline_s = 2 * self.sync_period_s
        self.kernel.horizon = math.inf
        self.kernel.on_horizon = None
        log.warning("ns-3 backend: %d of %d exchanges took longer than a sync period (%.0f ms) "
                    "of wall time: ns-3 cannot keep up at exact time in real time; switching to "
                    "a pipeline of two sync periods (%.0f ms more latency per datagram)",
                    self.exchanges_late, self.exchanges, self.sync_period_s * 1e3,
                    self.pipeline_s * 1e3)

    def _cycle_realtime(self) -> None:
        now = self.kernel.now
        if self._awaiting_since_s is not None:
            if self._process.poll(0):
                if now - self._awaiting_since_s > self.sync_period_s + 1e-9:
                    self.replies_late += 1
                self._awaiting_since_s = None
                self._apply(self._process.read_reply())
            else:
                gone = self._process.gone()
                if gone or now - self._awaiting_since_s > self.timeout_s:
                    self._lose(gone or f"no reply within {self.timeout_s} s")
                return  # still computing: this cycle's packets wait for the next request
        if not self._process.send_nowait(self._step_request()):  # no engine connected any more
            self._lose(self._process.gone() or "engine disconnected")
            return
        self._awaiting_since_s = now

    def _apply(self, reply: dict[str, Any]) -> None:
        now = self.kernel.now
        self.cells.step(reply)
        for item in reply["delivered"]:
            p = self._in_flight.pop(item["id"], None)
            if p is None:
                continue
            time_s = float(item["time_s"])
            p.net_latency_s = time_s - p.inject_at_s
            if time_s >= now:
                self.kernel.schedule(time_s, self._arrive, p, priority=PRIORITY_NETWORK)
            elif self.exact and now - time_s <= TIME_RESOLUTION_S:
                # ns-3's nanosecond against the kernel's unrounded float: the same instant.
                self.kernel.schedule(now, self._arrive, p, priority=PRIORITY_NETWORK)
            elif self.late_policy == "deliver":
                p.link.stats.late_delivered += 1
                self.kernel.schedule(now, self._arrive, p, priority=PRIORITY_NETWORK)
            else:
                self._count_drop(p, Drop.LATE.value)
        for item in reply["dropped"]:
            p = self._in_flight.pop(item["id"], None)
            if p is not None:
                self._count_drop(p, str(item["reason"]))

    def _arrive(self, p: _Packet) -> None:
        stats = p.link.stats
        stats.in_flight -= 1
        stats.record_delivery(self.kernel.now - p.sent_at_s, len(p.packet))
        if isinstance(stats, Ns3LinkStats):
            stats.net_latency_sum_s += p.net_latency_s
        if self.tracer is not None:
            self.tracer("recv", p.link.name, self.kernel.now, len(p.packet), "")
        p.link.deliver(p.packet, p.meta)

    def _send(self, link: Ns3Link, packet: bytes, meta: Any) -> None:
        stats = link.stats
        stats.sent += 1
        stats.bytes_sent += len(packet)
        now = self.kernel.now
        if self.lost is not None:
            stats.dropped[DROP_BACKEND] += 1
            if self.tracer is not None:
                self.tracer("drop", link.name, now, len(packet), DROP_BACKEND)
            return
        stats.in_flight += 1
        if self.tracer is not None:
            self.tracer("send", link.name, now, len(packet), "")
        self._outbox.append(_Packet(self._next_id, link, packet, meta, now))
        self._next_id += 1
        if self.exact and self.started:
            self.kernel.horizon = min(self.kernel.horizon, now + LOOKAHEAD_S)

    def _count_drop(self, p: _Packet, reason: str) -> None:
        p.link.stats.in_flight -= 1
        p.link.stats.dropped[reason] += 1
        if self.tracer is not None:
            self.tracer("drop", p.link.name, self.kernel.now, len(p.packet), reason)

    def _drop_all(self, reason: str) -> None:
        for p in [*self._in_flight.values(), *self._outbox]:
            self._count_drop(p, reason)
        self._in_flight.clear()
        self._outbox.clear()

    def _lose(self, why: str) -> None:
        """The engine is gone: say so once, drop what it held, stop it, carry on (or raise)."""
        self.cycles_lost += 1
        self.lost = why
        self._awaiting_since_s = None
        log.error("ns-3 backend (%s engine) lost at t=%.3f s: %s; its packets are dropped "
                  "(reason %r) and the physics keeps running", self.engine, self.kernel.now,
                  why, DROP_BACKEND)
        self._drop_all(DROP_BACKEND)
        self._process.stop()
        if self.strict:
            raise Ns3Error(f"ns-3 backend lost: {why}")

    def backend_stats(self) -> dict[str, Any]:
        """Cycle counters of the co-simulation itself (per-link counters are in each link)."""
        stats = {"engine": self.engine, "cycles": self.cycles, "cycles_lost": self.cycles_lost,
                 "replies_late": self.replies_late, "lost": self.lost,
                 "exchanges": self.exchanges, "exchanges_late": self.exchanges_late,
                 "pipeline_ms": round(self.pipeline_s * 1e3, 3)}
        if self.config.get("topology") == "lte":
            stats.update(self.cells.stats())
        return stats
