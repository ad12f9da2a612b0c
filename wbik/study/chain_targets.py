"""Chain targets, the study's case kinds ``pose`` and ``position``: FK of seeded random joints of one
chain inside the limits (:mod:`wbik.study.sampling`), each solved by one timed ``solve`` call (CPU watched
for wall-clock methods, :mod:`wbik.study.cpu_watch`), then by ``solve_many`` where a method has its own."""

from __future__ import annotations

import math
import time
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import wbik.study.results as store
from wbik.errors import InvalidSettingError, UnsupportedError, WbikError
from wbik.robot import Chain
from wbik.solvers.method_registry import budget_options
from wbik.study.blocks import (
    INTERVALS_TEXT,
    SOLVED_COLUMNS,
    TIME_COLUMNS,
    Block,
    budget_blocks,
    case_analysis,
    case_rows,
    fmt,
    fmt_p,
    image_blocks,
    reason_blocks,
    significance_blocks,
    status_blocks,
    summary_table,
    throughput_blocks,
    time_columns,
)
from wbik.study.case_kinds import CaseKind, ChunkTask, RegisteredMethods
from wbik.study.context import chain_of, make_solver
from wbik.study.cpu_watch import MAX_RERUNS, STARVED_CPU_SHARE, solve_watching_the_cpu
from wbik.study.metrics import STUDY_SEQUENCE, AngleConvention, axis_errors
from wbik.study.metrics import axes as case_axes
from wbik.study.reference import REFERENCE_METRICS, our_figures, same_significance, verdict
from wbik.study.sampling import PoseSet, poses_of_joints, sample_joints
from wbik.study.spec import CaseSpec, MethodSpec, Study
from wbik.study.statistics import ALPHA, BATCH_CALLS, summarize


@dataclass(frozen=True)
class ChainChunkTask(ChunkTask):
    """A chunk of chain targets."""

    chain: str | None
    angles: AngleConvention | None  # the reference's Euler angles: extra error columns
    positions: np.ndarray
    rotations: np.ndarray | None
    base: str | None = None  # a chain named by its base and tip frames (``chain`` is its name)
    tip: str | None = None


TARGETS = ("pose", "position")
"""What a chain solver can be given: full poses, or positions only."""


