"""One QP step at the kinematics' configuration q, one QP per priority level:

    min_dq  sum_k w_k |J_k dq + g_k e_k|^2 + (mu0 + mu |e|^2) |dq|^2
    s.t.    the constraints' rows (A dq = b, G dq <= h, lower <= dq <= upper) and |dq_i| <= radius

The Levenberg-Marquardt term mu |e|^2 (e: the level's goals) vanishes at the solution. Level k keeps what
the levels above achieved (:meth:`QPStep.keep`); inequality tasks take slacks w (min weight |w|^2 s.t.
J dq + g e <= w). No solution at the first level raises NoQPSolutionError; a later one keeps the step.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np

import wbik.qp.backends as backends
from wbik.errors import NoQPSolutionError
from wbik.kernels.twins import chosen, compiled_twin
from wbik.qp.constraint import Constraint
from wbik.qp.kinematics import Kinematics
from wbik.qp.row_plan import RowPlan
from wbik.qp.tasks import Task

_QUADRATIC = compiled_twin("qp_rows", "quadratic")
"""The compiled twin of Level.quadratic's products (None where it is not built)."""

PHASES = ("kinematics", "constraints", "tasks", "assemble", "qp")
"""Phases of a step timed by its ``profile`` argument: FK, joint Jacobians and CoM; constraint rows
and bounds (G, h, A, b, lb, ub); task rows (J and e); weighted H and c; the backend."""


def lap(profile: dict[str, float] | None, phase: str, since: float) -> float:
    """Add the time since ``since`` to ``profile[phase]``; returns now (``since`` without a profile)."""
    if profile is None:
        return since
    now = time.perf_counter()
    profile[phase] = profile.get(phase, 0.0) + now - since
    return now


def _joined(arrays: list[np.ndarray]) -> np.ndarray:
    return np.concatenate(arrays) if arrays else np.zeros(0)


def _row_slices(tasks: list[Task], inequality: bool) -> tuple[list[slice | None], list[tuple], int]:
    """Per task its rows among the level's (None: none), the (task, rows) pairs and the count: of the
    inequality tasks, or of the others but those with a constant diagonal."""
    slices, stop = [], 0
    for task in tasks:
        if task.inequality if inequality else not task.inequality and task.constant_diagonal() is None:
            slices.append(slice(stop, stop + task.dimension))
            stop += task.dimension
        else:
            slices.append(None)
    return slices, [pair for pair in zip(tasks, slices, strict=True) if pair[1] is not None], stop


