"""The task-based QP over the tangent displacement dq, one step at a time or iterated to convergence.

One step at configuration q (all tasks of one priority level):

    min_dq  sum_k w_k |J_k dq + g_k e_k|^2 + (mu0 + mu |e|^2) |dq|^2
    s.t.    A dq = b            (contacts: J_c dq = -e_c)
            G dq <= h           (CoM in the shrunk support polygon, minimum distances)
            lb <= dq <= ub      (joint position limits; joint velocity limits x dt; step size)

then q <- q (+) dq. The Levenberg-Marquardt term mu |e|^2 keeps far-away steps short and vanishes
at the solution, so it does not bias the answer. With several priority levels, level k is solved
with the achieved task values of levels < k kept (to ``hierarchy_slack``) as extra constraints.

``solve`` iterates steps until every goal task is under its tolerance and every contact holds,
or the steps stall (best effort: the constrained optimum, errors reported), or the budget ends.
It verifies the configuration it returns by forward kinematics: contacts, CoM margin, limits.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbik.qp import backends
from wbik.qp.constraints import Constraint, JointPositionLimits
from wbik.qp.kinematics import Kinematics
from wbik.qp.tasks import Task


@dataclass
class QPSolution:
    """Outcome of ``IKProblem.solve``.

    ``task_errors``: |e| per task name at q; ``violations``: per constraint, > 0 means violated
    (contacts in m or rad, CoM in m inside the margin, limits in rad or m); ``com_margins``:
    distance from the CoM projection to each polygon boundary (m, positive inside).
    """

    q: np.ndarray
    success: bool
    converged: bool
    feasible: bool
    iterations: int
    reason: str
    time_s: float
    task_errors: dict[str, float] = field(default_factory=dict)
    violations: dict[str, float] = field(default_factory=dict)
    com_margins: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"success": self.success, "converged": self.converged, "feasible": self.feasible,
                "iterations": self.iterations, "reason": self.reason, "time_s": self.time_s,
                "q": [float(v) for v in self.q], "task_errors": self.task_errors,
                "violations": self.violations, "com_margins": self.com_margins}


PHASES = ("kinematics", "constraints", "tasks", "assemble", "qp")
"""Phases of ``IKProblem.step`` timed by its ``profile`` argument: FK, joint Jacobians and CoM;
constraint rows and bounds (G, h, A, b, lb, ub); task rows (weighted J and e); H and c; the backend."""


def _lap(profile: dict[str, float], phase: str, since: float) -> float:
    now = time.perf_counter()
    profile[phase] = profile.get(phase, 0.0) + now - since
    return now


class IKProblem:
    """Tasks and constraints on one Pinocchio model, solved by a QP backend (qpsolvers name).

    ``constraint_tolerance`` is what ``solve`` verifies on its answer (1e-6 m for contacts).
    ``max_step`` bounds every tangent component of one IK step (a trust region, rad or m).
    ``progress``: five kept steps in a row that lower the merit by less than this fraction end
    the loop at the best effort.
    """

    def __init__(self, model: pin.Model, tasks: Sequence[Task], constraints: Sequence[Constraint] = (),
                 *, backend: str = backends.DEFAULT, damping: float = 1e-9, lm_damping: float = 1e-3,
                 max_step: float = 0.2, constraint_tolerance: float = 1e-6,
                 hierarchy_slack: float = 1e-9, progress: float = 1e-6):
        self.model = model
        self.kinematics = Kinematics(model)
        self.tasks = list(tasks)
        self.constraints = list(constraints)
        self.backend = backends.resolve(backend)
        self.damping = float(damping)
        self.lm_damping = float(lm_damping)
        self.max_step = float(max_step)
        self.constraint_tolerance = float(constraint_tolerance)
        self.hierarchy_slack = float(hierarchy_slack)
        self.progress = float(progress)
        self.nv = model.nv
        self._limits = [c for c in self.constraints if isinstance(c, JointPositionLimits)]
        self._constraints = backends.StackedConstraints(self.nv)
        self._started = False

    # -- set-up ---------------------------------------------------------------------------------
    def start(self, q: np.ndarray) -> None:
        """Set the configuration and let tasks and constraints resolve frames / capture placements."""
        q = self.clip(np.asarray(q, dtype=float))
        self.kinematics.update(q)
        for item in (*self.tasks, *self.constraints):
            item.start(self.kinematics)
        self._layout()
        self._started = True

    def _layout(self) -> None:
        """Preallocate the stacked task matrices of every priority level."""
        self.levels = sorted({task.priority for task in self.tasks}) or [0]
        self._level_tasks = {level: [t for t in self.tasks if t.priority == level] for level in self.levels}
        self._stack = {}
        self._level_rows = {}
        for level, tasks in self._level_tasks.items():
            rows = sum(task.dimension for task in tasks)
            stops = np.cumsum([task.dimension for task in tasks], dtype=int)
            self._level_rows[level] = [(task, slice(int(stop) - task.dimension, int(stop)))
                                       for task, stop in zip(tasks, stops, strict=True)]
            sqrt_weight = np.concatenate([np.sqrt(t.weight) for t in tasks]) if tasks else np.zeros(0)
            self._stack[level] = (np.zeros((rows, self.nv)), np.zeros(rows), sqrt_weight)
        self._identity = np.eye(self.nv)

    def clip(self, q: np.ndarray) -> np.ndarray:
        """q with every bounded 1-DOF joint clipped into its limits."""
        q = q.copy()
        for limits in self._limits:
            q[limits.q_index] = np.clip(q[limits.q_index], limits.lower, limits.upper)
        return q

    def _within_limits(self, q: np.ndarray) -> bool:
        """``clip(q)`` would leave q as it is."""
        for limits in self._limits:
            values = q[limits.q_index]
            if (values < limits.lower).any() or (values > limits.upper).any():
                return False
        return True

    # -- one QP step ----------------------------------------------------------------------------
    def _assemble_level(self, level: int) -> tuple[np.ndarray, np.ndarray, float]:
        """(weighted J, weighted gain*e, |e|^2 of goal tasks) for one priority level (views of
        buffers that the next call overwrites)."""
        jacobian, error, sqrt_weight = self._stack[level]
        goal_cost = 0.0
        for task, rows in self._level_rows[level]:
            task_error = error[rows]
            task.fill(self.kinematics, jacobian[rows], task_error)
            if task.goal:
                goal_cost += float(task_error @ task_error)
            if task.gain != 1.0:
                task_error *= task.gain
        jacobian *= sqrt_weight[:, None]
        error *= sqrt_weight
        return jacobian, error, goal_cost

    def _constraint_matrices(self, dt: float, max_step: float) -> backends.StackedConstraints:
        """Every constraint's rows and bounds at the current q, in the reused buffers."""
        stack = self._constraints
        lower, upper = stack.clear(max_step)
        for constraint in self.constraints:
            if constraint.kind == "bounds":
                constraint.bounds(self.kinematics, dt, lower, upper)
            elif constraint.kind == "equality":
                stack.add(*constraint.equality(self.kinematics), equality=True)
            elif constraint.kind == "inequality":
                stack.add(*constraint.inequality(self.kinematics))
        # a velocity bound may leave no room inside a position bound: keep the box non-empty
        np.minimum(lower, upper, out=lower)
        return stack

    def step(self, q: np.ndarray | None = None, dt: float = 1.0, max_step: float | None = None,
             profile: dict[str, float] | None = None) -> np.ndarray | None:
        """The QP displacement dq at q (default: the current q), or None if the QP has no solution.

        For control, v = dq / dt is the joint velocity to send for one period dt (velocity limits
        bound |dq| <= v_max dt); for IK, dt = 1 and dq is a Newton-like step. When q breaks an
        inequality by more than one step can repair, the violated rows ask for half the repair,
        then a quarter, ..., then only not to get worse.

        ``profile``: a dict to which the seconds spent in each phase are added (``PHASES``); the
        clock is read only when it is given.
        """
        clock = time.perf_counter if profile is not None else None
        tick = clock() if clock else 0.0
        if not self._started:
            self.start(self.kinematics.q if q is None else q)
        elif q is not None:
            self.kinematics.update(q)
        if clock:
            # the CoM (lazy) is computed here too, so that "constraints" only builds rows
            self.kinematics.com()
            tick = _lap(profile, "kinematics", tick)
        radius = self.max_step if max_step is None else max_step
        constraints = self._constraint_matrices(dt, radius)
        if clock:
            tick = _lap(profile, "constraints", tick)
        dq = None
        for index, level in enumerate(self.levels):
            weighted_jacobian, weighted_error, goal_cost = self._assemble_level(level)
            if clock:
                tick = _lap(profile, "tasks", tick)
            mu = self.damping + self.lm_damping * goal_cost
            H = weighted_jacobian.T @ weighted_jacobian
            H.flat[:: self.nv + 1] += mu
            c = weighted_jacobian.T @ weighted_error
            if clock:
                tick = _lap(profile, "assemble", tick)
            dq = self._solve_relaxed(H, c, constraints)
            if clock:
                tick = _lap(profile, "qp", tick)
            if dq is None:
                return None
            if index + 1 < len(self.levels):
                # keep what this level achieved: |J_l dq - J_l dq*| <= slack
                achieved = weighted_jacobian @ dq
                constraints.add(weighted_jacobian, achieved + self.hierarchy_slack)
                constraints.add(-weighted_jacobian, -achieved + self.hierarchy_slack)
                if clock:
                    tick = _lap(profile, "assemble", tick)
        return dq

    def _solve_relaxed(self, H: np.ndarray, c: np.ndarray,
                       constraints: backends.StackedConstraints) -> np.ndarray | None:
        dq = backends.solve_stacked(self.backend, H, c, constraints)
        if dq is not None:
            return dq
        rows = constraints.inequality_rows()
        upper = constraints.upper
        h = upper[rows]
        if not np.any(h < 0):
            return None
        relaxed = h.copy()
        try:
            for _ in range(6):
                relaxed[relaxed < 0] *= 0.5
                upper[rows] = relaxed
                dq = backends.solve_stacked(self.backend, H, c, constraints)
                if dq is not None:
                    return dq
            upper[rows] = np.maximum(h, 0.0)
            return backends.solve_stacked(self.backend, H, c, constraints)
        finally:
            upper[rows] = h

    def project(self, tolerance: float = 1e-12, max_iterations: int = 6) -> bool:
        """Newton steps onto the contacts from the current q: min |dq|^2 s.t. J_c dq = -e_c and the
        other constraints. True when every contact holds to ``tolerance`` afterwards."""
        equalities = [c for c in self.constraints if c.kind == "equality"]
        if not equalities:
            return True
        for _ in range(max_iterations):
            if all(c.violation(self.kinematics) <= tolerance for c in equalities):
                return True
            # cheap first: the minimum-norm Newton step dq = -J^T (J J^T)^-1 e, kept if it breaks
            # no bound; otherwise the QP with every constraint
            rows = [c.equality(self.kinematics) for c in equalities]
            if len(rows) == 1:
                A, b = rows[0]
            else:
                A = np.vstack([a for a, _ in rows])
                b = np.concatenate([b for _, b in rows])
            try:
                dq = A.T @ np.linalg.solve(A @ A.T, b)
            except np.linalg.LinAlgError:
                dq = None
            if dq is not None:
                trial = self.kinematics.integrate(dq)
                if self._within_limits(trial):
                    self.kinematics.update(trial)
                    continue
            constraints = self._constraint_matrices(1.0, self.max_step)
            dq = self._solve_relaxed(self._identity, np.zeros(self.nv), constraints)
            if dq is None:
                return False
            self.kinematics.update(self.clip(self.kinematics.integrate(dq)))
        return all(c.violation(self.kinematics) <= tolerance for c in equalities)

    # -- iterate to convergence -----------------------------------------------------------------
    def task_errors(self) -> dict[str, float]:
        return {task.name: math.sqrt(float(error @ error))
                for task in self.tasks for error in (task.error(self.kinematics),)}

    def violations(self) -> dict[str, float]:
        return {constraint.name: float(constraint.violation(self.kinematics))
                for constraint in self.constraints}

    def _goals_met(self) -> bool:
        return self._merit_and_goals()[1]

    def _equalities_met(self, tolerance: float) -> bool:
        return all(c.violation(self.kinematics) <= tolerance for c in self.constraints
                   if c.kind == "equality")

    def _inequality_violation(self) -> float:
        return sum(c.violation(self.kinematics) for c in self.constraints if c.kind == "inequality")

    def merit(self) -> float:
        """Weighted task cost (lower levels scaled down by 1e-6 each); contacts are kept by projection."""
        return self._merit_and_goals()[0]

    def _merit_and_goals(self) -> tuple[float, bool]:
        """(merit, every goal task under its tolerance), from one evaluation of each task error."""
        cost = 0.0
        goals_met = True
        for index, level in enumerate(self.levels):
            level_cost = 0.0
            for task in self._level_tasks[level]:
                error = task.error(self.kinematics)
                squared = error * error
                level_cost += float(task.weight @ squared)
                if goals_met and task.goal:
                    goals_met = math.sqrt(float(squared.sum())) <= task.tolerance
            cost += level_cost * 1e-6 ** index
        return cost, goals_met

    def solve(self, q0: np.ndarray, max_iterations: int = 200, deadline: float | None = None,
              equality_tolerance: float = 1e-10, stall: float = 1e-12) -> QPSolution:
        """Iterate QP steps from q0 to convergence (see the module docstring).

        A trust region (the step box, ``max_step`` at most) makes the loop globally convergent: each
        step is followed by Newton projections back onto the contacts (so every kept iterate
        holds them to 1e-11), and is kept only if it lowers the merit (the task cost) and keeps
        the inequalities by FK (or reduces their violation when q0 breaks them); otherwise the
        radius shrinks and the QP is solved again. A radius or step under ``stall`` ends the loop
        at the best effort under the constraints.
        """
        start_time = time.perf_counter()
        self.start(q0)
        kinematics = self.kinematics
        # the merit, the goals and the contacts of the kept iterate q (a projection that succeeds
        # holds the contacts to 0.1 * equality_tolerance)
        contacts_held = self.project(0.1 * equality_tolerance)
        q = kinematics.q.copy()
        merit, goals_met = self._merit_and_goals()
        inequality_violation = self._inequality_violation()
        radius = self.max_step
        slow = 0
        reason = ""
        converged = False
        iteration = 0
        for iteration in range(1, max_iterations + 1):
            if goals_met and (contacts_held or self._equalities_met(equality_tolerance)):
                converged = True
                iteration -= 1
                break
            if deadline is not None and time.perf_counter() > deadline:
                reason = "time budget used up"
                break
            dq = self.step(dt=1.0, max_step=radius)
            if dq is None:
                reason = (f"the QP has no solution ({self.backend}): the constraints conflict at this "
                          "configuration" if iteration == 1 else
                          f"best effort: {self.backend} found no further step (radius {radius:.2g})")
                break
            step_size = float(np.abs(dq).max()) if dq.size else 0.0
            kinematics.update(self.clip(pin.integrate(self.model, q, dq)))
            projected = self.project(0.1 * equality_tolerance)
            trial_violation = self._inequality_violation()
            trial_merit, trial_goals_met = self._merit_and_goals()
            keeps_inequalities = trial_violation <= 0.0 or trial_violation < inequality_violation
            if projected and keeps_inequalities and trial_merit <= merit + 1e-15:
                q = kinematics.q.copy()
                slow = slow + 1 if merit - trial_merit < self.progress * merit else 0
                merit, inequality_violation = trial_merit, trial_violation
                goals_met, contacts_held = trial_goals_met, True
                if slow >= 5 and not goals_met:
                    reason = "best effort under the constraints: progress stalled (see the task errors)"
                    break
                if step_size >= 0.9 * radius:
                    radius = min(2.0 * radius, self.max_step)
                if step_size < stall:
                    break
            else:
                kinematics.update(q)
                radius = 0.25 * min(radius, step_size)
                if radius < stall:
                    break
        else:
            iteration = max_iterations
            reason = f"no convergence in {max_iterations} iterations"
        if not converged:
            converged = self._goals_met() and self._equalities_met(equality_tolerance)
            if converged:
                reason = ""
            elif not reason:
                reason = "stalled: best effort under the constraints (see the task errors)"
        return self._report(q, converged, iteration, reason, start_time)

    def _report(self, q: np.ndarray, converged: bool, iterations: int, reason: str,
                start_time: float) -> QPSolution:
        if not np.array_equal(q, self.kinematics.q):  # (an update would recompute the same rows)
            self.kinematics.update(q)
        violations = self.violations()
        feasible = all(value <= self.constraint_tolerance if isinstance_equality else value <= 1e-9
                       for value, isinstance_equality in zip(
                           violations.values(), (c.kind == "equality" for c in self.constraints),
                           strict=True))
        if not feasible and not reason:
            worst = max(violations, key=violations.get)
            reason = f"constraint {worst!r} violated by {violations[worst]:.3g}"
        margins = {c.name: float(c.com_margin(self.kinematics)) for c in self.constraints
                   if hasattr(c, "com_margin")}
        return QPSolution(q.copy(), converged and feasible, converged, feasible, iterations, reason,
                          time.perf_counter() - start_time, self.task_errors(), violations, margins)
