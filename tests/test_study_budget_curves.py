"""Success versus budget, and budgets of methods with threads of their own: the curves are re-runs at
each budget (at the study's own budget they reproduce the study's rows of a seeded method), resume
like chunks, and appear in the report; a threaded method's CPU is judged against wall x threads and
its tasks get a core per thread."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from wbik.cli import main
from wbik.study import cpu_watch
from wbik.study.results import read_raw_csv
from wbik.study.runner import phases

STUDY = """
name: curves
robot: ur5
chain: arm
poses: 24
seed: 7
chunk_size: 12
timeout_s: 0.005
baseline: analytic
budget_curves: {poses: 10, budgets_ms: [0.2, 1, 5]}
methods: [analytic, bounded_lm, kdl]
"""


def _run(folder: Path, text: str = STUDY) -> Path:
    (folder / "curves.yaml").write_text(text)
    assert main(["study", str(folder / "curves.yaml"), "-o", str(folder / "out"), "--backend", "sequential",
                 "--no-progress"]) == 0
    return folder / "out"


def _curves(output: Path) -> dict[tuple[str, float], dict]:
    with open(output / "ur5_arm_pose" / "budget_curves.csv", newline="") as handle:
        return {(row["method"], float(row["budget_ms"])): row for row in csv.DictReader(handle)}


def test_budget_curves_are_re_runs_that_reproduce_the_study_at_its_own_budget(tmp_path):
    output = _run(tmp_path)
    curves = _curves(output)
    assert {key[0] for key in curves} == {"analytic", "bounded_lm", "kdl"}
    assert sorted({key[1] for key in curves}) == [0.2, 1.0, 5.0]
    rows = read_raw_csv(output / "ur5_arm_pose" / "raw.csv")
    # bounded_lm at 5 ms = the study's budget, the seed of its first chunk: the study's rows exactly
    first = rows["bounded_lm"]["success"][:10]
    assert int(curves["bounded_lm", 5.0]["solved"]) == int(first.sum())
    saved = np.load(output / "ur5_arm_pose" / "budget_curves" / "bounded_lm" / "budget_02.npz")
    assert np.array_equal(saved["success"], first)
    assert np.array_equal(saved["iterations"], rows["bounded_lm"]["iterations"][:10])
    # fewer iterations solve fewer poses; a closed form is flat, from its rows
    assert int(curves["bounded_lm", 0.2]["solved"]) <= int(curves["bounded_lm", 5.0]["solved"])
    assert {curves["analytic", b]["unbudgeted"] for b in (0.2, 1.0, 5.0)} == {"1"}
    assert not (output / "ur5_arm_pose" / "budget_curves" / "analytic").exists()
    for (_, _), row in curves.items():
        assert float(row["percent_solved_ci_low"]) <= float(row["percent_solved"]) <= \
            float(row["percent_solved_ci_high"])
    report = (output / "report.md").read_text()
    assert "### Success versus budget" in report and "figures/budget.png" in report
    assert "| bounded_lm | iterations |" in report and "| kdl | wall |" in report
    html = (output / "report.html").read_text()
    # 6 figures of every case + the budget curves + the throughput of the batched methods
    assert html.count("data:image/png;base64,") == 8
    assert "batch_success" not in saved  # a curve's rows are per-call solves only

    # resumed: nothing recomputed; a changed grid recomputes the curves only
    stamp = (output / "ur5_arm_pose" / "budget_curves" / "kdl" / "budget_00.npz").stat().st_mtime_ns
    _run(tmp_path)
    run = json.loads((output / "run.json").read_text())
    assert run["computed_tasks"] == 0 and run["budget_curve_tasks"] == 0
    assert (output / "ur5_arm_pose" / "budget_curves" / "kdl" / "budget_00.npz").stat().st_mtime_ns == stamp
    _run(tmp_path, STUDY.replace("[0.2, 1, 5]", "[0.5, 5]"))
    run = json.loads((output / "run.json").read_text())
    assert run["computed_tasks"] == 0 and run["budget_curve_tasks"] == 4  # 2 methods x 2 budgets
    assert sorted({key[1] for key in _curves(output)}) == [0.5, 5.0]


def test_no_curves_unless_the_study_asks(tmp_path):
    output = _run(tmp_path, STUDY.replace("budget_curves: {poses: 10, budgets_ms: [0.2, 1, 5]}\n", "")
                  .replace("poses: 24", "poses: 12"))
    assert not (output / "ur5_arm_pose" / "budget_curves").exists()
    assert "Success versus budget" not in (output / "report.md").read_text()


# -- threads -----------------------------------------------------------------------------------
def test_trac_ik_keeps_two_threads_busy_and_gets_a_core_for_each():
    assert cpu_watch.threads_of("trac_ik") == 2
    assert cpu_watch.threads_of("kdl") == 1 and cpu_watch.threads_of("not_a_chain_method") == 1
    assert cpu_watch.method_threads("x", type("Declared", (), {"threads": 3})) == 3
    assert cpu_watch.workers_for(2, jobs=2, cores=2) == 1
    assert cpu_watch.workers_for(1, jobs=2, cores=2) == 2
    assert cpu_watch.workers_for(2, jobs=4, cores=8) == 4
    assert cpu_watch.workers_for(4, jobs=2, cores=2) == 1
    tasks = [SimpleNamespace(method=m) for m in ("kdl", "trac_ik", "dls", "trac_ik")]
    grouped = phases(tasks, jobs=2, backend="loky", cores=2)
    assert [(workers, [t.method for t in group]) for workers, group in grouped] == [
        (2, ["kdl", "dls"]), (1, ["trac_ik", "trac_ik"])]
    assert [workers for workers, _ in phases(tasks, jobs=2, backend="dask", cores=2)] == [2]


def test_a_threaded_solve_is_starved_below_threads_x_wall(monkeypatch):
    """A 4 ms solve given 5 ms of CPU: fine for one thread, starved for two (5 < 0.8 x 2 x 4); the
    re-run's budget is stretched by threads x wall / CPU = 1.6."""
    assert not cpu_watch.starved(0.004, 0.005, threads=1)
    assert cpu_watch.starved(0.004, 0.005, threads=2)
    assert not cpu_watch.starved(0.0005, 0.0, threads=2)  # too short to judge

    clock = iter([0.0, 0.005, 1.0, 1.0075])  # process_time around each solve: 5 ms, then 7.5 ms of CPU
    monkeypatch.setattr(cpu_watch.time, "process_time", lambda: next(clock))
    budgets = []

    class Solver:
        name = "trac_ik"

        def solve(self, target, q0):
            return SimpleNamespace(time_s=0.004)

    def rebuild(budget):
        budgets.append(budget)
        return Solver()

    answer, cpu, reruns = cpu_watch.solve_watching_the_cpu(Solver(), None, None, 0.005, rebuild)
    assert reruns == 1 and budgets == [pytest.approx(0.005 * 1.6)] and cpu == pytest.approx(0.0075)
