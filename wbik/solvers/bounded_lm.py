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
import pinocchio as pin
from scipy.linalg.lapack import dposv

from wbik.solvers.base import Candidate, Solver
from wbik.solvers.task_error import BatchKinematics, converged
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
        self._model, self._data = chain_.model, chain_.model.createData()
        self._identity = np.eye(chain_.nq)

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
    def _attempt(self, goal: pin.SE3, pose: bool, q: np.ndarray, deadline: float
                 ) -> tuple[np.ndarray, bool, int, float]:
        """LM from q towards ``goal`` (tip pose in the model's world frame): (last q, converged?,
        iterations, |e|).

        Errors and Jacobians are taken in the tip's own axes: e = [R^T (p* - p); log3(R^T R*)] and
        the LOCAL frame Jacobian. They are the world-axes ones rotated by R^T, so |e|, J^T J and
        J^T e (all a step needs) are unchanged, and three Pinocchio calls plus one SE3 product give both.
        Hot loop: no Python-level helpers beyond the error evaluation, small numpy calls only.
        """
        model, data, tip = self._model, self._data, self.chain.tip_id
        joint_jacobians, frame_jacobian = pin.computeJointJacobians, pin.getFrameJacobian
        placement, log3, local = pin.updateFramePlacement, pin.log3, pin.ReferenceFrame.LOCAL
        lower, upper, n = self.lower, self.upper, self.chain.nq
        clipped, any_wrap = ~self.wraps, bool(self.wraps.any())
        unblocked = np.zeros(n, dtype=bool).tobytes()
        weight = self.position_weight
        weighted = weight != 1.0
        identity = self._identity
        cost_weight, floor, decrease, increase = self.cost_weight, self.damping, self.decrease, self.increase
        progress, stall, max_step = self.progress, self.stall, self.max_step
        sure_cost, maybe_cost = self._sure_cost, self._maybe_cost

        def evaluate(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            joint_jacobians(model, data, q)  # forward kinematics and every joint's Jacobian
            offset = placement(model, data, tip).actInv(goal).homogeneous
            jacobian = frame_jacobian(model, data, tip, local)
            if pose:
                error = np.empty(6)
                error[:3] = offset[:3, 3]
                error[3:] = log3(offset[:3, :3])
            else:
                error, jacobian = offset[:3, 3].copy(), jacobian[:3]
            if weighted:
                error[:3] *= weight
                jacobian[:3] *= weight
            return error, jacobian

        error, jacobian = evaluate(q)
        cost = float(error.dot(error))
        damping = floor
        best_cost, since_progress = cost, 0
        for iteration in range(1, self.max_iterations + 1):
            if cost <= sure_cost or (cost <= maybe_cost and self._passes(error)):
                return q, True, iteration - 1, math.sqrt(cost)
            if time.perf_counter() > deadline:
                break
            transpose = jacobian.T
            system = transpose.dot(jacobian)
            system += (cost_weight * cost + damping) * identity
            gradient = transpose.dot(error)
            _, step, info = dposv(system, gradient)
            if info:  # not numerically positive definite: least squares instead of Cholesky
                step = np.linalg.lstsq(system, gradient, rcond=None)[0]
            if max_step is not None:
                longest = float(np.abs(step).max())
                if longest > max_step:
                    step *= max_step / longest
            trial = q + step
            inside = np.maximum(np.minimum(trial, upper), lower)
            if inside.tobytes() != trial.tobytes():  # some joint left its range
                blocked = (q <= lower) & (step < 0)
                blocked |= (q >= upper) & (step > 0)
                blocked &= clipped
                if blocked.tobytes() != unblocked:
                    free = np.flatnonzero(~blocked)
                    step = np.zeros(n)
                    if free.size:
                        step[free] = dposv(system[free[:, None], free], gradient[free])[1]
                    trial = q + step
                inside = self.project(trial) if any_wrap else np.maximum(np.minimum(trial, upper), lower)
            trial_error, trial_jacobian = evaluate(inside)
            trial_cost = float(trial_error.dot(trial_error))
            if trial_cost < cost:
                q, error, jacobian, cost = inside, trial_error, trial_jacobian, trial_cost
                damping = max(damping * decrease, floor)
            else:
                damping = max(damping, 1e-3) * increase
            if cost < progress * best_cost:
                best_cost, since_progress = cost, 0
            else:
                since_progress += 1
                if since_progress >= stall:
                    return q, False, iteration, math.sqrt(cost)
        return q, self._passes(error), self.max_iterations, math.sqrt(cost)

    def _passes(self, error: np.ndarray) -> bool:
        """The shared check on a (position-weighted) error."""
        return converged(error, self.tolerances.position * self.position_weight, self.tolerances.rotation)

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        if self.batch_size > 1:
            return self._solve_batch(target, q0, deadline)
        goal = self.chain.base_placement * target.se3()
        pose = target.is_pose
        q_seed = self.project(q0)
        best_q, best_error = q_seed, math.inf
        attempts, iterations = 0, 0
        while True:
            q, ok, used, error = self._attempt(goal, pose, q_seed, deadline)
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
