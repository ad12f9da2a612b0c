"""The regression gate, ``wbik study FILE -o NEW --compare-to OLD``, on real runs of a small study and on
rows made up to sit on each side of each rule: the same run again exits 0; bounded_lm given fewer
iterations (3 targets lost of 80, or most) exits 1 naming the lost poses; a wall-clock method (kdl)
starved of time fails McNemar's test; a slowed method fails the time rule; a dropped method, a method
no longer applicable and a missing case exit 1; another seed or pose count exits 4 (not compared)."""

from __future__ import annotations

import csv
import math
import re
import time
from pathlib import Path

import numpy as np
import pytest

import wbik
from wbik.cli import main
from wbik.errors import UnsupportedError
from wbik.solvers.dls import DampedLeastSquares
from wbik.study import study_from_dict
from wbik.study.compare import judge, mcnemar_p
from wbik.study.regression_rule import RegressionRule
from wbik.study.results import read_raw_csv
from wbik.study.spec import StudyDefinitionError

STUDY = """
name: gate
figures: false
poses: 80
seed: 5
chunk_size: 40
baseline: dls
regression: {time_rise: 3}
cases:
  - {robot: ur5, chain: arm}
  - {robot: arm3r, chain: arm, target: position, poses: 40}
methods:
  - dls
  - BOUNDED_LM
  - kdl
"""
STRONG = "bounded_lm"


class SleepyDLS(DampedLeastSquares):
    """DLS that sleeps 20 ms per pose: the same answers, far above the rule's x3 even on a loaded machine."""

    name = "sleepy_dls"

    def _solve(self, target, q0, deadline):
        time.sleep(0.02)
        return super()._solve(target, q0, deadline)


class RefusingDLS(DampedLeastSquares):
    """DLS that takes no target at all (a method that stopped applying)."""

    name = "refusing_dls"

    def check_target_kind(self, kind):
        raise UnsupportedError("refuses every target (a test double)")


def _study(folder: Path, name: str, bounded_lm: str = STRONG, replace: tuple[str, str] = ("", "")) -> Path:
    path = folder / f"{name}.yaml"
    path.write_text(STUDY.replace("BOUNDED_LM", bounded_lm).replace(*replace))
    return path


def _run(study: Path, output: Path, *more: str) -> int:
    return main(["study", str(study), "-o", str(output), "--backend", "sequential", "--no-progress", *more])


