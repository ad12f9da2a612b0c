"""Why a QP solve did not succeed: what blocks the goal tasks at the answer, in words a user can act on.

With r(dq) = sum_g |e_g + J_g dq| the unmet goals' linearised error, the step's levels are solved with
every hard row (dq*) and without each group of active rows or each other task: r(dq*) - r(without it), the
``gain``, ranks ``blockers`` and ``tasks``; ``step_gain`` = sum_g |e_g| - r(dq*); ``stationary``: nothing
blocks, no step helps; ``infeasible``: the conflicting rows (:mod:`wbik.qp.elastic`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

import wbik.qp.backends as backends
from wbik.errors import NoQPSolutionError
from wbik.qp.constraint import StartViolation, StepBox
from wbik.qp.elastic import ConflictRow, conflict, describe_rows
from wbik.qp.hard_rows import HardRows, group_key, step_rows
from wbik.qp.rows import RowLabel
from wbik.qp.tasks import Task

__all__ = ["Blocker", "Diagnosis", "StartViolation", "TaskConflict", "diagnose", "report_lines"]

ACTIVE = 1e-7
"""A row is active when its multiplier exceeds this fraction of the largest one (and 1e-12)."""
SHOWN = 3
"""Blockers and conflicting tasks named in the summary (all are in the lists)."""


@dataclass(frozen=True)
class Blocker:
    """An active hard constraint that holds the goals back: its first row's label, rows, multiplier, gain."""

    label: RowLabel
    rows: int
    multiplier: float
    gain: float

    @property
    def text(self) -> str:
        return self.label.owner.blocker_text(self.label)

    def as_dict(self) -> dict:
        return {"kind": self.label.kind, **self.label.as_dict(), "rows": self.rows,
                "multiplier": self.multiplier, "gain": self.gain, "text": self.text}


@dataclass(frozen=True)
class TaskConflict:
    """A task that holds unmet goals back: without it one step would bring them ``gain`` closer."""

    task: str
    priority: int
    goal: bool
    gain: float
    holds_back: tuple[str, ...]
    advice: str

    @property
    def text(self) -> str:
        return f"task {self.task} (priority {self.priority}, {'goal' if self.goal else 'not a goal'})"

    def as_dict(self) -> dict:
        return {**asdict(self), "holds_back": list(self.holds_back), "text": self.text}


@dataclass
class Diagnosis:
    """What blocks progress at a failed answer (see the module docstring); ``as_dict`` for JSON."""

    goals: dict[str, float] = field(default_factory=dict)
    unit: str = ""
    step_gain: float = 0.0
    blockers: list[Blocker] = field(default_factory=list)
    tasks: list[TaskConflict] = field(default_factory=list)
    infeasible: list[ConflictRow] = field(default_factory=list)
    start: list[StartViolation] = field(default_factory=list)
    stationary: bool = False
    advice: list[str] = field(default_factory=list)

    def summary(self) -> str:
        """One line: the start, the conflicting rows, the blockers, the tasks in conflict, the advice."""
        parts = []
        for clipped in (True, False):
            if texts := [v.text for v in self.start if v.clipped == clipped]:
                parts.append(_start_text(", ".join(texts), clipped))
        if self.infeasible:
            parts.append("the hard constraints of the step conflict: " + describe_rows(self.infeasible))
        for title, items in (("blocked by", self.blockers), ("in conflict", self.tasks)):
            if items:
                parts.append(f"{title}: " + ", ".join(
                    f"{item.text} [{_amount(item.gain, self.unit)} per step]" for item in items[:SHOWN]))
        if self.advice:
            parts.append("to converge: " + "; ".join(self.advice[:2]))
        return "; ".join(parts)

    def as_dict(self) -> dict:
        return {"goals": dict(self.goals), "unit": self.unit, "step_gain": self.step_gain,
                "blockers": [b.as_dict() for b in self.blockers],
                "tasks": [t.as_dict() for t in self.tasks],
                "infeasible": [r.as_dict() for r in self.infeasible],
                "start": [s.as_dict() for s in self.start],
                "stationary": self.stationary, "advice": list(self.advice), "summary": self.summary()}

    def lines(self) -> list[str]:
        """The diagnosis as lines for a terminal (:func:`report_lines`)."""
        return report_lines(self.as_dict())

    def reason_with_summary(self, reason: str) -> str:
        """``reason`` with this diagnosis's summary at its end ("; " between them when both are given)."""
        text = self.summary()
        return f"{reason}; {text}" if reason and text else reason or text


