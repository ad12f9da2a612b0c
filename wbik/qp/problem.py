"""The IK loop: QP steps (:mod:`wbik.qp.step`) iterated from q0 until the goals are met.

``IKProblem.step`` is one QP step (for control: v = dq / dt); ``IKProblem.solve`` iterates steps
until every goal task is under its tolerance and every contact holds, or the steps stall (best
effort: the constrained optimum, errors reported), or the budget ends. A trust region (the step
box, ``max_step`` at most) with merit acceptance makes the loop globally convergent; Newton
projections bring the contacts back where a step's own contact rows are not enough
(:meth:`IKProblem.project`). The configuration returned is verified by forward kinematics:
contacts, CoM margin, limits.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from dataclasses import field

import numpy as np
import pinocchio as pin

from wbik.errors import NoQPSolutionError
from wbik.qp import backends
from wbik.qp.constraints import BoundConstraint
from wbik.qp.constraints import CoMInSupportPolygon
from wbik.qp.constraints import Constraint
from wbik.qp.constraints import EqualityConstraint
from wbik.qp.constraints import InequalityConstraint
from wbik.qp.constraints import JointPositionLimits
from wbik.qp.kinematics import Kinematics
from wbik.qp.step import PHASES
from wbik.qp.step import QPStep
from wbik.qp.step import lap
from wbik.qp.tasks import Task

__all__ = ["PHASES", "SOLVE_PHASES", "IKProblem", "QPSolution"]

SOLVE_PHASES = ("start", "projection", "checks", "report")
"""What ``IKProblem.solve``'s ``profile`` times besides its steps' ``PHASES``: setting q0 up (clip,
kinematics, tasks' and constraints' start), the Newton projections onto the contacts, the merit and
constraint checks of each trial configuration by FK, the final report (violations, margins, task
errors)."""


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
        self._equalities = [c for c in self.constraints if isinstance(c, EqualityConstraint)]
        self._bounds = [c for c in self.constraints if isinstance(c, BoundConstraint)]
        self._box = backends.StackedConstraints(self.nv, capacity=1)
        self._inequalities = [c for c in self.constraints if isinstance(c, InequalityConstraint)]
        self._step = QPStep(self.kinematics, self.tasks, self.constraints, self.backend, self.damping,
                            self.lm_damping, self.hierarchy_slack)
        self._started = False

    # -- set-up ---------------------------------------------------------------------------------
    def start(self, q: np.ndarray) -> None:
        """Set the configuration and let tasks and constraints resolve frames / capture placements."""
        q = self.clip(np.asarray(q, dtype=float))
        self.kinematics.update(q)
        for item in (*self.tasks, *self.constraints):
            item.start(self.kinematics)
        self._step.start()
        self._started = True

    def clip(self, q: np.ndarray) -> np.ndarray:
        """q with every bounded 1-DOF joint clipped into its limits (a copy)."""
        return self._clipped(q.copy())

    def _clipped(self, q: np.ndarray) -> np.ndarray:
        """``clip`` in place (for a q of our own, such as pin.integrate's answer); returns q."""
        for limits in self._limits:
            limits.clip(q)
        return q

    def _stands_at(self, q: np.ndarray) -> bool:
        """The kinematics stand at q (a configuration of this model: no np.array_equal shape checks)."""
        return bool((q == self.kinematics.q).all())

    def _within_bounds(self, dq: np.ndarray) -> bool:
        """dq keeps every bound constraint's rows at the current q (dt = 1)."""
        box = self._box
        lower, upper = box.clear(np.inf)
        for constraint in self._bounds:
            constraint.rows(self.kinematics, 1.0).add_to(box)
        return not ((dq < lower).any() or (dq > upper).any())

    # -- one QP step ----------------------------------------------------------------------------
    def step(self, q: np.ndarray | None = None, dt: float = 1.0, max_step: float | None = None,
             profile: dict[str, float] | None = None) -> np.ndarray:
        """The QP displacement dq at q (default: the current q); raises NoQPSolutionError (with the
        backend's status) when the QP has no solution.

        For control, v = dq / dt is the joint velocity to send for one period dt (velocity limits
        bound |dq| <= v_max dt); for IK, dt = 1 and dq is a Newton-like step.
        ``profile``: a dict to which the seconds spent in each phase are added (``PHASES``); the
        clock is read only when it is given.
        """
        tick = time.perf_counter() if profile is not None else 0.0
        if not self._started:
            self.start(self.kinematics.q if q is None else q)
        elif q is not None:
            self.kinematics.update(q)
        if profile is not None:
            self.kinematics.com()  # (lazy) here, so that "constraints" only builds rows
            lap(profile, "kinematics", tick)
        self._step.refresh()  # a caller may have moved a task's target since the last step
        return self._step.solve(dt, self.max_step if max_step is None else max_step, profile)

    def project(self, tolerance: float = 1e-12, max_iterations: int = 6) -> bool:
        """Newton steps onto the contacts from the current q: min |dq|^2 s.t. J_c dq = -e_c and the
        other constraints. True when every contact holds to ``tolerance`` afterwards."""
        equalities = self._equalities
        if not equalities:
            return True
        kinematics = self.kinematics
        for _ in range(max_iterations):
            if self._equalities_met(tolerance):
                return True
            # cheap first: the minimum-norm Newton step dq = A^T (A A^T)^-1 b, kept if it keeps
            # every bound (limits, locked joints, velocities); otherwise the QP with every constraint
            rows = [c.equality(kinematics) for c in equalities]
            A, b = rows[0] if len(rows) == 1 else (np.vstack([r.A for r in rows]),
                                                     np.concatenate([r.b for r in rows]))
            try:
                dq = A.T @ np.linalg.solve(A @ A.T, b)
            except np.linalg.LinAlgError:
                dq = None
            if dq is not None and self._within_bounds(dq):
                kinematics.update(kinematics.integrate(dq))
                continue
            try:
                dq = self._step.minimum_norm(self._step.build_constraints(1.0, self.max_step))
            except NoQPSolutionError:
                return False
            kinematics.update(self.clip(kinematics.integrate(dq)))
        return self._equalities_met(tolerance)

    # -- the task cost, the constraints ---------------------------------------------------------
    def task_errors(self) -> dict[str, float]:
        """|e| per task name at the current q."""
        self._step.fill_tasks()
        return {task.name: level.error_norm(index)
                for level in self._step.levels for index, task in enumerate(level.tasks)}

    def violations(self) -> dict[str, float]:
        return {constraint.name: float(constraint.violation(self.kinematics))
                for constraint in self.constraints}

    def merit(self) -> float:
        """Weighted task cost (lower levels scaled down by 1e-6 each); contacts are kept by projection."""
        return self._merit_and_goals()[0]

    def _merit_and_goals(self) -> tuple[float, bool]:
        """(merit, every goal task under its tolerance), from the step's task rows at q."""
        self._step.fill_tasks()
        cost, goals_met = 0.0, True
        for index, level in enumerate(self._step.levels):
            error = level.error
            cost += float(level.weight.dot(error * error)) * 1e-6 ** index
            for task, goal_error in level.goal_errors:
                if goals_met:
                    goals_met = math.sqrt(float(goal_error.dot(goal_error))) <= task.tolerance
        return cost, goals_met

    def _equalities_met(self, tolerance: float) -> bool:
        for constraint in self._equalities:
            if constraint.violation(self.kinematics) > tolerance:
                return False
        return True

    def _inequality_violation(self) -> float:
        total = 0
        for constraint in self._inequalities:
            total += constraint.violation(self.kinematics)
        return total

    # -- iterate to convergence -----------------------------------------------------------------
    def _trial(self, merit: float, violation: float,
               profile: dict[str, float] | None = None) -> tuple[bool, float, bool, float]:
        """(kept, merit, goals met, inequality violation) of the configuration the kinematics stand
        at: kept when it does not raise the merit and keeps the inequalities by FK (or reduces
        their violation when the kept iterate breaks them)."""
        tick = time.perf_counter() if profile is not None else 0.0
        trial_merit, goals_met = self._merit_and_goals()
        trial_violation = self._inequality_violation()
        keeps_inequalities = trial_violation <= 0.0 or trial_violation < violation
        if profile is not None:
            lap(profile, "checks", tick)
        return keeps_inequalities and trial_merit <= merit + 1e-15, trial_merit, goals_met, trial_violation

    def solve(self, q0: np.ndarray, max_iterations: int = 200, deadline: float | None = None,
              equality_tolerance: float = 1e-10, stall: float = 1e-12,
              profile: dict[str, float] | None = None) -> QPSolution:
        """Iterate QP steps from q0 to convergence: every goal task under its tolerance and every
        contact within ``equality_tolerance``.

        A trust region (the step box, ``max_step`` at most) makes the loop globally convergent: a
        step is kept only if it does not raise the merit (the task cost) and keeps the inequalities
        by FK (or reduces their violation when q0 breaks them); otherwise the radius shrinks and the
        QP is solved again. The contacts are rows of every step (J dq = -e), so their drift is of
        second order in the step and the next step removes it, as in PlaCo; Newton projections
        (:meth:`project`, to 0.1 ``equality_tolerance``) bring them back where that is not enough:
        from q0, for a step the merit test rejects while the contacts drift, when the goals are met
        before the contacts, and on the configuration returned. A radius or step under ``stall``
        ends the loop at the best effort under the constraints.

        ``profile``: a dict to which the seconds of each step phase (``PHASES``) and of the loop's
        own phases (``SOLVE_PHASES``) are added.
        """
        start_time = time.perf_counter()
        self.start(q0)
        if profile is not None:
            lap(profile, "start", start_time)
        kinematics = self.kinematics
        tolerance = 0.1 * equality_tolerance
        self._timed(profile, "projection", self.project, tolerance)
        q = kinematics.q.copy()
        if profile is not None:  # the first step's task rows, filled here for the merit
            self._timed(profile, "tasks", self._step.fill_tasks)
        merit, goals_met = self._timed(profile, "checks", self._merit_and_goals)
        violation = self._timed(profile, "checks", self._inequality_violation)
        radius, slow, reason, converged, iteration = self.max_step, 0, "", False, 0
        for iteration in range(1, max_iterations + 1):
            if goals_met:
                if self._timed(profile, "checks", self._equalities_met, equality_tolerance):
                    converged = True
                    iteration -= 1
                    break
                # the goals hold, the contacts still drift
                if self._timed(profile, "projection", self.project, tolerance):
                    q = kinematics.q.copy()
                    merit, goals_met = self._merit_and_goals()
                    violation = self._inequality_violation()
                    if goals_met:
                        converged = True
                        break
            if deadline is not None and time.perf_counter() > deadline:
                reason = "time budget used up"
                break
            try:
                dq = self._step.solve(1.0, radius, profile)
            except NoQPSolutionError as exc:
                reason = (f"the QP has no solution ({exc}): the constraints conflict at this configuration"
                          if iteration == 1 else
                          f"best effort: {self.backend} found no further step (radius {radius:.2g})")
                break
            step_size = float(np.abs(dq).max()) if dq.size else 0.0
            tick = time.perf_counter() if profile is not None else 0.0
            kinematics.update(self._clipped(pin.integrate(self.model, q, dq)))
            if profile is not None:  # the next step's task rows, filled here for the merit
                tick = lap(profile, "kinematics", tick)
                self._step.fill_tasks()
                lap(profile, "tasks", tick)
            kept, trial_merit, trial_goals_met, trial_violation = self._trial(merit, violation, profile)
            if not kept and not self._equalities_met(tolerance) and self._timed(profile, "projection",
                                                                                self.project, tolerance):
                kept, trial_merit, trial_goals_met, trial_violation = self._trial(merit, violation, profile)
            if kept:
                q = kinematics.q.copy()
                slow = slow + 1 if merit - trial_merit < self.progress * merit else 0
                merit, violation, goals_met = trial_merit, trial_violation, trial_goals_met
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
            if not self._stands_at(q):
                kinematics.update(q)
            if not self._equalities_met(tolerance) and self._timed(profile, "projection", self.project,
                                                                   tolerance):
                q = kinematics.q.copy()  # the answer holds the contacts, as every converged one does
            converged = self._merit_and_goals()[1] and self._equalities_met(equality_tolerance)
            if converged:
                reason = ""
            elif not reason:
                reason = "stalled: best effort under the constraints (see the task errors)"
        return self._report(q, converged, iteration, reason, start_time, profile)

    @staticmethod
    def _timed(profile: dict[str, float] | None, phase: str, function, *arguments):
        """``function(*arguments)``, its time added to ``profile[phase]`` when profiling."""
        if profile is None:
            return function(*arguments)
        tick = time.perf_counter()
        result = function(*arguments)
        lap(profile, phase, tick)
        return result

    def _report(self, q: np.ndarray, converged: bool, iterations: int, reason: str, start_time: float,
                profile: dict[str, float] | None = None) -> QPSolution:
        tick = time.perf_counter() if profile is not None else 0.0
        if not self._stands_at(q):  # (an update would recompute the same rows)
            self.kinematics.update(q)
        kinematics = self.kinematics
        violations, margins, feasible = {}, {}, True
        for constraint in self.constraints:  # (one pass: violation, feasibility, CoM margin)
            value = violations[constraint.name] = float(constraint.violation(kinematics))
            if isinstance(constraint, EqualityConstraint):
                feasible = feasible and value <= self.constraint_tolerance
            else:
                feasible = feasible and value <= 1e-9
                if isinstance(constraint, CoMInSupportPolygon):
                    margins[constraint.name] = float(constraint.com_margin(kinematics))
        if not feasible and not reason:
            worst = max(violations, key=violations.get)
            reason = f"constraint {worst!r} violated by {violations[worst]:.3g}"
        task_errors = self.task_errors()
        if profile is not None:
            lap(profile, "report", tick)
        return QPSolution(q.copy(), converged and feasible, converged, feasible, iterations, reason,
                          time.perf_counter() - start_time, task_errors, violations, margins)
