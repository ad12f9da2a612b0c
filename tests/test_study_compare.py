"""The regression gate, ``wbik study FILE --compare-to OLD``: a weakened method (bounded_lm with 2
iterations) or a slowed one (dls sleeping 5 ms a pose) compared with a run of the study exits 1 and
names it; an unchanged rerun exits 0; the rule's block in the study file is checked."""

from __future__ import annotations

import csv
import time
from pathlib import Path

import pytest

import wbik
from wbik.cli import main
from wbik.solvers.dls import DampedLeastSquares
from wbik.study import study_from_dict
from wbik.study.compare import RunFigures
from wbik.study.compare import judge
from wbik.study.definition import RegressionRule
from wbik.study.definition import StudyDefinitionError

STUDY = """
name: gate
robot: ur5
chain: arm
poses: 60
seed: 5
chunk_size: 30
baseline: dls
regression: {success_drop: ci, time_rise: 3}
methods:
  - dls
  - BOUNDED_LM
"""
STRONG = "bounded_lm"
WEAK = "{method: bounded_lm, options: {max_iterations: 2}}"


class SleepyDLS(DampedLeastSquares):
    """DLS that sleeps 5 ms per pose: the same answers, slower."""

    name = "sleepy_dls"

    def _solve(self, target, q0, deadline):
        time.sleep(0.005)
        return super()._solve(target, q0, deadline)


def _study(folder: Path, methods: str, name: str, extra: str = "") -> Path:
    path = folder / f"{name}.yaml"
    path.write_text(STUDY.replace("BOUNDED_LM", methods) + extra)
    return path


def _run(study: Path, output: Path, *more: str) -> int:
    return main(["study", str(study), "-o", str(output), "--backend", "sequential", "--no-progress", *more])


