"""CORNET's pytest plugin: simulated PX4 vehicles as fixtures, assertions on their flight logs.

Installed with cornet (the ``pytest11`` entry point ``cornet``), or loaded by hand with
``pytest -p gateway.pytest_plugin``. Importing it does nothing else: no autouse fixture, no hook,
and the simulator itself is imported only when a fixture or helper needs it.

Fixtures (both are factories; everything they start is stopped at the end of the test):

``cornet_daemon(*args, vehicles=1)``
    ``cornet run`` as a subprocess on a free ``--port-offset``, with ``--log-dir`` in a temporary
    directory and ``args`` passed through (``"--speed", "10"``, ``"--scenario", FILE`` ...).
    Returns once the daemon printed its ``ready`` line: a :class:`CornetDaemon` with
    ``mavsdk_url(i)`` (``udpin://0.0.0.0:<port>`` for MAVSDK's ``connect``), ``gcs_url()``,
    ``log_dir`` and ``stop()``. At teardown it is sent SIGTERM and must exit with code 0.

``cornet_sim(vehicles=1, **kwargs)``
    a lockstep :class:`gateway.testing.Sim` (no sockets, simulated clock) logging to a directory
    under ``tmp_path`` (its ``log_dir`` attribute); closed at teardown.

Assertion helpers, on a run's logs (a run directory, a base directory holding runs, a
:class:`CornetDaemon`, a ``Sim`` or a :class:`FlightLogView`). ``reached`` and ``landed_within``
return a :class:`Check`, true or false, whose repr says what was measured, so a failing
``assert`` explains itself::

    assert reached(log, 47.398012, 8.545594, rel_alt_m=15, within_m=2)
    assert landed_within(log, "home", 2)          # or landed_within(log, lat, lon, 2)
    assert max_deviation_m(log, "mission.plan") < 3

Positions come from ``state.csv`` (10 Hz): the vehicle's local NED position from its EKF origin
(meta.json), projected to latitude/longitude as the simulator does (flat earth); the relative
altitude is the height above that origin (where the vehicle spawned: its home).
"""

from __future__ import annotations

import csv
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from gateway.ports import API_CLIENT_PORT, GCS_CLIENT_PORT, free_port_offset, free_tcp_port

__all__ = ["Check", "CornetDaemon", "FlightLogView", "StateSample", "free_port_offset",
           "free_tcp_port", "landed_within", "max_deviation_m", "reached", "start_daemon"]

READY_TIMEOUT_S = 30.0
STOP_TIMEOUT_S = 10.0
EARTH_RADIUS_M = 6371000.0  # vehicles.types.EARTH_RADIUS_M: the simulator's projection
META_FILE = "meta.json"
STATE_FILE = "state.csv"


# --- the daemon ----------------------------------------------------------------------------------
def cornet_command() -> list[str]:
    """``cornet`` next to this interpreter (a venv's bin/), else ``python -m gateway.cli``."""
    exe = Path(sys.executable).with_name("cornet")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "gateway.cli"]


def _option(args: Sequence[str], name: str) -> str | None:
    for k, a in enumerate(args):
        if a == name and k + 1 < len(args):
            return args[k + 1]
        if a.startswith(name + "="):
            return a.split("=", 1)[1]
    return None


