"""Ours: joint-limit-bounded Levenberg-Marquardt with restarts (``bounded_lm``).

One attempt, from a seed q inside the limits, iterates the policy of
:mod:`wbik.solvers.levenberg_marquardt` (the same for the one-seed and the batched path):

    (J^T J + lambda I) dq = -J^T e,     lambda = w |e|^2 + mu,     q <- P(q + dq)

with w = ``cost_weight`` (0.01) and mu the base damping (floor ``damping``, 1e-6; x0.3 after an
accepted step, x10 after a rejected one): Sugihara's error-dependent damping, large far from the
target (robust start), vanishing near it (Newton-fast end). A step that does not lower |e| is
rejected. P wraps full-turn revolute joints by 2 pi and clips the others; a clipped joint on a
bound whose step points outwards is frozen and the step recomputed without it (a bounded step).
``max_step`` optionally caps the largest joint step.

The residual e is the pose-error convention of :mod:`wbik.geometry` in its SE(3) form (documented
in :mod:`wbik.solvers.task_error`): e = log6(T*^-1 T), whose rotation part is log3(R*^T R) and
whose translation part is R*^T (p - p*) bent along the screw motion, with the tip-axes (LOCAL) frame
Jacobian; a position target uses e = p - p* with the linear rows of the Jacobian (base axes).
Against the straight form [p - p*; log3(R*^T R)] with its exact Jacobian, the SE(3) form succeeds as
often, in fewer iterations and less CPU time per call (one SE(3) product and log6 in Pinocchio, and
the tip-axes Jacobian as Pinocchio gives it, against a log3, Jlog3 and two products per evaluation),
and from a far seed alone it succeeds as often or more. Hence the SE(3) form, in both paths (the
measurements: docs/measurements.md, bounded_lm).
Position rows are weighted by ``position_weight`` (default: 1 / the chain's length scale, at least
1), which puts metres and radians on a par on small chains (Pincher, Bioloid legs); the FK check is
unchanged. An attempt ends when the FK check passes (success), when the error stops dropping
(``stall`` iterations with less than 1 - ``progress`` relative progress: a local minimum or a
limit), or after ``attempt_iterations``.

Restarts, until the iteration budget ``max_iterations`` is spent (the result is the first solution
that passes, or the best attempt with a reason). The budget counts single-seed iterations; one
iteration of the vectorised batch counts ``BATCH_ITERATION_UNITS`` of them (what it costs relative
to a single one). By default the budget is the iterations that cost about 5 ms on
the reference machine, so the answer depends on the inputs and ``seed`` only, never on the load;
``timeout_s`` adds a wall clock. Restarts draw from the call's own random stream
(:meth:`Solver._call_rng`).

1. q0 and the nearest entry of a per-chain *seed table* (``table_size`` 1024 configurations, uniform
   inside the limits shrunk by ``table_margin`` = 10 % of each range at both ends; searched by brute
   force, :class:`SeedTable`): q0 first when it is near the target (tracking,
   warm starts); the entry first when its distance^2 is under ``table_first`` (0.1) x |e(q0)|^2
   (q0 an uninformed guess, as TRAC-IK's protocol's mid-range seed), q0 then coming third, after
   the library's nearest entry.
2. Then the entries of a per-chain *seed library* (``library_size`` 8192 uniform configurations,
   k-d trees over their tip poses, :func:`seed_library`, built once per chain) whose tip pose is
   nearest the target (weighted position distance^2 + 3 - trace(R*^T R_i)), nearest first: they
   start in the right region of the workspace, so an attempt from them succeeds more often and
   sooner than from a uniform seed. Table and library are built once per chain and cached.
3. After ``single_attempts`` one-seed attempts, ``batch_size`` seeds advance together, vectorised
   over the batch (:class:`VectorisedChain`: residuals and Jacobians of all seeds in a fixed number
   of numpy calls); the first ``library_share`` of them are the next library neighbours, the others
   uniform. A seed that stalls is replaced by a fresh uniform one. A batch iteration costs as much
   as several single ones (``BATCH_ITERATION_UNITS``) but advances 32 seeds, which is what solves the
   rare targets whose solution lies in a small basin (joints near their limits).

``solve_many`` (no wall clock) runs the same attempts for many targets at once, one vectorised row
per target (:meth:`BoundedLMSolver._solve_rows`).

Defaults were tuned under TRAC-IK's protocol with ``benchmarks/numerical.py`` on the UR5, Golem3,
Pincher, Bioloid and Panda chains. A one-seed iteration is three Pinocchio calls, the policy's damped
solve and a dozen small numpy calls with the Python trial; the compiled trial
(:meth:`LevenbergMarquardt.trial_function`) makes the same decisions with the sums in C. A call also has
a fixed cost (goal, seed table, first residual). What each costs: docs/measurements.md, bounded_lm.
"""

