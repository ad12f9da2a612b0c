"""Damped least squares: dq = -J^T (J J^T + lambda I)^-1 e on the pose error (:mod:`wbik.solvers.task_error`),
lambda from ``damping``, x0.3 (down to 1e-12) on an accepted step, x4 on a rejected one; joints clipped.
Stops on the shared tolerance, a stall (lambda above 1e6) or the budget.
"""

from __future__ import annotations

import time

import numpy as np

from wbik.solvers.base import Solver
from wbik.solvers.levenberg_marquardt import JointBounds, LevenbergMarquardt
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate
from wbik.solvers.task_error import converged, task_error
from wbik.targets import Target


class DampedLeastSquares(Solver):
    name = "dls"
    iteration_cost_s = 30e-6  # a trial FK + Jacobian and a damped solve

    def __init__(self, robot, chain=None, *, max_iterations: int | None = None, damping: float = 1e-3,
                 **options):
        super().__init__(robot, chain, **options)
        self.max_iterations = self._iteration_budget(max_iterations)
        self.policy = LevenbergMarquardt(cost_weight=0.0, floor=1e-12, start=float(damping),
                                         decrease=0.3, increase=4.0, reject_floor=0.0, stall=0,
                                         max_damping=1e6)
        self.bounds = JointBounds(self.chain.lower, self.chain.upper)  # clipped, never wrapped

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        chain, policy, bounds = self.chain, self.policy, self.bounds
        q = chain.clip(q0)
        error, jacobian = task_error(chain, target, q)
        cost = float(error @ error)
        damping, best, since = policy.first_damping, cost, 0
        workspace = policy.workspace(*jacobian.shape)
        for iteration in range(1, self.max_iterations + 1):
            if converged(error, self.tolerances.position, self.tolerances.rotation):
                return Candidate(q, iteration - 1)
            if time.perf_counter() > deadline:
                return Candidate(q, iteration - 1, f"wall-clock budget of {self.timeout_s:g} s used up")
            trial = policy.trial(jacobian, error, cost, damping, q, bounds, workspace)
            trial_error, trial_jacobian = task_error(chain, target, trial)
            trial_cost = float(trial_error @ trial_error)
            accepted = trial_cost < cost
            if accepted:
                q, error, jacobian, cost = trial, trial_error, trial_jacobian, trial_cost
            damping, best, since, stalled = policy.update(accepted, damping, cost, best, since)
            if stalled:  # no progress test here (stall=0): only the damping can saturate
                return Candidate(q, iteration, "stalled in a local minimum (damping saturated)")
        return Candidate(q, self.max_iterations,
                         f"iteration budget used up: no convergence in {self.max_iterations} iterations")


IK_METHODS = (
    IKMethod("dls", DampedLeastSquares,
             "damped least squares on the Pinocchio model (adaptive damping, joint limits by clipping)"),
)
