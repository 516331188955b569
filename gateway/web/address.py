"""``[ADDR:]PORT`` for ``--web`` and ``--listen``: parsed without importing the web stack."""

from __future__ import annotations

from gateway.sim.values import listen_address

AIOHTTP_MISSING = "the live view needs aiohttp: pip install 'cornet[web]'"


class WebListenError(OSError):
    """The live view's address could not be listened on; the message says which and why."""

    def __str__(self) -> str:
        return str(self.strerror)


def parse_listen(text: str, flag: str = "--web") -> tuple[str, int]:
    """(host, port) from ``8080``, ``0.0.0.0:8080``, ``localhost:8080`` or ``[::1]:8080``.
    Raises ValueError with a sentence that says what to write instead."""
    return listen_address(text, flag, f"{flag} 8080 or {flag} 127.0.0.1:8080")


def url(host: str, port: int) -> str:
    shown = "127.0.0.1" if host in ("0.0.0.0", "::") else host
    return f"http://[{shown}]:{port}/" if ":" in shown else f"http://{shown}:{port}/"


def listen_arg(flag: str):
    """An argparse type for ``flag``: (host, port); also says so if aiohttp is missing."""
    import argparse
    import importlib.util

    def parse(text: str) -> tuple[str, int]:
        try:
            listen = parse_listen(text, flag)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        if importlib.util.find_spec("aiohttp") is None:
            raise argparse.ArgumentTypeError(AIOHTTP_MISSING)
        return listen

    return parse
