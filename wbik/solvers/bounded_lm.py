"""Ours: joint-limit-bounded Levenberg-Marquardt with restarts (``bounded_lm``).

An attempt iterates :mod:`wbik.solvers.levenberg_marquardt`'s policy on e = log6(T*^-1 T) with the tip-axes
Jacobian (e = p - p* for a position), position rows weighted by ``position_weight``. Restarts spend the
iteration budget: q0 and the seed table's nearest entry, the seed library's nearest entries
(:mod:`wbik.solvers.seeds`), then ``batch_size`` seeds together, a stalled one replaced from the call's own
random stream. Defaults and costs: docs/measurements.md, bounded_lm.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pinocchio as pin

from wbik.errors import RobotDescriptionError
from wbik.kernels.twins import chosen, compiled_twin
from wbik.solvers.base import Solver
from wbik.solvers.check import evaluate
from wbik.solvers.levenberg_marquardt import (
    JointBounds,
    LevenbergMarquardt,
    batch_cost,
    keep_better,
)
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate, IKResult
from wbik.solvers.seeds import seed_library, seed_table
from wbik.solvers.task_error import converged, serial_structure
from wbik.solvers.vectorised_chain import VectorisedChain
from wbik.targets import Target, as_target

_LOCAL, _WORLD_ALIGNED = pin.ReferenceFrame.LOCAL, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_IDENTITY = np.eye(3)
_IDENTITY.flags.writeable = False
FIRST_QUERY = 3  # library entries asked for by a call's first k-d tree query (the rest by a second)
BATCH_ITERATION_UNITS = 10  # budget units of one batch iteration (32 seeds): its time over one seed's
_LM_ATTEMPT = compiled_twin("lm_trial", "lm_attempt")  # _attempt's on a pose target (None: not built)


@dataclass
class _CallDraws:
    """Uniform seeds of one call from its own stream, drawn lazily (most calls need none)."""

    solver: BoundedLMSolver
    target: Target
    q0: np.ndarray
    pool: np.ndarray | None = None
    used: int = 0
    rng: np.random.Generator | None = None

    def take(self, count: int) -> np.ndarray:
        """``count`` uniform seeds inside the limits (one generator call per 256)."""
        if self.pool is None or self.used + count > len(self.pool):
            if self.pool is None:
                self.rng = self.solver._call_rng(self.target, self.q0)
            self.pool, self.used = self.solver.chain.random(self.rng, max(256, count)), 0
        self.used += count
        return self.pool[self.used - count:self.used]


class BoundedLMSolver(Solver):
    """Bounded LM with restarts. Options: ``max_iterations`` (single-seed iterations; default about 5 ms);
    ``attempt_iterations``, ``stall``, ``progress``: an attempt's end; ``damping``, ``cost_weight``,
    ``decrease``, ``increase``, ``max_step``: :class:`LevenbergMarquardt`'s; ``position_weight`` (default 1 /
    the chain's length, at least 1); ``single_attempts`` before the batch; ``batch_size`` (1: one at a
    time); ``library_size`` (0: uniform restarts), ``library_share`` of the first batch; ``candidates``: a
    uniform restart is the best of this many draws; ``table_size`` (0: none), ``table_margin``: the share
    of each range kept off the limits."""

    name = "bounded_lm"
    table_first = 0.1  # the seed-table entry goes before q0 when its distance^2 < this x |e(q0)|^2
    iteration_cost_s = 20e-6  # a single-seed iteration of the Python trial (the compiled one keeps it)

    def __init__(self, robot, chain=None, *, max_iterations: int | None = None,
                 attempt_iterations: int = 30, stall: int = 3,
                 damping: float = 1e-6, batch_size: int = 32, cost_weight: float = 0.01,
                 decrease: float = 0.3, increase: float = 10.0, progress: float = 0.9,
                 max_step: float | None = None, position_weight: float | None = None,
                 candidates: int = 3, single_attempts: int = 12, library_size: int = 8192,
                 library_share: float = 0.5, table_size: int = 1024, table_margin: float = 0.1,
                 **options):
        super().__init__(robot, chain, **options)
        self.max_iterations = self._iteration_budget(max_iterations)
        self.attempt_iterations = int(attempt_iterations)
        self.policy = LevenbergMarquardt(
            cost_weight=float(cost_weight), floor=float(damping), decrease=float(decrease),
            increase=float(increase), progress=float(progress), stall=int(stall),
            max_step=None if max_step is None else float(max_step))
        self.batch_size = max(1, int(batch_size))
        self.candidates = max(1, int(candidates))
        self.single_attempts = max(0, int(single_attempts))
        self.position_weight = (chain_scale_weight(self.chain) if position_weight is None
                                else float(position_weight))
        weighted_position = self.tolerances.position * self.position_weight
        smallest = min(weighted_position, self.tolerances.rotation)
        largest = max(weighted_position, self.tolerances.rotation)
        self._sure_cost = (0.5 * smallest) ** 2  # |e|^2 below this passes both parts of the check
        self._maybe_cost = 2.0 * (0.5 * largest) ** 2
        chain_ = self.chain
        self.bounds = JointBounds.of_chain(chain_)
        self._trial = self.policy.trial_function(self.bounds)
        self.library_share = float(library_share)
        try:
            self._vectorised = VectorisedChain(chain_, self.position_weight)
        except RobotDescriptionError:  # not a serial chain: one seed at a time, uniform restarts
            self._vectorised, self.batch_size, library_size, table_size = None, 1, 0, 0
        self._library = seed_library(chain_, max(0, int(library_size)), self.position_weight,
                                     self._vectorised)
        self._table = seed_table(chain_, max(0, int(table_size)), self.position_weight, self._vectorised,
                                 float(table_margin))
        self._model = scaled_model(chain_.model, self.position_weight)
        self._base = None if chain_.base_placement.isIdentity() else chain_.base_placement
        # the scaled model scales placements; a prismatic joint's travel is scaled through q itself
        scales_travel = chain_.is_prismatic.any() and self.position_weight != 1.0
        self._joint_scale = (np.where(chain_.is_prismatic, self.position_weight, 1.0) if scales_travel
                             else None)
        self._compiled = self._compiled_arrays()

    def _compiled_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The compiled attempt's (chain, joints, settings) (its C file says what they hold), or None
        where it is not built, switched off or not for this chain: the Python loop."""
        kinematics, policy, bounds = self._vectorised, self.policy, self.bounds
        if (chosen(None, _LM_ATTEMPT, "lm_trial") is None or kinematics is None
                or self._joint_scale is not None or kinematics.n > 32):
            return None
        n, linear = kinematics.n, kinematics.linear
        steps = [linear[row, 16 * (row % n):16 * (row % n + 1)] for row in range(2 * n)]  # C1, then C2
        chain = np.vstack([kinematics.first.reshape(1, 16), kinematics.constant.reshape(n, 16), *steps])
        joints = np.array([bounds.lower, bounds.upper, bounds.wraps, kinematics.prismatic], dtype=float)
        settings = np.array([
            self.position_weight, policy.cost_weight, policy.floor, policy.decrease, policy.increase,
            policy.reject_floor, policy.progress, policy.stall,
            math.inf if policy.max_damping is None else policy.max_damping,
            -1.0 if policy.max_step is None else policy.max_step, policy.first_damping, self._sure_cost,
            self._maybe_cost, 0.5 * self.tolerances.position * self.position_weight,
            0.5 * self.tolerances.rotation, self.attempt_iterations], dtype=float)
        return chain, joints, settings

    def _new_thread_state(self) -> SimpleNamespace:
        """This thread's Pinocchio Data and LM workspaces by residual size."""
        return SimpleNamespace(data=self._model.createData(), workspaces={})

    def _goal(self, target: Target) -> pin.SE3:
        """T*^-1: the inverse of the target in the scaled model's world frame (lengths x w)."""
        position = self.position_weight * target.position
        if self._base is not None:  # the chain's base frame is not the model's world frame
            goal = self._base * target.se3()
            position = self.position_weight * goal.translation
            rotation_t = goal.rotation.T
        else:
            rotation_t = _IDENTITY if target.rotation is None else target.rotation.T
        return pin.SE3(rotation_t, -rotation_t.dot(position))

    def _residual(self, goal_inverse: pin.SE3, pose: bool, with_jacobian: bool = True):
        """q -> (e, J or None) on this thread's Data: e = log6(T*^-1 T) and the tip-axes Jacobian, or e =
        p - p* and the world-aligned linear rows; lengths x w (the scaled model at D q, J D; D = w on
        prismatic joints)."""
        model, data, tip, scale = self._model, self._thread_state().data, self.chain.tip_id, self._joint_scale
        kinematics = pin.computeJointJacobians if with_jacobian else pin.forwardKinematics
        placement, frame_jacobian, log6 = pin.updateFramePlacement, pin.getFrameJacobian, pin.log6
        frame = _LOCAL if pose else _WORLD_ALIGNED

        if pose and with_jacobian and scale is None:  # the hot case: no test inside
            def residual(q: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
                kinematics(model, data, q)  # forward kinematics and every joint's Jacobian
                error = log6(goal_inverse * placement(model, data, tip)).vector
                return error, frame_jacobian(model, data, tip, frame)

            return residual

        goal_position = None if pose else goal_inverse.inverse().translation

        def residual(q: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
            kinematics(model, data, q if scale is None else q * scale)  # FK (and joint Jacobians)
            reached = placement(model, data, tip)
            error = log6(goal_inverse * reached).vector if pose else reached.translation - goal_position
            if not with_jacobian:
                return error, None
            jacobian = frame_jacobian(model, data, tip, frame)
            if scale is not None:
                jacobian = jacobian * scale
            return error, jacobian if pose else jacobian[:3]

        return residual

    def _attempt_function(self, target: Target, pose: bool):
        """(q, deadline, budget) -> :meth:`_attempt`'s answer, by the compiled twin on a pose where built."""
        if self._compiled is None or not pose:
            evaluate = self._residual(self._goal(target), pose)
            return lambda q, deadline, budget: self._attempt(evaluate, q, deadline, budget)
        kernel, (chain, joints, settings), n = _LM_ATTEMPT, self._compiled, self.chain.nq
        rotation, position = target.rotation, target.position

        def attempt(q: np.ndarray, deadline: float, budget: int) -> tuple[np.ndarray, bool, int, float]:
            last = np.empty(n)
            answer = kernel(chain, joints, settings, rotation, position, q, budget, deadline, last)
            if answer is None:  # a path only the Python loop has (its C file says which)
                return self._attempt(self._residual(self._goal(target), pose), q, deadline, budget)
            return last, *answer

        return attempt

    def _attempt(self, evaluate, q: np.ndarray, deadline: float, budget: int
                 ) -> tuple[np.ndarray, bool, int, float]:
        """LM from q for at most ``budget`` iterations: (last q, converged?, iterations, |e|)."""
        policy, bounds = self.policy, self.bounds
        trial_of, update = self._trial, policy.update
        sure_cost, maybe_cost = self._sure_cost, self._maybe_cost
        clock = deadline < math.inf
        error, jacobian = evaluate(q)
        workspaces, rows = self._thread_state().workspaces, error.shape[0]  # this thread's, per residual size
        workspace = workspaces.get(rows) or workspaces.setdefault(rows, policy.workspace(rows, self.chain.nq))
        cost = float(error.dot(error))
        damping = policy.first_damping
        best_cost, since_progress = cost, 0
        limit = min(self.attempt_iterations, budget)
        for iteration in range(1, limit + 1):
            if cost <= sure_cost or (cost <= maybe_cost and self._passes(error)):
                return q, True, iteration - 1, math.sqrt(cost)
            if clock and time.perf_counter() > deadline:
                break
            inside = trial_of(jacobian, error, cost, damping, q, bounds, workspace)
            trial_error, trial_jacobian = evaluate(inside)
            trial_cost = float(trial_error.dot(trial_error))
            accepted = trial_cost < cost
            if accepted:
                q, error, jacobian, cost = inside, trial_error, trial_jacobian, trial_cost
            damping, best_cost, since_progress, stalled = update(accepted, damping, cost, best_cost,
                                                                 since_progress)
            if stalled:
                return q, False, iteration, math.sqrt(cost)
        return q, self._passes(error), limit, math.sqrt(cost)

    def _next_seed(self, target: Target, pose: bool, draws: _CallDraws) -> np.ndarray:
        """A random seed inside the limits: the best of ``candidates`` uniform draws by |e|."""
        if self.candidates <= 1:
            return draws.take(1)[0].copy()
        seeds = draws.take(self.candidates)
        evaluate = self._residual(self._goal(target), pose, with_jacobian=False)
        best, best_cost = seeds[0], math.inf
        for seed in seeds:
            error = evaluate(seed)[0]
            cost = float(error.dot(error))
            if cost < best_cost:
                best, best_cost = seed, cost
        return best

    def _neighbours(self, target: Target, count: int) -> tuple[np.ndarray, np.ndarray]:
        """The ``count`` library entries nearest the target, nearest first, and their distances^2."""
        library = self._library
        count = min(count, len(library.q))
        if count == 0:
            return library.q[:0], np.zeros(0)
        distance, nearest = library.query(target.position, target.rotation, self.position_weight, count)
        return library.q[np.atleast_1d(nearest)], np.atleast_1d(distance) ** 2

    def _passes(self, error: np.ndarray) -> bool:
        """The shared check on a (position-weighted) error."""
        return converged(error, self.tolerances.position * self.position_weight, self.tolerances.rotation)

    def _first_seeds(self, target: Target, pose: bool, q_start: np.ndarray, attempt
                     ) -> tuple[list[np.ndarray], bool]:
        """The first seeds and whether q0 is still to come: [q0, the table's nearest entry], or [the entry]
        when nearer than ``table_first`` x |e(q0)|^2 (q0 then after the library's nearest entry)."""
        if self._table.q.shape[0] == 0 or self.single_attempts <= 1:
            return [q_start], False
        if pose and self._compiled is not None:  # |e(q0)| from the compiled attempt, no iteration
            cost = attempt(q_start, math.inf, 0)[3] ** 2
        else:
            error = self._residual(self._goal(target), pose, with_jacobian=False)(q_start)[0]
            cost = float(error.dot(error))
        if cost <= self._sure_cost:  # q0 passes already
            return [q_start], False
        entry, distance2 = self._table.nearest(target, self.position_weight)
        if distance2 < self.table_first * cost:
            return [entry], True
        return [q_start, entry], False

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        pose = target.is_pose
        attempt = self._attempt_function(target, pose)
        q_start = self.bounds.project(q0)
        seeds, q0_later = self._first_seeds(target, pose, q_start, attempt)
        best_q, best_error = q_start, math.inf
        attempts, iterations, taken, queries = 0, 0, 0, 0  # taken: library entries handed out so far
        draws = None  # the call's random seeds, drawn only if needed
        while True:
            if self.batch_size > 1 and attempts >= self.single_attempts:
                batch_seeds = q_start[None] if attempts == 0 else \
                    self._neighbours(target, taken + int(self.library_share * self.batch_size))[0][taken:]
                return self._solve_batch(target, batch_seeds, deadline, attempts, iterations,
                                         (best_q, best_error), draws or _CallDraws(self, target, q0))
            if not seeds and queries < 2:  # the library's nearest entries, a few first (most calls need 1-2)
                count = max(1, self.single_attempts - attempts - q0_later) if self.batch_size > 1 else 32
                count = min(count, FIRST_QUERY) if queries == 0 else count
                seeds = list(self._neighbours(target, taken + count)[0][taken:])
                taken, queries = taken + len(seeds), queries + 1
                if q0_later:
                    seeds.insert(1, q_start)
                    q0_later = False
            if seeds:
                q_seed = seeds.pop(0)
            else:
                draws = draws or _CallDraws(self, target, q0)
                q_seed = self._next_seed(target, pose, draws)
            q, ok, used, error = attempt(q_seed, deadline, self.max_iterations - iterations)
            attempts += 1
            iterations += used
            if ok:
                return Candidate(q, iterations, "", {"attempts": attempts})
            if error < best_error:
                best_q, best_error = q, error
            if iterations >= self.max_iterations or time.perf_counter() > deadline:
                return Candidate(best_q, iterations, self._budget_reason(attempts, best_error, deadline),
                                 {"attempts": attempts})

    def _budget_reason(self, attempts: int, best_error: float, deadline: float) -> str:
        spent = (f"wall-clock budget of {self.timeout_s:g} s" if time.perf_counter() > deadline
                 else f"iteration budget of {self.max_iterations}")
        return (f"{spent} used up after {attempts} attempts (best task error {best_error:.3g}); "
                "the target may be out of reach")

    def _solve_targets(self, targets: list, q0s) -> list[IKResult]:
        """Solve a batch, without ``timeout_s`` all together (answers may differ from :meth:`solve`'s)."""
        starts = self._batch_starts(q0s, len(targets))
        if self.timeout_s is not None or self._vectorised is None or len(targets) < 2:
            return [self.solve(target, q0) for target, q0 in zip(targets, starts, strict=True)]
        converted = [as_target(target) for target in targets]
        for target in converted:
            self._check_target_kind(target)
        q_starts = np.array([self.chain.nominal if q0 is None else q0 for q0 in starts])
        results: list[IKResult | None] = [None] * len(targets)
        for pose in (True, False):
            rows = [index for index, target in enumerate(converted) if target.is_pose == pose]
            if rows:
                self._solve_rows([converted[index] for index in rows], q_starts[rows], results, rows)
        return results

    def _passes_rows(self, error: np.ndarray) -> np.ndarray:
        """:meth:`_passes` row by row (B, m) -> (B,)."""
        position = np.einsum("bi,bi->b", error[:, :3], error[:, :3])
        ok = position <= (0.5 * self.tolerances.position * self.position_weight) ** 2
        if error.shape[1] == 6:
            ok &= np.einsum("bi,bi->b", error[:, 3:], error[:, 3:]) <= (0.5 * self.tolerances.rotation) ** 2
        return ok

    def _keep_better_trials(self, inside: np.ndarray, goal_position: np.ndarray,
                            goal_rotation: np.ndarray | None, cost: np.ndarray, q: np.ndarray,
                            error: np.ndarray, transposed: np.ndarray) -> tuple[np.ndarray, ...]:
        """The batched accept step of the trials ``inside`` (B, n): (accepted (B,), cost, q, error, J^T)."""
        trial_error, trial_transposed = self._vectorised.evaluate(inside, goal_position, goal_rotation)
        accepted, cost, (q, error, transposed) = keep_better(
            batch_cost(trial_error), cost, (inside, q), (trial_error, error), (trial_transposed, transposed))
        return accepted, cost, q, error, transposed

    def _solve_rows(self, targets: list[Target], q0: np.ndarray, results: list, slots: list[int]) -> None:
        """Targets of one kind advanced together, answers into results[slots]: per row :meth:`solve`'s first
        seeds (:meth:`_queue_seeds`), attempts ending as in :meth:`_attempt`; then :meth:`solve`."""
        started = time.perf_counter()
        count, pose = len(targets), targets[0].is_pose
        kinematics, policy, bounds = self._vectorised, self.policy, self.bounds
        positions = np.array([target.position for target in targets])
        rotations = np.array([target.rotation for target in targets]) if pose else None
        q0 = bounds.project(q0)
        error0, _ = kinematics.evaluate(q0, positions, rotations)
        cost0 = batch_cost(error0)
        entries, distances2 = self._table.nearest_rows(positions, rotations, self.position_weight)
        table_first = distances2 < self.table_first * cost0 if len(entries) else np.zeros(count, dtype=bool)
        first = np.where(table_first[:, None], entries, q0) if len(entries) else q0
        # seeds after the first: built on a row's first failure (library entries: one query for all)
        queue: dict[int, list[np.ndarray]] = {}
        attempts = np.ones(count, dtype=int)
        spent = np.zeros(count, dtype=int)
        solution = np.full((count, q0.shape[1]), np.nan)
        failed = np.zeros(count, dtype=bool)
        # state of the active rows (rows: their indices)
        rows = np.arange(count)
        q = first.copy()
        error, transposed = kinematics.evaluate(q, positions, rotations)
        cost, damping, best, since = policy.start_batch(error)
        age = np.zeros(count, dtype=int)
        while rows.size:
            done = self._passes_rows(error)
            over = (spent[rows] >= self.max_iterations) | failed[rows]  # failed: out of seeds
            if done.any() or over.any():
                solution[rows[done]] = q[done]
                failed[rows[over & ~done]] = True
                keep = ~(done | over)
                rows, q, error, transposed, cost, damping, best, since, age = (
                    array[keep] for array in (rows, q, error, transposed, cost, damping, best, since, age))
                if not rows.size:
                    break
            goal_positions = positions[rows]
            goal_rotations = None if rotations is None else rotations[rows]
            inside = policy.trial_batch(np.swapaxes(transposed, 1, 2), error, cost, damping, q, bounds)
            accepted, cost, q, error, transposed = self._keep_better_trials(
                inside, goal_positions, goal_rotations, cost, q, error, transposed)
            damping, best, since, stalled = policy.update_batch(accepted, damping, cost, best, since)
            spent[rows] += 1
            age += 1
            ended = np.flatnonzero((stalled | (age >= self.attempt_iterations)) & ~self._passes_rows(error))
            if not ended.size:
                continue
            self._queue_seeds(queue, rows[ended], q0, entries, table_first, positions, rotations)
            seeded = np.array([bool(queue[row]) for row in rows[ended]])
            failed[rows[ended[~seeded]]] = True  # dropped at the next iteration's start
            restart = ended[seeded]
            if restart.size:
                renewed = rows[restart]
                q[restart] = [queue[row].pop(0) for row in renewed]
                attempts[renewed] += 1
                fresh_error, fresh_transposed = kinematics.evaluate(
                    q[restart], positions[renewed], None if rotations is None else rotations[renewed])
                error[restart], transposed[restart] = fresh_error, fresh_transposed
                cost[restart] = batch_cost(fresh_error)
                best[restart], since[restart], age[restart] = cost[restart], 0, 0
                damping[restart] = policy.first_damping
        share = (time.perf_counter() - started) / count
        chain, tolerances = self.chain, self.tolerances
        for index, slot in enumerate(slots):
            if failed[index]:
                results[slot] = self.solve(targets[index], q0[index])
            else:
                results[slot] = evaluate(chain, targets[index],
                                         Candidate(solution[index], int(spent[index]), "",
                                                   {"attempts": int(attempts[index])}),
                                         tolerances, share, self.name)

    def _queue_seeds(self, queue: dict, rows: np.ndarray, q0: np.ndarray, entries: np.ndarray,
                     table_first: np.ndarray, positions: np.ndarray, rotations: np.ndarray | None) -> None:
        """The seeds after the first of rows failing for the first time: :meth:`solve`'s order."""
        new = [int(row) for row in rows if int(row) not in queue]
        if not new:
            return
        count = max(1, self.single_attempts - 2)
        library = self._library
        if len(library.q):
            nearest = library.query(positions[new], None if rotations is None else rotations[new],
                                    self.position_weight, count)[1]
            neighbours = library.q[np.asarray(nearest).reshape(len(new), -1)]
        else:
            neighbours = np.zeros((len(new), 0, q0.shape[1]))
        for row, near in zip(new, neighbours, strict=True):
            near = list(near)
            if not len(entries):
                queue[row] = near
            elif table_first[row]:  # the entry went first: the library's nearest, q0, the others
                queue[row] = near[:1] + [q0[row]] + near[1:]
            else:  # q0 went first: the table entry, then the library
                queue[row] = [entries[row]] + near

    def _solve_batch(self, target: Target, seeds: np.ndarray, deadline: float, attempts: int,
                     iterations: int, best: tuple[np.ndarray, float], draws: _CallDraws) -> Candidate:
        """The same LM on ``batch_size`` seeds at once, ``seeds`` first, then random ones; an ended seed is
        replaced by a fresh one in the next trial (its cost set to infinity so the fresh one is accepted)."""
        kinematics, size = self._vectorised, self.batch_size
        goal_position, goal_rotation = target.position, target.rotation
        policy, bounds = self.policy, self.bounds
        sure_cost, maybe_cost = self._sure_cost, self._maybe_cost
        spent, budget = iterations, self.max_iterations  # budget units: single-seed iterations
        q = draws.take(size).copy()
        q[:len(seeds)] = seeds[:size]
        error, transposed = kinematics.evaluate(q, goal_position, goal_rotation)
        cost, damping, best_cost, since_progress = policy.start_batch(error)
        age = np.zeros(size, dtype=int)
        fresh = None
        best_q, best_error = best
        attempts += size
        while True:
            if cost.min() <= maybe_cost:
                for index in np.flatnonzero(cost <= maybe_cost):
                    if cost[index] <= sure_cost or self._passes(error[index]):
                        return Candidate(q[index].copy(), iterations, "", {"attempts": attempts})
            if spent + BATCH_ITERATION_UNITS > budget or time.perf_counter() > deadline:
                break
            iterations += 1
            spent += BATCH_ITERATION_UNITS
            inside = policy.trial_batch(np.swapaxes(transposed, 1, 2), error, cost, damping, q, bounds)
            if fresh is not None:
                inside[fresh] = draws.take(fresh.size)
                cost[fresh] = math.inf
            accepted, cost, q, error, transposed = self._keep_better_trials(
                inside, goal_position, goal_rotation, cost, q, error, transposed)
            damping, best_cost, since_progress, stalled = policy.update_batch(accepted, damping, cost,
                                                                              best_cost, since_progress)
            age += 1
            ended = stalled | (age >= self.attempt_iterations)
            fresh = None
            if ended.any():
                fresh = np.flatnonzero(ended)
                lowest = int(fresh[np.argmin(cost[fresh])])
                if math.sqrt(cost[lowest]) < best_error:
                    best_q, best_error = q[lowest].copy(), math.sqrt(cost[lowest])
                best_cost[fresh] = math.inf
                since_progress[fresh] = 0
                age[fresh] = 0
                damping[fresh] = policy.first_damping
                attempts += fresh.size
        lowest = int(np.argmin(cost))
        if math.sqrt(cost[lowest]) < best_error:
            best_q, best_error = q[lowest].copy(), math.sqrt(cost[lowest])
        return Candidate(best_q, iterations, self._budget_reason(attempts, best_error, deadline),
                         {"attempts": attempts})


def scaled_model(model: pin.Model, factor: float) -> pin.Model:
    """A copy of ``model`` with every length x ``factor``: position rows come out weighted at no cost."""
    if factor == 1.0:
        return model
    scaled = pin.Model(model)
    for index in range(scaled.njoints):
        placement = scaled.jointPlacements[index]
        scaled.jointPlacements[index] = pin.SE3(placement.rotation, factor * placement.translation)
    for index in range(len(scaled.frames)):
        frame = scaled.frames[index]
        frame.placement = pin.SE3(frame.placement.rotation, factor * frame.placement.translation)
        scaled.frames[index] = frame
    return scaled


def chain_scale_weight(chain) -> float:
    """1 / (the chain's length, m), at least 1: metres and radians on a par on small arms."""
    length = float(np.linalg.norm(serial_structure(chain).placements[1:, :3, 3], axis=1).sum())
    return max(1.0, 1.0 / max(length, 1e-3))


IK_METHODS = (
    IKMethod("bounded_lm", BoundedLMSolver,
             "ours: joint-limit-bounded Levenberg-Marquardt with vectorised random restarts"),
)
