"""The IK loop: QP steps (:mod:`wbik.qp.step`) iterated from q0 under a trust region until the goals are
met and the contacts hold (Newton projections), or at the best effort; answers verified by FK, a failed
solve diagnosed (:mod:`wbik.qp.diagnosis`)."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

import wbik.qp.backends as backends
from wbik.errors import NoQPSolutionError
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.constraint import BoundConstraint, Constraint, EqualityConstraint, InequalityConstraint
from wbik.qp.diagnosis import Diagnosis, StartViolation, diagnose
from wbik.qp.elastic import conflict
from wbik.qp.hard_rows import step_rows
from wbik.qp.kinematics import Kinematics
from wbik.qp.limits import JointPositionLimits
from wbik.qp.step import PHASES, QPStep, lap
from wbik.qp.tasks import Task

__all__ = ["PHASES", "SOLVE_PHASES", "IKProblem", "QPSolution"]

SOLVE_PHASES = ("start", "projection", "checks", "report")
"""What ``IKProblem.solve``'s ``profile`` also times: set-up, projections, FK checks, report."""


@dataclass
class QPSolution:
    """Outcome of ``IKProblem.solve``: |e| per task, violation per constraint (> 0: violated; m or rad), CoM
    margin per polygon (m, > 0 inside), what q0 broke and, for a failed solve, its ``diagnosis``."""

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
    start_violations: list[StartViolation] = field(default_factory=list)
    diagnosis: Diagnosis | None = None


