"""``cornet``'s argument types and the small commands and helpers of gateway/cli.py: value
parsers that say what to fix, ``--param`` and PX4_PARAM_* parsing, ``--gcs``, PX4 SITL's
environment variables, ``--version``, ``cornet scenarios``."""

from __future__ import annotations

import argparse
import ipaddress
import math
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from gateway.ci.flags import path_arg as path_arg  # the same check for every path flag

if TYPE_CHECKING:
    from vehicles.types import GeoPoint

LOG_LEVELS = ("debug", "info", "warning", "error")
ENV_PARAM_PREFIX = "PX4_PARAM_"
MAX_SPEED = 1000.0


def non_negative(kind: type, what: str):
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be a number, got {text!r}") from None
        if not value >= 0:  # also NaN
            raise argparse.ArgumentTypeError(f"{what} must be >= 0, got {text!r}")
        return value

    return parse


def delay_ms(what: str):
    """``--latency-ms``/``--jitter-ms``: >= 0 and within the link models' longest delay."""
    at_least_zero = non_negative(float, what)

    def parse(text: str) -> float:
        # imported when the flag is given: `cornet --help` and the parser stay free of numpy
        from netsim.models.base import MAX_DELAY_S

        value = at_least_zero(text)
        if value > MAX_DELAY_S * 1e3:
            raise argparse.ArgumentTypeError(f"{what} must be at most {MAX_DELAY_S * 1e3:g} ms "
                                             f"(the link models' longest delay), got {text!r}")
        return value

    return parse


def duration(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--duration must be a number of simulated seconds, "
                                         f"got {text!r}") from None
    if not 0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"--duration must be > 0 (simulated seconds), got "
                                         f"{text!r}")
    return value


def probability(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"loss must be a probability, got {text!r}") from None
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"loss must be between 0 and 1 (e.g. 0.2), got {text!r}")
    return value


def speed(text: str) -> float:
    if text == "max":
        return math.inf
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--speed must be a factor like 10, or max; got "
                                         f"{text!r}") from None
    if not 0 < value <= MAX_SPEED:
        raise argparse.ArgumentTypeError(f"--speed must be > 0 and <= {MAX_SPEED:g} (or max), "
                                         f"got {text!r}")
    return value


def ipv4(text: str) -> str:
    try:
        ipaddress.IPv4Address(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--bind must be an IPv4 address such as 127.0.0.1 or "
                                         f"0.0.0.0, got {text!r}") from None
    return text


def parse_params(parser: argparse.ArgumentParser, flags: list[str],
                  environ: dict[str, str]) -> dict[str, float]:
    from vehicles.params import ParamStore

    pairs = [(f"--param {flag}", flag) for flag in flags]
    pairs += [(f"environment {k}", f"{k[len(ENV_PARAM_PREFIX):]}={v}")
              for k, v in sorted(environ.items()) if k.startswith(ENV_PARAM_PREFIX)]
    store = ParamStore()
    out: dict[str, float] = {}
    for where, text in pairs:
        name, sep, value_text = text.partition("=")
        if not sep or not name:
            parser.error(f"{where}: expected NAME=VALUE, e.g. MIS_TAKEOFF_ALT=5")
        if name not in store:
            parser.error(f"{where}: no PX4 parameter named {name!r}")
        try:
            value = float(value_text)
            store.set(name, value)
        except ValueError:
            kind = store.info(name).type.name
            parser.error(f"{where}: {value_text!r} is not a valid {kind} value for {name}")
        out[name] = value
    return out


def version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("cornet")
    except PackageNotFoundError:  # run from a checkout that is not installed
        return "(not installed)"


def list_scenarios() -> int:
    from gateway import data

    names = data.scenario_names()
    width = max(map(len, names))
    for name in names:
        print(f"{name:<{width}}  {data.summary(data.SCENARIO_DIR / f'{name}.toml')}")
    print(f"\n`cornet run --scenario NAME`, `cornet check NAME`. Shipped files: scenarios in "
          f"{data.SCENARIO_DIR}, example plans in {data.PLAN_DIR}, the systemd unit and its "
          f"configuration in {data.SYSTEMD_DIR}")
    return 0


def gcs_partner(text: str) -> tuple[str, int | None]:
    """``--gcs HOST[:PORT]``: an IPv4 address, and a UDP port or None (the GCS link's own)."""
    from gateway.sim.values import ScenarioError
    from gateway.sim.values import gcs_partner as parse

    try:
        return parse(text, "--gcs")
    except ScenarioError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


