"""The MAVLink shell's transport (SERIAL_CONTROL, device SHELL), as PX4's mavlink_receiver and
MavlinkShell: bytes in from the client, the shell's output back in REPLY frames.

Source: PX4 src/modules/mavlink/mavlink_receiver.cpp (handle_message_serial_control),
mavlink_main.cpp (the shell output), mavlink_shell.cpp.
Rules:
- Only device SERIAL_CONTROL_DEV_SHELL without the REPLY flag is taken; the target system must
  be ours or 0. The shell starts with the first such message (``terminal_factory``; None: no
  shell on this vehicle, the message is ignored).
- ``count`` bytes of ``data`` go to the shell; its output returns to the sender as
  SERIAL_CONTROL frames (flags REPLY, device SHELL, at most 70 bytes each), right away (PX4
  also fills the target extension fields; this pymavlink's message has none, and the clients
  take the replies without them).
- A message without the RESPOND flag closes the shell (PX4: "no response requested, assume the
  shell is no longer used"); the next one starts a new one.
- At most ``MAX_PENDING`` bytes of output are kept per call (a flood of output is cut, counted).
- A command that runs on (``listener -n``) prints at its terminal's ``next_s``: the service's
  ``due_s``, when the session calls ``handle_timer``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

from pymavlink.dialects.v20 import common as M

from gateway.mavlink.link import LinkContext

DATA_LEN = 70
MAX_PENDING = 64 * 1024


class Terminal(Protocol):
    def write(self, data: bytes, now_s: float) -> bytes: ...  # input → what the shell printed

    @property
    def next_s(self) -> float: ...  # when a command still running prints next (inf: none)

    def poll(self, now_s: float) -> bytes: ...  # what it printed since


class SerialControlService:
    def __init__(self, ctx: LinkContext) -> None:
        self.sysid = ctx.sysid
        self.encoder = ctx.encoder
        self.send = ctx.send
        self.stats = ctx.stats
        self.terminal_factory: Callable[[], Terminal] | None = None  # attached by the shell
        self._terminal: Terminal | None = None
        self.truncated = 0  # output bytes dropped (MAX_PENDING)
        self.due_s = math.inf  # when the shell's running command prints next (``_next``)

    def on_serial_control(self, msg: M.MAVLink_serial_control_message, now_s: float) -> None:
        if msg.device != M.SERIAL_CONTROL_DEV_SHELL or msg.flags & M.SERIAL_CONTROL_FLAG_REPLY:
            return
        # target_system is an extension this pymavlink does not decode: absent means 0.
        if getattr(msg, "target_system", 0) not in (0, self.sysid) or self.terminal_factory is None:
            return
        if self._terminal is None:
            self._terminal = self.terminal_factory()
        count = max(0, min(int(msg.count), len(msg.data)))
        if count:
            self._reply(self._terminal.write(bytes(msg.data[:count]), now_s))
        if not msg.flags & M.SERIAL_CONTROL_FLAG_RESPOND:
            self._terminal = None
        self._next()

    def handle_timer(self, now_s: float) -> None:
        if self._terminal is not None:
            self._reply(self._terminal.poll(now_s))
        self._next()

    def _next(self) -> None:
        """``due_s``: when the shell's running command prints next (``listener -n``; inf:
        none), read after each call into the terminal (only those change it)."""
        self.due_s = self._terminal.next_s if self._terminal is not None else math.inf

    def _reply(self, out: bytes) -> None:
        if len(out) > MAX_PENDING:
            self.truncated += len(out) - MAX_PENDING
            out = out[:MAX_PENDING]
        for i in range(0, len(out), DATA_LEN):
            chunk = out[i:i + DATA_LEN]
            self.send(self.encoder.pack(
                M.MAVLink_serial_control_message, M.SERIAL_CONTROL_DEV_SHELL,
                M.SERIAL_CONTROL_FLAG_REPLY, 0, 0, len(chunk),
                list(chunk.ljust(DATA_LEN, b"\0"))))
