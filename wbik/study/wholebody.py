"""Whole-body cases, the case kind ``wholebody`` (``scenario: <sampler>``): the cases of a sampler of
:mod:`wbik.wholebody.cases` (a worker rebuilds each from sampler, seed and index), solved by
``wbik.solver(method, robot).solve(problem, q0)``."""

from __future__ import annotations

import math
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import wbik.study.results as store
from wbik.errors import UnknownChainError, UnsupportedError
from wbik.schema import Context, Key, Text, join
from wbik.solvers.method_registry import budget_options
from wbik.solvers.method_registry import solver as registered_solver
from wbik.solvers.result import Tolerances
from wbik.study.blocks import (
    INTERVALS_TEXT,
    SOLVED_COLUMNS,
    TIME_COLUMNS,
    Block,
    budget_blocks,
    case_analysis,
    case_rows,
    image_blocks,
    reason_blocks,
    significance_blocks,
    status_blocks,
    summary_table,
    time_columns,
)
from wbik.study.case_kinds import CaseKind, ChunkTask, RegisteredMethods
from wbik.study.context import _frozen, _robot
from wbik.study.metrics import AngleConvention
from wbik.study.sampling import PoseSet
from wbik.study.spec import CaseSpec, MethodSpec, Study
from wbik.study.statistics import finite_statistic, mann_whitney_row
from wbik.study.statistics import summarize as base_summary
from wbik.wholebody.cases import CASE_REGISTRY, CaseSampler, register_sampler, sample_case

WHOLEBODY = "wholebody"
ROW_COLUMNS = ("pose", "method", "success", "reason", "time_s", "iterations", "task_error",
               "task_position_error", "task_rotation_error", "contact_drift", "com_margin", "limit_excess",
               "collision_clearance", "unsupported")
"""The columns of a whole-body row in raw.csv (then q); a chunk's rows hold ``ROW_COLUMNS[2:]``."""
COLUMN_TYPES = {"success": bool, "reason": str, "iterations": int, "unsupported": str}
"""The types of a chunk's columns that are not floats."""
ERROR_AXES = ("task", "contact")
"""The error axes of a whole-body row (``err_task``, ``err_contact``)."""
FLOAT_ROWS = 7
"""The float columns from ``task_error`` to ``collision_clearance``."""


@dataclass(frozen=True)
class WholeBodyChunkTask(ChunkTask):
    """A chunk of whole-body cases: the sampler and the study seed rebuild them in the worker."""

    scenario: str
    scenario_seed: int


