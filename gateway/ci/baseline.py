"""Flight baselines: what a good run did, and how a new run differs from it.

``cornet fly PLAN --save-baseline DIR`` writes the flight into DIR:

- ``manifest.json``: the plan (name and digest of its items), the conditions it was flown in
  (gateway/ci/spec.py: network, seed, scenario, parameters), the verdict, when each mission item
  was reached, every mode change, the events (the scenario's faults as they fired, the vehicle's
  failsafe messages and warnings) and each link's counters;
- ``track.csv``: the flown track from arming on (t_s, n_m, e_m, d_m, local NED of the vehicle's
  origin, every 0.1 s of simulated time), floats written exactly.

``cornet fly PLAN --baseline DIR`` flies again under the stored conditions (flags given on the
command line override them) and compares (:func:`compare`):

- the track at equal progress: both tracks resampled at the same fractions of their length, the
  largest and the RMS distance between them (and, for information, the largest distance at equal
  time) — a flight that only starts later does not diverge;
- when each mission item was reached and when each mode change happened (and whether the modes
  came in the same order), and the flight's duration;
- events added or missing (compared by text, not by time) and the verdict;
- each link's loss rate.

Lockstep flights are deterministic: the same plan, conditions and seed compare equal exactly.
Whatever exceeds a tolerance (:class:`Tolerances`) is a regression.
"""

from __future__ import annotations

import csv
import json
import math
import re
from collections import Counter
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gateway.ci.spec import FlightSpec, plan_digest

FORMAT = "cornet-baseline/1"
MANIFEST = "manifest.json"
TRACK = "track.csv"
PROGRESS_SAMPLES = 400
_TIME_PREFIX = re.compile(r"^t=[0-9.]+ s ")


class BaselineError(ValueError):
    """The baseline is missing, unreadable or from another plan: bad input (exit 2)."""


@dataclass(frozen=True)
class Tolerances:
    track_m: float = 1.0  # largest distance between the tracks at equal progress
    time_s: float = 2.0  # mission item, mode change and duration timing
    loss: float = 0.02  # a link's loss rate (fraction of datagrams sent)


DEFAULT_TOLERANCES = Tolerances()


@dataclass
class Baseline:
    plan: str
    plan_digest: str
    spec: FlightSpec
    result: dict[str, Any]
    item_times: dict[int, float]
    mode_changes: list[tuple[float, str]]
    events: dict[str, list[str]]
    link_stats: dict[str, dict]
    track: np.ndarray  # (k, 4): t, n, e, d

    @classmethod
    def of(cls, res: Any, spec: FlightSpec, plan: Any) -> Baseline:
        """The baseline of a gateway.ci.fly.FlyResult ``res`` flown with ``spec``; ``plan``: the
        gateway.ci.fly.QgcPlan flown, or (name, digest)."""
        name, digest = plan if isinstance(plan, tuple) else (Path(plan.source).name,
                                                              plan_digest(plan))
        result = {k: getattr(res, k) for k in ("passed", "reasons", "items_total",
                                                "items_reached", "mission_finished", "landed",
                                                "disarmed", "max_deviation_m", "sim_s")}
        events = {"faults": list(res.faults), "failsafes": list(res.failsafes),
                  "warnings": list(res.vehicle_texts)}
        links = {name: link_summary(s) for name, s in sorted(res.link_stats.items())}
        track = np.array(res.track, dtype=float).reshape(-1, 4)
        return cls(name, digest, spec, result,
                   dict(res.item_times), list(res.mode_changes), events, links, track)

    def save(self, directory: str | Path) -> Path:
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        manifest = {"format": FORMAT, "plan": self.plan, "plan_digest": self.plan_digest,
                    "spec": {**self.spec.as_dict(), "plan": self.plan}, "result": self.result,
                    "item_times": {str(k): v for k, v in sorted(self.item_times.items())},
                    "mode_changes": [list(m) for m in self.mode_changes],
                    "events": self.events, "link_stats": self.link_stats}
        (d / MANIFEST).write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
        with open(d / TRACK, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["t_s", "n_m", "e_m", "d_m"])
            w.writerows([repr(float(v)) for v in row] for row in self.track)
        return d

    @classmethod
    def load(cls, directory: str | Path) -> Baseline:
        d = Path(directory)
        try:
            manifest = json.loads((d / MANIFEST).read_text())
            with open(d / TRACK, newline="") as f:
                rows = list(csv.reader(f))[1:]
        except FileNotFoundError as exc:
            raise BaselineError(f"{d}: no baseline there (missing {Path(exc.filename).name}; "
                                "record one with --save-baseline)") from None
        except (OSError, json.JSONDecodeError) as exc:
            raise BaselineError(f"{d}: unreadable baseline ({exc})") from None
        if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
            raise BaselineError(f"{d}/{MANIFEST}: not a {FORMAT} manifest")
        try:
            track = np.array([[float(v) for v in r] for r in rows], dtype=float).reshape(-1, 4)
            return cls(manifest["plan"], manifest["plan_digest"],
                       FlightSpec.from_dict(manifest["spec"]), manifest["result"],
                       {int(k): float(v) for k, v in manifest["item_times"].items()},
                       [(float(t), str(m)) for t, m in manifest["mode_changes"]],
                       manifest["events"], manifest["link_stats"], track)
        except (KeyError, TypeError, ValueError) as exc:
            raise BaselineError(f"{d}: damaged baseline ({exc!r})") from None

    def check_plan(self, plan: Any, directory: str | Path) -> None:
        if plan_digest(plan) != self.plan_digest:
            raise BaselineError(f"{directory}: the baseline is of another plan ({self.plan}, "
                                f"items {self.plan_digest}; {Path(plan.source).name} has "
                                f"{plan_digest(plan)})")