class ChainTargets(RegisteredMethods, CaseKind):
    """Targets of one chain, full poses (``target`` "pose") or positions only ("position")."""

    sampled_from = "FK of uniform random joints inside the limits"
    """How the targets were drawn, in the report's words."""
    methods_note = ("Budgets: methods whose loop is ours (bounded_lm, dls, newton, qp) get the study's time "
                    "budget as the iterations that cost that long on the reference machine, no wall clock: "
                    "their rows are the same on any machine and load. KDL, TRAC-IK and PlaCo are budgeted by "
                    "wall-clock time inside their libraries; TRAC-IK also restarts from random seeds of its "
                    "own, so its rows vary from run to run.")

    def __init__(self, name: str, target: str | None = None):
        self.name = name
        self.target = target or name
        if self.target not in TARGETS:
            raise InvalidSettingError(f"case kind {name!r}: target must be one of {', '.join(TARGETS)} "
                                      f"(what a chain solver is given), got {self.target!r}")

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, target={self.target!r})"

    def sampling_text(self, case: CaseSpec) -> str:
        """How the case's targets were drawn, in the report's words (a kind with parameters says them)."""
        return self.sampled_from

    # -- the study file ----------------------------------------------------------------------------
    def axes(self, angles: AngleConvention | None = None) -> list[str]:
        return case_axes(self.target, angles)

    # -- sampling and tasks ------------------------------------------------------------------------
    def joints(self, chain: Chain, count: int, seed: int) -> np.ndarray:
        """(count, n) joint vectors whose FK are the targets: uniform inside the chain's limits."""
        return sample_joints(chain, count, seed)

    def sample(self, study: Study, case: CaseSpec) -> PoseSet:
        chain = chain_of(case)
        q_true = self.joints(chain, study.poses_of(case), study.seed)
        return poses_of_joints(chain, q_true, study.seed, self.target, study.start)

    def budget(self, method: str, timeout_s: float, options: dict) -> tuple[float | None, dict]:
        return budget_options(method, timeout_s, options)

    def unbudgeted(self, method: str) -> bool:
        try:
            return getattr(self.method_factory(method), "budgeted", True) is False
        except WbikError:
            return False

    task_type: type[ChainChunkTask] = ChainChunkTask
    """The chunk task: a :class:`ChainChunkTask`, or a subclass whose own fields :meth:`task_fields` gives."""

    def task_fields(self, study: Study, case: CaseSpec) -> dict:
        """The fields ``task_type`` adds to those of a :class:`ChainChunkTask` (none here)."""
        return {}

    def task(self, study: Study, case: CaseSpec, method: MethodSpec, poses: PoseSet, chunk: int,
             start: int, stop: int) -> ChainChunkTask:
        return self.task_type(
            **self.chunk_fields(study, case, method, poses, chunk, start, stop), chain=case.chain,
            angles=case.reference.angles if case.reference else None, positions=poses.positions[start:stop],
            rotations=None if poses.rotations is None else poses.rotations[start:stop],
            base=case.base, tip=case.tip, **self.task_fields(study, case))

    # -- in the worker -----------------------------------------------------------------------------
    def build(self, task: ChainChunkTask, timeout_s: float | None = None):
        """The task's solver (``timeout_s``: another wall budget than the task's)."""
        return make_solver(task.robot, task.robot_params, task.chain, task.method, dict(task.options),
                           task.timeout_s if timeout_s is None else timeout_s, task.tolerances, task.seed,
                           task.base, task.tip)

    def refusal(self, task: ChainChunkTask, solver) -> str | None:
        """The solver's refusal of the case's target kind (its capability query ``check_target_kind``)."""
        try:
            solver.check_target_kind("position" if task.rotations is None else "pose")
        except UnsupportedError as exc:
            return str(exc)
        return None

    def solve_one(self, task: ChainChunkTask, solver, target, q0: np.ndarray) -> tuple:
        """(answer, CPU seconds (NaN: not measured), re-runs) of one timed ``solve`` call, a wall-clock
        method's with the CPU watched; a raise is an unsolved answer whose reason says what was raised."""
        try:
            if task.timeout_s is not None and solver.timeout_s is not None and solver.budgeted:
                return solve_watching_the_cpu(solver, target, q0, task.timeout_s,
                                              lambda budget: self.build(task, budget))
            return solver.solve(target, q0), math.nan, 0
        except Exception as exc:  # noqa: BLE001 - recorded in the row, counted in the report
            return _raised(solver, exc), math.nan, 0

    def solve(self, task: ChainChunkTask) -> dict[str, np.ndarray]:
        """One chunk's rows: one timed ``solve`` call per pose (:meth:`solve_one`)."""
        solver = self.build(task)
        count = task.count
        targets = _targets(task)
        answers, cpu, reruns = zip(*(self.solve_one(task, solver, target, q0)
                                     for target, q0 in zip(targets, task.q0, strict=True)), strict=True)
        nq = solver.chain.nq
        types = (bool, str, float, int, float, float)  # of ROW_FIELDS after "pose"
        columns = {"pose": np.arange(task.first_pose, task.first_pose + count),
                   **{key: np.array([getattr(a, key) for a in answers], dtype=dtype)
                      for key, dtype in zip(store.ROW_FIELDS[1:], types, strict=True)},
                   "cpu_s": np.array(cpu, dtype=float), "reruns": np.array(reruns, dtype=int)}
        columns.update(axis_errors(answers, task.rotations, task.angles))
        columns["q"] = np.array([np.full(nq, np.nan) if a.q is None else a.q for a in answers],
                                dtype=float).reshape(count, nq)
        return columns

    def throughput(self, task: ChainChunkTask, workers: int) -> dict[str, np.ndarray] | None:
        """With ``task.batch``, a batched path's ``solve_many`` over the case (:func:`batch_columns`); no
        columns for a method without one."""
        if not task.batch:
            return None
        solver = self.build(task)
        return batch_columns(solver, _batch(task), task.q0, workers) if has_batched_path(solver) else {}

    # -- the report --------------------------------------------------------------------------------
    def case_results(self, study: Study, case: CaseSpec, output: Path) -> tuple[Path, dict, dict, Chain]:
        """What the analysis of a case starts from: (its folder, {label: rows} of the methods with every
        chunk present, {label: not-applicable message}, its chain)."""
        return store.case_dir(output, case.name), *case_rows(study, case, output), chain_of(case)

    def analyse(self, study: Study, case: CaseSpec, output: Path) -> dict:
        directory, rows_by_method, not_applicable, chain = self.case_results(study, case, output)
        store.write_raw_csv(directory / "raw.csv", rows_by_method, chain.joint_names)
        summaries = {label: summarize(rows) for label, rows in rows_by_method.items()}
        angles = case.reference.angles if case.reference else None
        return {**case_analysis(self, study, case, output, rows_by_method, not_applicable, summaries,
                                f"{case.robot}.{chain.name} ({case.target})", self.axes(angles), angles),
                "chain": chain}

    def blocks(self, study: Study, analysis: dict) -> list[Block]:
        case: CaseSpec = analysis["case"]
        chain, summaries, rows_by_method = analysis["chain"], analysis["summaries"], analysis["rows"]
        blocks = [Block("h2", f"Case {case.name}: {case.robot}.{chain.name}, {case.target} targets"),
                  Block("p", f"{study.poses_of(case)} {case.target} targets from {self.sampling_text(case)} "
                             f"(seed {study.seed}); chain {chain.base_frame} -> "
                             f"{chain.tip_frame}, {chain.nq} joints ({', '.join(chain.joint_names)}); "
                             f"every method starts from q0 = {study.start}.")]
        blocks.extend(status_blocks(study, analysis))
        if not summaries:
            return blocks
        blocks.append(Block("h3", "Poses solved and time"))
        blocks.append(summary_table(summaries, [
            *SOLVED_COLUMNS,
            *TIME_COLUMNS,
            *time_columns("solved", "max"),
            *time_columns("unsolved", "median", "p95", "max", "mean"),
            ("median iterations", "iterations_median"),
            ("exceptions", "raised"),
            ("re-run (CPU starved)", lambda s: s.get("rerun", 0)),
            (f"re-run {MAX_RERUNS} times", lambda s: s.get("rerun_exhausted", 0)),
            ("CPU / wall (median)", lambda s: s.get("cpu_per_wall_median")),
        ]))
        blocks.append(Block("p", "Times are per call of the method alone; \"all calls\" counts every pose, "
                                 "\"solved\" and \"not solved\" split them by the shared FK check. "
                                 "\"Re-run\": wall-clock solves given less CPU time than "
                                 f"{STARVED_CPU_SHARE:g} x wall time (x the method's threads; "
                                 "wbik.study.cpu_watch), solved again with a stretched budget, at most "
                                 f"{MAX_RERUNS} times, the last answer kept; 'CPU / wall': the kept answers' "
                                 "median share of CPU. " + INTERVALS_TEXT))
        blocks.extend(reason_blocks(rows_by_method, "Most frequent reasons for 'not solved':", "poses"))
        blocks.extend(image_blocks(analysis["images"], {
            "solved": "Poses solved per method", "time": "Time per pose",
            "time_histogram": "Histogram of time per pose",
            "time_ecdf": "Time per call (ECDF): calls returned and poses solved within t"}))
        blocks.extend(throughput_blocks(study, analysis))
        blocks.extend(budget_blocks(study, analysis))
        blocks.append(Block("h3", "Error per axis (solved poses)"))
        blocks.append(Block("p", "Median |error| per axis, then the maximum. x, y, z in metres (reached - "
                                 "target, base axes); rot_* the rotation vector log3(R_target^T R_reached); "
                                 "alpha, beta, gamma the angles of R = Rz(gamma) Ry(beta) Rx(alpha)"
                                 + _reference_angles_text(case) + "; radians. Near beta = +-90 deg (gimbal "
                                 "lock) a tiny rotation can show as large, opposite alpha and gamma errors; "
                                 "the rotation vector has no such artefact."))
        axes = analysis["axes"]
        for statistic, title in (("abs_median", "median |e|"), ("abs_max", "max |e|"),
                                 ("zero_fraction", "fraction exactly 0")):
            table = [[f"{title}: {label}", *(fmt(summary.get(f"err_{axis}_{statistic}")) for axis in axes)]
                     for label, summary in summaries.items()]
            blocks.append(Block("table", header=["method", *axes], rows=table))
        blocks.extend(image_blocks(analysis["images"], {
            "errors": "Error per axis", "error_histograms": "Distribution of |error| per axis"}))
        blocks.extend(significance_blocks(analysis, "per axis on |e| of the solved poses of each method, "
                                                    "and on the time of every pose"))
        blocks.extend(_reference_blocks(case, summaries, analysis["tests"]))
        return blocks