class WholeBodyCases(RegisteredMethods, CaseKind):
    """Whole-body problems drawn by a case sampler (the case's ``scenario:``)."""

    name = WHOLEBODY
    target = WHOLEBODY
    entry_keys = ("scenario",)
    study_note = ("Whole-body cases: every method runs a loop of ours (our QP, a peer's single QP step "
                  "iterated by our loop, or a method's own iteration), budgeted in iterations: the study's "
                  "time budget / the method's cost per iteration (problem_iteration_cost_s, "
                  "wbik.solvers.base.IterationBudget), no wall clock; the rows are the same on any machine "
                  "(times aside).")

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    # -- the study file ----------------------------------------------------------------------------
    def entry_schema(self) -> dict[str, Key]:
        samplers = Text(lambda: tuple(CASE_REGISTRY.entries()))
        return {"scenario": Key(samplers, required=True, doc="the whole-body case sampler")}

    def entry(self, item: dict, path: str, ctx: Context) -> dict:
        """A whole-body case entry with its robot and name filled from the sampler."""
        scenario = item["scenario"]
        robot = CASE_REGISTRY.entries()[scenario].robot
        if item.get("robot", robot) != robot:
            ctx.fail(path, f"sampler {scenario!r} is on robot {robot!r}, not {item['robot']!r} (leave "
                           "robot: out)")
        for key in ("chain", "robot_params", "reference", "base", "tip"):
            if item.get(key):
                ctx.says(join(path, key), "does not apply to a whole-body case")
        return {**item, "target": WHOLEBODY, "robot": robot, "name": item.get("name", scenario)}

    def code_roots(self, case: CaseSpec) -> list:
        """The case's sampler."""
        return [CASE_REGISTRY.get(case.scenario).sample]

    def axes(self, angles: AngleConvention | None = None) -> list[str]:
        return list(ERROR_AXES)

    # -- sampling and tasks ------------------------------------------------------------------------
    def sample(self, study: Study, case: CaseSpec) -> PoseSet:
        """The case's whole-body cases as a PoseSet (anchor points as positions, no rotations)."""
        cases = [sample_case(case.scenario, study.seed, index) for index in range(study.poses_of(case))]
        nq = cases[0].q0.size
        q_true = np.array([np.full(nq, np.nan) if c.q_true is None else c.q_true for c in cases])
        return PoseSet(q_true, np.array([c.anchor for c in cases]), None, np.array([c.q0 for c in cases]))

    def budget(self, method: str, timeout_s: float, options: dict) -> tuple[float | None, dict]:
        return budget_options(method, timeout_s, options, problem=True)

    def task(self, study: Study, case: CaseSpec, method: MethodSpec, poses: PoseSet, chunk: int,
             start: int, stop: int) -> WholeBodyChunkTask:
        return WholeBodyChunkTask(**self.chunk_fields(study, case, method, poses, chunk, start, stop),
                                  scenario=case.scenario, scenario_seed=study.seed)

    def run_time_entries(self, case: CaseSpec, method: str) -> tuple:
        """The case's sampler and the method, those user code registered at run time."""
        sampler = CASE_REGISTRY.added_at_run_time(case.scenario)
        return (*(() if sampler is None else (sampler,)), *super().run_time_entries(case, method))

    def register_entries(self, entries: tuple) -> None:
        super().register_entries(tuple(entry for entry in entries if not isinstance(entry, CaseSampler)))
        for sampler in (entry for entry in entries if isinstance(entry, CaseSampler)):
            register_sampler(sampler, replace=True)

    # -- in the worker -----------------------------------------------------------------------------
    def build(self, task: WholeBodyChunkTask):
        """The method's solver on the robot (UnsupportedError: a chain method given no chain)."""
        try:
            return registered_solver(task.method, _robot(task.robot, task.robot_params),
                                     tolerances=Tolerances(*task.tolerances), timeout_s=task.timeout_s,
                                     seed=task.seed, **dict(task.options))
        except UnknownChainError as exc:
            raise UnsupportedError(f"method {task.method!r} solves chain targets and the case names no "
                                   f"chain: {exc}") from None

    def refusal(self, task: WholeBodyChunkTask, solver) -> str | None:
        """The method's own reason it cannot express the case's first problem."""
        case = sample_case(task.scenario, task.scenario_seed, task.first_pose)
        return solver.cannot_express(case.problem, task.q0[0])

    def solve(self, task: WholeBodyChunkTask) -> dict[str, np.ndarray]:
        """One whole-body chunk's rows; a case the method raises on is unsolved, its reason the raise."""
        nq = _robot(task.robot, task.robot_params).model.nq
        solver = self.build(task)
        rows, q_rows = [], []
        for offset in range(task.count):
            case = sample_case(task.scenario, task.scenario_seed, task.first_pose + offset)
            try:
                answer = solver.solve(case.problem, task.q0[offset])
            except Exception as exc:  # noqa: BLE001 - recorded in the row, counted in the report
                detail = "".join(traceback.format_exception_only(type(exc), exc)).strip()
                values = (False, f"raised {detail}", math.nan, 0, *([math.nan] * FLOAT_ROWS), "")
                answer = None
            else:
                joints = answer.q is not None
                values = (answer.success, answer.reason, answer.time_s, answer.iterations, answer.task_error,
                          max(answer.task_position_errors.values(), default=0.0) if joints else math.nan,
                          max(answer.task_rotation_errors.values(), default=0.0) if joints else math.nan,
                          answer.contact_drift, answer.com_margin, answer.limit_excess,
                          answer.collision_clearance, "; ".join(answer.unsupported))
            q_rows.append(np.full(nq, np.nan) if answer is None or answer.q is None else answer.q)
            rows.append(values)
        columns = {"pose": np.arange(task.first_pose, task.first_pose + task.count),
                   **{key: np.array(values, dtype=COLUMN_TYPES.get(key, float))
                      for key, values in zip(ROW_COLUMNS[2:], zip(*rows, strict=True), strict=True)}}
        columns.update(cpu_s=np.full(task.count, np.nan), reruns=np.zeros(task.count, dtype=int),
                       err_task=columns["task_error"], err_contact=columns["contact_drift"],
                       q=np.array(q_rows, dtype=float).reshape(task.count, nq))
        return columns

    # -- the report --------------------------------------------------------------------------------
    def analyse(self, study: Study, case: CaseSpec, output: Path) -> dict:
        """raw.csv, summary.csv, significance.csv and figures of one whole-body case; the numbers."""
        rows_by_method, not_applicable = case_rows(study, case, output)
        robot = _robot(case.robot, _frozen(case.robot_params))
        model = robot.model
        joint_names = [model.names[j] for j in range(1, model.njoints) for _ in range(model.joints[j].nq)]
        if robot.has_floating_base:
            joint_names = ["base_x", "base_y", "base_z", "base_qx", "base_qy", "base_qz", "base_qw",
                           *joint_names[7:]]
        directory = store.case_dir(output, case.name)
        store.write_csv(directory / "raw.csv", [*ROW_COLUMNS, *(f"q_{name}" for name in joint_names)],
                        (row for label, rows in rows_by_method.items()
                         for row in store.method_csv_rows(label, rows, ROW_COLUMNS[2:])))
        margin = sample_case(case.scenario, study.seed, 0).problem.margin
        summaries = {label: summarize(rows, margin) for label, rows in rows_by_method.items()}
        title = f"{case.robot} {case.scenario}"
        analysis = case_analysis(self, study, case, output, rows_by_method, not_applicable, summaries, title,
                                 self.axes(), more_tests=lambda label: com_margin_test(label, rows_by_method))
        if study.figures and any(np.isfinite(rows["com_margin"]).any() for rows in rows_by_method.values()):
            analysis["images"]["com_margin"] = com_margin_boxplots(rows_by_method, margin, title,
                                                                   directory / "figures" / "com_margin.png")
        return {**analysis, "margin": margin, "robot": robot}

    def blocks(self, study: Study, analysis: dict) -> list[Block]:
        case = analysis["case"]
        summaries, rows_by_method = analysis["summaries"], analysis["rows"]
        margin, tolerances = analysis["margin"], study.tolerances
        blocks = [
            Block("h2", f"Case {case.name}: {case.robot}, whole body ({case.scenario})"),
            Block("p", f"{study.poses_of(case)} whole-body cases from the sampler {case.scenario} (seed "
                       f"{study.seed}): {CASE_REGISTRY.get(case.scenario).description}. Every answer is "
                       "judged by the shared whole-body check (wbik.solvers.check.check_problem): goal task "
                       f"errors and contact drift by FK within {tolerances['position']:g} m / "
                       f"{tolerances['rotation']:g} rad, the CoM margin in the support soles' polygon at the "
                       "answer, joint limits."),
            *status_blocks(study, analysis),
        ]
        if not summaries:
            return blocks
        marked = {label: s["unsupported"] for label, s in summaries.items() if s["unsupported"]}
        blocks.append(Block("h3", "Cases solved, task error, contact drift, CoM margin"))
        blocks.append(summary_table(summaries, [
            *SOLVED_COLUMNS,
            ("median task error (all calls)", "task_error_all_median"),
            ("median task error (solved)", "task_error_solved_median"),
            ("max task error (solved)", "task_error_solved_max"),
            ("max contact drift (all calls)", "contact_drift_all_max"),
            ("max contact drift (solved)", "contact_drift_solved_max"),
            ("median CoM margin mm (all calls)", lambda s: s["com_margin_all_median"] * 1e3),
            ("min CoM margin mm (all calls)", lambda s: s["com_margin_all_min"] * 1e3),
            (f"% calls with CoM margin >= {margin * 1e3:g} mm", "percent_com_margin_kept_all"),
            ("max limit excess (all calls)", "limit_excess_all_max"),
            ("solved without", _solved_without),
        ]))
        blocks.append(Block("p", "Task error: the largest over the goal tasks of a task's larger position "
                                 "(m) or rotation (rad) error; contact drift in m or rad; CoM margin: the "
                                 "distance of the CoM's ground projection inside the support polygon "
                                 "(negative outside; '-' without one). 'All calls' counts every case, "
                                 "'solved' those the shared check passed. " + INTERVALS_TEXT))
        if marked:
            blocks.append(Block("p", "What each method could not express (it solved the problem without it; "
                                     "the check still judges everything):"))
            blocks.append(Block("list", items=[f"{label}: {text}" for label, text in marked.items()]))
        blocks.append(Block("h3", "Time"))
        blocks.append(summary_table(summaries, [
            *TIME_COLUMNS,
            *time_columns("unsolved", "median", "max"),
            ("median iterations (all calls)", "iterations_median"),
            ("exceptions", "raised"),
        ]))
        blocks.extend(reason_blocks(rows_by_method, "Most frequent reasons for 'not solved' (as the methods "
                                    "and the check gave them; causes are not measured here):", "cases"))
        blocks.extend(image_blocks(analysis["images"], {
            "solved": "Cases solved per method", "errors": "Task error and contact drift (solved)",
            "error_histograms": "Distribution of task error and contact drift (solved)",
            "com_margin": "CoM margin per method (all calls)", "time": "Time per case",
            "time_histogram": "Histogram of time per case",
            "time_ecdf": "Time per call (ECDF): calls returned and cases solved within t"}))
        blocks.extend(budget_blocks(study, analysis))
        blocks.extend(significance_blocks(analysis, "task error and contact drift on the solved cases of "
                                                    "each method, time on every case, CoM margin on every "
                                                    "case"))
        return blocks


