"""`cornet fly PLAN`: QGC plan parsing, the planned path, and the two shipped plans."""

import json
import math
from pathlib import Path

import pytest

from gateway.ci.fly import PlanFileError, distance_to_path, fly, load_plan, main, parse_plan, planned_path
from vehicles.plan_types import MavCmd, PlanType
from vehicles.types import PX4_SITL_HOME

PLANS = Path(__file__).resolve().parents[2] / "gcs_examples" / "plans"


def test_square_plan_parses_as_qgc_writes_it():
    plan = load_plan(PLANS / "square.plan")
    assert [it.command for it in plan.mission] == [22, 16, 16, 16, 16, 20]
    assert math.isnan(plan.mission[1].param4)  # JSON null -> NaN (yaw not commanded)
    assert plan.mission[0].x == 473977420 and plan.mission[0].z == 15
    assert [it.command for it in plan.fence] == [MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION] * 4
    assert all(it.param1 == 4 and it.mission_type == PlanType.FENCE for it in plan.fence)
    assert [it.command for it in plan.rally] == [MavCmd.NAV_RALLY_POINT]
    assert plan.planned_home == PX4_SITL_HOME


def test_complex_items_circles_and_errors():
    simple = {"type": "SimpleItem", "command": 16, "frame": 3, "autoContinue": True,
              "params": [0, 0, 0, None, 47.4, 8.5, 20]}
    doc = {"fileType": "Plan",
           "mission": {"items": [{"type": "ComplexItem", "complexItemType": "survey",
                                  "TransectStyleComplexItem": {"Items": [simple, simple]}}]},
           "geoFence": {"circles": [{"circle": {"center": [47.4, 8.5], "radius": 80},
                                     "inclusion": False, "version": 1}], "polygons": []}}
    plan = parse_plan(doc)
    assert len(plan.mission) == 2 and plan.mission[1].y == 85000000
    assert plan.fence[0].command == MavCmd.NAV_FENCE_CIRCLE_EXCLUSION and plan.fence[0].param1 == 80
    with pytest.raises(PlanFileError, match="fileType"):
        parse_plan({"mission": {}})
    with pytest.raises(PlanFileError, match="unknown item type"):
        parse_plan({"fileType": "Plan", "mission": {"items": [{"type": "Odd"}]}})


def test_planned_path_and_distance():
    plan = load_plan(PLANS / "square.plan")
    path = planned_path(plan.mission, PX4_SITL_HOME, (0.0, 0.0, 0.0))
    assert path[0] == (0.0, 0.0, 0.0) and path[1] == (0.0, 0.0, -15.0)
    assert path[3][0] == pytest.approx(30.0, abs=0.05) and len(path) == 7  # RTL leg not judged
    assert distance_to_path((15.0, 1.0, -15.0), path) == pytest.approx(1.0, abs=0.05)


def test_square_plan_passes(capsys, tmp_path):
    assert main(PLANS / "square.plan", max_deviation_m=5.0, log_dir=tmp_path) == 0
    out = capsys.readouterr().out
    assert ": PASS" in out and "items reached, finished" in out
    assert "never breached" in out and "RTF" in out
    assert (tmp_path / "v1-api.tlog").stat().st_size > 0


def test_breach_plan_fails_and_says_why():
    res = fly(PLANS / "breach.plan")
    assert res.exit_code == 1 and not res.passed
    assert res.geofence_breach is not None
    assert any(r.startswith("geofence breached at t=") for r in res.reasons)
    assert "FAIL: geofence breached" in res.summary()


def test_deviation_limit_is_a_criterion():
    res = fly(PLANS / "square.plan", max_deviation_m=0.01)
    assert res.exit_code == 1 and "max deviation" in res.reasons[0]


def test_bad_plan_file_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.plan"
    bad.write_text(json.dumps({"fileType": "Plan", "mission": {"items": []}}))
    assert main(bad) == 2
    assert "no items" in capsys.readouterr().err
    assert main(tmp_path / "missing.plan") == 2


def test_a_plan_the_vehicle_refuses_is_bad_input_not_a_failed_flight(tmp_path):
    """exit 2 when the vehicle refuses the upload (here: a waypoint with an unknown frame)."""
    doc = json.loads((PLANS / "square.plan").read_text())
    doc["mission"]["items"][1]["frame"] = 99
    bad = tmp_path / "refused.plan"
    bad.write_text(json.dumps(doc))
    res = fly(bad)
    assert res.refused_plan and res.exit_code == 2, res.reasons
    assert "mission upload rejected" in res.reasons[0]
