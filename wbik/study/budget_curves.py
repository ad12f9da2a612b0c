"""Success versus budget: each method solved again on a sample of a case's targets at a grid of
budgets (``budget_curves:`` in the study file, :class:`wbik.study.definition.BudgetCurveSpec`).

Why re-runs, and not the full run's rows cut at a smaller budget: for that, a method's answer at
budget B would have to be its full-budget run stopped at B. For a wall-clock method (KDL, TRAC-IK,
PlaCo) nothing in a row says what it had found by then. For our iteration-budgeted ones it almost
holds but not exactly: ``bounded_lm``'s vectorised batch phase counts 10 budget units per batch
iteration but records 1 iteration, a budget that ends inside an attempt still checks that
attempt's last step, and its ``solve_many`` re-solves a row whose budget ran out from scratch.
A re-run and the cut rows do differ on a few poses at small budgets, for ``bounded_lm``, ``dls``
and ``newton`` alike (the measurements: docs/measurements.md, budget_curves). So every budgeted method
is re-run, on the same sample (the case's first ``poses`` targets) at every budget of the grid; a
closed form (no budget) answers the same at any budget, and its curve is its rows' success on that
sample.

Budgets. The curve's budget replaces the method's in the study file (``timeout_s``, and
``max_iterations`` in its options): our iteration-budgeted methods get the iterations that cost
that long on the reference machine (so the curve is in CPU work, the same on any machine),
wall-clock methods the wall budget, watched for CPU starvation as in the study's own rows
(:mod:`wbik.study.cpu_watch`, threads counted). Each (case, method, budget) is one task solved in
the study's workers, written to ``<case>/budget_curves/<method>/budget_NN.npz`` (the usual raw
rows), and resumed like the study's chunks; ``budget.json`` beside them records what they were
computed with (a changed method or grid recomputes that method's curve only). Seeds: every budget
of a method uses the seed of the study's first chunk of that method, so a seeded method's curve
differs between budgets by the budget alone.

The case's ``budget_curves.csv`` holds a row per (method, budget): poses, solved, % solved with its
Wilson 95 % interval, the median time of all calls and the CPU-starved re-runs.
"""

from __future__ import annotations

import csv
import io
import math
import shutil
from dataclasses import dataclass
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

import wbik.study.results as store
from wbik.study.case_kinds import case_kind
from wbik.study.sampling import PoseSet
from wbik.study.statistics import wilson_interval

if TYPE_CHECKING:
    from wbik.study.case_kinds import ChunkTask
    from wbik.study.spec import CaseSpec
    from wbik.study.spec import MethodSpec
    from wbik.study.spec import Study

FOLDER = "budget_curves"
RECORD = "budget.json"


@dataclass(frozen=True)
class BudgetCurve:
    """One method's success at each budget of the grid, on the case's first ``poses`` targets."""

    label: str
    budgets_ms: np.ndarray
    poses: int
    solved: np.ndarray  # poses solved at each budget
    median_time_ms: np.ndarray  # median time of all calls at each budget
    reruns: np.ndarray  # CPU-starved solves run again at each budget
    unbudgeted: bool = False  # a closed form: the same answer at every budget

    @property
    def percent(self) -> np.ndarray:
        return 100.0 * self.solved / self.poses

    def interval(self) -> tuple[np.ndarray, np.ndarray]:
        """Wilson 95 % interval of the % solved at each budget: (low, high)."""
        bounds = np.array([wilson_interval(int(k), self.poses) for k in self.solved]).reshape(-1, 2)
        return 100.0 * bounds[:, 0], 100.0 * bounds[:, 1]


def curve_poses(study: Study, case: CaseSpec) -> int:
    """How many targets of ``case`` the curves are measured on (0: none)."""
    return min(study.budget_curves.poses, study.poses_of(case))


def budget_path(output: Path, case_name: str, label: str, index: int) -> Path:
    """The rows of method ``label`` at the ``index``-th budget of the grid."""
    return store.case_dir(output, case_name) / FOLDER / label / f"budget_{index:02d}.npz"


def curve_method(method: MethodSpec, budget_ms: float) -> MethodSpec:
    """``method`` with the budget ``budget_ms`` instead of its own (its ``max_iterations`` dropped)."""
    options = {key: value for key, value in method.options.items() if key != "max_iterations"}
    return replace(method, timeout_s=budget_ms / 1e3, options=options)


def _record(study: Study, method: MethodSpec, poses: int) -> dict:
    return {"fingerprint": study.method_fingerprint(method), "poses": poses,
            "budgets_ms": list(study.budget_curves.budgets_ms)}