def summarize(rows: dict, margin: float) -> dict:
    """The usual summary (solved, times, err_task / err_contact over solved cases) plus the whole-body
    figures over all calls and over solved cases."""
    summary = base_summary(rows)
    success = rows["success"].astype(bool)

    for group, mask in (("all", np.ones(success.size, dtype=bool)), ("solved", success)):
        for key, statistics in (("task_error", ("median", "max")), ("contact_drift", ("median", "max")),
                                ("com_margin", ("median", "min")), ("limit_excess", ("max",))):
            for name in statistics:
                summary[f"{key}_{group}_{name}"] = finite_statistic(rows[key][mask], getattr(np, name))
    summary["percent_com_margin_kept_all"] = finite_statistic(
        rows["com_margin"], lambda margins: 100.0 * float(np.mean(margins >= margin - 1e-9)))
    summary["unsupported"] = "; ".join(sorted({str(u) for u in rows["unsupported"] if str(u)}))
    return summary


def com_margin_test(baseline: str, rows_by_method: dict) -> list[dict]:
    """Mann-Whitney U of the CoM margin (all calls) of each method against the baseline."""
    if baseline not in rows_by_method or not np.isfinite(rows_by_method[baseline]["com_margin"]).any():
        return []
    first = rows_by_method[baseline]["com_margin"]
    return [mann_whitney_row(label, baseline, "com_margin_all_calls", first, rows["com_margin"])
            for label, rows in rows_by_method.items() if label != baseline]


