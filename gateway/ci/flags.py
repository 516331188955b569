"""The flags of ``cornet fly``'s baselines and reports and of ``cornet sweep`` (argparse only:
building the parser imports nothing heavy). Bad values exit 2 with one line saying what to fix."""

from __future__ import annotations

import argparse
from pathlib import Path

DEFAULT_TOL_TRACK_M = 1.0  # gateway.ci.baseline.Tolerances
DEFAULT_TOL_TIME_S = 2.0
DEFAULT_TOL_LOSS = 0.02
CONTROLS = ("mission", "ground")  # gateway.ci.fly.fly(control=...)
MAX_DELAY_MS = 60_000.0  # netsim.models.base.MAX_DELAY_S: the link models' longest delay


def _number(flag: str, *, integer: bool = False, maximum: float | None = None):
    def parse(text: str) -> float:
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{flag} must be a{'n integer' if integer else ' number'}"
                                             f", got {text!r}") from None
        if not value >= 0 or (maximum is not None and value > maximum):
            bounds = f"between 0 and {maximum:g}" if maximum is not None else ">= 0"
            raise argparse.ArgumentTypeError(f"{flag} must be {bounds}, got {text!r}")
        return value

    return parse


def path_arg(flag: str):
    """A path flag's type: an empty string (which pathlib reads as ".") is refused."""
    def parse(text: str) -> Path:
        if not text.strip():
            raise argparse.ArgumentTypeError(f"{flag} needs a path, got an empty string")
        return Path(text)

    return parse


def number_list(flag: str, *, maximum: float | None = None):
    """``0,50,100``: comma-separated, each >= 0 (and <= maximum), at least one, no repeats."""
    one = _number(flag, maximum=maximum)

    def parse(text: str) -> list[float]:
        items = [t.strip() for t in text.split(",")]
        if not text.strip() or any(not t for t in items):
            raise argparse.ArgumentTypeError(f"{flag}: an empty value in {text!r}; give "
                                             "comma-separated numbers, e.g. 0,50,100")
        values = [one(t) for t in items]
        if len(set(values)) != len(values):
            raise argparse.ArgumentTypeError(f"{flag}: {text!r} repeats a value")
        return values

    return parse


def _positive_int(flag: str):
    def parse(text: str) -> int:
        value = _number(flag, integer=True)(text)
        if value < 1:
            raise argparse.ArgumentTypeError(f"{flag} must be at least 1, got {text!r}")
        return int(value)

    return parse


def add_report_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument("--junit-xml", type=path_arg("--junit-xml"), default=None, metavar="FILE",
                   help="write a JUnit XML report (one test case per flight)")
    p.add_argument("--summary", type=path_arg("--summary"), default=None, metavar="FILE",
                   help="append a Markdown summary (e.g. to the CI job summary file)")


def add_fly_flags(p: argparse.ArgumentParser) -> None:
    """``cornet fly``'s control, baseline and report flags."""
    p.add_argument("--control", choices=CONTROLS, default=None,
                   help="mission: PX4 flies the plan in Mission mode (default); ground: a "
                   "ground-side controller flies its waypoints with offboard velocity setpoints "
                   "over the network")
    p.add_argument("--save-baseline", type=path_arg("--save-baseline"), default=None, metavar="DIR",
                   help="store this flight, if it passes, as the baseline in DIR (manifest.json, "
                   "track.csv)")
    p.add_argument("--baseline", type=path_arg("--baseline"), default=None, metavar="DIR",
                   help="fly under the baseline's conditions (flags given override them) and "
                   "compare: exit 1 if anything changed beyond the tolerances")
    p.add_argument("--tol-track-m", type=_number("--tol-track-m"), default=DEFAULT_TOL_TRACK_M,
                   metavar="M", help="largest distance between the tracks at equal progress "
                   f"(default {DEFAULT_TOL_TRACK_M:g} m)")
    p.add_argument("--tol-time-s", type=_number("--tol-time-s"), default=DEFAULT_TOL_TIME_S,
                   metavar="S", help="mission item, mode change and duration timing "
                   f"(default {DEFAULT_TOL_TIME_S:g} s)")
    p.add_argument("--tol-loss", type=_number("--tol-loss", maximum=1.0),
                   default=DEFAULT_TOL_LOSS, metavar="P",
                   help=f"change of a link's loss rate (default {DEFAULT_TOL_LOSS:g})")
    p.add_argument("--overlay", type=path_arg("--overlay"), default=None, metavar="FILE",
                   help="with --baseline: draw baseline vs this flight (PNG)")
    add_report_flags(p)


def add_sweep_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("plan", type=path_arg("PLAN"), metavar="PLAN",
                   help="a QGroundControl .plan file, or a shipped plan's name (square, breach)")
    p.add_argument("--latency-ms", type=number_list("--latency-ms", maximum=MAX_DELAY_MS), default=None,
                   metavar="X,X,...", help="one-way latencies, every link (default 0)")
    p.add_argument("--jitter-ms", type=number_list("--jitter-ms", maximum=MAX_DELAY_MS), default=None,
                   metavar="Y,Y,...", help="uniform jitters +-Y ms, every link (default 0)")
    p.add_argument("--loss", type=number_list("--loss", maximum=1.0), default=None,
                   metavar="P,P,...", help="loss probabilities, every link (default 0)")
    p.add_argument("--seeds", type=_positive_int("--seeds"), default=1, metavar="N",
                   help="fly every cell with seeds 0..N-1 (network, sensor noise, wind)")
    p.add_argument("--scenario", type=path_arg("--scenario"), action="append", default=[], metavar="FILE",
                   help="a scenario to sweep over (repeatable); it sets the network unless "
                   "--latency-ms/--jitter-ms/--loss are given")
    p.add_argument("--param", action="append", default=[], metavar="NAME=V1,V2",
                   help="a PX4 parameter to sweep over (repeatable)")
    p.add_argument("--control", choices=CONTROLS, default="ground",
                   help="ground (default): a ground-side controller flies the plan's waypoints "
                   "over the swept network, so latency and loss shape the path (the paper's "
                   "Fig. 8); mission: PX4 flies the plan onboard, as cornet fly does")
    p.add_argument("--time-limit", type=_number("--time-limit"), default=None, metavar="S",
                   help="simulated seconds per flight before giving up (default 900)")
    p.add_argument("--max-deviation", type=_number("--max-deviation"), default=None,
                   metavar="M", help="a flight deviating more from its path fails")
    p.add_argument("--jobs", type=_positive_int("--jobs"), default=None, metavar="N",
                   help="flights at a time, each in its own process (default: the core count)")
    p.add_argument("--out", type=path_arg("--out"), default=Path("sweep"), metavar="DIR",
                   help="where sweep.csv and the PNGs go (default ./sweep)")
    add_report_flags(p)