def has_batched_path(solver) -> bool:
    """Whether ``solver`` has a batched path of its own (its class overrides ``Solver._solve_targets``)."""
    from wbik.solvers.base import Solver

    return type(solver)._solve_targets is not Solver._solve_targets


def _targets(task: ChainChunkTask) -> list:
    """The task's targets, as ``Target``s."""
    from wbik.targets import Target

    return [Target(task.positions[i], None if task.rotations is None else task.rotations[i])
            for i in range(task.count)]


def _batch(task: ChainChunkTask) -> np.ndarray:
    """The task's targets as one array, as ``solve_many`` takes a batch: (B, 4, 4) poses or (B, 3)
    positions (a forked part gets its rows of it, not pickled objects)."""
    if task.rotations is None:
        return np.array(task.positions, dtype=float)
    poses = np.zeros((task.count, 4, 4))
    poses[:, :3, :3], poses[:, :3, 3], poses[:, 3, 3] = task.rotations, task.positions, 1.0
    return poses


def batch_columns(solver, targets, q0: np.ndarray, workers: int) -> dict[str, np.ndarray]:
    """The targets solved again by ``solve_many``, in one process and over ``workers`` processes, each
    the best of :data:`BATCH_CALLS` calls over all of them after an untimed call on a few (which also forks
    the processes). Per pose: ``batch_success`` and ``batch_cores_success`` (the verdicts of each way),
    ``batch_share_s`` and ``batch_cores_share_s`` (the best call's wall time / the poses; NaN and
    unsolved where a call raised), ``batch_workers``."""
    count = len(targets)
    workers = min(workers, count)  # (solve_many splits a batch into at most one part per target)
    columns = {"batch_workers": np.full(count, workers)}
    for name, split in (("batch", 1), ("batch_cores", workers)):
        try:
            # untimed first: a first call's costs (imports, tables) and the fork of the processes
            solver.solve_many(targets[:2 * split], q0[:2 * split], workers=split)
            seconds = math.inf
            for _ in range(BATCH_CALLS):  # (a first call over the whole batch also pays for its memory)
                start = time.perf_counter()
                answers = solver.solve_many(targets, q0, workers=split)
                seconds = min(seconds, time.perf_counter() - start)
        except Exception:  # noqa: BLE001 - no throughput for this call; the per-call rows stand
            columns.update({f"{name}_success": np.zeros(count, dtype=bool),
                            f"{name}_share_s": np.full(count, np.nan)})
            continue
        columns.update({f"{name}_success": np.asarray(answers.success, dtype=bool),
                        f"{name}_share_s": np.full(count, seconds / count)})
    return columns