class CornetDaemon:
    """A running ``cornet run``; see :func:`start_daemon`."""

    def __init__(self, proc: subprocess.Popen, command: list[str], offset: int, vehicles: int,
                 log_dir: Path | None) -> None:
        self.proc, self.command, self.offset, self.vehicles = proc, command, offset, vehicles
        self.log_dir = log_dir
        self.ready_line = ""
        self.returncode: int | None = None
        self.output: deque[str] = deque(maxlen=200)  # the last lines of stdout and stderr
        self._ready = threading.Event()
        self._threads = [threading.Thread(target=self._pump, args=(s, s is proc.stdout),
                                          name="cornet-daemon-output", daemon=True)
                         for s in (proc.stdout, proc.stderr)]
        for t in self._threads:
            t.start()

    def _pump(self, stream: Any, is_stdout: bool) -> None:
        try:
            for line in stream:
                line = line.rstrip()
                self.output.append(line)
                if is_stdout and not self._ready.is_set() and line.startswith("cornet ready"):
                    self.ready_line = line
                    self._ready.set()
        except (OSError, ValueError):  # the stream was closed under us
            pass

    # --- where clients connect ------------------------------------------------------------------
    def mavsdk_port(self, index: int = 0) -> int:
        """The UDP port vehicle ``index`` sends its MAVSDK (onboard API) link to."""
        return API_CLIENT_PORT + min(index, 9) + self.offset

    def mavsdk_url(self, index: int = 0) -> str:
        """For MAVSDK's ``System.connect(system_address=...)``."""
        return f"udpin://0.0.0.0:{self.mavsdk_port(index)}"

    def gcs_port(self) -> int:
        """The UDP port every vehicle sends its GCS link to (QGroundControl's 14550, shifted)."""
        return GCS_CLIENT_PORT + self.offset

    def gcs_url(self) -> str:
        return f"udpin://0.0.0.0:{self.gcs_port()}"

    @property
    def run_dir(self) -> Path:
        """This daemon's flight-log directory (``log_dir/run-<date>-<time>``)."""
        if self.log_dir is None:
            raise FileNotFoundError("this daemon was started with log_dir=None")
        from gateway.flightlog import resolve_run_dir

        return resolve_run_dir(self.log_dir)

    def log(self) -> FlightLogView:
        """Its flight logs as they are on disk now (flushed every simulated second; all of it
        once :meth:`stop` returned)."""
        return FlightLogView.load(self.run_dir)

    def log_tail(self, n: int = 40) -> str:
        return "\n".join(list(self.output)[-n:])

    # --- lifetime -------------------------------------------------------------------------------
    def _wait_ready(self, timeout_s: float) -> bool:
        deadline = time.monotonic() + timeout_s
        while not self._ready.wait(0.05):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                break
        return self._ready.is_set()

    @property
    def running(self) -> bool:
        return self.proc.poll() is None

    def stop(self, timeout_s: float = STOP_TIMEOUT_S) -> int:
        """SIGTERM (the daemon flushes its logs and exits 0); killed after ``timeout_s``.
        Returns the exit code; calling it again returns the same code."""
        if self.returncode is not None:
            return self.returncode
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            code = self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
            self.output.append(f"[pytest: killed after {timeout_s:g} s without exiting on SIGTERM]")
        for t in self._threads:
            t.join(timeout=5)
        for stream in (self.proc.stdout, self.proc.stderr):
            if stream is not None and not stream.closed:
                stream.close()
        self.returncode = code
        return code

    def __enter__(self) -> CornetDaemon:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def __repr__(self) -> str:
        state = "running" if self.returncode is None else f"exited {self.returncode}"
        return f"<CornetDaemon port-offset {self.offset}, {self.vehicles} vehicle(s), {state}>"


def start_daemon(*args: str, vehicles: int | None = None, log_dir: str | Path | None = None,
                 ready_timeout_s: float = READY_TIMEOUT_S, attempts: int = 3,
                 env: dict[str, str] | None = None) -> CornetDaemon:
    """Start ``cornet run [--vehicles N] --port-offset K [--log-dir DIR] ARGS`` and wait for its
    ``ready`` line. ``vehicles``: also read from ``args`` (``--vehicles``); default 1 (or what
    the ``--scenario`` says). A port taken in the meantime by someone else: another offset."""
    args = [str(a) for a in args]
    if "--port-offset" in args or _option(args, "--port-offset") is not None:
        raise ValueError("start_daemon picks --port-offset itself")
    given = _option(args, "--vehicles")
    if given is not None and vehicles is not None and int(given) != vehicles:
        raise ValueError(f"vehicles={vehicles} but --vehicles {given}")
    n = int(given) if given is not None else vehicles
    extra = [] if n is None or given is not None else ["--vehicles", str(n)]
    if log_dir is not None:
        if _option(args, "--log-dir") is not None:
            raise ValueError("--log-dir given twice")
        Path(log_dir).mkdir(parents=True, exist_ok=True)
        extra += ["--log-dir", str(log_dir)]
    elif _option(args, "--log-dir") is not None:
        log_dir = _option(args, "--log-dir")
    tried: list[int] = []
    for _ in range(attempts):
        offset = free_port_offset(n or 1, skip=tried)
        tried.append(offset)
        cmd = cornet_command() + ["run", *extra, "--port-offset", str(offset), *args]
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                env=env, stdin=subprocess.DEVNULL)
        daemon = CornetDaemon(proc, cmd, offset, n or 1,
                              None if log_dir is None else Path(log_dir))
        if daemon._wait_ready(ready_timeout_s):
            return daemon
        daemon.stop()
        if "already in use" not in daemon.log_tail():
            break
    raise RuntimeError(f"cornet run was not ready within {ready_timeout_s:g} s "
                       f"(exit code {daemon.returncode}): {' '.join(cmd)}\n{daemon.log_tail()}")