def link_summary(stats: dict) -> dict[str, float]:
    dropped = stats.get("dropped", {})
    lost = sum(dropped.values()) if isinstance(dropped, dict) else int(dropped)
    sent = int(stats.get("sent", 0))
    return {"sent": sent, "delivered": int(stats.get("delivered", 0)), "dropped": lost,
            "loss": round(lost / sent, 6) if sent else 0.0,
            "latency_mean_ms": float(stats.get("latency_mean_ms", 0.0))}


# --- track geometry --------------------------------------------------------------------------------
def by_progress(xyz: np.ndarray, samples: int = PROGRESS_SAMPLES) -> np.ndarray:
    """``samples`` points at equal fractions of the polyline's length (progress 0 → 1)."""
    if len(xyz) == 0:
        return np.zeros((samples, 3))
    seg = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
    keep = np.concatenate([[True], seg > 0])
    xyz = xyz[keep]
    s = np.concatenate([[0.0], np.cumsum(seg[seg > 0])])
    if s[-1] == 0:
        return np.repeat(xyz[:1], samples, axis=0)
    u = np.linspace(0.0, s[-1], samples)
    return np.column_stack([np.interp(u, s, xyz[:, i]) for i in range(3)])


@dataclass(frozen=True)
class TrackDiff:
    max_m: float  # at equal progress
    rms_m: float
    at_progress: float  # where (fraction of the track) the largest distance is
    time_max_m: float  # at equal time (information)


def track_diff(base: np.ndarray, now: np.ndarray) -> TrackDiff:
    if len(base) == 0 or len(now) == 0:
        return TrackDiff(math.inf, math.inf, 0.0, math.inf)
    a, b = by_progress(base[:, 1:]), by_progress(now[:, 1:])
    dist = np.linalg.norm(a - b, axis=1)
    k = int(np.argmax(dist))
    at_t = np.column_stack([np.interp(base[:, 0], now[:, 0], now[:, i]) for i in (1, 2, 3)])
    return TrackDiff(float(dist[k]), float(np.sqrt(np.mean(dist ** 2))),
                     k / (len(dist) - 1), float(np.max(np.linalg.norm(at_t - base[:, 1:], axis=1))))


# --- the comparison --------------------------------------------------------------------------------
@dataclass(frozen=True)
class Finding:
    what: str
    detail: str
    regression: bool  # beyond its tolerance


@dataclass
class Comparison:
    baseline_dir: str
    plan: str
    conditions: str
    tolerances: Tolerances
    track: TrackDiff
    findings: list[Finding] = field(default_factory=list)

    @property
    def regressions(self) -> list[Finding]:
        return [f for f in self.findings if f.regression]

    @property
    def passed(self) -> bool:
        return not self.regressions

    def message(self) -> str:
        """One line: what changed beyond tolerance (for JUnit and summaries)."""
        return "; ".join(f"{f.what}: {f.detail}" for f in self.regressions) or "no regression"

    def report(self) -> str:
        n = len(self.regressions)
        verdict = "SAME" if self.passed else f"REGRESSION ({n} change{'s' * (n != 1)} beyond " \
            "tolerance)"
        lines = [f"baseline {self.baseline_dir} ({self.plan}, {self.conditions}): {verdict}"]
        lines += [f"  {'FAIL' if f.regression else 'ok  '} {f.what}: {f.detail}"
                  for f in self.findings]
        return "\n".join(lines)

    def as_dict(self) -> dict[str, Any]:
        return {"baseline": self.baseline_dir, "passed": self.passed,
                "tolerances": asdict(self.tolerances), "track": asdict(self.track),
                "findings": [asdict(f) for f in self.findings]}