def last_solve_diagnosis(local, success: bool, diagnose: bool, reason: str) -> tuple[Diagnosis | None, str]:
    """(diagnosis, reason) of the ``(problem, solution)`` left in ``local.last`` (cleared): a failed one,
    with ``diagnose``, is diagnosed and summarised in ``reason``; another keeps what its start broke."""
    if (last := getattr(local, "last", None)) is None:
        return None, reason
    problem, solution = last
    local.last = None
    if not success and diagnose:
        diagnosis = problem.diagnose(solution)
        return diagnosis, diagnosis.reason_with_summary(reason)
    return (Diagnosis(start=list(solution.start_violations)) if solution.start_violations else None), reason


def _start_text(texts: str, clipped: bool) -> str:
    return (f"start outside limits: {texts} (clipped into them first)" if clipped
            else f"the start breaks: {texts} (the first steps repair it)")


def _amount(value: float, unit: str) -> str:
    if unit in ("m", "rad"):
        return f"{value * 1e3:.3g} m{unit}"
    return f"{value:.3g} ({unit})" if unit else f"{value:.3g}"


def report_lines(data: dict) -> list[str]:
    """A diagnosis in its JSON form (``Diagnosis.as_dict()``, as a scenario report keeps it) as lines."""
    unit = data.get("unit", "")
    lines = [_start_text(item["text"], bool(item.get("clipped"))) for item in data.get("start", [])]
    if data.get("infeasible"):
        lines.append("the hard constraints of the step conflict (an irreducible set):")
        lines += [f"  - {item['text']}" for item in data["infeasible"]]
    for key, title in (("blockers", "blocked by (relaxing it alone would bring the goals closer by, in one "
                                    "step):"),
                       ("tasks", "tasks in conflict with the goals (without it, one step closer by):")):
        if data.get(key):
            lines.append(title)
            lines += [f"  - {item['text']}: {_amount(item['gain'], unit)}" for item in data[key]]
    lines += [f"to converge: {item}" for item in data.get("advice", [])]
    return lines


class _Hierarchy:
    """The step's levels as a QP per level over the labelled rows, with rows or one task left out."""

    def __init__(self, problem, rows: HardRows):
        step = problem.qp
        self.nv, self.rows, self.backend = step.nv, rows, problem.backend
        self.slack = problem.hierarchy_slack
        self.levels = []
        for level in step.levels:
            damping = problem.damping + problem.lm_damping * level.goal_cost()
            entries = []
            for index, task in enumerate(level.tasks):
                inequality, jacobian, error = level.rows_of(index)
                copies = (None, None) if inequality is None else (jacobian.copy(), error.copy())
                entries.append((task, inequality, *copies))
            self.levels.append((entries, damping))

    @staticmethod
    def error_after(task_entry, dq: np.ndarray) -> float:
        task, inequality, jacobian, error = task_entry
        after = error + jacobian @ dq
        return float(np.linalg.norm(np.maximum(after, 0.0) if inequality else after))

    def solve(self, upto: int, drop_rows: np.ndarray | None = None, drop_task: Task | None = None
              ) -> tuple[np.ndarray, list[np.ndarray]]:
        """dq through levels 0..upto, and per level the rows' multipliers; NoQPSolutionError."""
        nv, rows = self.nv, self.rows
        keep = np.ones(len(rows), dtype=bool) if drop_rows is None else ~drop_rows
        kept_rows = rows.subset(keep)
        G0, h0, A0, b0 = kept_rows.split()
        inequality_index = np.flatnonzero(keep)[~kept_rows.equality]
        equality_index = np.flatnonzero(keep)[kept_rows.equality]
        extra_G, extra_h = ([], []) if G0 is None else ([G0], [h0])  # the rows, then those levels keep
        dq, duals = np.zeros(nv), []
        for entries, damping in self.levels[:upto + 1]:
            hessian, gradient = np.eye(nv) * damping, np.zeros(nv)
            soft_J, soft_b, soft_w, kept_eq = [], [], [], []
            for task, inequality, jacobian, error in entries:
                if task is drop_task:
                    continue
                if inequality is None:
                    hessian += np.diag(task.constant_diagonal())
                    kept_eq.append(np.diag(np.sqrt(task.constant_diagonal())))
                elif inequality:
                    soft_J.append(jacobian)
                    soft_b.append(-task.gain * error)
                    soft_w.append(np.maximum(task.weight, damping))
                else:
                    scale = np.sqrt(task.weight)[:, None]
                    weighted = scale * jacobian
                    hessian += weighted.T @ weighted
                    gradient += weighted.T @ (scale[:, 0] * task.gain * error)
                    kept_eq.append(weighted)
            count = sum(len(b) for b in soft_b)
            from scipy.linalg import block_diag  # kept out of import wbik

            H = block_diag(hessian, np.diag(np.concatenate(soft_w)) if count else np.zeros((0, 0)))
            c = np.concatenate((gradient, np.zeros(count)))
            blocks_G = [np.hstack((block, np.zeros((len(block), count)))) for block in extra_G]
            blocks_h = list(extra_h)
            if count:
                J_soft, bound = np.vstack(soft_J), np.concatenate(soft_b)
                blocks_G.append(np.hstack((J_soft, -np.eye(count))))
                blocks_h.append(bound)
            G = np.vstack(blocks_G) if blocks_G else None
            h = np.concatenate(blocks_h) if blocks_h else None
            A = None if A0 is None else np.hstack((A0, np.zeros((len(b0), count))))
            x, z, y = backends.solve_with_duals(self.backend, H, c, G, h, A, b0)
            dq = x[:nv]
            multipliers = np.zeros(len(rows))
            if G0 is not None:
                multipliers[inequality_index] = np.abs(z[:len(h0)])
            if A0 is not None:
                multipliers[equality_index] = np.abs(y)
            duals.append(multipliers)
            if kept_eq:  # keep what this level achieved (the step's hierarchy rows)
                kept = np.vstack(kept_eq)
                achieved = kept @ dq
                extra_G += [kept, -kept]
                extra_h += [achieved + self.slack, -achieved + self.slack]
            if count:
                extra_G.append(J_soft)
                extra_h.append(np.maximum(J_soft @ dq - bound, 0.0) + bound + self.slack)
        return dq, duals


