"""Starting the live view: inside the daemon (``cornet run --web``) or on its own, fed from a
running daemon's ZeroMQ bus (``cornet web --zmq ENDPOINT --listen [ADDR:]PORT``)."""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import logging
import os
import signal
import sys
from typing import TextIO

from gateway.bus.zmq_pub import Publisher
from gateway.web.address import WebListenError
from gateway.web.server import WebServer, zmq_feed, zmq_subscribe

log = logging.getLogger(__name__)


def _warn_if_open(host: str) -> None:
    if host != "localhost" and not ipaddress.ip_address(host).is_loopback:
        log.warning("the live view is open to the network on %s (it shows, it cannot fly)", host)


async def _start(server: WebServer, flag: str) -> None:
    try:
        await server.start()
    except OSError as exc:
        reason = os.strerror(exc.errno) if exc.errno else str(exc)
        raise WebListenError(exc.errno, f"{flag} {server.host}:{server.port}: {reason}; "
                                        "choose a free port") from exc


async def attach(listen: tuple[str, int], publisher: Publisher) -> WebServer:
    """The daemon's live view: listening on ``listen``, fed by ``publisher``'s messages."""
    server = WebServer(*listen, source="this daemon")
    await _start(server, "--web")
    publisher.listeners.append(server.publish)
    _warn_if_open(server.host)
    log.info("live view: %s", server.url)
    return server


async def serve_bus(endpoint: str, listen: tuple[str, int], out: TextIO = sys.stdout) -> int:
    """``cornet web``: the live view of the daemon publishing on ``endpoint``, until
    SIGINT/SIGTERM."""
    sock = zmq_subscribe(endpoint)
    server = WebServer(*listen, source=endpoint)
    try:
        await _start(server, "--listen")
    except OSError:
        sock.close(0)
        raise
    feed = asyncio.create_task(zmq_feed(server, sock), name="zmq feed")
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    _warn_if_open(server.host)
    print(f"cornet web: {server.url} shows {endpoint}", file=out, flush=True)
    waiter = asyncio.create_task(stop.wait())
    try:
        await asyncio.wait([feed, waiter], return_when=asyncio.FIRST_COMPLETED)
        if feed.done() and (failure := feed.exception()) is not None:
            raise failure
    finally:
        for task in (feed, waiter):
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)
        await server.close()
        sock.close(0)
    return 0


def main(endpoint: str, listen: tuple[str, int]) -> int:
    import zmq

    logging.basicConfig(level="INFO", format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        return asyncio.run(serve_bus(endpoint, listen))
    except WebListenError as exc:
        print(f"cornet web: {exc}", file=sys.stderr)
        return 2
    except zmq.ZMQError as exc:
        print(f"cornet web: --zmq {endpoint}: {exc} (e.g. tcp://127.0.0.1:5556)", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 0
