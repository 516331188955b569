"""What one wake-up of a link reads from its vehicle: ``Snapshot``, and ``Sample``, the part
both links of a vehicle share; and ``LinkTelemetry``, what a link remembers of the streams it
sent (PING's sequence, the GPS origin it announced: telemetry_link.py).

Rules and invariants:
- A ``Snapshot`` reads each vehicle property at most once per wake-up (``_once``), however many
  builders ask for it.
- Both links of a vehicle sample it at the same instants (every 50 Hz stream of one fires with
  the other's), so what depends only on the kinematics and the time (ATTITUDE,
  GLOBAL_POSITION_INT …) is computed and packed once per vehicle and instant (``Sample``, kept
  in the vehicle's ``SampleCache``) and framed per link.
- Only what cannot change within an instant belongs in a ``Sample``: status and home can (a
  command may arrive between the two links' wake-ups), so they are read per Snapshot.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Generic, TypeVar, overload

from gateway.mavlink.vehicle_port import VehiclePort
from vehicles.geodesy import GeoPoint
from vehicles.types import Kinematics, Targets, VehicleStatus

T = TypeVar("T")


class _once(Generic[T]):
    """A lazily computed attribute, stored on the instance at first read (like
    functools.cached_property without its per-access lock, which 3.11 still takes)."""

    def __init__(self, fn: Callable[[Any], T]) -> None:
        self.fn = fn
        self.name = fn.__name__

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> _once[T]: ...

    @overload
    def __get__(self, obj: object, owner: type | None = None) -> T: ...

    def __get__(self, obj: object, owner: type | None = None) -> T | _once[T]:
        if obj is None:
            return self
        value = self.fn(obj)
        obj.__dict__[self.name] = value  # later reads never reach the descriptor
        return value


def _stamps(now_s: float) -> tuple[int, int]:
    """(time_boot_ms, time_usec) of ``now_s``, as every message stamps them."""
    return int(now_s * 1000.0) & 0xFFFFFFFF, int(now_s * 1e6)


class Sample:
    """What one vehicle's kinematics at one instant give every link: derived values, and the
    payloads that depend on nothing else (see ``_shared``). Builders read it through
    ``Snapshot``; only what cannot change within an instant belongs here (status and home can:
    a command may arrive between the two links' wake-ups)."""

    def __init__(self, vehicle: VehiclePort, now_s: float, kin: Kinematics) -> None:
        self.vehicle = vehicle
        self.now_s = now_s
        self.kin = kin
        self.payloads: dict[object, bytes] = {}  # by message id, or (message id, key)
        # ``_stamps`` inlined: a Sample is made at every instant
        self.time_boot_ms = int(now_s * 1000.0) & 0xFFFFFFFF
        self.time_usec = int(now_s * 1e6)

    @_once
    def euler(self) -> tuple[float, float, float]:
        return self.kin.euler_rad()

    @_once
    def geo(self) -> GeoPoint:
        # The vehicle derives it from the same measured position as ``kinematics``.
        return self.vehicle.global_position

    @_once
    def sensors(self) -> list[float] | None:
        """The latest sensor samples (vehicles/estimation.py S_*); None: the vehicle has none."""
        return getattr(self.vehicle, "sensors", None)

    @_once
    def estimator(self) -> list[float] | None:
        """The estimator's state (vehicles/estimation.py E_*); None: the vehicle has none."""
        return getattr(self.vehicle, "estimator", None)


class LinkTelemetry:
    """What one link remembers of the streams it sent (the fields of PX4's stream objects)."""

    __slots__ = ("ping_seq", "origin_sent", "origin_time_us", "gps_sent_us", "rtl_estimate_seq",
                 "manual_seq", "tstatus", "scheduler", "hl2")

    def __init__(self, tstatus: Any = None) -> None:
        """``tstatus``: the link's telemetry_status (link_status.TelemetryStatus; None: none,
        as for a one-off build)."""
        self.tstatus = tstatus
        self.ping_seq = 0
        self.gps_sent_us = 0  # GPS_RAW_INT's _last_send_ts (0: nothing sent yet)
        self.origin_sent: tuple[float, float, float] | None = None  # (lat, lon, alt) last sent
        self.origin_time_us = 0  # when the origin became global (0: not yet)
        self.rtl_estimate_seq = 0  # the last rtl_time_estimate publication sent
        self.manual_seq = 0  # the last manual_control_setpoint publication sent
        self.scheduler: Any = None  # the link's streams (streams.Scheduler; None: a one-off)
        self.hl2: Any = None  # its HIGH_LATENCY2 stream's state (telemetry_high_latency.py)


class SampleCache:
    """The latest ``Sample`` of one vehicle; the sessions of one vehicle share one cache."""

    def __init__(self) -> None:
        self._last: Sample | None = None

    def at(self, vehicle: VehiclePort, now_s: float) -> Sample:
        kin = vehicle.kinematics
        last = self._last
        # Keyed by identity: the vehicle makes a new Kinematics at each physics step, and as
        # the cache holds the old one, a new one can never take its id. A vehicle that builds
        # a new object on every read only loses the sharing.
        if last is None or last.kin is not kin or last.now_s != now_s or last.vehicle is not vehicle:
            last = self._last = Sample(vehicle, now_s, kin)
        return last


class Snapshot:
    """What one wake-up reads from the vehicle; each property is read at most once.

    ``samples``: the vehicle's ``SampleCache``, shared with its other links (None: a private
    one)."""

    def __init__(self, vehicle: VehiclePort, now_s: float, boot_unix_s: float | None,
                 samples: SampleCache | None = None, link: LinkTelemetry | None = None,
                 requested: bool = False) -> None:
        """``link``: what the link remembers of its streams (``LinkTelemetry``; None:
        nothing, as for a one-off build); ``requested``: built for a REQUEST_MESSAGE, which
        streams that send only on change answer all the same."""
        self.vehicle = vehicle
        self.link = link
        self.requested = requested
        self.now_s = now_s
        self.boot_unix_s = boot_unix_s
        self.samples = samples
        # Nearly every wake-up sends a message of the kinematics, so the sample is taken now
        # rather than through lazy attributes; its time stamps are this instant's. A vehicle
        # whose kinematics raise leaves it lazy: each builder that needs it fails on its own,
        # the others still send.
        try:
            sample = (samples if samples is not None else SampleCache()).at(vehicle, now_s)
        except Exception:  # noqa: BLE001 - re-raised by the first builder that reads it
            self.time_boot_ms, self.time_usec = _stamps(now_s)
            return
        fields = self.__dict__
        fields["sample"] = sample
        fields["kin"] = sample.kin
        fields["payloads"] = sample.payloads
        self.time_boot_ms = sample.time_boot_ms
        self.time_usec = sample.time_usec

    @_once
    def status(self) -> VehicleStatus:
        return self.vehicle.status

    @_once
    def sample(self) -> Sample:
        samples = self.samples if self.samples is not None else SampleCache()
        return samples.at(self.vehicle, self.now_s)

    @_once
    def kin(self) -> Kinematics:
        """``vehicle.kinematics``: position, velocity, attitude, rates as plain floats."""
        return self.sample.kin

    @_once
    def payloads(self) -> dict[object, bytes]:
        """The sample's packed payloads (``Sample.payloads``)."""
        return self.sample.payloads

    @_once
    def home_alt_m(self) -> float:
        home = self.vehicle.home
        return home.geo.alt_amsl_m if home is not None else self.vehicle.origin.alt_amsl_m

    @_once
    def targets(self) -> Targets | None:
        """The controllers' setpoints and motor commands; None: the vehicle has none."""
        return getattr(self.vehicle, "targets", None)

    @_once
    def mav_type(self) -> int:
        mav_type = self.vehicle.params.get("MAV_TYPE", 2)
        return 2 if mav_type is None else int(mav_type)