from __future__ import annotations

import math
import time
import weakref
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.spatial import cKDTree

from wbik.errors import RobotDescriptionError
from wbik.solvers.base import Solver
from wbik.solvers.check import evaluate
from wbik.solvers.levenberg_marquardt import JointBounds
from wbik.solvers.levenberg_marquardt import LevenbergMarquardt
from wbik.solvers.levenberg_marquardt import Workspace
from wbik.solvers.levenberg_marquardt import batch_cost
from wbik.solvers.levenberg_marquardt import keep_better
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate
from wbik.solvers.result import IKResult
from wbik.solvers.task_error import batch_se3_error
from wbik.solvers.task_error import converged
from wbik.targets import Target
from wbik.targets import as_target

_LOCAL, _WORLD_ALIGNED = pin.ReferenceFrame.LOCAL, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_IDENTITY = np.eye(3)
_IDENTITY.flags.writeable = False
FIRST_QUERY = 3
"""Library entries asked for by a call's first k-d tree query (the rest, if needed, by a second)."""
BATCH_ITERATION_UNITS = 10
"""Budget units one vectorised batch iteration (32 seeds) counts: its time over a single-seed
iteration's on the reference machine (the measurements: docs/measurements.md, bounded_lm)."""


@dataclass
class _ThreadState:
    """What a thread keeps between calls: its Pinocchio Data and LM workspaces by residual size."""

    data: pin.Data
    workspaces: dict


