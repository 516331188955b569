"""sd_notify(3) without libsystemd: readiness, watchdog, reload and status for a Type=notify unit.

The protocol (sd_notify(3), "Socket protocol"): newline-separated ``KEY=VALUE`` assignments in
one datagram to the AF_UNIX SOCK_DGRAM socket named by ``$NOTIFY_SOCKET``; a name that starts with
``@`` lives in the abstract namespace (the ``@`` stands for a leading NUL byte). Without
``$NOTIFY_SOCKET`` every call is a no-op, so the daemon runs the same outside systemd.

Rules:
- Never raises and never blocks the event loop: the socket is non-blocking, and a send that fails
  (no listener, a full queue) is counted in ``send_errors`` and logged once. A lost notification
  must not take the simulation down; systemd's own time-outs handle a daemon that never reports.
- The watchdog is on only as sd_watchdog_enabled(3) decides: ``$WATCHDOG_USEC`` is a positive
  integer, and ``$WATCHDOG_PID`` is unset or our pid (a child that inherited the variables does not
  ping on its parent's behalf). ``watchdog_interval_s`` is half the period, as the man page advises.
- Reloading follows systemd ≥ 253's ``Type=notify-reload`` protocol, which older versions accept:
  ``RELOADING=1`` with ``MONOTONIC_USEC`` (CLOCK_MONOTONIC, as systemd reads it), then ``READY=1``
  once the new configuration is in effect (or the old one is kept).
- ``Watchdog`` is the daemon's policy on top: it pings only while the simulation is healthy.
"""

from __future__ import annotations

import logging
import os
import socket
import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gateway.sim.simulation import Simulation

log = logging.getLogger(__name__)


def socket_address(name: str) -> str | None:
    """The ``AF_UNIX`` address ``$NOTIFY_SOCKET`` names: a path, or ``@name`` → ``\\0name``.
    None for anything else (e.g. ``vsock:``, which this module does not speak)."""
    if name.startswith("/"):
        return name
    if name.startswith("@") and len(name) > 1:
        return "\0" + name[1:]
    return None


def watchdog_usec(environ: Mapping[str, str], pid: int) -> int | None:
    """The watchdog period in µs if it applies to process ``pid`` (sd_watchdog_enabled(3)),
    else None. Malformed values disable it with a warning, as libsystemd returns -EINVAL."""
    text = environ.get("WATCHDOG_USEC")
    if text is None:
        return None
    try:
        usec = int(text)
    except ValueError:
        usec = 0
    if usec <= 0:
        log.warning("ignoring WATCHDOG_USEC=%r: not a positive integer", text)
        return None
    owner = environ.get("WATCHDOG_PID")
    if owner is not None:
        try:
            owner_pid = int(owner)
        except ValueError:
            log.warning("ignoring the watchdog: WATCHDOG_PID=%r is not a pid", owner)
            return None
        if owner_pid != pid:
            return None  # meant for another process (our parent)
    return usec


