"""Flight regression: baselines (`cornet fly --save-baseline/--baseline`), sweeps (`cornet sweep`),
JUnit XML and Markdown reports, bad input. Short plans, lockstep flights (no wall-clock timing)."""

from __future__ import annotations

import csv
import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from gateway.ci.baseline import Baseline, Tolerances, by_progress, track_diff
from gateway.cli import main as cli

PLANS = Path(__file__).resolve().parents[2] / "gcs_examples" / "plans"


def short_plan(directory: Path, name: str = "short.plan", north_items: int = 1) -> Path:
    """square.plan cut to take-off, ``north_items`` waypoint(s) and return: ~35 s of flight."""
    doc = json.loads((PLANS / "square.plan").read_text())
    items = doc["mission"]["items"]
    doc["mission"]["items"] = [items[0], *items[1:1 + north_items], items[-1]]
    path = directory / name
    path.write_text(json.dumps(doc))
    return path


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A short plan and its baseline, recorded once for the module's tests."""
    d = tmp_path_factory.mktemp("regress")
    plan = short_plan(d)
    assert cli(["fly", str(plan), "--save-baseline", str(d / "base")]) == 0
    return plan, d / "base"


def test_baseline_files(recorded):
    _, base_dir = recorded
    base = Baseline.load(base_dir)
    assert base.result["passed"] and base.track.shape[1] == 4 and len(base.track) > 100
    assert base.spec.plan == "short.plan" and base.item_times
    assert [m for _, m in base.mode_changes][:2] == ["AUTO_MISSION", "AUTO_RTL"]
    assert set(base.link_stats) == {"v1/api/up", "v1/api/down"}


def test_same_plan_same_seed_compares_equal_exactly(recorded, tmp_path, capsys):
    plan, base_dir = recorded
    assert cli(["fly", str(plan), "--baseline", str(base_dir), "--overlay",
                str(tmp_path / "overlay.png")]) == 0
    out = capsys.readouterr().out
    assert ": SAME" in out
    assert "max 0.00 m at 0% of the track, RMS 0.00 m at equal progress" in out
    assert "+0.00 s" in out and "FAIL" not in out
    assert (tmp_path / "overlay.png").stat().st_size > 10_000


def test_latency_is_a_regression_and_the_report_says_how_much(recorded, tmp_path, capsys):
    plan, base_dir = recorded
    junit = tmp_path / "fly.xml"
    summary = tmp_path / "summary.md"
    code = cli(["fly", str(plan), "--baseline", str(base_dir), "--latency-ms", "300",
                "--junit-xml", str(junit), "--summary", str(summary)])
    out = capsys.readouterr().out
    assert code == 1
    assert "(short.plan, latency 300 ms): REGRESSION" in out
    assert "FAIL mission item 0: reached at" in out and "tolerance 2 s)" in out
    assert "FAIL duration:" in out
    assert "latency 300 ms (baseline 0 ms)" in out  # the link statistics changed too
    root = ET.parse(junit).getroot()
    assert root.tag == "testsuites" and root.get("tests") == "1" and root.get("failures") == "1"
    (suite,) = root.findall("testsuite")
    (case,) = suite.findall("testcase")
    assert case.get("name") == "latency 300 ms" and case.get("classname") == "cornet.fly.short"
    failure = case.find("failure")
    assert failure is not None and "mission item 0: reached at" in failure.get("message", "")
    assert "REGRESSION" in (failure.text or "")
    assert "❌ 1 of 1 failed" in summary.read_text()


def test_a_changed_parameter_is_a_regression(recorded, capsys):
    plan, base_dir = recorded
    assert cli(["fly", str(plan), "--baseline", str(base_dir), "--param", "MPC_XY_CRUISE=3"]) == 1
    out = capsys.readouterr().out
    assert "MPC_XY_CRUISE=3" in out and "FAIL mission item" in out


def test_tolerances_absorb_sensor_noise_of_another_seed(recorded, capsys):
    plan, base_dir = recorded
    assert cli(["fly", str(plan), "--baseline", str(base_dir), "--seed", "7",
                "--tol-track-m", "5", "--tol-time-s", "5"]) == 0, capsys.readouterr().out


def test_equal_progress_ignores_a_late_start():
    t = np.arange(0.0, 20.0, 0.1)
    base = np.column_stack([t, t, 0 * t, -5 + 0 * t])
    late = np.column_stack([t + 3.0, t, 0 * t, -5 + 0 * t])
    d = track_diff(base, late)
    assert d.max_m == pytest.approx(0.0, abs=1e-9) and d.time_max_m > 2.5
    assert np.allclose(by_progress(base[:, 1:], 3)[:, 0], [0.0, 9.95, 19.9])