@dataclass
class _CallDraws:
    """Uniform seeds of one call, drawn lazily (most calls never need one) from its own stream."""

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
    """Bounded LM with restarts (see the module docstring). Options, besides the base ones:

    max_iterations: the budget of a call, in single-seed iterations (default: the iterations that
    cost about 5 ms on the reference machine);
    attempt_iterations, stall, progress: end of an attempt (30 iterations; 3 without a 10 % drop);
    damping, cost_weight, decrease, increase: mu floor, w, mu factors on accept/reject (the
    policy, :class:`LevenbergMarquardt`); max_step: cap on the largest joint step (rad or m), None =
    no cap; position_weight: w of the position rows (default 1 / the chain's length, at least 1);
    single_attempts: one-seed attempts before the vectorised batch (12); batch_size: seeds per batch
    (32; 1 = one seed at a time for ever); library_size: seed-library entries (8192; 0 = uniform
    restarts); library_share: share of the first batch taken from the library (0.5); candidates: a
    uniform restart seed is the best of this many draws by task error (3; used once the library
    neighbours run out); table_size, table_margin: the seed table's entries (1024; 0 = none) and the
    share of each joint range they keep off the limits (0.1).
    """

    name = "bounded_lm"
    table_first = 0.1
    """The seed-table entry goes before q0 when its distance^2 is under this x |e(q0)|^2. From an
    uninformed q0 (the mid-range seed), an attempt from an entry that much nearer succeeds about as
    often or more, in fewer iterations; where the entry is less near, the two are even (the
    measurements: docs/measurements.md, bounded_lm)."""
    iteration_cost_s = 20e-6
    """The budget's unit: one single-seed iteration (FK, Jacobian, Cholesky) of the Python trial on the
    reference machine, kept for the compiled trial too, so the default budget is the same number of
    iterations (the same answers on every machine, compiled or not; the measured cost:
    docs/measurements.md, bounded_lm)."""

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
        except RobotDescriptionError:  # not a plain serial chain: one seed at a time, uniform restarts
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

    def _new_thread_state(self) -> _ThreadState:
        return _ThreadState(self._model.createData(), {})

    def _workspace(self, rows: int) -> Workspace:
        """This thread's buffers for the damped system of an m = ``rows`` residual (made once)."""
        workspaces = self._thread_state().workspaces
        if rows not in workspaces:
            workspaces[rows] = self.policy.workspace(rows, self.chain.nq)
        return workspaces[rows]

    def project(self, q: np.ndarray) -> np.ndarray:
        """Wrap full-turn revolute joints by 2 pi into their range, clip the others."""
        return self.bounds.project(q)

    # -- the residual of one configuration ----------------------------------------------------------
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
        """The residual and Jacobian at a configuration, as a function q -> (e, J) (J None when not
        asked for). Pose: e = log6(T*^-1 T) with the tip-axes (LOCAL) Jacobian; position: e = p - p*
        with the linear rows of the world-aligned Jacobian. Lengths are scaled by w (the scaled model
        at D q, D = w on prismatic joints, 1 on revolute ones; Jacobian J D). Uses this thread's Data."""
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

    # -- one seed ---------------------------------------------------------------------------------
    def _attempt(self, evaluate, q: np.ndarray, deadline: float, budget: int
                 ) -> tuple[np.ndarray, bool, int, float]:
        """LM from q for at most ``budget`` iterations on the residual ``evaluate`` (q -> (e, J), from
        :meth:`_residual`): (last q, converged?, iterations, |e|). Hot loop: the policy's calls and
        small numpy calls only."""
        policy, bounds = self.policy, self.bounds
        trial_of, update = self._trial, policy.update
        sure_cost, maybe_cost = self._sure_cost, self._maybe_cost
        clock = deadline < math.inf
        error, jacobian = evaluate(q)
        workspace = self._workspace(error.shape[0])
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

    def _next_seed(self, goal_inverse: pin.SE3, pose: bool, draws: _CallDraws) -> np.ndarray:
        """A random seed inside the limits: the best of ``candidates`` uniform draws by |e|."""
        if self.candidates <= 1:
            return draws.take(1)[0].copy()
        seeds = draws.take(self.candidates)
        evaluate = self._residual(goal_inverse, pose, with_jacobian=False)
        best, best_cost = seeds[0], math.inf
        for seed in seeds:
            error = evaluate(seed)[0]
            cost = float(error.dot(error))
            if cost < best_cost:
                best, best_cost = seed, cost
        return best

    def _neighbours(self, target: Target, count: int) -> tuple[np.ndarray, np.ndarray]:
        """The ``count`` library configurations whose tip poses are nearest the target, nearest first,
        and their distances^2.

        Distance^2 = w^2 |p* - p_i|^2 + (3 - trace(R*^T R_i)) (the second term is ~ angle^2, so the
        distance^2 compares with a residual's |e|^2), found with a k-d tree, whose query time hardly
        grows with the library.
        """
        library = self._library
        count = min(count, len(library.q))
        if count == 0:
            return library.q[:0], np.zeros(0)
        position = self.position_weight * target.position
        if target.rotation is None:
            distance, nearest = library.position_tree.query(position, k=count)
        else:
            point = np.concatenate((position, target.rotation.reshape(9) / math.sqrt(2)))
            distance, nearest = library.pose_tree.query(point, k=count)
        return library.q[np.atleast_1d(nearest)], np.atleast_1d(distance) ** 2

    def _passes(self, error: np.ndarray) -> bool:
        """The shared check on a (position-weighted) error."""
        return converged(error, self.tolerances.position * self.position_weight, self.tolerances.rotation)

    def _first_seeds(self, target: Target, goal_inverse: pin.SE3, pose: bool, q_start: np.ndarray
                     ) -> tuple[list[np.ndarray], bool]:
        """The first seeds, and whether q0 is still to come: [q0, the seed-table entry nearest the
        target] when q0 is near (tracking, warm starts); [the entry] when its distance^2 is under
        ``table_first`` x |e(q0)|^2 (q0 an uninformed guess such as TRAC-IK's mid-range seed), q0
        then coming after the library's nearest entry: where the table entry failed, an attempt from
        the library's nearest succeeds more often than from the mid-range seed (the measurements:
        docs/measurements.md, bounded_lm)."""
        if self._table.q.shape[0] == 0 or self.single_attempts <= 1:
            return [q_start], False
        error = self._residual(goal_inverse, pose, with_jacobian=False)(q_start)[0]
        cost = float(error.dot(error))
        if cost <= self._sure_cost:  # q0 passes already
            return [q_start], False
        entry, distance2 = self._table.search(target, self.position_weight).nearest()
        if distance2 < self.table_first * cost:
            return [entry], True
        return [q_start, entry], False

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        goal_inverse = self._goal(target)
        pose = target.is_pose
        evaluate = self._residual(goal_inverse, pose)
        q_start = self.bounds.project(q0)
        seeds, q0_later = self._first_seeds(target, goal_inverse, pose, q_start)
        best_q, best_error = q_start, math.inf
        attempts, iterations, taken, queries = 0, 0, 0, 0  # taken: library entries handed out so far
        draws = None  # the call's random seeds, drawn only if needed
        while True:
            if self.batch_size > 1 and attempts >= self.single_attempts:
                batch_seeds = q_start[None] if attempts == 0 else \
                    self._neighbours(target, taken + int(self.library_share * self.batch_size))[0][taken:]
                return self._solve_batch(target, batch_seeds, deadline, attempts, iterations,
                                         (best_q, best_error), draws or _CallDraws(self, target, q0))
            if not seeds and queries < 2:  # then the library's nearest entries (k-d tree queries: the
                # first for a few, as most calls need one or two and a query's cost grows with k)
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
                q_seed = self._next_seed(goal_inverse, pose, draws)
            q, ok, used, error = self._attempt(evaluate, q_seed, deadline, self.max_iterations - iterations)
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

    # -- many targets at once -------------------------------------------------------------------
    def solve_many(self, targets: Iterable, q0s=None) -> list[IKResult]:
        """Solve a batch. With iteration budgets only (no ``timeout_s``: a wall clock per pose has no
        meaning inside a vectorised run), vectorised over the targets (:meth:`_solve_rows`): every
        target runs the same LM policy on the same residual from the same seeds as :meth:`solve`
        (the seed-table entry or q0 first, then the library's nearest entries), one row per target,
        all rows advancing together; a target the vectorised rounds leave unsolved is solved by
        :meth:`solve` itself. Each answer passes the shared FK check; it may be another solution
        than :meth:`solve` finds for the same target. ``time_s`` of a vectorised answer is the
        run's time shared equally among its targets."""
        targets = list(targets)
        starts = self._batch_starts(q0s, len(targets))
        if self.timeout_s is not None or self._vectorised is None or len(targets) < 2:
            return [self.solve(target, q0) for target, q0 in zip(targets, starts, strict=True)]
        converted = [as_target(target) for target in targets]
        for target in converted:
            if not (self.supports_pose if target.is_pose else self.supports_position_only):
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
        """The batched paths' accept step: the trials ``inside`` (B, n) evaluated on the vectorised
        residual, each row keeping the trial where it lowers the cost (:func:`keep_better`). Returns
        (accepted (B,), cost, q, error, J^T) after the step."""
        trial_error, trial_transposed = self._vectorised.evaluate(inside, goal_position, goal_rotation)
        accepted, cost, (q, error, transposed) = keep_better(
            batch_cost(trial_error), cost, (inside, q), (trial_error, error), (trial_transposed, transposed))
        return accepted, cost, q, error, transposed

    def _solve_rows(self, targets: list[Target], q0: np.ndarray, results: list, slots: list[int]) -> None:
        """Targets of one kind, one row each, advanced together; answers written to results[slots].

        Row r runs attempts from its seeds in :meth:`solve`'s order, ``single_attempts`` of them:
        q0 and its seed-table entry, the nearer first (``table_first``), then the library's nearest
        entries (found for all rows that need them in one k-d tree query), q0 after the first of
        them when the table entry went first. An attempt ends as in :meth:`_attempt` (converged,
        stalled, ``attempt_iterations``); a row whose seeds or iteration budget run out is left to
        :meth:`solve`."""
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
            over = spent[rows] >= self.max_iterations
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
            restart, exhausted = [], []
            for local in ended:
                seeds = queue[rows[local]]
                (restart if seeds else exhausted).append(local)
            if exhausted:
                failed[rows[exhausted]] = True
                keep = np.ones(rows.size, dtype=bool)
                keep[exhausted] = False
                restart = [int(np.count_nonzero(keep[:local])) for local in restart]
                rows, q, error, transposed, cost, damping, best, since, age = (
                    array[keep] for array in (rows, q, error, transposed, cost, damping, best, since, age))
            if restart:
                restart = np.array(restart)
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
            points = self.position_weight * positions[new]
            if rotations is not None:
                points = np.hstack((points, rotations[new].reshape(-1, 9) / math.sqrt(2)))
                nearest = library.pose_tree.query(points, k=count)[1]
            else:
                nearest = library.position_tree.query(points, k=count)[1]
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

    # -- many seeds at once ---------------------------------------------------------------------
    def _solve_batch(self, target: Target, seeds: np.ndarray, deadline: float, attempts: int,
                     iterations: int, best: tuple[np.ndarray, float], draws: _CallDraws) -> Candidate:
        """The same LM (the same residual, the same policy) on ``batch_size`` seeds at once:
        ``seeds`` first, then random ones.

        A seed that stalls, or has run ``attempt_iterations``, is replaced by a fresh random one in the
        next trial evaluation (its cost is set to infinity so the fresh point is accepted): a restart
        costs no extra evaluation.
        """
        kinematics, size = self._vectorised, self.batch_size
        goal_position = target.position
        goal_rotation = target.rotation
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