class Notifier:
    """Sends notifications to systemd's socket; every method is a no-op without one."""

    def __init__(self, address: str | None = None, watchdog_usec: int | None = None) -> None:
        self.address = address  # as for socket.sendto: a path, or "\0name" (abstract)
        self.watchdog_usec = watchdog_usec
        self.sent = 0
        self.send_errors = 0
        self._sock: socket.socket | None = None

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None,
                 pid: int | None = None) -> Notifier:
        """From ``$NOTIFY_SOCKET``, ``$WATCHDOG_USEC`` and ``$WATCHDOG_PID`` (default: this
        process's environment and pid). Unset or unusable socket: a notifier that does nothing."""
        environ = os.environ if environ is None else environ
        pid = os.getpid() if pid is None else pid
        name = environ.get("NOTIFY_SOCKET") or None
        address = None
        if name is not None:
            address = socket_address(name)
            if address is None:
                log.warning("NOTIFY_SOCKET=%r: only AF_UNIX paths and @abstract names are "
                            "supported; not notifying systemd", name)
        return cls(address, watchdog_usec(environ, pid) if address is not None else None)

    @property
    def enabled(self) -> bool:
        return self.address is not None

    @property
    def watchdog_interval_s(self) -> float | None:
        """How often to ping: half the watchdog period; None when no watchdog is asked for."""
        if self.address is None or self.watchdog_usec is None:
            return None
        return self.watchdog_usec / 2e6

    def send(self, *assignments: str) -> bool:
        """One datagram of ``KEY=VALUE`` lines. True if it left; False if not (or no socket)."""
        if self.address is None:
            return False
        message = "\n".join(assignments).encode("utf-8", "replace")
        try:
            if self._sock is None:
                sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC)
                sock.setblocking(False)
                self._sock = sock
            self._sock.sendto(message, self.address)
        except OSError as exc:
            self.send_errors += 1
            if self.send_errors == 1:
                shown = self.address.replace("\0", "@", 1)
                log.warning("cannot notify systemd at %s: %s (further failures are only "
                            "counted)", shown, exc.strerror or exc)
            return False
        self.sent += 1
        return True

    def ready(self, status: str | None = None) -> bool:
        return self.send("READY=1", *self._status(status))

    def watchdog(self) -> bool:
        return self.send("WATCHDOG=1")

    def stopping(self, status: str | None = None) -> bool:
        return self.send("STOPPING=1", *self._status(status))

    def reloading(self, status: str | None = None, monotonic_usec: int | None = None) -> bool:
        """Say a reload started; call ``ready()`` when it is over, whatever its outcome."""
        if monotonic_usec is None:
            monotonic_usec = time.clock_gettime_ns(time.CLOCK_MONOTONIC) // 1000
        return self.send("RELOADING=1", f"MONOTONIC_USEC={monotonic_usec}", *self._status(status))

    def status(self, text: str) -> bool:
        return self.send(*self._status(text))

    @staticmethod
    def _status(text: str | None) -> list[str]:
        # One line per assignment: a newline inside would start a new (bogus) assignment.
        return [] if text is None else ["STATUS=" + " ".join(text.splitlines())]

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None


class Watchdog:
    """Feeds systemd's watchdog (WATCHDOG=1 every ``interval_s`` of wall time) while the
    simulation is healthy. Healthy means all of:

    - the pacer's loop runs: ``poll`` is called from it, so a blocked event loop, a hung
      callback or a crashed pacer stops the pings;
    - simulated time advanced since the previous ping: the kernel is moving, not stuck;
    - no unrecovered fatal error: the network backend is not lost (an ns-3 engine that died is
      not restarted in the process; systemd restarts the whole daemon instead).

    Errors the daemon recovers from — a datagram that raised inside a session
    (``internal_errors``), the pacer slipping behind the wall clock under load — do not stop the
    pings: the vehicles still fly. When the pings stop, systemd kills and restarts the unit after
    WatchdogSec (Restart=on-failure).
    """

    def __init__(self, notifier: Notifier, sim: Simulation, interval_s: float,
                 clock: Callable[[], float]) -> None:
        self.notifier = notifier
        self.sim = sim
        self.interval_s = interval_s
        self._clock = clock
        self._due = clock()
        self._last_sim_s = sim.now
        self._complained = False
        self.pings = 0

    def problem(self) -> str | None:
        """Why the simulation is not healthy, or None if it is."""
        lost = getattr(self.sim.backend, "lost", None)
        if lost:
            return f"the network backend was lost ({lost})"
        if not self.sim.now > self._last_sim_s:
            return f"simulated time has not advanced since t={self._last_sim_s:.3f} s"
        return None

    def poll(self) -> None:
        now = self._clock()
        if now < self._due:
            return
        problem = self.problem()
        if problem is not None:
            if not self._complained:
                log.error("not feeding the systemd watchdog: %s", problem)
                self._complained = True
            return
        self.notifier.watchdog()
        self.pings += 1
        self._last_sim_s = self.sim.now
        self._due = now + self.interval_s
        self._complained = False