def _signed(x: float) -> str:
    return f"{x:+.2f}"


def _texts(lines: list[str]) -> Counter:
    return Counter(_TIME_PREFIX.sub("", s) for s in lines)


def compare(base: Baseline, res: Any, tol: Tolerances = DEFAULT_TOLERANCES,
            baseline_dir: str = "", conditions: str = "") -> Comparison:
    """How the flight ``res`` (a gateway.ci.fly.FlyResult) differs from ``base``."""
    now = Baseline.of(res, base.spec, (base.plan, base.plan_digest))
    td = track_diff(base.track, now.track)
    cmp = Comparison(baseline_dir, base.plan, conditions or base.spec.conditions(), tol, td)
    add = cmp.findings.append
    add(Finding("track", f"max {td.max_m:.2f} m at {100 * td.at_progress:.0f}% of the track, RMS "
                f"{td.rms_m:.2f} m at equal progress (tolerance {tol.track_m:g} m); max "
                f"{td.time_max_m:.2f} m at equal time", not td.max_m <= tol.track_m))
    was, is_ = base.result, now.result
    if bool(was["passed"]) != bool(is_["passed"]):
        add(Finding("verdict", ("FAIL: " + "; ".join(is_["reasons"])) if was["passed"]
                    else "PASS (the baseline failed)", bool(was["passed"])))
    dt = is_["sim_s"] - was["sim_s"]
    add(Finding("duration", f"{is_['sim_s']:.1f} s (baseline {was['sim_s']:.1f} s, "
                f"{_signed(dt)} s; tolerance {tol.time_s:g} s)", abs(dt) > tol.time_s))
    _timings(cmp, base, now, tol)
    for kind in ("faults", "failsafes", "warnings"):
        old, new = _texts(base.events.get(kind, [])), _texts(now.events[kind])
        for text in sorted((new - old).elements()):
            add(Finding(kind[:-1], f"added: {text!r}", True))
        for text in sorted((old - new).elements()):
            add(Finding(kind[:-1], f"missing: {text!r}", True))
    for name in sorted(set(base.link_stats) | set(now.link_stats)):
        a, b = base.link_stats.get(name), now.link_stats.get(name)
        if a is None or b is None:
            add(Finding(f"link {name}", "added" if a is None else "missing", True))
            continue
        d_loss = b["loss"] - a["loss"]
        add(Finding(f"link {name}", f"loss {100 * b['loss']:.1f}% (baseline "
                    f"{100 * a['loss']:.1f}%), latency {b['latency_mean_ms']:.0f} ms (baseline "
                    f"{a['latency_mean_ms']:.0f} ms), {b['sent']} sent (baseline {a['sent']})",
                    abs(d_loss) > tol.loss))
    return cmp


def _timings(cmp: Comparison, base: Baseline, now: Baseline, tol: Tolerances) -> None:
    add = cmp.findings.append
    worst: tuple[float, int] | None = None
    for seq in sorted(set(base.item_times) | set(now.item_times)):
        a, b = base.item_times.get(seq), now.item_times.get(seq)
        if a is None or b is None:
            add(Finding(f"mission item {seq}", "reached now, not in the baseline" if a is None
                        else f"not reached (baseline: at {a:.1f} s)", True))
        elif abs(b - a) > tol.time_s:
            add(Finding(f"mission item {seq}", f"reached at {b:.1f} s (baseline {a:.1f} s, "
                        f"{_signed(b - a)} s; tolerance {tol.time_s:g} s)", True))
        elif worst is None or abs(b - a) > abs(worst[0]):
            worst = (b - a, seq)
    if worst is not None:
        add(Finding("mission items", f"largest timing change within tolerance: "
                    f"{_signed(worst[0])} s (item {worst[1]})", False))
    old = [m for _, m in base.mode_changes]
    new = [m for _, m in now.mode_changes]
    if old != new:
        add(Finding("modes", f"{' > '.join(new)} (baseline {' > '.join(old)})", True))
        return
    deltas = [(tb - ta, m) for (ta, m), (tb, _) in zip(base.mode_changes, now.mode_changes)]
    late = [(d, m) for d, m in deltas if abs(d) > tol.time_s]
    for d, m in late:
        add(Finding(f"mode {m}", f"entered {_signed(d)} s from the baseline "
                    f"(tolerance {tol.time_s:g} s)", True))
    if not late:
        add(Finding("modes", f"same {len(new)} mode changes, largest timing change "
                    f"{_signed(max((d for d, _ in deltas), key=abs, default=0.0))} s", False))
