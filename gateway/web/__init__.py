"""The live view: one web page (a local map, the links, a timeline of drops) fed from the bus.

address.py parses ``[ADDR:]PORT``; model.py (sans-IO) folds bus messages into what the page
shows; server.py serves the page and streams it (aiohttp, server-sent events), fed in-process
by the daemon (``cornet run --web``) or from a ZeroMQ bus (``cornet web --zmq``); static/ is the
page itself (plain JavaScript on a canvas). docs/web.md describes it.
"""

from __future__ import annotations

import errno
import sys
from typing import TYPE_CHECKING

from gateway.web.address import AIOHTTP_MISSING, WebListenError, missing_aiohttp

if TYPE_CHECKING:
    from gateway.bus.zmq_pub import Publisher
    from gateway.web.server import WebServer


async def start(listen: tuple[str, int], publisher: Publisher) -> WebServer:
    """The daemon's live view on ``listen``, fed by ``publisher``. Raises WebListenError (an
    OSError) if it cannot start: the address is taken, or aiohttp is missing."""
    try:
        from gateway.web.run import attach  # aiohttp: imported only for the live view
    except ImportError as exc:
        if not missing_aiohttp(exc):
            raise
        raise WebListenError(errno.ENOENT, AIOHTTP_MISSING) from exc
    return await attach(listen, publisher)


def main(endpoint: str, listen: tuple[str, int]) -> int:
    """``cornet web``: exit 2 naming aiohttp where it is missing."""
    try:
        from gateway.web.run import main as run
    except ImportError as exc:
        if not missing_aiohttp(exc):
            raise
        print(f"cornet web: {AIOHTTP_MISSING}", file=sys.stderr)
        return 2
    return run(endpoint, listen)
