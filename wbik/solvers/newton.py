"""Newton-Raphson IK (seed 001, arm3r.md): q <- clip(q - x), J x = e on the pose error (3 rows for a
position), x by LU where J is square and regular, else J^+ e; steps scaled down to ``max_step`` (None: pure
Newton). Stops on the shared tolerance, the budget, or a stall (the best error not 0.1 % lower in
``stall_iterations``).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg

from wbik.solvers.base import Solver
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate
from wbik.solvers.task_error import converged, task_error
from wbik.targets import Target


def newton_step(jacobian: np.ndarray, error: np.ndarray) -> np.ndarray:
    """x with J x = e (the step is dq = -x): LU where J is square and regular, least squares otherwise."""
    rows, columns = jacobian.shape
    if rows == columns:
        lu, pivots, info = scipy.linalg.lapack.dgetrf(jacobian)
        diagonal = np.abs(np.diag(lu))
        if info == 0 and diagonal.min() > 1e-12 * max(diagonal.max(), 1.0):
            return scipy.linalg.lapack.dgetrs(lu, pivots, error)[0]
    return np.linalg.lstsq(jacobian, error, rcond=1e-10)[0]


class NewtonRaphson(Solver):
    name = "newton"
    iteration_cost_s = 30e-6  # one FK + Jacobian and one LU or least-squares solve

    def __init__(self, robot, chain=None, *, max_iterations: int | None = None, stall_iterations: int = 10,
                 max_step: float | None = None, **options):
        super().__init__(robot, chain, **options)
        self.max_iterations = self._iteration_budget(max_iterations)
        self.stall_iterations = int(stall_iterations)
        self.max_step = None if max_step is None else float(max_step)

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        chain = self.chain
        q = chain.clip(q0)
        error, jacobian = task_error(chain, target, q)
        best_q, best_norm, best_iteration = q, float(np.linalg.norm(error)), 0
        for iteration in range(1, self.max_iterations + 1):
            if converged(error, self.tolerances.position, self.tolerances.rotation):
                return Candidate(q, iteration - 1)
            if time.perf_counter() > deadline:
                return Candidate(best_q, iteration - 1, f"wall-clock budget of {self.timeout_s:g} s used up "
                                 f"(best task error {best_norm:.3g})")
            step = newton_step(jacobian, error)
            if self.max_step is not None:
                length = float(np.linalg.norm(step))
                if length > self.max_step:
                    step *= self.max_step / length
            q = chain.clip(q - step)
            error, jacobian = task_error(chain, target, q)
            norm = float(np.linalg.norm(error))
            if norm < best_norm * (1.0 - 1e-3):
                best_iteration = iteration
            if norm < best_norm:
                best_q, best_norm = q, norm
            if iteration - best_iteration >= self.stall_iterations:
                return Candidate(best_q, iteration, stall_reason(chain, best_q, best_norm, iteration))
        if converged(error, self.tolerances.position, self.tolerances.rotation):
            return Candidate(q, self.max_iterations)
        return Candidate(best_q, self.max_iterations,
                         f"iteration budget used up: no convergence in {self.max_iterations} iterations "
                         f"(best task error {best_norm:.3g})")


def stall_reason(chain, q: np.ndarray, error_norm: float, iteration: int) -> str:
    """Why the iteration stopped making progress, with the evidence."""
    _, jacobian = chain.fk_jacobian(q)
    singular_values = np.linalg.svd(jacobian, compute_uv=False)
    smallest = float(singular_values[min(chain.nq, 6) - 1]) if singular_values.size else 0.0
    at_limit = [name for name, value, low, high in zip(chain.joint_names, q, chain.lower, chain.upper,
                                                       strict=True)
                if value <= low + 1e-9 or value >= high - 1e-9]
    detail = f"smallest singular value of J {smallest:.2g}"
    if at_limit:
        detail += f"; at a joint limit: {', '.join(at_limit)}"
    return (f"stalled after {iteration} iterations with task error {error_norm:.3g} ({detail}): "
            "the target is probably out of reach or outside the joint limits")


IK_METHODS = (
    IKMethod("newton", NewtonRaphson,
             "Newton-Raphson (seed 001): LU where J is square, least squares otherwise"),
)