def diagnose(problem, reason: str = "", start: list[StartViolation] | None = None) -> Diagnosis:
    """The diagnosis at the configuration an IKProblem ``problem`` stands at (see the module docstring)."""
    step = problem.qp
    step.fill_tasks()
    diagnosis = Diagnosis(start=list(start or []))
    unmet = [(li, i, task) for li, level in enumerate(step.levels) for i, task in enumerate(level.tasks)
             if task.goal and level.error_norm(i) > task.tolerance]
    deepest = max((li for li, _, _ in unmet), default=-1)
    diagnosis.goals = {task.name: step.levels[li].error_norm(i) for li, i, task in unmet}
    units = {task.unit for _, _, task in unmet}  # the goals' ("m, rad": a pose, or a mix)
    diagnosis.unit = units.pop() if len(units) == 1 else "" if "" in units else "m, rad"
    rows = step_rows(step, 1.0, problem.max_step)
    try:
        hierarchy = _Hierarchy(problem, rows)
        dq, duals = hierarchy.solve(deepest if unmet else len(step.levels) - 1)
    except NoQPSolutionError:
        diagnosis.infeasible = conflict(rows)
        labels = [row.label for row in diagnosis.infeasible]
        diagnosis.advice = [next(filter(None, (label.owner.conflict_advice(labels) for label in labels)),
                                 "drop or relax one of the conflicting constraints (each of them is needed "
                                 "for the conflict)")]
        return diagnosis
    if not unmet:
        return diagnosis
    goal_entries = {(li, i): hierarchy.levels[li][0][i] for li, i, _ in unmet}

    def residual(step_dq: np.ndarray) -> float:
        return sum(hierarchy.error_after(entry, step_dq) for entry in goal_entries.values())

    base = residual(dq)
    diagnosis.step_gain = sum(diagnosis.goals.values()) - base
    scale = max(sum(diagnosis.goals.values()), 1e-300)
    multipliers = np.max(np.vstack(duals[:deepest + 1]), axis=0)
    threshold = max(1e-12, ACTIVE * float(multipliers.max(initial=0.0)))
    groups: dict[tuple, list[int]] = {}
    for index in np.flatnonzero(multipliers > threshold).tolist():
        if not isinstance(rows.labels[index].owner, StepBox):
            groups.setdefault(group_key(rows.labels[index]), []).append(index)
    masks = []
    for indices in groups.values():  # (a group: every row of one constraint's subject and side)
        mask = np.isin(np.arange(len(rows)), indices)
        try:
            relaxed, _ = hierarchy.solve(deepest, drop_rows=mask)
        except NoQPSolutionError:
            continue
        masks.append(mask)
        diagnosis.blockers.append(Blocker(rows.labels[indices[0]], len(indices),
                                          float(multipliers[indices].max()), base - residual(relaxed)))
    unmet_tasks = {id(task) for _, _, task in unmet}
    for level_index, (entries, _) in enumerate(hierarchy.levels[:deepest + 1]):
        for task, *_ in entries:
            if id(task) in unmet_tasks and len(unmet) == 1:
                continue
            try:
                relaxed, _ = hierarchy.solve(deepest, drop_task=task)
            except NoQPSolutionError:
                continue
            others = [(key, e) for key, e in goal_entries.items() if e[0] is not task]
            gain = (sum(hierarchy.error_after(e, dq) for _, e in others)
                    - sum(hierarchy.error_after(e, relaxed) for _, e in others))
            if gain <= max(1e-12, 1e-3 * scale):
                continue
            held = tuple(e[0].name for _, e in others)
            goal_level = min(key[0] for key, _ in others)
            diagnosis.tasks.append(TaskConflict(task.name, task.priority, task.goal, gain, held,
                                                _task_advice(task, level_index, goal_level, held, step)))
    diagnosis.tasks.sort(key=lambda t: -t.gain)
    # a blocker must still bring the goals closer with the non-goal task that conflicts most with them
    # left out as well, and by at least 1 % of the largest gain
    if (top := next((t for t in diagnosis.tasks if not t.goal), None)) is not None:
        task = next(e[0] for entries, _ in hierarchy.levels for e in entries if e[0].name == top.task)
        alone = 0.0
        try:
            alone = residual(hierarchy.solve(deepest, drop_task=task)[0])
            gains = [alone - residual(hierarchy.solve(deepest, drop_rows=mask, drop_task=task)[0])
                     for mask in masks]
        except NoQPSolutionError:
            gains = [b.gain for b in diagnosis.blockers]
        diagnosis.blockers = [b for b, own in zip(diagnosis.blockers, gains, strict=True)
                              if own > max(1e-12, 1e-6 * scale, 1e-3 * alone)]
    largest = max((b.gain for b in diagnosis.blockers), default=0.0)
    floor = max(1e-12, 1e-6 * scale, 0.01 * largest)
    diagnosis.blockers = sorted((b for b in diagnosis.blockers if b.gain > floor), key=lambda b: -b.gain)
    diagnosis.stationary = (not diagnosis.blockers and not diagnosis.tasks
                            and diagnosis.step_gain <= max(1e-12, 1e-6 * scale))
    diagnosis.advice = _advice(diagnosis, reason, problem)
    return diagnosis