def _raised(solver, exc: BaseException):
    """The unsolved answer of a solve that raised ``exc``."""
    from wbik.solvers.check import no_joints
    from wbik.solvers.result import Candidate

    detail = "".join(traceback.format_exception_only(type(exc), exc)).strip()
    return no_joints(f"raised {detail}", math.nan, Candidate(None), solver.name)


def _reference_angles_text(case: CaseSpec) -> str:
    """Where the reference's angle columns come from, for the per-axis error paragraph."""
    angles = case.reference.angles if case.reference else None
    if not angles:
        return ""
    if angles.sequence == STUDY_SEQUENCE:
        return (f" (repeated under the {case.reference.name}'s names: "
                + ", ".join(f"{angles.study_angle(axis)} = {name}" for axis, name in angles.names) + ")")
    return f"; {', '.join(angles.columns)} the {case.reference.name}'s angles of {angles.describe()}"


def _reference_blocks(case: CaseSpec, summaries: dict, tests: list[dict]) -> list[Block]:
    """Our figures and p-values beside the reference's (the case's ``reference:`` block)."""
    reference = case.reference
    if reference is None:
        return []
    name = reference.name
    blocks = [Block("h3", f"Beside the {name}")]
    if reference.source:
        blocks.append(Block("p", f"{reference.title} figures from {reference.source}."))
    table = []
    for label, metrics in reference.figures.items():
        ours = our_figures(summaries[label]) if label in summaries else {}
        for metric, value in metrics.items():
            described = REFERENCE_METRICS[metric]
            our = ours.get(metric)
            unmeasured = label in summaries and (our is None or not math.isfinite(our))
            judged = "no such poses in our run" if unmeasured else verdict(metric, value, our)
            table.append([label, f"{described.description} ({described.unit})", fmt(value), fmt(our), judged])
    if table:
        blocks.append(Block("table", header=["method", "metric", name, "ours", "comparison"], rows=table))
    ours = {(t["method"], t["axis"]): t["p_value"] for t in tests}
    rows = [[label, axis, fmt_p(p_value), fmt_p(ours.get((label, axis))),
             same_significance(p_value, ours.get((label, axis)))]
            for label, axes in reference.significance.items() for axis, p_value in axes.items()]
    if rows:
        where = f" ({reference.significance_source})" if reference.significance_source else ""
        blocks.append(Block("p", f"Mann-Whitney p-values against the baseline, the {name}'s{where} "
                                 f"beside ours; 'same verdict' compares significance at {ALPHA:g}."))
        blocks.append(Block("table", header=["method", "axis", f"{name} p", "our p", "same verdict"],
                            rows=rows))
    if reference.notes:
        blocks.append(Block("p", "Where and why we differ: " + reference.notes.strip()))
    return blocks


CASE_KINDS = (ChainTargets("pose"), ChainTargets("position"))