class Level:
    """A priority level's tasks: their stacked rows J (m x nv), e (m), scales sqrt(w) and g sqrt(w)."""

    def __init__(self, tasks: list[Task], nv: int):
        self.tasks = tasks
        self.diagonal = np.zeros(nv)
        for task in tasks:
            if not task.inequality and task.constant_diagonal() is not None:
                self.diagonal += task.constant_diagonal()
        self.slices, stacked_rows, stop = _row_slices(tasks, False)
        self.inequality_slices, inequality_rows, inequality_stop = _row_slices(tasks, True)
        stacked = [task for task, _ in stacked_rows]
        self.inequalities = [task for task, _ in inequality_rows]
        """The level's inequality tasks (their rows: J dq + g e <= w, weight |w|^2)."""
        self.inequality_jacobian = np.zeros((inequality_stop, nv))
        self.inequality_error = np.zeros(inequality_stop)
        self.inequality_weight = _joined([task.weight for task in self.inequalities])
        self.inequality_gain = _joined([np.full(task.dimension, task.gain) for task in self.inequalities])
        self.inequality_goal_errors = [(task, self.inequality_error[rows]) for task, rows in inequality_rows
                                       if task.goal]
        self.jacobian, self.error = np.zeros((stop, nv)), np.zeros(stop)
        self.weighted = np.zeros((stop, nv))
        # H and c of the level's QP, refilled in place at every step (``quadratic``)
        self.hessian, self.gradient, self._scaled_error = np.zeros((nv, nv)), np.zeros(nv), np.zeros(stop)
        self._hessian_diagonal = self.hessian.ravel()[:: nv + 1]  # a view of H's diagonal
        # each task's rows and each goal's error as views of the buffers (no slicing per fill)
        self._task_rows = [(task, self.jacobian[rows], self.error[rows]) for task, rows in stacked_rows]
        self._task_rows += [(task, self.inequality_jacobian[rows], self.inequality_error[rows])
                            for task, rows in inequality_rows]
        self.goal_errors = [(task, self.error[rows]) for task, rows in stacked_rows if task.goal]
        self._goal_views = [error for _, error in self.goal_errors]
        self._goal_rows = np.zeros(stop)  # 1 on the goal tasks' rows (the compiled quadratic's goal cost)
        for task, rows in stacked_rows:
            self._goal_rows[rows] = 1.0 if task.goal else 0.0
        self.weight = _joined([task.weight for task in stacked])
        self.row_scale = np.sqrt(self.weight)[:, None]
        self._row_scale = self.row_scale[:, 0]  # (a contiguous view: the kernel's 1-D form)
        self._compiled_quadratic = chosen(None, _QUADRATIC, "qp_rows")
        self.error_scale = self._row_scale * _joined([np.full(task.dimension, task.gain) for task in stacked])

    def fill(self, kinematics: Kinematics) -> None:
        for task, jacobian, error in self._task_rows:
            task.fill(kinematics, jacobian, error)

    def goal_cost(self) -> float:
        """sum |e|^2 over the goal tasks (|max(0, e)|^2 for an inequality task)."""
        cost = 0.0
        for error in self._goal_views:
            cost += float(error.dot(error))
        return cost + self._inequality_goal_cost() if self.inequality_goal_errors else cost

    def _inequality_goal_cost(self) -> float:
        cost = 0.0
        for _, error in self.inequality_goal_errors:
            excess = np.maximum(error, 0.0)
            cost += float(excess.dot(excess))
        return cost

    def rows_of(self, index: int) -> tuple[bool | None, np.ndarray | None, np.ndarray | None]:
        """(inequality, J, e) of ``tasks[index]`` at the last fill (views; None: on H's diagonal)."""
        if (rows := self.slices[index]) is not None:
            return False, self.jacobian[rows], self.error[rows]
        if (rows := self.inequality_slices[index]) is not None:
            return True, self.inequality_jacobian[rows], self.inequality_error[rows]
        return None, None, None

    def error_norm(self, index: int) -> float:
        """|e| of ``tasks[index]`` at the last fill (|max(0, e)| for an inequality task)."""
        inequality, _, error = self.rows_of(index)
        if inequality:
            error = np.maximum(error, 0.0)
        return 0.0 if error is None else math.sqrt(error.dot(error))

    def inequality_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """(J, -g e) of the inequality tasks: their rows J dq + w... as J dq - w <= -g e."""
        return self.inequality_jacobian, -self.inequality_gain * self.inequality_error

    def quadratic(self, damping: float, lm_damping: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """H = (sqrt(w) J)^T (sqrt(w) J) + diag(constant diagonal + damping + lm_damping * goal_cost()),
        c = (sqrt(w) J)^T (g sqrt(w) e) in reused buffers; ``weighted`` holds sqrt(w) J afterwards."""
        if self._compiled_quadratic is not None:
            if self.inequality_goal_errors:  # (their cost in Python, the stacked goals' in the kernel)
                damping += lm_damping * self._inequality_goal_cost()
            self._compiled_quadratic(self.jacobian, self._row_scale, self.error, self.error_scale,
                                     self.diagonal, damping, self.weighted, self.hessian, self.gradient,
                                     self._goal_rows, lm_damping)
            return self.hessian, self.gradient
        if lm_damping:
            damping += lm_damping * self.goal_cost()
        weighted = np.multiply(self.jacobian, self.row_scale, out=self.weighted)
        H = weighted.T.dot(weighted, out=self.hessian)
        self._hessian_diagonal += self.diagonal + damping
        scaled_error = np.multiply(self.error, self.error_scale, out=self._scaled_error)
        c = weighted.T.dot(scaled_error, out=self.gradient)
        return H, c


class QPStep:
    """The QP of one step over tasks and constraints on one Kinematics (see the module docstring)."""

    def __init__(self, kinematics: Kinematics, tasks: Sequence[Task], constraints: Sequence[Constraint],
                 backend: str, damping: float, lm_damping: float, hierarchy_slack: float):
        self.kinematics = kinematics
        self.tasks = list(tasks)
        self.constraints = list(constraints)
        self.backend = backend
        self.damping, self.lm_damping, self.hierarchy_slack = damping, lm_damping, hierarchy_slack
        self.nv = kinematics.nv
        self.stack = backends.StackedConstraints(self.nv)
        self.workspace = backends.DaqpWorkspace() if backend == "daqp" else None
        self.levels: list[Level] = []
        self._layout: tuple | None = None
        self._filled = -1
        self._augmented: dict[int, backends.StackedConstraints] = {}
        self._constraint_rows = 0  # general rows of the constraints in the stack (the levels' follow)
        # the constraints' rows by compiled calls, made after their first Python build; kept across starts
        # (each writer checks its own rows) until a writer cannot write
        self._plan: RowPlan | None = None
        self._planned = False
        self._single: Level | None = None  # the one level, when it is the only one and has no inequality task

    def __getstate__(self) -> dict:
        """Without the row plan: its calls hold views of this step's buffers (a copy makes its own)."""
        return {**self.__dict__, "_plan": None, "_planned": False}

    def start(self) -> None:
        """Lay out every priority level's rows (tasks know their dimension once started)."""
        key = tuple((id(task), task.priority, task.dimension, task.gain, task.weight.tobytes(),
                     task.constant_diagonal() is None, task.inequality) for task in self.tasks)
        if key != self._layout:
            priorities = sorted({task.priority for task in self.tasks}) or [0]
            self.levels = [Level([t for t in self.tasks if t.priority == p], self.nv) for p in priorities]
            self._layout = key
        self._filled = -1
        first = self.levels[0]
        self._single = first if len(self.levels) == 1 and not first.inequalities else None
        self._planned = self._plan is not None  # (no plan yet: asked again, the constraints now started)

    def fill_tasks(self) -> None:
        """Every level's J and e at the kinematics' q (once per configuration)."""
        if self._filled != self.kinematics.version:
            for level in self.levels:
                level.fill(self.kinematics)
            self._filled = self.kinematics.version

    def refresh(self) -> None:
        """Fill the task rows again at the next step (a task's target may have changed)."""
        self._filled = -1

    def build_constraints(self, dt: float, radius: float,
                          recover: bool = True) -> backends.StackedConstraints:
        """Every constraint's rows at q, stacked; ``recover``: see ``StackedConstraints.close_box``."""
        stack = self.stack
        if self._plan is not None and self._plan.write(radius, recover):
            self._constraint_rows = stack.rows
            return stack
        stack.clear(radius)
        kinematics, spans = self.kinematics, []
        for constraint in self.constraints:
            start = stack.rows
            constraint.rows(kinematics, dt).add_to(stack)
            spans.append((start, stack.rows))
        stack.close_box(recover)
        self._constraint_rows = stack.rows
        if not self._planned or self._plan is not None:  # (a plan that stopped writing is made again)
            self._plan = RowPlan.compile(stack, self.constraints, kinematics, spans)
            self._planned = True
        return stack

    def solve(self, dt: float, radius: float, profile: dict[str, float] | None = None,
              recover: bool = True) -> np.ndarray:
        """dq at the kinematics' q (``recover``: see :meth:`build_constraints`); NoQPSolutionError."""
        if profile is None and (level := self._single) is not None:  # (the loop below, with one level)
            stack = self.build_constraints(dt, radius, recover)
            self.fill_tasks()
            H, c = level.quadratic(self.damping, self.lm_damping)
            return self._solve_relaxed(H, c, stack)
        tick = time.perf_counter() if profile is not None else 0.0
        stack = self.build_constraints(dt, radius, recover)
        tick = lap(profile, "constraints", tick)
        self.fill_tasks()
        tick = lap(profile, "tasks", tick)
        dq = None
        for index, level in enumerate(self.levels):
            damping = self.damping + self.lm_damping * level.goal_cost()
            H, c = level.quadratic(damping)
            tick = lap(profile, "assemble", tick)
            solver = (self._with_slacks(index, level, damping) if level.inequalities
                      else self._solve_strict if index else None)
            try:
                dq = self._solve_relaxed(H, c, stack, solver)
            except NoQPSolutionError:
                if not index:
                    raise  # (below: numerical, the previous level's dq meets every row; it is kept)
            tick = lap(profile, "qp", tick)
            if index + 1 < len(self.levels):
                self.keep(level, dq, stack)
        return dq

    def keep(self, level: Level, dq: np.ndarray, stack: backends.StackedConstraints) -> None:
        """Rows that keep what ``level`` achieved with dq* for the levels below: |sqrt(w) J (dq - dq*)| <=
        slack, and J dq + g e <= max(0, J dq* + g e) + slack for its inequality tasks."""
        slack = self.hierarchy_slack
        kept = np.vstack((level.weighted, np.diag(np.sqrt(level.diagonal))[level.diagonal > 0]))
        if kept.shape[0]:
            achieved = kept @ dq
            stack.add(kept, achieved + slack)
            stack.add(-kept, -achieved + slack)
        if level.inequalities:
            jacobian, bound = level.inequality_rows()
            stack.add(jacobian, np.maximum(jacobian @ dq - bound, 0.0) + bound + slack)

    def _with_slacks(self, index: int, level: Level, damping: float):
        """The solver of a level with inequality tasks: the QP over x = [dq; w], w one slack per
        inequality row, min 1/2 x^T [H 0; 0 diag(weight)] x + [c; 0]^T x s.t. the stacked rows on dq,
        J dq - w <= -g e (the rows' cost weight |w|^2); returns dq."""
        nv, jacobian, bound = self.nv, *level.inequality_rows()
        count = len(bound)
        weight = np.maximum(level.inequality_weight, damping)  # (> 0: the QP stays strictly convex)

        def solve(H: np.ndarray, c: np.ndarray, stack: backends.StackedConstraints) -> np.ndarray:
            augmented = self._augmented.get(index)
            if augmented is None or augmented.n != nv + count:
                augmented = self._augmented[index] = backends.StackedConstraints(nv + count)
            lower, upper = augmented.clear(1e30)
            G, h, A, b, lower[:nv], upper[:nv] = stack.split()
            for rows, bound_rows, equality in ((G, h, False), (A, b, True)):
                if rows is not None:
                    augmented.add(np.hstack((rows, np.zeros((len(bound_rows), count)))), bound_rows, equality)
            augmented.add(np.hstack((jacobian, -np.eye(count))), bound)
            from scipy.linalg import block_diag  # kept out of import wbik

            hessian = block_diag(H, np.diag(weight))
            gradient = np.concatenate((c, np.zeros(count)))
            x = (backends.solve_precise(self.backend, hessian, gradient, augmented, self.hierarchy_slack)
                 if index else backends.solve_stacked(self.backend, hessian, gradient, augmented))
            return x[:nv]

        return solve

    def _solve(self, H: np.ndarray, c: np.ndarray, stack: backends.StackedConstraints) -> np.ndarray:
        if self.workspace is not None:  # (DAQP's reused workspaces, one call layer fewer)
            return self.workspace.solve(H, c, stack)
        return backends.solve_stacked(self.backend, H, c, stack, self.workspace)

    def _solve_strict(self, H: np.ndarray, c: np.ndarray, stack: backends.StackedConstraints) -> np.ndarray:
        """A level below the first: its kept rows must hold to the slack (``backends.solve_precise``)."""
        return backends.solve_precise(self.backend, H, c, stack, self.hierarchy_slack, self.workspace)

    def _solve_relaxed(self, H: np.ndarray, c: np.ndarray, stack: backends.StackedConstraints,
                       solver=None) -> np.ndarray:
        """The QP by ``solver(H, c, stack)`` (default: the plain QP); without a solution while q breaks
        inequality rows (h < 0), those rows ask for half the repair, ..., 1/64, then not to get worse."""
        solve = solver or self._solve
        try:
            return solve(H, c, stack)
        except NoQPSolutionError:
            rows = stack.inequality_rows()
            rows = rows[rows < stack.n + self._constraint_rows]  # the constraints' rows, not the levels'
            upper = stack.upper
            h = upper[rows]
            if not np.any(h < 0):
                raise
        relaxed = h.copy()
        try:
            for _ in range(6):
                relaxed[relaxed < 0] *= 0.5
                upper[rows] = relaxed
                try:
                    return solve(H, c, stack)
                except NoQPSolutionError:
                    pass
            upper[rows] = np.maximum(h, 0.0)
            return solve(H, c, stack)
        finally:
            upper[rows] = h

    def minimum_norm(self, stack: backends.StackedConstraints) -> np.ndarray:
        """min |dq|^2 under the stacked rows (the projection's QP)."""
        return self._solve_relaxed(np.eye(self.nv), np.zeros(self.nv), stack)
