"""Scenario expectations: a figure beyond its task-file threshold makes the scenario FAILED.

Each test loads a real task file, tightens one threshold beyond the figure the scenario measures
(the figures are known from the seed documents: the faithful step must show >= 10 mm of closed-chain
mismatch, bioloid.md 4.5; CoM margins are bounded by the sole size, 100 x 60 mm) and checks the
verdict turns to FAILED, with the figure, threshold and ok shown in the printed report.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from wbik.errors import WbikError
from wbik.expectations import ExpectationError, Rule, evaluate, verdict
from wbik.scenarios import format_report, load_scenario, run_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"
RULES = {"margin_min_m": Rule("margin_m", ">=", "m"), "ok": Rule("ok", "==")}


def test_evaluate_judges_and_reports_figure_threshold_ok():
    checks = evaluate({"margin_min_m": 0.005, "ok": True}, {"margin_m": 0.004, "ok": True}, RULES)
    assert [(c["name"], c["figure"], c["threshold"], c["ok"]) for c in checks] == [
        ("margin_min_m", 0.004, 0.005, False), ("ok", True, True, True)]
    assert verdict(checks) == "FAILED"
    assert verdict(evaluate({}, {"margin_m": -1.0}, RULES)) == "informational"


def test_expected_to_fail_needs_a_reason_and_is_strict():
    entry = {"threshold": 0.0, "expected_to_fail": True, "why": "an open-loop pose"}
    failing = evaluate({"margin_min_m": entry}, {"margin_m": -0.01}, RULES)
    assert not failing[0]["ok"] and failing[0]["passed"] and verdict(failing) == "PASSED"
    met_anyway = evaluate({"margin_min_m": entry}, {"margin_m": 0.01}, RULES)
    assert met_anyway[0]["ok"] and not met_anyway[0]["passed"]
    with pytest.raises(ExpectationError, match="why"):
        evaluate({"margin_min_m": {"threshold": 0.0, "expected_to_fail": True}}, {"margin_m": 0.0}, RULES)


def test_unknown_key_raises_a_typed_error_naming_the_known_keys():
    with pytest.raises(ExpectationError) as error:
        evaluate({"margin_min_mm": 5}, {}, RULES)
    assert isinstance(error.value, WbikError)
    assert "margin_min_m" in str(error.value) and "ok" in str(error.value)
    with pytest.raises(ExpectationError, match="number"):
        evaluate({"margin_min_m": "5 mm"}, {"margin_m": 0.01}, RULES)


def test_unknown_key_in_a_task_file_raises(tmp_path):
    spec = load_scenario(TASKS / "bioloid_step_forward.yaml")
    spec["generators"] = ["faithful"]
    spec["expect"]["faithful"]["com_margin_min_mm"] = 5.0
    with pytest.raises(ExpectationError, match="com_margin_min_m"):
        run_scenario(spec)
    spec = load_scenario(TASKS / "bioloid_walk_keyframes.yaml")
    spec["expect"]["wobble"] = 1
    with pytest.raises(ExpectationError, match="units_round_trip_exact"):
        run_scenario(spec)


def test_wholebody_phase_fails_on_a_tightened_com_margin():
    spec = load_scenario(TASKS / "bioloid_balance.yaml")
    spec["phases"] = spec["phases"][:1]
    assert run_scenario(spec)["passed"]
    # the CoM cannot be 60 mm inside a 100 x 60 mm sole pair's hull edge here (30 mm measured)
    spec["phases"][0]["expect"] = {"success": True, "com_margin_min_m": 0.060}
    report = run_scenario(spec)
    assert not report["passed"] and report["verdict"] == "FAILED"
    text = format_report(report)
    assert "FAILED" in text.splitlines()[0] and "com_margin_min_m" in text and ">= 0.06 m / NOT ok" in text


def test_faithful_step_fails_on_a_tightened_threshold():
    spec = load_scenario(TASKS / "bioloid_step_forward.yaml")
    spec["generators"] = ["faithful"]
    assert run_scenario(spec)["passed"]
    # bioloid.md 4.5 asks for a mismatch of at least 10 mm; 1 m is beyond any Bioloid leg
    spec["expect"]["faithful"]["closed_chain_mismatch_min_m"] = 1.0
    assert not run_scenario(spec)["passed"]
    # floor penetration judged without the expected_to_fail mark: FAILED
    spec = load_scenario(TASKS / "bioloid_step_forward.yaml")
    spec["generators"] = ["faithful"]
    spec["expect"]["faithful"]["clearance_min_m"] = 0.0
    report = run_scenario(spec)
    assert not report["passed"]
    assert "clearance_min_m: min_clearance_m" in format_report(report)


def test_keyframes_com_margin_without_the_reason_fails_and_no_expect_is_informational():
    spec = load_scenario(TASKS / "bioloid_walk_keyframes.yaml")
    spec["behaviours"] = ["right_turn_medium"]
    spec["expect"] = {"com_margin_single_min_m": 0.0}
    assert not run_scenario(spec)["passed"]
    del spec["expect"]
    report = run_scenario(spec)
    assert report["passed"] and report["verdict"] == "informational"
    assert format_report(report).splitlines()[0].endswith("informational")


def test_motion_fails_on_a_tightened_knot_tolerance():
    spec = load_scenario(TASKS / "motion_seed001_waypoints.yaml")
    assert run_scenario(spec)["passed"]
    spec["expect"]["knot_error_max_m"] = 1e-15
    report = run_scenario(spec)
    assert not report["passed"] and "knot_error_max_m" in format_report(report)


def test_riveting_expectations_judge_a_run_and_check_keys_before_simulating():
    from wbik.apps.riveting.report import _check_expect_keys, judge

    summary = {"score": {"total": 22}, "collisions": 0, "rivets": 9, "failed_plans": 0,
               "min_clearance_links_mm": 12.0}
    report = {"runs": {"thesis": {"summary": summary}}}
    assert judge(report, {"thesis": {"min_rivets": 9, "min_clearance_links_m": 0.01}})["passed"]
    assert not judge(report, {"thesis": {"min_rivets": 10}})["passed"]
    assert not judge(report, {"thesis": {"min_clearance_links_m": 0.013}})["passed"]
    spec = load_scenario(TASKS / "ur5_riveting.yaml")
    spec["expect"]["ours"]["min_scores"] = 30
    with pytest.raises(ExpectationError, match="min_score"):
        _check_expect_keys(spec)