class VectorisedChain:
    """Task residuals and Jacobians of B configurations of a serial chain, with a fixed number of
    numpy calls (independent of B): the same residual as the one-seed path.

    Each joint frame is first turned so that its axis is z (Q_k e_z = a_k): joint axes and origins
    are then plain slices of the frames. T(q) = F_1 A_1(q_1) ... A_n(q_n) with F_1 = P_0 Q_1,
    A_k = Z(q_k) Q_k^T P_k Q_{k+1} (Q_{n+1} = I) and Z(q) = I + f(q) K + g(q) K^2, K the
    cross-product matrix of e_z, f = sin, g = 1 - cos (revolute); Z(q) = I + q E_z (prismatic, E_z
    the translation along z, g = 0). So every ``A_k(q_k) = [1, f, g] [C0; C1; C2]_k`` comes from one
    matrix product, followed by n products down the chain. Jacobian column k in base axes:
    [z_k x (p - o_k); z_k] (revolute) or [z_k; 0] (prismatic). Jacobians are returned transposed
    (B, n, m), position rows (and errors) weighted by ``position_weight``.
    """

    def __init__(self, chain, position_weight: float = 1.0):
        from wbik.solvers.task_error import serial_structure

        structure = serial_structure(chain)
        n = chain.nq
        turns = [np.eye(4) for _ in range(n + 1)]
        for k, axis in enumerate(structure.axes):
            turns[k][:3, :3] = rotation_taking_z_to(axis)
        placements = structure.placements
        self.first = placements[0] @ turns[0]
        cross_z = np.zeros((4, 4))
        cross_z[0, 1], cross_z[1, 0] = -1.0, 1.0
        along_z = np.zeros((4, 4))
        along_z[2, 3] = 1.0
        # A_k flattened = C0_k + f_k C1_k + g_k C2_k; F_1 is folded into A_1 (its frame is constant)
        constant = np.zeros((n, 16))
        linear = np.zeros((2 * n, 16 * n))  # rows: f_1..f_n, g_1..g_n; column block k: joint k
        for k in range(n):
            placement = turns[k].T @ placements[k + 1] @ turns[k + 1]
            before = self.first if k == 0 else np.eye(4)
            columns = slice(16 * k, 16 * (k + 1))
            constant[k] = (before @ placement).reshape(16)
            if structure.prismatic[k]:
                linear[k, columns] = (before @ along_z @ placement).reshape(16)
            else:
                linear[k, columns] = (before @ cross_z @ placement).reshape(16)
                linear[n + k, columns] = (before @ cross_z @ cross_z @ placement).reshape(16)
        self.n, self.constant, self.linear = n, constant.reshape(16 * n), linear
        self.prismatic = structure.prismatic
        self.any_prismatic = bool(self.prismatic.any())
        self.weight = float(position_weight)
        levi_civita = np.zeros((3, 3, 3))
        for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
            levi_civita[i, j, k], levi_civita[i, k, j] = 1.0, -1.0
        # (a outer b).flat @ this = weight * (a x b)
        self._cross = self.weight * levi_civita.transpose(1, 2, 0).reshape(9, 3)

    def evaluate(self, q: np.ndarray, goal_position: np.ndarray, goal_rotation: np.ndarray | None
                 ) -> tuple[np.ndarray, np.ndarray]:
        """(e (B, m), J^T (B, n, m)) against one goal in the base frame (p* (3,), R* (3, 3)) or one
        goal per row (p* (B, 3), R* (B, 3, 3)). Pose (m = 6): e = log6(T*^-1 T) (weighted lengths)
        with the Jacobian in tip axes, both given turned into base axes (R e, R J); position (m = 3):
        e = w (p - p*) with the linear rows in base axes."""
        size, n = q.shape
        frames = self.frames(q)
        axes = frames[:, :n, :3, 2]
        tip = frames[:, n]
        position = tip[:, :3, 3]
        lever = position[:, None, :] - frames[:, :n, :3, 3]
        pose = goal_rotation is not None
        transposed = np.empty((size, n, 6 if pose else 3))
        transposed[..., :3] = (axes[..., :, None] * lever[..., None, :]).reshape(size, n, 9) @ self._cross
        if self.any_prismatic:
            transposed[:, self.prismatic, :3] = self.weight * axes[:, self.prismatic]
        if not pose:
            error = position - goal_position
            if self.weight != 1.0:
                error *= self.weight
            return error, transposed
        transposed[..., 3:] = axes
        if self.any_prismatic:
            transposed[:, self.prismatic, 3:] = 0.0
        rotation = tip[:, :3, :3]
        error = batch_se3_error(rotation, self.weight * position, goal_rotation, self.weight * goal_position)
        # the tip-axes Jacobian is R^T J: instead of turning J, turn both 3-blocks of e by R (the
        # same |e|, J^T J and J^T e, so the same steps, one small product cheaper)
        error = np.matmul(error.reshape(size, 2, 3), np.swapaxes(rotation, 1, 2)).reshape(size, 6)
        return error, transposed

    def tip_poses(self, q: np.ndarray) -> np.ndarray:
        """(B, 4, 4) tip poses in the base frame."""
        return self.frames(q)[:, -1]

    def frames(self, q: np.ndarray) -> np.ndarray:
        """(B, n + 1, 4, 4): the n joint frames (z = the joint axis) and the tip frame, base frame."""
        size, n = q.shape
        coefficients = np.empty((size, 2 * n))
        np.sin(q, out=coefficients[:, :n])
        np.cos(q, out=coefficients[:, n:])
        np.subtract(1.0, coefficients[:, n:], out=coefficients[:, n:])
        if self.any_prismatic:
            coefficients[:, :n][:, self.prismatic] = q[:, self.prismatic]
        steps = (coefficients.dot(self.linear) + self.constant).reshape(size, n, 4, 4)
        frames = np.empty((size, n + 1, 4, 4))
        frames[:, 0] = self.first
        frames[:, 1] = steps[:, 0]
        for k in range(1, n):
            np.matmul(frames[:, k], steps[:, k], out=frames[:, k + 1])
        return frames


