"""The commands a vehicle was sent and how it answered them: what PX4's logger records from the
vehicle_command and vehicle_command_ack topics (every message, no interval).

Rules:
- ``record`` is called once per command a link dispatched (COMMAND_LONG, COMMAND_INT and the
  legacy SET_MODE as DO_SET_MODE), with the MAV_RESULT its COMMAND_ACK carried, or None when
  none was sent (PX4 leaves some unanswered).
- Records are numbered from 1 (``seq``); the newest ``KEEP`` are kept, so a reader that polls
  ``after(seq)`` at the logger's rate never misses one.
- ``onboard_ack`` is an answer a module gives later, on its own (PX4's calibration routine
  ACCEPTs the cancel that Commander had TEMPORARILY_REJECTED): every link of the vehicle sends
  it as COMMAND_ACK (``acks_after``), and the logger records it.
- ``log_message``: a log_message publication from outside the autopilot (a STATUSTEXT of the
  vehicle's own system, gateway/mavlink/statustext_in.py), which the logger writes as a logged
  string; numbered as the records (``log_seq``, ``log_messages_after``).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

KEEP = 256


@dataclass(frozen=True)
class CommandRecord:
    seq: int
    time_s: float
    command: int
    params: tuple[float, float, float, float, float, float, float]
    source_system: int
    source_component: int
    result: int | None  # the COMMAND_ACK's MAV_RESULT; None: not answered


@dataclass(frozen=True)
class LogMessage:
    seq: int
    timestamp_us: int
    severity: int
    text: str


@dataclass(frozen=True)
class OnboardAck:
    seq: int
    time_s: float
    command: int
    result: int
    target_system: int
    target_component: int


class CommandJournal:
    def __init__(self) -> None:
        self._records: deque[CommandRecord] = deque(maxlen=KEEP)
        self.seq = 0
        self._acks: deque[OnboardAck] = deque(maxlen=KEEP)
        self.ack_seq = 0
        self._logs: deque[LogMessage] = deque(maxlen=KEEP)
        self.log_seq = 0

    def log_message(self, timestamp_us: int, severity: int, text: str) -> None:
        self.log_seq += 1
        self._logs.append(LogMessage(self.log_seq, timestamp_us, severity, text))

    def log_messages_after(self, seq: int) -> list[LogMessage]:
        if seq >= self.log_seq:
            return []
        return [m for m in self._logs if m.seq > seq]

    def onboard_ack(self, now_s: float, command: int, result: int, target: tuple[int, int]
                    ) -> None:
        self.ack_seq += 1
        self._acks.append(OnboardAck(self.ack_seq, now_s, command, result, *target))

    def acks_after(self, seq: int) -> list[OnboardAck]:
        if seq >= self.ack_seq:
            return []
        return [a for a in self._acks if a.seq > seq]

    def record(self, now_s: float, command: int,
               params: tuple[float, float, float, float, float, float, float],
               source: tuple[int, int], result: int | None) -> None:
        self.seq += 1
        self._records.append(CommandRecord(self.seq, now_s, command, params, source[0],
                                           source[1], result))

    def after(self, seq: int) -> list[CommandRecord]:
        """The records numbered above ``seq``, oldest first."""
        if seq >= self.seq:
            return []
        return [r for r in self._records if r.seq > seq]
