"""``cornet fly`` with baselines and CI reports: fly one plan, judge it, and compare it with the
last good flight (gateway/ci/baseline.py).

    cornet fly PLAN --save-baseline DIR        # fly, judge, store the flight as the baseline
    cornet fly PLAN --baseline DIR             # fly under the baseline's conditions, compare
    cornet fly PLAN --baseline DIR --latency-ms 300 --overlay overlay.png --junit-xml fly.xml

Exit codes: 0 the flight passed (and matches its baseline), 1 it failed its checks or regressed,
2 bad input (an unreadable plan, a missing baseline, a baseline of another plan).
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from gateway.ci import report
from gateway.ci.baseline import (
    DEFAULT_TOLERANCES,
    Baseline,
    BaselineError,
    Comparison,
    Tolerances,
    compare,
)
from gateway.ci.fly import FlyResult, PlanFileError, QgcPlan, fly, load_plan
from gateway.ci.spec import FlightSpec


@dataclass
class Outcome:
    """A judged flight, and its comparison with a baseline when there was one."""

    spec: FlightSpec
    result: FlyResult
    comparison: Comparison | None = None
    baseline: Baseline | None = None

    @property
    def passed(self) -> bool:
        return self.result.passed and (self.comparison is None or self.comparison.passed)

    @property
    def exit_code(self) -> int:
        if self.result.refused_plan:
            return report.EXIT_BAD_INPUT
        return report.EXIT_PASS if self.passed else report.EXIT_FAIL

    def failure(self) -> str | None:
        """One line with the numbers, None if the flight passed."""
        if self.passed:
            return None
        parts = [] if self.result.passed else ["; ".join(self.result.reasons)]
        if self.comparison is not None and not self.comparison.passed:
            parts.append("regression: " + self.comparison.message())
        return " | ".join(parts)

    def text(self) -> str:
        out = self.result.summary()
        if self.comparison is not None:
            out += "\n" + self.comparison.report()
        return out

    def case(self, classname: str) -> report.Case:
        return report.Case(self.spec.conditions(), classname, self.result.wall_s,
                           self.failure(), self.text())


def open_baseline(directory: str | Path, plan: QgcPlan) -> Baseline:
    """The baseline in ``directory``, checked to be of ``plan``. Raises BaselineError."""
    base = Baseline.load(directory)
    base.check_plan(plan, directory)
    return base


def fly_spec(spec: FlightSpec, plan: QgcPlan | None = None, **kwargs: Any) -> FlyResult:
    """Fly ``spec`` (kwargs: ``log_dir``, ``progress``, ``clock`` of gateway.ci.fly.fly)."""
    return fly(plan if plan is not None else spec.plan, **spec.fly_kwargs(), **kwargs)


def run(plan_path: str | Path, overrides: dict[str, Any], *, baseline: str | Path | None = None,
        save_baseline: str | Path | None = None, tolerances: Tolerances = DEFAULT_TOLERANCES,
        **fly_kwargs: Any) -> Outcome:
    """Fly ``plan_path`` under ``overrides`` (FlightSpec fields) over the baseline's conditions
    (if any), judge it, compare it with the baseline, save it as the baseline if it passed. Raises
    PlanFileError / BaselineError (bad input)."""
    plan = load_plan(plan_path)
    base = None if baseline is None else open_baseline(baseline, plan)
    spec = dataclasses.replace(base.spec if base is not None else FlightSpec(str(plan_path)),
                               **{**overrides, "plan": str(plan_path)})
    res = fly_spec(spec, plan, **fly_kwargs)
    out = Outcome(spec, res, baseline=base)
    if base is not None:
        out.comparison = compare(base, res, tolerances, str(baseline), spec.conditions())
    if save_baseline is not None and out.passed:  # a baseline is a good flight
        Baseline.of(res, spec, plan).save(save_baseline)
    return out


def main(plan_path: str | Path, overrides: dict[str, Any], *,
         baseline: str | Path | None = None, save_baseline: str | Path | None = None,
         tolerances: Tolerances = DEFAULT_TOLERANCES, overlay: str | Path | None = None,
         junit_xml: str | Path | None = None, summary: str | Path | None = None,
         out: TextIO | None = None, err: TextIO | None = None,
         clock: Callable[[], float] = time.perf_counter, **fly_kwargs: Any) -> int:
    """What ``cornet fly`` runs: print the verdict (and the comparison), write the reports,
    return the exit code."""
    out = out or sys.stdout
    err = err or sys.stderr
    try:
        outcome = run(plan_path, overrides, baseline=baseline, save_baseline=save_baseline,
                      tolerances=tolerances, clock=clock, **fly_kwargs)
    except (PlanFileError, BaselineError) as exc:
        print(f"cornet fly: {exc}", file=err)
        return report.EXIT_BAD_INPUT
    print(outcome.text(), file=out, flush=True)
    if save_baseline is not None:
        print(f"baseline saved in {save_baseline}" if outcome.passed else
              f"baseline not saved in {save_baseline}: the flight did not pass", file=out)
    if overlay is not None and outcome.baseline is not None:
        from gateway.ci.regress_plot import plot_overlay

        print(f"overlay: {plot_overlay(outcome.baseline, outcome.result, overlay)}", file=out)
    name = Path(plan_path).stem
    cases = [outcome.case(f"cornet.fly.{name}")]
    if junit_xml is not None:
        report.write_junit(junit_xml, f"cornet fly {name}", cases)
    if summary is not None:
        report.write_summary(summary, f"cornet fly {Path(plan_path).name}", cases,
                             "```\n" + outcome.text() + "\n```")
    return outcome.exit_code