class IKProblem:
    """Tasks and constraints on one Pinocchio model, solved by a QP backend (qpsolvers name).
    ``constraint_tolerance``: what ``solve`` verifies on its answer (m); ``max_step``: the trust region on
    each tangent component of a step (rad or m); ``progress``: five kept steps in a row that lower the merit
    by less than this fraction end the loop."""

    def __init__(self, model: pin.Model, tasks: Sequence[Task], constraints: Sequence[Constraint] = (),
                 *, backend: str = backends.DEFAULT, damping: float = 1e-9, lm_damping: float = 1e-3,
                 max_step: float = 0.2, constraint_tolerance: float = 1e-6,
                 hierarchy_slack: float = 1e-10, progress: float = 1e-6):
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
        for constraint in self.constraints:
            constraint.bind(model)
        self._limits = [c for c in self.constraints if isinstance(c, JointPositionLimits)]
        self._equalities = [c for c in self.constraints if isinstance(c, EqualityConstraint)]
        self._bounds = [c for c in self.constraints if isinstance(c, BoundConstraint)]
        self._box = backends.StackedConstraints(self.nv, capacity=1)
        self._inequalities = [c for c in self.constraints if isinstance(c, InequalityConstraint)]
        self.qp = QPStep(self.kinematics, self.tasks, self.constraints, self.backend, self.damping,
                         self.lm_damping, self.hierarchy_slack)
        self._started = False
        # constraints that remember the steps taken (acceleration limits: the previous velocity)
        self._memories = [c for c in self.constraints if type(c).stepped is not Constraint.stepped]
        self._start_violations: list[StartViolation] = []

    def start(self, q: np.ndarray, clip: bool = True) -> None:
        """Start the tasks and constraints at q, first clipped into the joint limits if ``clip``."""
        q = self.clip(np.asarray(q, dtype=float)) if clip else np.array(q, dtype=float)
        self.kinematics.update(q)
        for item in (*self.tasks, *self.constraints):
            item.start(self.kinematics)
        self.qp.start()
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

    def step(self, q: np.ndarray | None = None, dt: float = 1.0, max_step: float | None = None,
             profile: dict[str, float] | None = None, velocity: np.ndarray | None = None) -> np.ndarray:
        """The QP displacement dq at q (default: the current q), v = dq / dt for control; NoQPSolutionError
        (``conflict``: the hard rows that conflict) without a solution. ``velocity`` (nv): the joint velocity
        for acceleration limits (default: the last dq / dt); ``profile``: seconds per ``PHASES`` added."""
        tick = time.perf_counter() if profile is not None else 0.0
        if not self._started:
            self.start(self.kinematics.q if q is None else q, clip=False)
        elif q is not None:
            self.kinematics.update(q)
        if profile is not None:
            self.kinematics.com()  # (lazy) here, so that "constraints" only builds rows
            lap(profile, "kinematics", tick)
        if velocity is not None:
            for constraint in self._memories:
                constraint.velocity = np.asarray(velocity, dtype=float).reshape(self.nv).copy()
        self.qp.refresh()  # a caller may have moved a task's target since the last step
        radius = self.max_step if max_step is None else max_step
        try:
            dq = self.qp.solve(dt, radius, profile)
        except NoQPSolutionError as exc:
            exc.conflict = tuple(self.conflict(dt, radius))
            raise
        for constraint in self._memories:
            constraint.stepped(dq, dt)
        return dq

    def conflict(self, dt: float = 1.0, max_step: float | None = None) -> list:
        """The conflicting hard rows of a failed step at q (:func:`wbik.qp.elastic.conflict`; empty: none)."""
        return conflict(step_rows(self.qp, dt, self.max_step if max_step is None else max_step))

    def diagnose(self, solution: QPSolution | None = None) -> Diagnosis:
        """Why the solve stopped at q; ``solution`` (the one q was returned in) gives its reason and start."""
        if solution is not None and not self._stands_at(solution.q):
            self.kinematics.update(solution.q)
        self.qp.refresh()
        return diagnose(self, solution.reason if solution is not None else "",
                        solution.start_violations if solution is not None else self._start_violations)

    def project(self, tolerance: float = 1e-12, max_iterations: int = 6,
                violation: float | None = None) -> bool:
        """Newton steps onto the contacts, min |dq|^2 s.t. J_c dq = -e_c and the other constraints: whether
        they hold to ``tolerance`` then. No step raises the inequality ``violation`` (default: measured)."""
        if not (equalities := self._equalities):
            return True
        kinematics = self.kinematics
        allowed = None
        for _ in range(max_iterations):
            if self._equalities_met(tolerance):
                return True
            # cheap first: the minimum-norm Newton step dq = A^T (A A^T)^-1 b, kept if it keeps every
            # bound and, by FK, the inequalities; otherwise the QP with every constraint
            rows = [c.equality(kinematics) for c in equalities]
            A, b = rows[0] if len(rows) == 1 else (np.vstack([r.A for r in rows]),
                                                     np.concatenate([r.b for r in rows]))
            try:
                dq = A.T @ np.linalg.solve(A @ A.T, b)
            except np.linalg.LinAlgError:
                dq = None
            if dq is not None and self._within_bounds(dq):
                if not self._inequalities:
                    kinematics.update(kinematics.integrate(dq))
                    continue
                if allowed is None:
                    allowed = max(self._inequality_violation() if violation is None else violation, 0.0)
                q = kinematics.q.copy()
                kinematics.update(kinematics.integrate(dq))
                if (after := self._inequality_violation()) <= allowed + 1e-15:
                    allowed = after
                    continue
                kinematics.update(q)  # it broke an inequality: the QP's projection instead
            try:
                dq = self.qp.minimum_norm(self.qp.build_constraints(1.0, self.max_step, recover=False))
            except NoQPSolutionError:
                return False
            kinematics.update(self.clip(kinematics.integrate(dq)))
        return self._equalities_met(tolerance)

    def task_errors(self) -> dict[str, float]:
        """|e| per task name at the current q."""
        self.qp.fill_tasks()
        return {task.name: level.error_norm(index)
                for level in self.qp.levels for index, task in enumerate(level.tasks)}

    def _merit_and_goals(self) -> tuple[float, bool]:
        """(merit: the task cost, each lower level scaled by 1e-6; every goal task under its tolerance)."""
        self.qp.fill_tasks()
        cost, goals_met = 0.0, True
        for index, level in enumerate(self.qp.levels):
            error = level.error
            cost += float(level.weight.dot(error * error)) * 1e-6 ** index
            goals_met = goals_met and all(math.sqrt(float(goal_error.dot(goal_error))) <= task.tolerance
                                          for task, goal_error in level.goal_errors)
            if level.inequalities:  # their cost and error: max(0, e)
                excess = np.maximum(level.inequality_error, 0.0)
                cost += float(level.inequality_weight.dot(excess * excess)) * 1e-6 ** index
                goals_met = goals_met and all(float(np.linalg.norm(np.maximum(error, 0.0))) <= task.tolerance
                                              for task, error in level.inequality_goal_errors)
        return cost, goals_met

    def _equalities_met(self, tolerance: float) -> bool:
        return all(constraint.violation(self.kinematics) <= tolerance for constraint in self._equalities)

    def _inequality_violation(self) -> float:
        return sum(constraint.violation(self.kinematics) for constraint in self._inequalities)

    def _checks(self) -> tuple[float, bool, float]:
        """(merit, goals met, inequality violation) at the current q."""
        return *self._merit_and_goals(), self._inequality_violation()

    def _at_rest(self) -> None:
        for constraint in self._memories:  # (acceleration limits: the motion stops here)
            constraint.stepped(np.zeros(self.nv), 1.0)

    def _trial(self, merit: float, violation: float,
               profile: dict[str, float] | None = None) -> tuple[bool, float, bool, float]:
        """(kept, merit, goals met, inequality violation) at q: kept when it keeps the merit and the
        inequalities by FK or, while the kept iterate breaks inequalities, when it reduces their violation."""
        trial_merit, goals_met, trial_violation = self._timed(profile, "checks", self._checks)
        if violation > 0.0:
            return trial_violation < violation, trial_merit, goals_met, trial_violation
        kept = trial_violation <= 0.0 and trial_merit <= merit + 1e-15
        return kept, trial_merit, goals_met, trial_violation

    def solve(self, q0: np.ndarray, max_iterations: int = 200, deadline: float | None = None,
              equality_tolerance: float = 1e-10, stall: float = 1e-12,
              profile: dict[str, float] | None = None, diagnose: bool = True) -> QPSolution:
        """QP steps from q0 until the goal tasks are under their tolerance and the contacts within
        ``equality_tolerance``; a step not kept (:meth:`_trial`) shrinks the trust region, a radius or step
        under ``stall`` ends the loop. ``profile``: seconds per ``PHASES`` and ``SOLVE_PHASES``."""
        start_time = time.perf_counter()
        q0 = np.asarray(q0, dtype=float)
        self.start(q0)
        outside = bool(self._limits) and not self._stands_at(q0)  # (start clipped q0 into the limits)
        self._at_rest()
        lap(profile, "start", start_time)
        kinematics = self.kinematics
        tolerance = 0.1 * equality_tolerance
        self._timed(profile, "projection", self.project, tolerance)
        q = kinematics.q.copy()
        if profile is not None:  # the first step's task rows, filled here for the merit
            self._timed(profile, "tasks", self.qp.fill_tasks)
        merit, goals_met, violation = self._timed(profile, "checks", self._checks)
        # what the start breaks: joints outside their limits (clipped), inequalities (repaired first)
        self._start_violations = ([found for constraint in self.constraints
                                   for found in constraint.start_violations(kinematics, q0)]
                                  if outside or violation > 1e-9 else [])
        radius, slow, reason, converged, iteration = self.max_step, 0, "", False, 0
        for iteration in range(1, max_iterations + 1):
            if goals_met:
                if self._timed(profile, "checks", self._equalities_met, equality_tolerance):
                    converged = True
                    iteration -= 1
                    break
                # the goals hold, the contacts still drift
                if self._timed(profile, "projection", self.project, tolerance, 6, violation):
                    q = kinematics.q.copy()
                    merit, goals_met, violation = self._checks()
                    if goals_met:
                        converged = True
                        break
            if deadline is not None and time.perf_counter() > deadline:
                reason = "time budget used up"
                break
            try:
                dq = self.qp.solve(1.0, radius, profile, recover=False)  # (iterates are inside the limits)
            except NoQPSolutionError as exc:
                if iteration > 1 and not self._equalities_met(tolerance) and self._timed(
                        profile, "projection", self.project, tolerance) and self._inequality_violation() \
                        <= max(violation, 0.0) + 1e-15:
                    # the contacts drift more than the step box lets one step repair: back onto them
                    q = kinematics.q.copy()
                    merit, goals_met, violation = self._checks()
                    radius = self.max_step
                    continue
                reason = (f"the QP has no solution ({exc}): the constraints conflict at this configuration"
                          if iteration == 1 else
                          f"best effort: {self.backend} found no further step (radius {radius:.2g})")
                break
            step_size = float(np.abs(dq).max()) if dq.size else 0.0
            tick = time.perf_counter() if profile is not None else 0.0
            kinematics.update(self._clipped(pin.integrate(self.model, q, dq)))
            tick = lap(profile, "kinematics", tick)
            if profile is not None:  # the next step's task rows, filled here for the merit
                self.qp.fill_tasks()
            lap(profile, "tasks", tick)
            kept, trial_merit, trial_goals_met, trial_violation = self._trial(merit, violation, profile)
            if not kept and not self._equalities_met(tolerance) and self._timed(
                    profile, "projection", self.project, tolerance, 6, trial_violation):
                kept, trial_merit, trial_goals_met, trial_violation = self._trial(merit, violation, profile)
            if kept:
                q = kinematics.q.copy()
                for constraint in self._memories:
                    constraint.stepped(dq, 1.0)
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
                self._at_rest()
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
        solution = self._report(q, converged, iteration, reason, start_time, profile)
        solution.start_violations = list(self._start_violations)
        if diagnose and not solution.success:
            solution.diagnosis = self.diagnose(solution)
            solution.reason = solution.diagnosis.reason_with_summary(solution.reason)
        return solution

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
        lap(profile, "report", tick)
        return QPSolution(q.copy(), converged and feasible, converged, feasible, iterations, reason,
                          time.perf_counter() - start_time, task_errors, violations, margins)
