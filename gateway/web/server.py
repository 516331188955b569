"""The live view's HTTP side (aiohttp): the page, its static files, and its stream.

  GET /             the page (static/index.html); /static/… its script and style
  GET /events       server-sent events: a ``snapshot`` (with trails) first, then ``frame``s
  GET /state.json   the snapshot, once (tools, tests)

The model (model.py) is fed by ``publish(topic, message)``: in-process, a listener of the
daemon's publisher (``cornet run --web``), or from a ZeroMQ subscription (``cornet web``, see
``zmq_feed``). Feeding only updates the model, so it never holds up the simulation. A frame is
encoded once every FRAME_PERIOD_S of wall-clock time, when something changed, and offered to
every page; each page has a queue of QUEUE_FRAMES: a page that does not keep up loses its
oldest frames (counted in ``frames_dropped``), never the simulation's time.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
from collections import deque
from pathlib import Path
from typing import Any

from aiohttp import web

from gateway.bus.zmq_pub import TOPIC_FAULT, TOPIC_LINKS, TOPIC_STATE
from gateway.web.address import url
from gateway.web.model import LiveModel

log = logging.getLogger(__name__)

STATIC = Path(__file__).with_name("static")
FRAME_PERIOD_S = 0.25
QUEUE_FRAMES = 8
SHUTDOWN_TIMEOUT_S = 1.0


def _finite(value: Any) -> Any:
    """``value`` with every NaN or infinity replaced by None (JSON has neither)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def _json(body: dict[str, Any]) -> str:
    try:
        return json.dumps(body, separators=(",", ":"), allow_nan=False)
    except ValueError:  # a NaN somewhere (a browser's JSON.parse would refuse the whole frame)
        return json.dumps(_finite(body), separators=(",", ":"))


def _event(kind: str, body: dict[str, Any]) -> bytes:
    return f"event: {kind}\ndata: {_json(body)}\n\n".encode()


class _Page:
    """One connected page: its frames waiting to be written, oldest dropped first."""

    def __init__(self) -> None:
        self.frames: deque[bytes] = deque(maxlen=QUEUE_FRAMES)
        self.ready = asyncio.Event()
        self.dropped = 0

    def offer(self, data: bytes) -> bool:
        """Queue ``data``; True if that pushed out an unsent frame."""
        full = len(self.frames) == self.frames.maxlen
        self.frames.append(data)
        self.ready.set()
        if full:
            self.dropped += 1
        return full


class WebServer:
    def __init__(self, host: str, port: int, model: LiveModel | None = None, *,
                 source: str = "", frame_period_s: float = FRAME_PERIOD_S) -> None:
        self.host, self.port = host, port
        self.model = model or LiveModel()
        self.source = source  # what feeds it, for the page's header
        self.frame_period_s = frame_period_s
        self.pages: set[_Page] = set()
        self.frames_sent = 0
        self.frames_dropped = 0
        self._closing = False
        self._runner: web.AppRunner | None = None
        self._ticker: asyncio.Task | None = None
        app = web.Application()
        app.router.add_get("/", self._index)
        app.router.add_get("/events", self._events)
        app.router.add_get("/state.json", self._state)
        app.router.add_static("/static/", STATIC)
        self.app = app

    def publish(self, topic: bytes, message: dict) -> None:
        """A bus message (a Publisher listener): folded into the model, nothing more."""
        if topic in (TOPIC_STATE, TOPIC_LINKS, TOPIC_FAULT):
            self.model.ingest(topic, message)

    async def start(self) -> None:
        """Listen (raises OSError if the address cannot be bound) and start the frames."""
        runner = web.AppRunner(self.app, access_log=None, shutdown_timeout=SHUTDOWN_TIMEOUT_S)
        await runner.setup()
        site = web.TCPSite(runner, self.host, self.port)
        try:
            await site.start()
        except BaseException:
            await runner.cleanup()
            raise
        self._runner = runner
        if self.port == 0 and runner.addresses:  # a free port was asked for
            self.port = int(runner.addresses[0][1])
        self._ticker = asyncio.create_task(self._tick(), name="web frames")

    @property
    def url(self) -> str:
        return url(self.host, self.port)

    def stats(self) -> dict[str, Any]:
        return {"pages": len(self.pages), "frames_sent": self.frames_sent,
                "frames_dropped": self.frames_dropped, "messages": self.model.messages,
                "ignored": self.model.ignored, "source": self.source}

    def broadcast(self) -> None:
        """Encode the model's frame once and offer it to every page."""
        frame = self.model.frame()
        frame["server"] = self.stats()
        data = _event("frame", frame)
        for page in self.pages:
            if page.offer(data):
                self.frames_dropped += 1
        self.frames_sent += 1

    async def _tick(self) -> None:
        shown = -1
        while True:
            await asyncio.sleep(self.frame_period_s)
            if self.pages and self.model.version != shown:
                shown = self.model.version
                self.broadcast()

    async def close(self) -> None:
        log.info("live view: %d frames sent, %d dropped for pages that did not keep up",
                 self.frames_sent, self.frames_dropped)
        self._closing = True
        for page in self.pages:
            page.ready.set()
        if self._ticker is not None:
            self._ticker.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._ticker
        if self._runner is not None:
            await self._runner.cleanup()
            self._runner = None

    # --- handlers ---------------------------------------------------------------------------
    async def _index(self, request: web.Request) -> web.StreamResponse:
        return web.FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-cache"})

    def _snapshot(self) -> dict[str, Any]:
        snapshot = self.model.snapshot()
        snapshot["server"] = self.stats()
        return snapshot

    async def _state(self, request: web.Request) -> web.Response:
        return web.json_response(text=_json(self._snapshot()))

    async def _events(self, request: web.Request) -> web.StreamResponse:
        response = web.StreamResponse(headers={"Content-Type": "text/event-stream",
                                               "Cache-Control": "no-cache"})
        await response.prepare(request)
        page = _Page()
        self.pages.add(page)
        try:
            await response.write(_event("snapshot", self._snapshot()))
            while not self._closing:
                await page.ready.wait()
                page.ready.clear()
                while page.frames and not self._closing:
                    await response.write(page.frames.popleft())
        except ConnectionError:
            pass  # the page went away
        finally:
            self.pages.discard(page)
        return response


def zmq_subscribe(endpoint: str) -> Any:
    """A SUB socket on a daemon's ZeroMQ bus (``--zmq-pub``), for what the page shows; raises
    zmq.ZMQError for an endpoint it cannot use."""
    import zmq
    import zmq.asyncio

    sock = zmq.asyncio.Context.instance().socket(zmq.SUB)
    sock.setsockopt(zmq.LINGER, 0)
    for topic in (TOPIC_STATE, TOPIC_LINKS, TOPIC_FAULT):
        sock.setsockopt(zmq.SUBSCRIBE, topic)
    try:
        sock.connect(endpoint)
    except BaseException:
        sock.close(0)
        raise
    return sock


async def zmq_feed(server: WebServer, sock: Any) -> None:
    """Feed ``server`` from ``sock`` (``zmq_subscribe``) until cancelled."""
    while True:
        topic, body = await sock.recv_multipart()
        try:
            message = json.loads(body)
        except ValueError:
            server.model.ignored += 1
            continue
        if isinstance(message, dict):
            server.publish(topic, message)