# --- flight logs ---------------------------------------------------------------------------------
def _float(s: str) -> float:
    return float(s) if s else math.nan


@dataclass(frozen=True)
class StateSample:
    """One row of state.csv for one vehicle, with its position as latitude/longitude."""

    t_s: float
    lat_deg: float
    lon_deg: float
    rel_alt_m: float  # height above the vehicle's EKF origin (its spawn point)
    n_m: float  # local NED from the EKF origin
    e_m: float
    d_m: float
    vn_mps: float
    ve_mps: float
    vd_mps: float
    mode: str  # NavState name: AUTO_MISSION, AUTO_RTL, POSCTL ...
    armed: bool
    landed_state: str  # ON_GROUND, TAKEOFF, IN_AIR, LANDING
    battery_remaining: float
    mission_seq: int | None

    @property
    def in_air(self) -> bool:
        return self.landed_state != "ON_GROUND"

    @property
    def ground_speed_mps(self) -> float:
        return math.hypot(self.vn_mps, self.ve_mps)


def _project(origin: Sequence[float], n: float, e: float) -> tuple[float, float]:
    lat0, lon0 = origin[0], origin[1]
    return (lat0 + math.degrees(n / EARTH_RADIUS_M),
            lon0 + math.degrees(e / (EARTH_RADIUS_M * math.cos(math.radians(lat0)))))


def distance_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Horizontal distance between two points, with the simulator's flat-earth projection."""
    north = math.radians(lat2 - lat1) * EARTH_RADIUS_M
    east = math.radians(lon2 - lon1) * EARTH_RADIUS_M * math.cos(math.radians(lat1))
    return math.hypot(north, east)


class FlightLogView:
    """A run's flight logs, read-only: meta.json and state.csv, by vehicle index (0-based, as
    ``mavsdk_url(i)`` and ``Sim.api(i)``); paths of the tlogs and the packet trace."""

    def __init__(self, run_dir: str | Path) -> None:
        from gateway.flightlog import resolve_run_dir

        self.run_dir = resolve_run_dir(run_dir)
        self.meta: dict = json.loads((self.run_dir / META_FILE).read_text())
        self._by_sysid: dict[int, list[StateSample]] = {}
        origins = {int(v["sysid"]): v["origin"] for v in self.meta["vehicles"]}
        state = self.run_dir / STATE_FILE
        if state.is_file():
            with open(state, newline="") as f:
                for r in csv.DictReader(f):
                    sysid = int(r["sysid"])
                    origin = origins.get(sysid)
                    if origin is None:
                        continue
                    n, e, d = _float(r["n_m"]), _float(r["e_m"]), _float(r["d_m"])
                    lat, lon = _project(origin, n, e)
                    seq = r.get("mission_seq") or ""
                    self._by_sysid.setdefault(sysid, []).append(StateSample(
                        float(r["t_s"]), lat, lon, -d, n, e, d, _float(r["vn_mps"]),
                        _float(r["ve_mps"]), _float(r["vd_mps"]), r["mode"], r["armed"] == "1",
                        r["landed_state"], _float(r["battery_remaining"]),
                        int(seq) if seq else None))

    @classmethod
    def load(cls, source: Any) -> FlightLogView:
        """From a run directory, a base directory of runs (the newest), a CornetDaemon, a
        ``gateway.testing.Sim`` (flushed first) or a FlightLogView."""
        if isinstance(source, FlightLogView):
            return source
        if isinstance(source, CornetDaemon):
            return source.log()
        flightlog = getattr(source, "flightlog", None)
        if flightlog is not None:  # a Sim
            flightlog.flush()
            return cls(flightlog.dir)
        if isinstance(source, (str, os.PathLike)):
            return cls(source)
        raise TypeError(f"not a flight log: {source!r}")

    @property
    def vehicles(self) -> int:
        return len(self.meta["vehicles"])

    def sysid(self, vehicle: int = 0) -> int:
        return int(self.meta["vehicles"][vehicle]["sysid"])

    def home(self, vehicle: int = 0) -> tuple[float, float, float]:
        """The vehicle's home: its EKF origin (lat, lon, alt AMSL), where it spawned."""
        lat, lon, alt = self.meta["vehicles"][vehicle]["origin"]
        return (lat, lon, alt)

    def states(self, vehicle: int = 0) -> list[StateSample]:
        return self._by_sysid.get(self.sysid(vehicle), [])

    def __iter__(self) -> Iterator[StateSample]:
        return iter(self.states(0))

    def modes(self, vehicle: int = 0) -> list[tuple[float, str]]:
        """(time, mode) at every mode change."""
        out: list[tuple[float, str]] = []
        for s in self.states(vehicle):
            if not out or out[-1][1] != s.mode:
                out.append((s.t_s, s.mode))
        return out

    def tlog(self, vehicle: int = 0, link: str = "api") -> Path:
        return self.run_dir / f"v{vehicle + 1}-{link}.tlog"

    @property
    def packet_trace(self) -> Path:
        return self.run_dir / "packets.trace"

    @property
    def duration_s(self) -> float:
        rows = self.states(0)
        return rows[-1].t_s - rows[0].t_s if rows else 0.0

    def __repr__(self) -> str:
        return (f"<FlightLogView {self.run_dir}: {self.vehicles} vehicle(s), "
                f"{self.duration_s:.1f} s>")


