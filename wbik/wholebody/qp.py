"""Method ``qp``: our task QP (:class:`wbik.qp.IKProblem`) on the whole model, behind the whole-body
interface of :mod:`wbik.wholebody.solvers` (see there for what it keeps hard and how it is budgeted)."""

from __future__ import annotations

import math

from wbik.qp.diagnosis import last_solve_diagnosis
from wbik.qp.tasks import RegularizationTask
from wbik.wholebody.methods import WholeBodyMethod
from wbik.wholebody.problem import WholeBody
from wbik.wholebody.problem import WholeBodyResult
from wbik.wholebody.solvers import WholeBodyCandidate
from wbik.wholebody.solvers import WholeBodySolver
from wbik.wholebody.solvers import lowest_priority


class QPWholeBody(WholeBodySolver):
    """Our task QP (wbik.qp.IKProblem) on the whole model."""

    name = "qp"
    # the budget's unit: a DAQP step, projection, FK checks (measured: docs/measurements.md, wholebody)
    iteration_cost_s = 800e-6
    default_budget_s = 0.08

    def __init__(
        self,
        robot,
        *,
        backend: str = "default",
        max_step: float = 0.2,
        lm_damping: float = 1e-3,
        regularization: float = 1e-6,
        diagnose: bool = True,
        **options,
    ):
        from wbik.qp import backends

        super().__init__(robot, **options)
        self.backend = backends.resolve(backend)
        self.max_step, self.lm_damping, self.regularization = (
            float(max_step),
            float(lm_damping),
            float(regularization),
        )
        self.diagnose = bool(diagnose)

    def solve(self, problem: WholeBody, q0=None) -> WholeBodyResult:
        """The shared check's result; one that fails it gets the QP's diagnosis (after the timing), and
        a start outside the limits is reported in ``diagnosis.start`` either way."""
        self._local.last = None
        result = super().solve(problem, q0)
        result.diagnosis, result.reason = last_solve_diagnosis(self._local, result.success, self.diagnose,
                                                               result.reason)
        return result

    def _solve(self, problem, q0, placements, polygon, deadline):
        from wbik.qp.problem import IKProblem

        model = self.robot.model
        tasks = problem.copied_tasks()
        tolerance = 0.5 * min(self.tolerances.position, self.tolerances.rotation)
        for task in tasks:
            if task.goal:
                task.tolerance = min(task.tolerance, tolerance)
        # on the lowest level: on a level above others, its kept rows sqrt(w) dq would pin the step for them
        tasks.append(RegularizationTask(self.regularization, priority=lowest_priority(tasks)))
        constraints = problem.constraints(placements, polygon)
        ik = IKProblem(
            model,
            tasks,
            constraints,
            backend=self.backend,
            max_step=self.max_step,
            lm_damping=self.lm_damping,
        )
        solution = ik.solve(
            q0, max_iterations=self.max_iterations, deadline=None if deadline == math.inf else deadline,
            diagnose=False,
        )
        self._local.last = (ik, solution)
        return WholeBodyCandidate(
            solution.q,
            solution.iterations,
            solution.reason,
            {"backend": self.backend, "converged": solution.converged},
        )


WHOLEBODY_METHODS = (
    WholeBodyMethod(
        "qp", QPWholeBody,
        "our task QP (wbik.qp.IKProblem): hard contacts, hard CoM polygon, limits; backend= any installed",
    ),
)
"""The methods this module declares (registered through wbik.wholebody.methods.METHOD_MODULES)."""