def com_margin_boxplots(rows_by_method: dict, margin: float, title: str, path: Path) -> Path:
    """Box plots of the CoM margin (mm, all calls) per method, the required margin as a line."""
    import matplotlib.pyplot as plt

    import wbik.study.figures as figures

    labels = list(rows_by_method)
    figure, axes = plt.subplots(figsize=(max(6.0, 1.1 * len(labels) + 2), 4.0))
    margins = [rows["com_margin"] * 1e3 for rows in rows_by_method.values()]
    figures.boxes(axes, [values[np.isfinite(values)] for values in margins])
    axes.axhline(margin * 1e3, color="tab:red", linestyle="--", linewidth=1,
                 label=f"required {margin * 1e3:g} mm")
    axes.set_xticks(np.arange(1, len(labels) + 1), labels, rotation=30, ha="right")
    axes.set_ylabel("CoM margin in the support polygon (mm)")
    axes.set_title(f"{title}: CoM margin by FK, all calls")
    axes.legend(fontsize=8)
    return figures.save(figure, path)


def _solved_without(summary: dict) -> str:
    """The 'solved without' cell: what the method could not express."""
    if "hard CoM constraint" in summary["unsupported"]:
        return "no hard polygon"
    return "see below" if summary["unsupported"] else "-"


CASE_KINDS = (WholeBodyCases(),)