# --- assertion helpers ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Check:
    """The outcome of a check on a log: true or false, and what was measured."""

    ok: bool
    detail: str
    value: float = math.nan

    def __bool__(self) -> bool:
        return self.ok

    def __repr__(self) -> str:
        return f"<{'PASS' if self.ok else 'FAIL'}: {self.detail}>"


def _samples(log: Any, vehicle: int) -> tuple[FlightLogView, list[StateSample]]:
    view = FlightLogView.load(log)
    rows = view.states(vehicle)
    if not rows:
        raise AssertionError(f"{view.run_dir}: no state samples of vehicle {vehicle}")
    return view, rows


def reached(log: Any, lat: float, lon: float, rel_alt_m: float | None = None, *,
            within_m: float = 2.0, vehicle: int = 0) -> Check:
    """Whether the vehicle came within ``within_m`` of (lat, lon) — and, if ``rel_alt_m`` is
    given, of that height above its home (3-D distance)."""
    _, rows = _samples(log, vehicle)
    best, when = math.inf, math.nan
    for s in rows:
        h = distance_m(lat, lon, s.lat_deg, s.lon_deg)
        dist = h if rel_alt_m is None else math.hypot(h, s.rel_alt_m - rel_alt_m)
        if dist < best:
            best, when = dist, s.t_s
    where = f"({lat:.7f}, {lon:.7f}" + ("" if rel_alt_m is None else f", {rel_alt_m:g} m") + ")"
    return Check(best <= within_m, f"vehicle {vehicle} came within {best:.2f} m of {where} at "
                 f"t={when:.1f} s (limit {within_m:g} m)", best)


def _target(view: FlightLogView, where: Sequence[Any], vehicle: int) -> tuple[float, float, str]:
    if len(where) == 1 and isinstance(where[0], str) and where[0] == "home":
        lat, lon, _ = view.home(vehicle)
        return lat, lon, "home"
    if len(where) == 1 and hasattr(where[0], "lat_deg"):
        return where[0].lat_deg, where[0].lon_deg, f"({where[0].lat_deg:.7f}, {where[0].lon_deg:.7f})"
    if len(where) == 1 and isinstance(where[0], (tuple, list)) and len(where[0]) >= 2:
        where = where[0][:2]
    if len(where) == 2:
        lat, lon = float(where[0]), float(where[1])
        return lat, lon, f"({lat:.7f}, {lon:.7f})"
    raise TypeError("landed_within(log, lat, lon, m), landed_within(log, (lat, lon), m) or "
                    "landed_within(log, 'home', m)")