def _task_advice(task: Task, level_index: int, goal_level: int, held: tuple[str, ...], step) -> str:
    goals = ", ".join(held)
    if level_index == goal_level and not task.goal:
        priorities = [level.tasks[0].priority for level in step.levels if level.tasks]
        own = priorities[goal_level] if goal_level < len(priorities) else 0
        below = min((p for p in priorities if p > own), default=own + 1)  # the next level's, or a new one
        return (f"move {task.name} to a lower priority level (priority={below}) "
                f"so that it acts only in the null space of {goals}, or lower its weight")
    if level_index == goal_level:
        return (f"{task.name} and {goals} conflict on one level: give the one that matters more a higher "
                "priority")
    return (f"{task.name} (priority {task.priority}) takes precedence over {goals}: give {goals} its "
            "priority, or free the higher level")


def _advice(diagnosis: Diagnosis, reason: str, problem) -> list[str]:
    advice = [task.advice for task in diagnosis.tasks[:1]]
    advice += [blocker.label.owner.advice(blocker.label) for blocker in diagnosis.blockers[:2]]
    if diagnosis.step_gain > max(1e-9, 1e-3 * sum(diagnosis.goals.values())) and "no convergence" in reason:
        advice.append("the steps still reduce the goal error: a larger budget (max_iterations) goes further")
    if diagnosis.stationary:
        advice.append("no constraint is active and no task conflicts: the goal error is at a stationary "
                      "point (the target is out of reach, or a local minimum): try another start q0")
    return list(dict.fromkeys(item for item in advice if item))

