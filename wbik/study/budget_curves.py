"""Success versus budget (``budget_curves:``): each method solved again on a case's first ``poses``
targets at every budget of a grid, the budget replacing its own (a run cut short is not a run given a
smaller budget); each (case, method, budget) is a task resumed like a chunk."""

from __future__ import annotations

import math
import shutil
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

import wbik.study.results as store
from wbik.study.case_kinds import ChunkTask, case_kind
from wbik.study.sampling import PoseSet
from wbik.study.spec import CaseSpec, MethodSpec, Study
from wbik.study.statistics import wilson_interval

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
    """(tasks still to run, rows already done, rows in total) of the budget curves: a task per budget, its
    ``chunk`` the budget's index; none for closed forms, refused methods or kinds without curves."""
    tasks: list[ChunkTask] = []
    done = total = 0
    for case in study.cases:
        count, kind = curve_poses(study, case), case_kind(case)
        directory = store.case_dir(output, case.name)
        if count == 0 or not getattr(kind, "budget_curves", True) or not (directory / "poses.npz").is_file():
            continue
        poses = PoseSet.load(directory / "poses.npz")
        refused = store.read_json(directory / "not_applicable.json", {}) or {}
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
    """The curves of ``case``'s methods whose every budget is on disk (a closed form's from its rows), also
    written to the case's ``budget_curves.csv``."""
    count, kind = curve_poses(study, case), case_kind(case)
    if count == 0 or not getattr(kind, "budget_curves", True):
        return {}
    budgets = np.array(study.budget_curves.budgets_ms, dtype=float)
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
        paths = [budget_path(output, case.name, label, index) for index in range(budgets.size)]
        if record != _record(study, method, count) or not all(path.is_file() for path in paths):
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
    rows = []
    for label, curve in curves.items():
        count = len(curve.budgets_ms)
        columns = [[label] * count, curve.budgets_ms, [curve.poses] * count, curve.solved, curve.percent,
                   *curve.interval(), curve.median_time_ms, curve.reruns, [int(curve.unbudgeted)] * count]
        rows.extend(zip(*(store.csv_cells(column) for column in columns), strict=True))
    store.write_csv(path, ["method", "budget_ms", "poses", "solved", "percent_solved",
                           "percent_solved_ci_low", "percent_solved_ci_high", "time_all_median_ms", "rerun",
                           "unbudgeted"], rows)
