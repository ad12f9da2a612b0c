"""Ours: joint-limit-bounded Levenberg-Marquardt with random restarts (``bounded_lm``).

One attempt, from a seed q inside the limits, iterates

    (J^T J + lambda_k I) dq = J^T e,     lambda_k = w |e|^2 + lambda_0,     q <- P(q + dq)

with e, J the task error and Jacobian (evaluated in world axes, which leaves |e|, J^T J and J^T e
unchanged: :class:`wbik.solvers.task_error.WorldTaskError`), w = ``cost_weight`` (0.01) and
lambda_0 = ``damping`` (1e-6). This is Sugihara's error-dependent damping: large far from the
target (robust start), vanishing near it (Newton-fast end). The system is solved by Cholesky.
A step that raises |e| is rejected and lambda_0 grows ten-fold; an accepted one halves it.
P is the projection into the limits: a revolute joint whose range spans a full turn is wrapped by
2 pi instead of clipped; otherwise joints are clipped, and a joint already on a bound whose step
points outwards is frozen and the step recomputed without it (an active-set, i.e. bounded, step).
``max_step`` optionally caps the largest joint step. Position rows are weighted by
``position_weight`` (default: 1 / the chain's length scale, at least 1), which puts metres and
radians on a par on small chains (Pincher, Bioloid legs); the FK check is unchanged.

An attempt ends when the FK check passes (success), when the error stops dropping (``stall``
iterations with less than 2 % progress: a local minimum or a limit), or after ``max_iterations``.
Then the next attempt starts from a random seed inside the limits, until the deadline; the result
is the first solution that passes, or the best attempt with a reason.

``batch_size`` > 1 advances that many seeds together in one vectorised numpy evaluation
(:class:`wbik.solvers.task_error.BatchKinematics`; seed 0 is q0, the others random), and stops at
the first seed that passes the check; stalled seeds are replaced by fresh random ones. On 6-7
joint chains the numpy batch costs more per seed than the single-seed loop (measured: several
times slower per solve), so the default is 1.

Defaults were tuned on the UR5, Panda and Pincher under TRAC-IK's protocol (benchmarks/numerical.py).
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.linalg.lapack import dposv

from wbik.solvers.base import Candidate, Solver
from wbik.solvers.task_error import BatchKinematics, WorldTaskError, converged
from wbik.targets import Target

TWO_PI = 2.0 * math.pi


class BoundedLMSolver(Solver):
    name = "bounded_lm"

    def __init__(self, robot, chain=None, *, max_iterations: int = 30, stall: int = 3,
                 damping: float = 1e-6, batch_size: int = 1, cost_weight: float = 0.01,
                 decrease: float = 0.5, increase: float = 10.0, progress: float = 0.98,
                 max_step: float | None = None, position_weight: float | None = None, **options):
        super().__init__(robot, chain, **options)
        self.max_iterations = int(max_iterations)
        self.stall = int(stall)
        self.damping = float(damping)
        self.batch_size = max(1, int(batch_size))
        self.cost_weight, self.decrease, self.increase = float(cost_weight), float(decrease), float(increase)
        self.progress = float(progress)
        self.max_step = None if max_step is None else float(max_step)
        self.position_weight = (chain_scale_weight(self.chain) if position_weight is None
                                else float(position_weight))
        weighted_position = self.tolerances.position * self.position_weight
        smallest = min(weighted_position, self.tolerances.rotation)
        largest = max(weighted_position, self.tolerances.rotation)
        self._sure_cost = (0.5 * smallest) ** 2  # |e|^2 below this passes both parts of the check
        self._maybe_cost = 2.0 * (0.5 * largest) ** 2
        chain_ = self.chain
        self.lower, self.upper = chain_.lower, chain_.upper
        self.wraps = (~chain_.is_prismatic) & (chain_.upper - chain_.lower >= TWO_PI - 1e-9)
        self._batch = BatchKinematics(chain_) if self.batch_size > 1 else None

    # -- projection into the limits -----------------------------------------------------------
    def project(self, q: np.ndarray) -> np.ndarray:
        """Wrap full-turn revolute joints by 2 pi into their range, clip the others."""
        if self.wraps.any():
            q = q.copy()
            wrapped = q[..., self.wraps]
            low = self.lower[self.wraps]
            outside = (wrapped < low) | (wrapped > self.upper[self.wraps])
            wrapped = np.where(outside, low + np.mod(wrapped - low, TWO_PI), wrapped)
            q[..., self.wraps] = wrapped
        return np.clip(q, self.lower, self.upper)

    # -- one seed ---------------------------------------------------------------------------------
    def _attempt(self, evaluate: WorldTaskError, q: np.ndarray, deadline: float
                 ) -> tuple[np.ndarray, bool, int, float]:
        """LM from q: (last q, converged?, iterations, |e|)."""
        lower, upper, wraps = self.lower, self.upper, self.wraps
        n = self.chain.nq
        diagonal = slice(None, None, n + 1)
        max_step = self.max_step
        weight = self.position_weight
        if weight != 1.0:
            unweighted = evaluate

            def evaluate(q):
                error, jacobian = unweighted(q)
                error[:3] *= weight
                jacobian[:3] *= weight
                return error, jacobian

        error, jacobian = evaluate(q)
        cost = float(error @ error)
        damping = self.damping
        best_cost, since_progress = cost, 0
        for iteration in range(1, self.max_iterations + 1):
            if cost <= self._sure_cost or (cost <= self._maybe_cost and self._passes(error)):
                return q, True, iteration - 1, math.sqrt(cost)
            if time.perf_counter() > deadline:
                break
            transpose = jacobian.T
            system = transpose @ jacobian
            gradient = transpose @ error
            system.flat[diagonal] += self.cost_weight * cost + damping
            _, step, info = dposv(system, gradient)
            if info:  # not numerically positive definite: least squares instead of Cholesky
                step = np.linalg.lstsq(system, gradient, rcond=None)[0]
            if max_step is not None:
                longest = float(np.abs(step).max())
                if longest > max_step:
                    step *= max_step / longest
            trial = q + step
            if (trial < lower).any() or (trial > upper).any():
                blocked = ((q <= lower) & (step < 0)) | ((q >= upper) & (step > 0))
                blocked &= ~wraps
                if blocked.any():
                    free = ~blocked
                    step = np.zeros(n)
                    if free.any():
                        step[free] = dposv(system[np.ix_(free, free)], gradient[free])[1]
                    trial = q + step
                trial = self.project(trial)
            trial_error, trial_jacobian = evaluate(trial)
            trial_cost = float(trial_error @ trial_error)
            if trial_cost < cost:
                q, error, jacobian, cost = trial, trial_error, trial_jacobian, trial_cost
                damping = max(damping * self.decrease, self.damping)
            else:
                damping = max(damping, 1e-3) * self.increase
            if cost < self.progress * best_cost:
                best_cost, since_progress = cost, 0
            else:
                since_progress += 1
                if since_progress >= self.stall:
                    return q, False, iteration, math.sqrt(cost)
        return q, self._passes(error), self.max_iterations, math.sqrt(cost)

    def _passes(self, error: np.ndarray) -> bool:
        """The shared check on a (position-weighted) error."""
        return converged(error, self.tolerances.position * self.position_weight, self.tolerances.rotation)

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        if self.batch_size > 1:
            return self._solve_batch(target, q0, deadline)
        evaluate = WorldTaskError(self.chain, target)
        q_seed = self.project(q0)
        best_q, best_error = q_seed, math.inf
        attempts, iterations = 0, 0
        while True:
            q, ok, used, error = self._attempt(evaluate, q_seed, deadline)
            attempts += 1
            iterations += used
            if ok:
                return Candidate(q, iterations, "", {"attempts": attempts})
            if error < best_error:
                best_q, best_error = q, error
            if time.perf_counter() > deadline:
                return Candidate(best_q, iterations,
                                 f"time budget of {self.timeout_s:g} s used up after {attempts} attempts "
                                 f"(best task error {best_error:.3g}); the target may be out of reach",
                                 {"attempts": attempts})
            q_seed = self.chain.random(self.rng)

    # -- many seeds at once ---------------------------------------------------------------------
    def _solve_batch(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        batch, size = self._batch, self.batch_size
        n = self.chain.nq
        tolerance_p, tolerance_r = self.tolerances.position, self.tolerances.rotation
        q = self.chain.random(self.rng, size)
        q[0] = self.project(q0)
        error, jacobian = batch.error_jacobian(target, q)
        cost = np.einsum("bi,bi->b", error, error)
        damping = np.full(size, self.damping)
        best_cost = cost.copy()
        since_progress = np.zeros(size, dtype=int)
        age = np.zeros(size, dtype=int)
        overall_q, overall_error = q[0].copy(), math.inf
        iterations, attempts = 0, size
        while True:
            position_norm = np.linalg.norm(error[:, :3], axis=1)
            done = position_norm <= 0.5 * tolerance_p
            if error.shape[1] == 6:
                done &= np.linalg.norm(error[:, 3:], axis=1) <= 0.5 * tolerance_r
            if done.any():
                winner = int(np.flatnonzero(done)[0])
                return Candidate(q[winner], iterations, "", {"attempts": attempts})
            if time.perf_counter() > deadline:
                break
            iterations += 1
            normal = np.einsum("bmi,bmj->bij", jacobian, jacobian)
            gradient = np.einsum("bmi,bm->bi", jacobian, error)
            system = normal + (self.cost_weight * cost + damping)[:, None, None] * np.eye(n)
            step = np.linalg.solve(system, gradient[..., None])[..., 0]
            if self.max_step is not None:
                longest = np.abs(step).max(axis=1)
                step *= np.minimum(1.0, self.max_step / np.maximum(longest, 1e-300))[:, None]
            blocked = ((q <= self.lower) & (step < 0)) | ((q >= self.upper) & (step > 0))
            blocked &= ~self.wraps
            if blocked.any():
                # freeze blocked joints: zero their rows/columns and keep the diagonal
                keep = ~blocked
                masked = system * keep[:, :, None] * keep[:, None, :]
                masked += np.eye(n) * blocked[:, :, None]
                step = np.linalg.solve(masked, (gradient * keep)[..., None])[..., 0]
            trial = self.project(q + step)
            trial_error, trial_jacobian = batch.error_jacobian(target, trial)
            trial_cost = np.einsum("bi,bi->b", trial_error, trial_error)
            better = trial_cost < cost
            q = np.where(better[:, None], trial, q)
            error = np.where(better[:, None], trial_error, error)
            jacobian = np.where(better[:, None, None], trial_jacobian, jacobian)
            cost = np.where(better, trial_cost, cost)
            damping = np.where(better, np.maximum(damping * self.decrease, self.damping),
                               np.maximum(damping, 1e-3) * self.increase)
            progress = cost < self.progress * best_cost
            best_cost = np.where(progress, cost, best_cost)
            since_progress = np.where(progress, 0, since_progress + 1)
            age += 1
            restart = (since_progress >= self.stall) | (age >= self.max_iterations)
            if restart.any():
                index = np.flatnonzero(restart)
                worst_best = int(index[np.argmin(cost[index])])
                if math.sqrt(cost[worst_best]) < overall_error:
                    overall_q, overall_error = q[worst_best].copy(), math.sqrt(cost[worst_best])
                q[index] = self.chain.random(self.rng, index.size)
                fresh_error, fresh_jacobian = batch.error_jacobian(target, q[index])
                error[index], jacobian[index] = fresh_error, fresh_jacobian
                cost[index] = np.einsum("bi,bi->b", fresh_error, fresh_error)
                best_cost[index] = cost[index]
                damping[index] = self.damping
                since_progress[index] = 0
                age[index] = 0
                attempts += index.size
        current_best = int(np.argmin(cost))
        if math.sqrt(cost[current_best]) < overall_error:
            overall_q, overall_error = q[current_best].copy(), math.sqrt(cost[current_best])
        return Candidate(overall_q, iterations,
                         f"time budget of {self.timeout_s:g} s used up after {attempts} seeds "
                         f"(best task error {overall_error:.3g}); the target may be out of reach",
                         {"attempts": attempts})


def chain_scale_weight(chain) -> float:
    """1 / (the chain's length scale, m), at least 1: puts metres and radians on a par on small arms.

    The length scale is the sum of the distances between consecutive joint origins and the tip.
    """
    from wbik.solvers.task_error import serial_structure

    length = float(np.linalg.norm(serial_structure(chain).placements[1:, :3, 3], axis=1).sum())
    return max(1.0, 1.0 / max(length, 1e-3))