@pytest.fixture(scope="module")
def old_run(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("gate")
    assert _run(_study(folder, STRONG, "strong"), folder / "old") == 0
    return folder / "old"


def _comparison(output: Path) -> dict[str, dict]:
    with open(output / "comparison.csv", newline="") as handle:
        return {row["method"]: row for row in csv.DictReader(handle)}


def test_a_weakened_method_fails_the_gate_and_is_named(old_run, tmp_path, capsys):
    assert _run(_study(tmp_path, WEAK, "weak"), tmp_path / "new", "--compare-to", str(old_run)) == 1
    out = capsys.readouterr().out
    assert "1 regression(s)" in out
    line = next(line for line in out.splitlines() if "/ bounded_lm:" in line)
    assert "REGRESSION: success dropped" in line
    assert "REGRESSION" not in next(line for line in out.splitlines() if "/ dls:" in line)
    rows = _comparison(tmp_path / "new")
    assert rows["bounded_lm"]["success_regressed"] == "1" and rows["dls"]["success_regressed"] == "0"
    assert float(rows["bounded_lm"]["new_percent_high"]) < float(rows["bounded_lm"]["old_percent_low"])
    report = (tmp_path / "new" / "report.md").read_text()
    assert f"## Compared with {old_run}" in report
    assert "1 regression(s): ur5_arm_pose/bounded_lm." in report
    # the gate on results already there: the same verdict without solving
    assert main(["study", str(tmp_path / "weak.yaml"), "-o", str(tmp_path / "new"), "--report-only",
                 "--compare-to", str(old_run)]) == 1


def test_an_unchanged_rerun_passes_the_gate(old_run, tmp_path, capsys):
    assert _run(_study(tmp_path, STRONG, "strong"), tmp_path / "again", "--compare-to", str(old_run)) == 0
    out = capsys.readouterr().out
    assert "0 regression(s)" in out and "REGRESSION" not in out
    rows = _comparison(tmp_path / "again")
    for label in ("dls", "bounded_lm"):  # iteration budgets: the same rows, the same share solved
        assert rows[label]["old_solved"] == rows[label]["new_solved"]
        assert rows[label]["verdict"] in ("same within the intervals", "faster")
    assert "No regression." in (tmp_path / "again" / "report.md").read_text()


def test_a_slower_method_fails_the_time_rule(old_run, tmp_path, capsys):
    wbik.register("sleepy_dls", SleepyDLS, "test only")
    study = _study(tmp_path, STRONG, "slow").read_text()
    study = study.replace("  - dls\n", "  - {label: dls, method: sleepy_dls}\n")
    (tmp_path / "slow.yaml").write_text(study.replace("time_rise: 3", "time_rise: 1.2"))
    assert _run(tmp_path / "slow.yaml", tmp_path / "slow", "--compare-to", str(old_run)) == 1
    line = next(line for line in capsys.readouterr().out.splitlines() if "/ dls:" in line)
    assert "REGRESSION: median time rose beyond x1.2" in line
    assert _comparison(tmp_path / "slow")["dls"]["success_regressed"] == "0"


def test_compare_to_a_folder_without_a_run_is_a_usage_error(tmp_path, capsys):
    assert _run(_study(tmp_path, STRONG, "strong"), tmp_path / "out", "--compare-to", str(tmp_path)) == 2
    assert "holds no results of a study" in capsys.readouterr().err


def _figures(percent_low, percent, percent_high, median_low, median, median_high) -> RunFigures:
    return RunFigures(100, int(percent), percent, percent_low, percent_high, median, median_low, median_high)


def test_the_rule_exactly():
    old = _figures(90, 94, 97, 1.0, 1.1, 1.2)
    rule = RegressionRule()  # success_drop: ci, time_rise: 1.2
    assert not judge("c", "m", old, _figures(86, 91, 95, 1.0, 1.1, 1.2), rule).regressed  # intervals overlap
    assert judge("c", "m", old, _figures(80, 85, 89.9, 1.0, 1.1, 1.2), rule).success_regressed
    assert not judge("c", "m", old, _figures(90, 94, 97, 1.44, 1.5, 1.6), rule).regressed  # 1.44 = 1.2 x 1.2
    assert judge("c", "m", old, _figures(90, 94, 97, 1.45, 1.5, 1.6), rule).time_regressed
    points = RegressionRule(success_drop=2.0, time_rise=None)
    assert judge("c", "m", old, _figures(86, 91.9, 95, 9, 9, 9), points).success_regressed  # 94 - 2 > 91.9
    assert not judge("c", "m", old, _figures(86, 92.0, 95, 9, 9, 9), points).regressed  # times not gated
    assert not judge("c", "m", None, old, rule).regressed


@pytest.mark.parametrize(("block", "message"), [
    ({"success_drop": "lots"}, "success_drop must be 'ci'"),
    ({"time_rise": 0.5}, "time_rise must be a factor >= 1"),
    ({"time_ris": 2}, "did you mean 'time_rise'"),
    ("strict", "regression must be a mapping {success_drop: ci, time_rise: 1.2}"),
])
def test_the_regression_block_is_checked(block, message):
    with pytest.raises(StudyDefinitionError, match=message.replace("(", r"\(").replace("{", r"\{")):
        study_from_dict({"robot": "ur5", "chain": "arm", "methods": ["dls"], "regression": block})


def test_the_regression_block_reads_and_leaves_the_fingerprint_alone():
    plain = study_from_dict({"robot": "ur5", "chain": "arm", "methods": ["dls"]})
    ruled = study_from_dict({"robot": "ur5", "chain": "arm", "methods": ["dls"],
                             "regression": {"success_drop": 1, "time_rise": "off"},
                             "budget_curves": {"poses": 50}})
    assert plain.regression == RegressionRule("ci", 1.2)
    assert ruled.regression == RegressionRule(1.0, None)
    assert ruled.budget_curves.poses == 50
    assert plain.fingerprint() == ruled.fingerprint()