def landed_within(log: Any, *where_and_m: Any, vehicle: int = 0) -> Check:
    """Whether the vehicle flew, and its last sample is on the ground within ``m`` (horizontal)
    of the target: ``landed_within(log, lat, lon, m)``, ``landed_within(log, (lat, lon), m)``
    or ``landed_within(log, "home", m)`` (its spawn point)."""
    if len(where_and_m) < 2:
        raise TypeError("landed_within needs a target and a distance in metres")
    view, rows = _samples(log, vehicle)
    lat, lon, name = _target(view, where_and_m[:-1], vehicle)
    limit = float(where_and_m[-1])
    last = rows[-1]
    dist = distance_m(lat, lon, last.lat_deg, last.lon_deg)
    if not any(s.in_air for s in rows):
        return Check(False, f"vehicle {vehicle} never left the ground", dist)
    if last.in_air:
        return Check(False, f"vehicle {vehicle} had not landed at the end of the log "
                     f"(t={last.t_s:.1f} s, {last.landed_state}, {last.rel_alt_m:.1f} m up)", dist)
    return Check(dist <= limit, f"vehicle {vehicle} landed {dist:.2f} m from {name} "
                 f"(limit {limit:g} m)", dist)


def max_deviation_m(log: Any, plan: Any, *, vehicle: int = 0,
                    modes: Sequence[str] = ("AUTO_MISSION",)) -> float:
    """The largest distance (3-D, m) of the flown track, while in one of ``modes``, from the
    planned path: ``cornet fly``'s polyline (start → takeoff altitude → each positional item; a
    land item descends; return-to-launch legs are not judged). ``plan``: a QGroundControl
    ``.plan`` path, a ``gateway.fly.QgcPlan`` or a sequence of mission PlanItems. The path
    starts where the vehicle was when the first judged sample was taken."""
    from gateway.fly import QgcPlan, distance_to_path, load_plan, planned_path
    from vehicles.types import GeoPoint

    if isinstance(plan, (str, os.PathLike)):
        plan = load_plan(plan)
    items = plan.mission if isinstance(plan, QgcPlan) else list(plan)
    view, rows = _samples(log, vehicle)
    judged = [s for s in rows if s.mode in modes]
    if not judged:
        raise AssertionError(f"vehicle {vehicle} was never in {'/'.join(modes)}: no flight "
                             "to compare with the plan")
    origin = GeoPoint(*view.home(vehicle))
    path = planned_path(items, origin, (judged[0].n_m, judged[0].e_m, judged[0].d_m))
    return max(distance_to_path((s.n_m, s.e_m, s.d_m), path) for s in judged)


# --- fixtures ------------------------------------------------------------------------------------
@pytest.fixture
def cornet_daemon(tmp_path_factory: pytest.TempPathFactory):
    """Factory: ``cornet_daemon(*args, vehicles=None, log_dir=<tmp>, ...)`` → CornetDaemon
    (see :func:`start_daemon`); each one is stopped with SIGTERM at teardown and must exit 0."""
    started: list[CornetDaemon] = []

    def start(*args: str, vehicles: int | None = None, log_dir: str | Path | None = None,
              **kwargs: Any) -> CornetDaemon:
        if log_dir is None and _option(args, "--log-dir") is None:
            log_dir = tmp_path_factory.mktemp("cornet-logs")
        d = start_daemon(*args, vehicles=vehicles, log_dir=log_dir, **kwargs)
        started.append(d)
        return d

    yield start
    failed = []
    for d in started:
        code = d.stop()
        if code != 0:
            failed.append(f"{' '.join(d.command)}: exit code {code}\n{d.log_tail()}")
    assert not failed, "cornet run did not stop cleanly:\n" + "\n".join(failed)


@pytest.fixture
def cornet_sim(tmp_path: Path):
    """Factory: ``cornet_sim(vehicles=1, **kwargs)`` → a lockstep ``gateway.testing.Sim``
    recording flight logs in ``tmp_path/sim-<n>`` (its ``log_dir`` attribute) unless
    ``log_dir`` is given (None: no logs). Closed at teardown."""
    sims: list[Any] = []

    def make(vehicles: int | None = 1, **kwargs: Any) -> Any:
        from gateway.testing import Sim

        if "log_dir" not in kwargs:
            kwargs["log_dir"] = tmp_path / f"sim-{len(sims) + 1}"
        if kwargs.get("scenario") is not None and vehicles == 1:
            vehicles = None  # the scenario says how many
        sim = Sim(vehicles, **kwargs)
        sim.log_dir = None if kwargs["log_dir"] is None else Path(kwargs["log_dir"])
        close, closed = sim.close, []

        def close_once() -> None:  # the test may close it (``with sim:``), then the teardown
            if not closed:
                closed.append(True)
                close()

        sim.close = close_once
        sims.append(sim)
        return sim

    yield make
    for sim in sims:
        sim.close()