def rotation_taking_z_to(axis: np.ndarray) -> np.ndarray:
    """A rotation Q with Q e_z = axis (a unit vector)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, axis)
    x /= np.linalg.norm(x)
    return np.column_stack((x, np.cross(axis, x), axis))


@dataclass(frozen=True)
class SeedLibrary:
    """Configurations q (N, n) of a chain and k-d trees over their tip poses in the base frame:
    ``pose_tree`` on [w p, R / sqrt 2] (Euclidean distance^2 = w^2 |dp|^2 + 3 - trace(R*^T R)),
    ``position_tree`` on w p."""

    q: np.ndarray
    pose_tree: cKDTree
    position_tree: cKDTree


_LIBRARIES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def seed_library(chain, size: int, weight: float, kinematics: VectorisedChain | None) -> SeedLibrary:
    """The chain's seed library of ``size`` uniform configurations (a fixed random stream, so the
    same for every solver), built once per (chain, size, weight) and cached."""
    cache = _LIBRARIES.setdefault(chain, {})
    key = ("library", size, weight)
    if key not in cache:
        q = chain.random(np.random.default_rng(size), size)
        tips = kinematics.tip_poses(q) if size and kinematics is not None else np.zeros((0, 4, 4))
        positions = weight * tips[:, :3, 3]
        rotations = tips[:, :3, :3].reshape(-1, 9) / math.sqrt(2)
        cache[key] = SeedLibrary(q[:len(tips)], cKDTree(np.hstack((positions, rotations)).reshape(-1, 12)),
                                 cKDTree(positions.reshape(-1, 3)))
    return cache[key]


@dataclass(frozen=True)
class SeedTable:
    """A small set of configurations q (N, n) searched by brute force (one matrix-vector product:
    cheaper than a k-d tree query, whose cost is mostly call overhead; the measurements:
    docs/measurements.md, bounded_lm).

    With the weighted tip positions p_i and rotations R_i, the distance^2 of an entry to a target
    (p*, R*) is w^2 |p* - p_i|^2 + 3 - trace(R*^T R_i) = offset_i - features_i . [w p*, vec R*]
    + w^2 |p*|^2 + 3, with features_i = [2 w p_i, vec R_i] and offset_i = w^2 |p_i|^2."""

    q: np.ndarray
    features: np.ndarray  # (N, 12)
    position_features: np.ndarray  # (N, 3): 2 w p_i, contiguous
    offsets: np.ndarray  # (N,)

    def nearest_rows(self, positions: np.ndarray, rotations: np.ndarray | None, weight: float,
                     chunk: int = 256) -> tuple[np.ndarray, np.ndarray]:
        """The entry nearest each of B targets (positions (B, 3), rotations (B, 3, 3) or None) and
        its distance^2: (q (B, n), (B,)), by one matrix product per ``chunk`` targets."""
        if not len(self.q):
            return self.q[:0], np.zeros(0)
        weighted = weight * positions
        queries = weighted if rotations is None else np.hstack((weighted, rotations.reshape(-1, 9)))
        features = self.position_features if rotations is None else self.features
        constant = np.einsum("bi,bi->b", weighted, weighted) + (0.0 if rotations is None else 3.0)
        best = np.empty(len(positions), dtype=int)
        for begin in range(0, len(positions), chunk):  # scores (chunk, N): row-wise argmin, in cache
            scores = queries[begin:begin + chunk].dot(features.T)
            np.subtract(self.offsets, scores, out=scores)
            best[begin:begin + chunk] = np.argmin(scores, axis=1)
        distances2 = (self.offsets[best] - np.einsum("bi,bi->b", features[best], queries)) + constant
        return self.q[best], distances2

    def search(self, target: Target, weight: float) -> TableSearch:
        """The entries' distances^2 to a target (pose distance, or position only), to draw the
        nearest from (:class:`TableSearch`)."""
        position = weight * target.position
        if target.rotation is None:
            scores = self.offsets - self.position_features.dot(position)
            constant = float(position.dot(position))
        else:
            scores = self.offsets - self.features.dot(np.concatenate((position, target.rotation.reshape(9))))
            constant = float(position.dot(position)) + 3.0
        return TableSearch(self.q, scores, constant)


@dataclass
class TableSearch:
    """The distances of a seed table's entries to one target: the nearest by argmin, the next ones
    only when asked for."""

    q: np.ndarray
    scores: np.ndarray  # distance^2 - constant
    constant: float

    def nearest(self) -> tuple[np.ndarray, float]:
        """The nearest entry and its distance^2."""
        index = int(np.argmin(self.scores))
        return self.q[index], float(self.scores[index]) + self.constant


def seed_table(chain, size: int, weight: float, kinematics: VectorisedChain | None,
               margin: float) -> SeedTable:
    """The chain's seed table: ``size`` configurations uniform inside the limits shrunk by ``margin``
    x the range at both ends (full-turn joints: the whole turn), a fixed random stream, built once
    per (chain, size, weight, margin) and cached. The margin: an attempt from an entry near a limit
    fails more often (the measurements: docs/measurements.md, bounded_lm)."""
    cache = _LIBRARIES.setdefault(chain, {})
    key = ("table", size, weight, margin)
    if key not in cache:
        bounds = JointBounds.of_chain(chain)
        inset = np.where(bounds.wraps, 0.0, margin * (chain.upper - chain.lower))
        q = np.random.default_rng([size, 1]).uniform(chain.lower + inset, chain.upper - inset,
                                                     size=(size, chain.nq))
        tips = kinematics.tip_poses(q) if size and kinematics is not None else np.zeros((0, 4, 4))
        positions = weight * tips[:, :3, 3]
        features = np.hstack((2.0 * positions, tips[:, :3, :3].reshape(-1, 9))).reshape(-1, 12)
        cache[key] = SeedTable(q[:len(tips)], features, np.ascontiguousarray(features[:, :3]),
                               np.einsum("bi,bi->b", positions, positions))
    return cache[key]


def scaled_model(model: pin.Model, factor: float) -> pin.Model:
    """A copy of ``model`` with every length multiplied by ``factor``: its tip positions are factor x
    the original ones, the linear rows of its Jacobians too, rotations are unchanged. So position
    rows come out weighted at no cost per iteration."""
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
    """1 / (the chain's length scale, m), at least 1: puts metres and radians on a par on small arms.

    The length scale is the sum of the distances between consecutive joint origins and the tip.
    """
    from wbik.solvers.task_error import serial_structure

    length = float(np.linalg.norm(serial_structure(chain).placements[1:, :3, 3], axis=1).sum())
    return max(1.0, 1.0 / max(length, 1e-3))


IK_METHODS = (
    IKMethod("bounded_lm", BoundedLMSolver,
             "ours: joint-limit-bounded Levenberg-Marquardt with vectorised random restarts"),
)
"""The methods this module declares to :mod:`wbik.solvers.method_registry`."""