def budget_tasks(study: Study, output: Path, log=print) -> tuple[list[ChunkTask], int, int]:
    """(tasks still to run, rows already done, rows in total) of the study's budget curves. A task
    is the kind's chunk task of the case's first targets for the method at one budget; its
    ``chunk`` is the budget's index in the grid (its seed that of the method's first chunk).
    Methods not applicable to a case, closed forms, and cases of a kind that says ``budget_curves =
    False`` (its inputs are no targets a budget applies to) get none."""
    tasks: list[ChunkTask] = []
    done = total = 0
    for case in study.cases:
        count = curve_poses(study, case)
        directory = store.case_dir(output, case.name)
        takes_curves = getattr(case_kind(case), "budget_curves", True)
        if count == 0 or not takes_curves or not (directory / "poses.npz").is_file():
            continue
        poses = PoseSet.load(directory / "poses.npz")
        refused = store.read_json(directory / "not_applicable.json", {}) or {}
        kind = case_kind(case)
        for method in study.methods:
            if method.label in refused or kind.unbudgeted(method.method):
                continue
            folder = directory / FOLDER / method.label
            record = _record(study, method, count)
            if store.read_json(folder / RECORD) not in (None, record):
                log(f"  {case.name}: {method.label} changed since its budget curve was computed; "
                    "recomputing it")
                shutil.rmtree(folder)
            store.write_json(folder / RECORD, record)
            for index, budget_ms in enumerate(study.budget_curves.budgets_ms):
                total += count
                if budget_path(output, case.name, method.label, index).is_file():
                    done += count
                    continue
                task = kind.task(study, case, curve_method(method, budget_ms), poses, 0, 0, count)
                tasks.append(replace(task, chunk=index, batch=False))
    return tasks, done, total


def read_curves(study: Study, case: CaseSpec, output: Path, rows_by_method: dict) -> dict[str, BudgetCurve]:
    """The curves of ``case``'s methods whose every budget is on disk (a closed form's from its
    rows), in the order of ``rows_by_method``; written to the case's ``budget_curves.csv``."""
    count = curve_poses(study, case)
    if count == 0 or not getattr(case_kind(case), "budget_curves", True):
        return {}
    budgets = np.array(study.budget_curves.budgets_ms, dtype=float)
    kind = case_kind(case)
    curves: dict[str, BudgetCurve] = {}
    for label, rows in rows_by_method.items():
        method = study.method(label)
        if kind.unbudgeted(method.method):
            success = rows["success"][:count].astype(bool)
            time_ms = float(np.nanmedian(rows["time_s"][:count] * 1e3))
            curves[label] = BudgetCurve(label, budgets, count, np.full(budgets.size, int(success.sum())),
                                        np.full(budgets.size, time_ms), np.zeros(budgets.size, dtype=int),
                                        unbudgeted=True)
            continue
        record = store.read_json(store.case_dir(output, case.name) / FOLDER / label / RECORD)
        if record != _record(study, method, count):
            continue
        paths = [budget_path(output, case.name, label, index) for index in range(budgets.size)]
        if not all(path.is_file() for path in paths):
            continue
        parts = [store.read_chunk(path) for path in paths]
        curves[label] = BudgetCurve(
            label, budgets, count, np.array([int(np.sum(part["success"])) for part in parts]),
            np.array([float(np.nanmedian(part["time_s"] * 1e3)) if np.isfinite(part["time_s"]).any()
                      else math.nan for part in parts]),
            np.array([int(np.sum(part["reruns"] > 0)) if "reruns" in part else 0 for part in parts]))
    _write_csv(store.case_dir(output, case.name) / "budget_curves.csv", curves)
    return curves


def _write_csv(path: Path, curves: dict[str, BudgetCurve]) -> None:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["method", "budget_ms", "poses", "solved", "percent_solved", "percent_solved_ci_low",
                     "percent_solved_ci_high", "time_all_median_ms", "rerun", "unbudgeted"])
    for label, curve in curves.items():
        low, high = curve.interval()
        for i, budget in enumerate(curve.budgets_ms):
            writer.writerow([label, repr(float(budget)), curve.poses, int(curve.solved[i]),
                             repr(float(curve.percent[i])), repr(float(low[i])), repr(float(high[i])),
                             repr(float(curve.median_time_ms[i])), int(curve.reruns[i]),
                             int(curve.unbudgeted)])
    store.atomic_write_text(path, buffer.getvalue())
