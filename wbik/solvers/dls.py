"""Damped least squares (Levenberg-Marquardt) with adaptive damping.

Step: dq = J^T (J J^T + lambda I)^-1 e, then q <- clip(q + dq). A step that lowers |e| is kept
and lambda shrinks; one that does not is rejected and lambda grows. Joint limits are kept by
clipping (projection). Stops on the shared tolerance, a stall, the iteration budget
(``max_iterations``; by default the iterations that cost about 5 ms here) or, when ``timeout_s`` is
given, the deadline.
"""

from __future__ import annotations

import time

import numpy as np

from wbik.solvers.base import Candidate, Solver
from wbik.solvers.task_error import converged, task_error
from wbik.targets import Target


class DampedLeastSquares(Solver):
    name = "dls"
    iteration_cost_s = 30e-6  # a trial FK + Jacobian and a damped solve; measured 27-29 us here

    def __init__(self, robot, chain=None, *, max_iterations: int | None = None, damping: float = 1e-3,
                 **options):
        super().__init__(robot, chain, **options)
        self.max_iterations = self._iteration_budget(max_iterations)
        self.initial_damping = float(damping)

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        chain = self.chain
        q = chain.clip(q0)
        error, jacobian = task_error(chain, target, q)
        cost = float(error @ error)
        damping = self.initial_damping
        identity = np.eye(error.size)
        for iteration in range(1, self.max_iterations + 1):
            if converged(error, self.tolerances.position, self.tolerances.rotation):
                return Candidate(q, iteration - 1)
            if time.perf_counter() > deadline:
                return Candidate(q, iteration - 1, f"wall-clock budget of {self.timeout_s:g} s used up")
            step = jacobian.T @ np.linalg.solve(jacobian @ jacobian.T + damping * identity, error)
            trial = chain.clip(q + step)
            trial_error, trial_jacobian = task_error(chain, target, trial)
            trial_cost = float(trial_error @ trial_error)
            if trial_cost < cost:
                q, error, jacobian, cost = trial, trial_error, trial_jacobian, trial_cost
                damping = max(damping * 0.3, 1e-12)
            else:
                damping *= 4.0
                if damping > 1e6:
                    return Candidate(q, iteration, "stalled in a local minimum (damping saturated)")
        return Candidate(q, self.max_iterations,
                         f"iteration budget used up: no convergence in {self.max_iterations} iterations")
