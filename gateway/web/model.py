"""What the live view shows, folded from bus messages (docs/zmq.md, schema v1). Sans-IO: no
sockets and no clock but the messages' own simulated time, so tests feed it dictionaries.

- ``cornet.state``: every vehicle's latest state and a trail of where it has been (a point each
  time it has moved TRAIL_STEP_M from the last one, the last TRAIL_POINTS of them); the ground
  nodes (access points, ground radios) and the world's home.
- ``cornet.links``: per vehicle link (``v1/gcs``: both directions together) the loss and mean
  latency over the last interval (the difference of two messages), and its state for the page's
  colours: ``idle`` (nothing sent, or nothing arrived nor lost yet), ``lost`` (loss, the
  datagrams dropped over those sent, >= LOST_LOSS), ``degraded`` (loss >= GOOD_LOSS or mean
  latency >= GOOD_LATENCY_MS), else ``good``. Each interval
  is also a bin of the timeline: drops by reason and late packets, over all links.
- ``cornet.fault``: an event on the timeline. So are links going to or coming back from ``lost``.

Simulated time going backwards means the daemon restarted: everything starts again.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from typing import Any

from gateway.bus.zmq_pub import SCHEMA_VERSION

GOOD_LOSS = 0.05
LOST_LOSS = 0.5
GOOD_LATENCY_MS = 100.0
TRAIL_STEP_M = 0.5
TRAIL_POINTS = 400
TIMELINE_BINS = 300  # one per cornet.links message: 5 minutes of simulated time
EVENTS = 200
STATES = ("good", "degraded", "lost", "idle")


def classify(sent: int, delivered: int, loss: float, latency_ms: float | None) -> str:
    if sent <= 0:
        return "idle"
    if loss >= LOST_LOSS:
        return "lost"
    if delivered <= 0:  # nothing lost, nothing arrived yet: still in flight
        return "idle"
    if loss >= GOOD_LOSS or (latency_ms is not None and latency_ms >= GOOD_LATENCY_MS):
        return "degraded"
    return "good"


def _interval(now: dict, before: dict | None) -> tuple[int, int, float, Counter, int]:
    """(sent, delivered, latency sum ms, drops by reason, late delivered) since ``before``."""
    before = before or {}
    dropped = Counter(now.get("dropped", {}))
    dropped.subtract(before.get("dropped", {}))
    delivered = now["delivered"] - before.get("delivered", 0)
    latency_sum = (now["latency_mean_ms"] * now["delivered"]
                   - before.get("latency_mean_ms", 0.0) * before.get("delivered", 0))
    return (now["sent"] - before.get("sent", 0), delivered, max(0.0, latency_sum),
            +dropped, now.get("late_delivered", 0) - before.get("late_delivered", 0))


class LiveModel:
    def __init__(self) -> None:
        self.messages = 0
        self.ignored = 0  # messages of another schema version
        self.version = 0  # grows with every message taken in
        self._reset()

    def _reset(self) -> None:
        self.t: float | None = None
        self.home: dict | None = None
        self.vehicles: dict[int, dict] = {}
        self.trails: dict[int, deque[tuple[float, float]]] = {}
        self.nodes: list[dict] = []
        self.links: dict[str, dict] = {}
        self.serving: dict[str, str | None] = {}
        self._counters: dict[str, dict] = {}
        self.timeline: deque[dict] = deque(maxlen=TIMELINE_BINS)
        self.events: deque[dict] = deque(maxlen=EVENTS)

    def ingest(self, topic: bytes | str, msg: dict[str, Any]) -> bool:
        """Take in one bus message; False if it is not understood (and ignored)."""
        if msg.get("v") != SCHEMA_VERSION:
            self.ignored += 1
            return False
        name = topic.decode() if isinstance(topic, bytes) else topic
        t = msg.get("t")
        if not isinstance(t, (int, float)):
            self.ignored += 1
            return False
        if self.t is not None and t < self.t - 1.0:
            self._reset()
            self.events.append({"t": t, "kind": "restart", "text": "the simulation restarted"})
        if name == "cornet.state":
            self._state(msg)
        elif name == "cornet.links":
            self._links(msg)
        elif name == "cornet.fault":
            self.events.append({"t": t, "kind": "fault", "text": str(msg.get("fault", "fault"))})
        else:
            self.ignored += 1
            return False
        self.t = t if self.t is None else max(self.t, t)
        self.messages += 1
        self.version += 1
        return True

    def _state(self, msg: dict) -> None:
        self.home = msg.get("home", self.home)
        self.nodes = msg.get("nodes", self.nodes)
        for v in msg.get("vehicles", []):
            sysid = int(v["sysid"])
            self.vehicles[sysid] = v
            n, e, _ = v["world_ned_m"]
            trail = self.trails.get(sysid)
            if trail is None:
                trail = self.trails[sysid] = deque(maxlen=TRAIL_POINTS)
            if not trail or math.hypot(n - trail[-1][0], e - trail[-1][1]) >= TRAIL_STEP_M:
                trail.append((n, e))

    def _links(self, msg: dict) -> None:
        t = msg["t"]
        stats: dict[str, dict] = msg.get("links", {})
        groups: dict[str, list[str]] = {}
        for name in stats:
            groups.setdefault(name.rpartition("/")[0], []).append(name)
        all_dropped: Counter = Counter()
        all_late = 0
        for base, names in sorted(groups.items()):
            sent = delivered = late = 0
            latency_sum = 0.0
            dropped: Counter = Counter()
            for name in names:
                s, d, lat, drops, lt = _interval(stats[name], self._counters.get(name))
                sent, delivered, latency_sum, late = sent + s, delivered + d, latency_sum + lat, \
                    late + lt
                dropped.update(drops)
            lost = sum(dropped.values())
            loss = lost / sent if sent > 0 else 0.0
            latency = latency_sum / delivered if delivered > 0 else None
            state = classify(sent, delivered, loss, latency)
            before = self.links.get(base, {}).get("state")
            if before is not None and before != state and "lost" in (before, state):
                self.events.append({"t": t, "kind": "link", "link": base, "state": state,
                                    "text": f"{base} {'lost' if state == 'lost' else state}"})
            vehicle, _, tag = base.partition("/")
            self.links[base] = {
                "link": base, "sysid": int(vehicle[1:]) if vehicle[1:].isdigit() else None,
                "tag": tag, "state": state, "loss": round(loss, 4),
                "latency_ms": None if latency is None else round(latency, 2),
                "sent": sent, "delivered": delivered, "dropped": dict(dropped), "late": late}
            all_dropped.update(dropped)
            all_late += late
        self._counters = stats
        self.timeline.append({"t": t, "dropped": dict(all_dropped), "late": all_late})
        network = msg.get("network") or {}
        self.serving = network.get("serving") or {}

    # --- what the page gets -----------------------------------------------------------------
    def frame(self) -> dict[str, Any]:
        """The page's update: everything but the trails (the page extends its own)."""
        return {
            "type": "frame", "t": self.t, "home": self.home,
            "vehicles": [self.vehicles[k] for k in sorted(self.vehicles)],
            "nodes": self.nodes, "links": [self.links[k] for k in sorted(self.links)],
            "serving": self.serving, "timeline": list(self.timeline),
            "events": list(self.events)[-50:],
            "thresholds": {"good_loss": GOOD_LOSS, "lost_loss": LOST_LOSS,
                           "good_latency_ms": GOOD_LATENCY_MS, "trail_step_m": TRAIL_STEP_M,
                           "trail_points": TRAIL_POINTS},
        }

    def snapshot(self) -> dict[str, Any]:
        """A frame with every vehicle's trail: what a page gets first."""
        out = self.frame()
        out["type"] = "snapshot"
        out["trails"] = {str(k): [list(p) for p in trail] for k, trail in self.trails.items()}
        return out