@pytest.fixture(scope="module")
def old_run(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("gate")
    assert _run(_study(folder, "strong"), folder / "old") == 0
    return folder / "old"


def _comparison(output: Path) -> dict[tuple[str, str], dict]:
    with open(output / "comparison.csv", newline="") as handle:
        return {(row["case"], row["method"]): row for row in csv.DictReader(handle)}


def _line(out: str, case: str, label: str) -> str:
    return next(line for line in out.splitlines() if line.startswith(f"  {case} / {label}:"))


def test_the_same_study_run_again_passes_the_gate(old_run, tmp_path, capsys):
    assert _run(_study(tmp_path, "strong"), tmp_path / "again", "--compare-to", str(old_run)) == 0
    out = capsys.readouterr().out
    assert "0 regression(s)" in out and "REGRESSION" not in out
    rows = _comparison(tmp_path / "again")
    for label in ("dls", "bounded_lm"):  # iteration budgets: the same rows, target by target
        assert rows["ur5_arm_pose", label]["budget"] == "iterations"
        assert rows["ur5_arm_pose", label]["lost"] == rows["ur5_arm_pose", label]["gained"] == "0"
    assert rows["ur5_arm_pose", "kdl"]["budget"] == "wall"
    assert "No regression." in (tmp_path / "again" / "report.md").read_text()


@pytest.mark.parametrize("iterations", [40, 2])
def test_an_iteration_budgeted_method_that_loses_any_target_regresses(old_run, tmp_path, capsys, iterations):
    """40 iterations lose 3 of the 80 targets, 2 lose most: either is a regression, the lost pose ids
    (those solved in OLD's raw rows and not in this run's) listed."""
    weak = _study(tmp_path, "weak", f"{{method: bounded_lm, options: {{max_iterations: {iterations}}}}}")
    assert _run(weak, tmp_path / "new", "--compare-to", str(old_run)) == 1
    before = read_raw_csv(old_run / "ur5_arm_pose" / "raw.csv")["bounded_lm"]
    after = read_raw_csv(tmp_path / "new" / "ur5_arm_pose" / "raw.csv")["bounded_lm"]
    lost = before["pose"][before["success"] & ~after["success"]]
    assert lost.size >= 1 and (iterations == 2) == (lost.size > 40)
    out = capsys.readouterr().out
    assert "1 regression(s)" in out if iterations == 40 else "regression(s)" in out
    line = _line(out, "ur5_arm_pose", "bounded_lm")
    assert f"REGRESSION: {lost.size} target(s) solved in OLD unsolved now: poses " in line
    assert line.split("poses ")[1].startswith(", ".join(map(str, lost[:20])))
    row = _comparison(tmp_path / "new")["ur5_arm_pose", "bounded_lm"]
    assert row["lost_poses"] == " ".join(map(str, lost)) and row["success_regressed"] == "1"
    assert "REGRESSION" not in _line(out, "ur5_arm_pose", "dls")
    assert "max_iterations" in out  # the note: bounded_lm is defined otherwise than in OLD
    report = (tmp_path / "new" / "report.md").read_text()
    assert f"## Compared with {old_run}" in report and "ur5_arm_pose/bounded_lm" in report
    # the gate on results already there: the same verdict without solving
    assert main(["study", str(weak), "-o", str(tmp_path / "new"), "--report-only",
                 "--compare-to", str(old_run)]) == 1


def test_a_wall_clock_method_starved_of_time_fails_the_paired_test(old_run, tmp_path, capsys):
    """kdl (a wall clock) given 3 NR_JL iterations instead of 100: the targets it solved in OLD only
    outnumber the reverse far beyond chance (McNemar exact p < 0.05)."""
    weak = "  - {method: kdl, options: {max_iterations: 3}}\n"
    study = _study(tmp_path, "starved", replace=("  - kdl\n", weak))
    assert _run(study, tmp_path / "new", "--compare-to", str(old_run)) == 1
    row = _comparison(tmp_path / "new")["ur5_arm_pose", "kdl"]
    lost, gained = int(row["lost"]), int(row["gained"])
    assert float(row["mcnemar_p"]) == pytest.approx(mcnemar_p(lost, gained))
    assert lost > 10 and float(row["mcnemar_p"]) < 0.05
    assert "McNemar exact" in _line(capsys.readouterr().out, "ur5_arm_pose", "kdl")


def test_a_slower_method_fails_the_time_rule(old_run, tmp_path, capsys):
    wbik.register("sleepy_dls", SleepyDLS, "test only")
    study = _study(tmp_path, "slow", replace=("  - dls\n", "  - {label: dls, method: sleepy_dls}\n"))
    assert _run(study, tmp_path / "slow", "--compare-to", str(old_run)) == 1
    line = _line(capsys.readouterr().out, "ur5_arm_pose", "dls")
    assert "REGRESSION: time per call rose: median ratio new/old" in line and "above x3" in line
    assert "target(s) solved in OLD unsolved" not in line  # the same answers
    assert _comparison(tmp_path / "slow")["ur5_arm_pose", "dls"]["time_regressed"] == "1"


def test_a_dropped_method_a_refusing_one_and_a_missing_case_regress(old_run, tmp_path, capsys):
    assert _run(_study(tmp_path, "strong"), tmp_path / "dropped", "--methods", "dls,kdl",
                "--compare-to", str(old_run)) == 1
    out = capsys.readouterr().out
    assert "ur5_arm_pose / bounded_lm: REGRESSION: not in this run's study" in out
    assert "arm3r_arm_position / bounded_lm: REGRESSION: not in this run's study" in out

    wbik.register("refusing_dls", RefusingDLS, "test only")
    study = _study(tmp_path, "refusing", replace=("  - dls\n", "  - {label: dls, method: refusing_dls}\n"))
    assert _run(study, tmp_path / "refusing", "--compare-to", str(old_run)) == 1
    line = _line(capsys.readouterr().out, "ur5_arm_pose", "dls")
    assert "REGRESSION: not applicable here:" in line and "a test double" in line

    one_case = _study(tmp_path, "one_case", replace=("  - {robot: arm3r, chain: arm, target: position, "
                                                       "poses: 40}\n", ""))
    assert _run(one_case, tmp_path / "one_case", "--compare-to", str(old_run)) == 1
    out = capsys.readouterr().out
    assert "arm3r_arm_position / dls: REGRESSION: its case is not in this run" in out
    assert "REGRESSION" not in _line(out, "ur5_arm_pose", "dls")


@pytest.mark.parametrize(("more", "says"), [
    (("--seed", "6"), "seed: 5 in OLD, 6 here"),
    (("--poses", "60"), "case ur5_arm_pose: poses 80 in OLD, 60 here"),
])
def test_runs_on_other_settings_are_not_compared_nor_run(old_run, tmp_path, capsys, more, says):
    assert _run(_study(tmp_path, "strong"), tmp_path / "other", *more, "--compare-to", str(old_run)) == 4
    out = capsys.readouterr().out
    assert f"not compared with {old_run}: the runs' targets differ (nothing run)" in out and says in out
    assert not (tmp_path / "other").exists()


def test_other_targets_drawn_by_the_same_settings_are_not_compared(old_run, tmp_path, capsys, monkeypatch):
    """The same study file and settings, but the sampling gives other targets (as a change to the
    sampling code would): found from the saved targets after the run, exit 4, the report says so."""
    import wbik.study.chain_targets as chain_targets

    drawn = chain_targets.sample_joints
    monkeypatch.setattr(chain_targets, "sample_joints",
                        lambda chain, count, seed: drawn(chain, count, seed + 9))
    assert _run(_study(tmp_path, "strong"), tmp_path / "other", "--compare-to", str(old_run)) == 4
    out = capsys.readouterr().out
    assert "case ur5_arm_pose: other targets (the same settings and definition drew them: the sampling " \
           "code differs)" in out
    assert "Not compared: the two runs' targets differ" in (tmp_path / "other" / "report.md").read_text()
    rows = _comparison(tmp_path / "other")
    assert list(rows) == [("", "")] and "other targets" in rows["", ""]["refused"]  # no method compared


def test_compare_to_a_folder_without_a_run_is_a_usage_error(tmp_path, capsys):
    assert _run(_study(tmp_path, "strong"), tmp_path / "out", "--compare-to", str(tmp_path)) == 2
    assert "holds no results of a study" in capsys.readouterr().err


def _rows(success, times=None) -> dict[str, np.ndarray]:
    success = np.asarray(success, dtype=bool)
    times = np.full(success.size, 1e-3) if times is None else np.asarray(times, dtype=float)
    return {"pose": np.arange(success.size), "success": success, "time_s": times}


def test_each_success_rule_with_a_small_and_a_large_regression():
    rule = RegressionRule()  # success_level 0.05, time_rise 1.2
    old = _rows([True] * 100)
    one_lost = _rows([True] * 99 + [False])
    # deterministic (closed form, iterations): one target lost is a regression, none is not
    for budget in ("none", "iterations"):
        verdict = judge("c", "m", budget, old, one_lost, rule)
        assert verdict.success_regressed and verdict.lost == (99,) and "poses 99" in verdict.verdict
        assert not judge("c", "m", budget, old, old, rule).regressed
    # wall clock: McNemar's exact test on the discordant targets, one-sided
    three_lost_one_gained = _rows([True] * 97 + [False] * 3)
    old_with_one_unsolved = _rows([False] + [True] * 99)
    small = judge("c", "m", "wall", old_with_one_unsolved, three_lost_one_gained, rule)
    assert (len(small.lost), len(small.gained)) == (3, 1)
    assert small.p_value == pytest.approx(5 / 16) and not small.regressed  # P(X >= 3), X ~ B(4, 1/2)
    large = judge("c", "m", "wall", old, _rows([True] * 90 + [False] * 10), rule)
    assert large.p_value == pytest.approx(0.5 ** 10) and large.success_regressed
    assert not judge("c", "m", "wall", old, one_lost, rule).regressed  # p = 1/2
    assert judge("c", "m", "wall", old, one_lost, RegressionRule(success_level=0.6)).regressed
    assert mcnemar_p(0, 0) == 1.0


def test_the_time_rule_on_paired_ratios():
    rng = np.random.default_rng(3)
    before = rng.uniform(1e-4, 1e-2, 400)  # targets of very different difficulty
    noise = rng.uniform(0.95, 1.05, 400)
    old = _rows([True] * 400, before)
    rule = RegressionRule(time_rise=1.2)
    assert not judge("c", "m", "iterations", old, _rows([True] * 400, before * 1.1 * noise), rule).regressed
    slower = judge("c", "m", "iterations", old, _rows([True] * 400, before * 1.5 * noise), rule)
    assert slower.time_regressed and not slower.success_regressed
    assert 1.2 < slower.ratio[1] <= slower.ratio[0] <= slower.ratio[2] < 1.6
    assert not judge("c", "m", "iterations", old, _rows([True] * 400, before * 1.5),
                     RegressionRule(time_rise=None)).regressed
    nan_times = _rows([True] * 400, np.full(400, math.nan))
    assert not judge("c", "m", "wall", nan_times, nan_times, rule).time_regressed


@pytest.mark.parametrize(("block", "message"), [
    ({"success_level": 1.5}, "success_level must be a test level between 0 and 1"),
    ({"success_drop": "ci"}, "unknown field(s) ['success_drop'] (did you mean 'success_level'?)"),
    ({"time_rise": 0.5}, "time_rise must be a factor >= 1"),
    ({"time_ris": 2}, "did you mean 'time_rise'"),
    ("strict", "regression must be a mapping {success_level: 0.05, time_rise: 1.2}"),
])
def test_the_regression_block_is_checked(block, message):
    with pytest.raises(StudyDefinitionError, match=re.escape(message)):
        study_from_dict({"robot": "ur5", "chain": "arm", "methods": ["dls"], "regression": block})


def test_the_regression_block_reads_and_leaves_the_fingerprint_alone():
    plain = study_from_dict({"robot": "ur5", "chain": "arm", "methods": ["dls"]})
    ruled = study_from_dict({"robot": "ur5", "chain": "arm", "methods": ["dls"],
                             "regression": {"success_level": 0.01, "time_rise": "off"},
                             "budget_curves": {"poses": 50}})
    assert plain.regression == RegressionRule(0.05, 1.2)
    assert ruled.regression == RegressionRule(0.01, None)
    assert ruled.budget_curves.poses == 50
    assert plain.fingerprint() == ruled.fingerprint()
