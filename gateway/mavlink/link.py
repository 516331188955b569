"""What the services of one link share: its kind, its counters and a ``LinkContext``.

Rules and invariants:
- The Session builds one ``LinkContext`` per link and gives it to each service, with whatever
  else that service needs from its neighbours as plain callables (a STATUSTEXT sink, the
  telemetry snapshot, the stream scheduler). A service never sees the Session, so nothing here
  or in a service imports session.py: the Session sits above them all.
- ``send(frame)`` queues one whole frame (built with ``encoder``, so signed when signing is on)
  for this link; the Session packs frames into datagrams.
- A service that drops a message addressed to another system or component calls
  ``other_target()``: it is counted (``rx_other_target``) and the message does not make its
  sender this link's client (the Session's ``peer``).
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import asdict, dataclass

from gateway.mavlink.codec import DecodeStats, Encoder
from gateway.mavlink.vehicle_port import VehiclePort
from vehicles.types import Severity

DATARATE_B_S = 4_000_000  # px4-rc.mavlink: -r 4000000 on every SITL instance

# A text for this link only, from the gateway itself: (now_s, severity, text).
Say = Callable[[float, Severity, str], None]


class LinkKind(enum.Enum):
    GCS = "gcs"  # PX4 "normal" mode link → 14550
    API = "api"  # PX4 "onboard" mode link → 14540+i


@dataclass
class SessionStats(DecodeStats):
    rx_other_target: int = 0  # addressed to another sysid/compid
    rx_unhandled: int = 0  # valid, for us (or broadcast), but no service handles it
    handler_errors: int = 0  # a service or a telemetry builder raised (a bug: logged, skipped)
    rx_setup_signing_refused: int = 0  # SETUP_SIGNING that passed verification (signing on)
    rx_ping_replies: int = 0  # answers to the vehicle's own PINGs
    offboard_setpoints: int = 0  # setpoints handed to the vehicle
    offboard_dropped: int = 0  # setpoint messages that were unusable (frame, inf, nothing set)
    tx_frames: int = 0
    tx_datagrams: int = 0
    tx_bytes: int = 0

    def as_dict(self) -> dict[str, int]:
        return asdict(self)

    def get(self, name: str, default: int = 0) -> int:
        """Mapping-style access for the shell's status line."""
        return getattr(self, name, default)

    def __getitem__(self, name: str) -> int:
        return getattr(self, name)


@dataclass(frozen=True, slots=True)
class LinkContext:
    """One link as its services see it (module docstring)."""

    vehicle: VehiclePort
    kind: LinkKind
    sysid: int  # ours: vehicle.params['MAV_SYS_ID']
    encoder: Encoder  # this link's MAVLink 2 endpoint (sysid, compid 1, seq, signer)
    stats: SessionStats
    send: Callable[[bytes], None]
    other_target: Callable[[], None]
