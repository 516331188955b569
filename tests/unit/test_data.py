"""The files shipped in the package (gateway/data/): found by name, described in one line."""

import sys

import pytest

import gateway.ci
from gateway import cli, data
from gateway.sim.scenario import ScenarioError, load


def test_every_shipped_scenario_has_a_one_line_description():
    names = data.scenario_names()
    assert {"ideal", "lossy-wifi", "two-radios", "gps-loss"} <= set(names)
    for name in names:
        text = data.summary(data.SCENARIO_DIR / f"{name}.toml")
        assert 10 < len(text) <= 100 and text.endswith("."), (name, text)


def test_a_scenario_by_name_with_or_without_suffix():
    assert load("lossy-wifi").source == str(data.SCENARIO_DIR / "lossy-wifi.toml")
    assert load("lossy-wifi.toml").vehicles == 2


def test_a_path_that_exists_wins_over_a_name(tmp_path, monkeypatch):
    (tmp_path / "ideal").write_text("[vehicles]\ncount = 3\n")
    monkeypatch.chdir(tmp_path)
    assert load("ideal").vehicles == 3


def test_an_unknown_name_says_where_names_come_from():
    with pytest.raises(ScenarioError, match="cornet scenarios"):
        load("no-such-scenario")


def test_a_plan_by_name():
    assert data.plan_path("square") == data.PLAN_DIR / "square.plan"
    assert data.plan_path("gateway/nope.plan").name == "nope.plan"  # a path stays a path


def test_cornet_scenarios_lists_name_and_description(capsys):
    assert cli.main(["scenarios"]) == 0
    out = capsys.readouterr().out
    assert any(line.startswith("lossy-wifi ") and "case study" in line for line in out.splitlines())
    assert str(data.SYSTEMD_DIR) in out


def test_plot_without_matplotlib_says_what_to_install(monkeypatch, capsys, tmp_path):
    for name in ["matplotlib", *(m for m in sys.modules if m.startswith("matplotlib."))]:
        monkeypatch.setitem(sys.modules, name, None)  # as if it were not installed
    monkeypatch.delitem(sys.modules, "gateway.ci.plot", raising=False)
    monkeypatch.delattr(gateway.ci, "plot", raising=False)  # imported by an earlier test
    assert cli.main(["plot", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["cornet plot: needs matplotlib, which is not installed: pip install matplotlib"]


def test_the_former_checkout_paths_still_find_the_shipped_files(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no scenarios/ here
    assert load("scenarios/lossy-wifi.toml").source == str(data.SCENARIO_DIR / "lossy-wifi.toml")
    assert data.plan_path("gcs_examples/plans/square.plan") == data.PLAN_DIR / "square.plan"
    with pytest.raises(ScenarioError, match="cannot read"):
        load("myscenarios/lossy-wifi.toml")