# PX4 SITL's start-up variables (ROMFS/px4fmu_common/init.d-posix/rcS, px4-rc.simulator): the
# speed factor and the home position. Each PX4_HOME_* replaces one coordinate of the default.
ENV_SPEED = "PX4_SIM_SPEED_FACTOR"
ENV_HOME = ("PX4_HOME_LAT", "PX4_HOME_LON", "PX4_HOME_ALT")


def env_speed(environ: dict[str, str]) -> float | None:
    """PX4_SIM_SPEED_FACTOR as ``--speed`` reads it; ValueError names the variable."""
    text = environ.get(ENV_SPEED, "").strip()
    if not text:
        return None
    try:
        return speed(text)
    except argparse.ArgumentTypeError as exc:
        raise ValueError(f"environment {ENV_SPEED}: {str(exc).replace('--speed ', '')}") from None


def env_home(environ: dict[str, str], home: GeoPoint) -> tuple[GeoPoint, tuple[str, ...]]:
    """``home`` (a GeoPoint) with the coordinates PX4_HOME_LAT/LON/ALT give, and their names."""
    from dataclasses import replace

    from gateway.sim.scenario import MAX_HOME_ALT_M, MIN_HOME_ALT_M

    ranges = ((-90.0, 90.0), (-180.0, 180.0), (MIN_HOME_ALT_M, MAX_HOME_ALT_M))
    names: list[str] = []
    changes: dict[str, float] = {}
    for name, field, (low, high) in zip(ENV_HOME, ("lat_deg", "lon_deg", "alt_amsl_m"), ranges):
        text = environ.get(name, "").strip()
        if not text:
            continue
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"environment {name}: must be a number, got {text!r}") from None
        if not low <= value <= high:
            raise ValueError(f"environment {name}: must be between {low:g} and {high:g}, "
                             f"got {text!r}")
        names.append(name)
        changes[field] = value
    return replace(home, **changes), tuple(names)


def vehicle_params(from_file: dict[int, dict[str, float]], specs: list[str], vehicles: int,
                   flag_params: dict[str, float]) -> dict[int, dict[str, float]]:
    """Per-vehicle values: the scenario's param_files, then --param-file's, without what --param
    and PX4_PARAM_* set (they win). Raises ScenarioError naming the file and line."""
    from gateway.sim import param_files

    out = {sysid: dict(values) for sysid, values in from_file.items()}
    for sysid, values in param_files.merge(specs, vehicles).items():
        out.setdefault(sysid, {}).update(values)
    return {sysid: kept for sysid, values in out.items()
            if (kept := {k: v for k, v in values.items() if k not in flag_params})}


def writable_dir(parser: argparse.ArgumentParser, path: Path, flag: str) -> None:
    """Exit 2 naming ``flag`` unless ``path`` is (or can be made) a directory we can write."""
    if path.exists() and not path.is_dir():
        parser.error(f"{flag} {path}: is a file, not a directory; give a directory")
    try:
        path.mkdir(parents=True, exist_ok=True)
        # A probe of its own (unnamed where the filesystem allows): the ranks of a sharded run
        # check the same directory at the same moment.
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as exc:
        parser.error(f"{flag} {path}: not a writable directory ({exc.strerror}); give a "
                     "directory you can write")


def writable_file(parser: argparse.ArgumentParser, path: Path, flag: str) -> None:
    """Exit 2 naming ``flag`` unless ``path`` can be a file we write: not a directory, in a
    directory that exists, and open for appending takes a write (checked before a run, not
    after it). The probe writes nothing; a file it had to create is removed again."""
    problem = None
    if path.is_dir():
        problem = "is a directory; give a file name"
    elif not path.parent.is_dir():
        problem = f"no directory {path.parent}"
    else:
        existed = path.exists()
        try:
            # Non-blocking: a FIFO nobody reads fails (ENXIO) rather than hanging the start.
            fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NONBLOCK, 0o644)
            try:
                # An empty write reaches the file's driver: /proc/version (EIO) and /dev/full
                # (ENOSPC) open for root and fail only here, as the first trace line would.
                os.write(fd, b"")
            finally:
                os.close(fd)
        except OSError as exc:
            problem = f"cannot be written ({exc.strerror}); give a file you can write"
        finally:
            if not existed and path.exists():
                path.unlink(missing_ok=True)
    if problem is not None:
        parser.error(f"{flag} {path}: {problem}")


def endpoint(flag: str):
    """A ZeroMQ endpoint flag's type (``tcp://127.0.0.1:5556``), as daemon.zmq_pub is checked."""
    def parse(text: str) -> str:
        if "://" not in text or not text.partition("://")[2]:
            raise argparse.ArgumentTypeError(f"{flag} must be a ZeroMQ endpoint such as "
                                             f"tcp://127.0.0.1:5556, got {text!r}")
        return text

    return parse
