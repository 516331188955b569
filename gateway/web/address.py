"""``[ADDR:]PORT`` for ``--web`` and ``--listen``: parsed without importing the web stack."""

from __future__ import annotations

from typing import Any

from gateway.sim.values import listen_address

AIOHTTP_MISSING = "the live view needs aiohttp: pip install 'cornet[web]'"


def missing_aiohttp(exc: ImportError) -> bool:
    """Whether ``exc`` is aiohttp (or a part of it) missing."""
    return (exc.name or "").partition(".")[0] == "aiohttp"


def have_aiohttp() -> bool:
    try:
        import aiohttp  # noqa: F401
    except ImportError as exc:
        if missing_aiohttp(exc):
            return False
        raise
    return True


class WebListenError(OSError):
    """The live view cannot start (its address cannot be listened on, or aiohttp is missing);
    the message says which and why."""

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

    def parse(text: str) -> tuple[str, int]:
        try:
            listen = parse_listen(text, flag)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        if not have_aiohttp():
            raise argparse.ArgumentTypeError(AIOHTTP_MISSING)
        return listen

    return parse


def add_web_parser(sub: Any) -> None:
    """``cornet web``: its subparser (``sub``: the command line's subparsers)."""
    web = sub.add_parser("web", help="the live view of a daemon running with --zmq-pub",
                         description="Serve the live view (docs/web.md) of the daemon "
                         "publishing on --zmq.")
    web.add_argument("--zmq", default="tcp://127.0.0.1:5556", metavar="ENDPOINT",
                     help="the daemon's --zmq-pub endpoint (default tcp://127.0.0.1:5556)")
    web.add_argument("--listen", type=listen_arg("--listen"), default=("127.0.0.1", 8080),
                     metavar="[ADDR:]PORT", help="default 127.0.0.1:8080")