def test_junit_of_a_sweep_has_one_testcase_per_flight(tmp_path, capsys):
    """A small sweep: 2 latencies x 1 seed, two processes, flown from the ground (the default:
    the paper's Fig. 8)."""
    plan = short_plan(tmp_path, north_items=2)
    out = tmp_path / "sweep"
    code = cli(["sweep", str(plan), "--latency-ms", "0,300", "--jobs", "2",
                "--out", str(out), "--junit-xml", str(tmp_path / "sweep.xml"),
                "--summary", str(tmp_path / "sweep.md")])
    text = capsys.readouterr().out
    assert code == 0, text
    with open(out / "cells.csv", newline="") as f:
        cells = list(csv.DictReader(f))
    assert "control ground: waypoints flown from the ground" in text.splitlines()[0]
    assert [c["conditions"] for c in cells] == ["ideal network", "latency 300 ms"]
    assert float(cells[1]["drift_m"]) > float(cells[0]["drift_m"]) + 0.5  # drift grows
    with open(out / "sweep.csv", newline="") as f:
        assert [r["control"] for r in csv.DictReader(f)] == ["ground", "ground"]
    for name in ("success_rate.png", "completion_time.png", "drift.png"):
        assert (out / name).stat().st_size > 10_000
    suite = ET.parse(tmp_path / "sweep.xml").getroot().find("testsuite")
    assert suite is not None and len(suite.findall("testcase")) == 2
    assert suite.findall("testcase/failure") == []
    assert "| 1 | 1/1 |" in (tmp_path / "sweep.md").read_text()


def test_a_failing_sweep_cell_is_a_junit_failure(tmp_path, capsys):
    plan = short_plan(tmp_path)
    code = cli(["sweep", str(plan), "--latency-ms", "0", "--max-deviation", "0.01", "--jobs", "1",
                "--out", str(tmp_path / "s"), "--junit-xml", str(tmp_path / "s.xml")])
    assert code == 1
    assert "failing cells: ideal network: 0/1 passed" in capsys.readouterr().out
    (failure,) = ET.parse(tmp_path / "s.xml").getroot().iter("failure")
    assert "max deviation" in failure.get("message", "") and "drift" in failure.get("message", "")


def _exit_2(argv: list[str], capsys) -> str:
    try:
        code = cli(argv)
    except SystemExit as exc:  # argparse
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    return err[-1]


def test_bad_input_exits_2_with_one_line(recorded, tmp_path, capsys):
    plan, base_dir = recorded
    line = _exit_2(["fly", str(plan), "--baseline", str(tmp_path / "nothing")], capsys)
    assert "no baseline there" in line and "--save-baseline" in line
    other = short_plan(tmp_path, "other.plan", north_items=2)
    line = _exit_2(["fly", str(other), "--baseline", str(base_dir)], capsys)
    assert "the baseline is of another plan (short.plan" in line
    line = _exit_2(["fly", str(plan), "--overlay", str(tmp_path / "o.png")], capsys)
    assert "give --baseline DIR too" in line
    line = _exit_2(["sweep", str(plan), "--param", "NOT_A_PARAM=1,2"], capsys)
    assert "no PX4 parameter named 'NOT_A_PARAM'" in line
    line = _exit_2(["sweep", str(plan), "--latency-ms", ""], capsys)
    assert "--latency-ms: an empty value" in line
    line = _exit_2(["sweep", str(plan), "--wind-mps", "1,2"], capsys)
    assert "unrecognized arguments: --wind-mps" in line
    line = _exit_2(["sweep", str(plan), "--param", "MPC_XY_CRUISE="], capsys)
    assert "expected NAME=V1,V2" in line
    line = _exit_2(["sweep", str(plan), "--scenario", "x.toml", "--loss", "0.1"], capsys)
    assert "not both" in line
    line = _exit_2(["sweep", str(tmp_path / "missing.plan")], capsys)
    assert "missing.plan: cannot read" in line


def test_tolerances_defaults_match_the_flags():
    from gateway.ci import flags

    t = Tolerances()
    assert (t.track_m, t.time_s, t.loss) == (flags.DEFAULT_TOL_TRACK_M, flags.DEFAULT_TOL_TIME_S,
                                              flags.DEFAULT_TOL_LOSS)


def test_flight_spec_network_and_conditions():
    from gateway.ci.spec import FlightSpec
    from gateway.sim.scenario import load

    windy = str(PLANS.parent / "scenarios" / "windy.toml")
    spec = FlightSpec("p.plan", scenario=windy, seed=3)
    net = spec.network()
    assert net is not None and net.seed == 3 and net.topology == load(windy).network.topology
    assert FlightSpec("p.plan", scenario=windy).network() is None  # the scenario's own
    lossy = FlightSpec("p.plan", latency_ms=50, loss=0.1, seed=2, params={"MPC_XY_CRUISE": 8.0})
    link = lossy.network().topology["link"]
    assert (link["latency_s"], link["loss"], lossy.network().seed) == (0.05, 0.1, 2)
    assert lossy.conditions() == "latency 50 ms, loss 0.1, seed 2, MPC_XY_CRUISE=8"
    assert FlightSpec("p.plan").network() is None and FlightSpec("p.plan").conditions() == \
        "ideal network"


def test_a_broken_flight_is_a_failed_row_not_a_lost_sweep(tmp_path):
    from gateway.ci.spec import FlightSpec
    from gateway.ci.sweep import _fly_one

    row = _fly_one(FlightSpec(str(tmp_path / "gone.plan"), seed=0))
    assert not row["passed"] and row["reasons"].startswith("error: PlanFileError(")
