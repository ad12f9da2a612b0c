"""The one Levenberg-Marquardt policy of wbik's iterative methods: damping law, accept/reject update,
bound freezing and stall detection, for one configuration and for a batch.

For a residual e(q) (the pose error of :mod:`wbik.geometry`, e = [p - p*; log3(R*^T R)], its SE(3)
form, or any other least-squares residual) with Jacobian J (m x n), one step is

    dq = -(J^T J + lambda I)^-1 J^T e = -J^T (J J^T + lambda I)^-1 e,   lambda = w |e|^2 + mu
                                                                                   (damping law)

with w = ``cost_weight`` and mu the *base damping*, which starts at ``start`` (default ``floor``):
Sugihara's error-dependent damping, large far from the target (robust start), vanishing near it
(Newton-fast end). The smaller of the two equal systems is solved (n x n normal equations when
n <= m, the m x m minimum-norm form otherwise, which stays well conditioned under a tiny damping on
a redundant chain), by Cholesky.

- **Step cap**: with ``max_step`` set, a step whose largest joint change exceeds it is scaled down.
- **Bounds** (:class:`JointBounds`): the trial q + dq is projected into the limits (full-turn
  revolute joints wrapped by 2 pi, the others clipped). A clipped joint already on a bound whose
  step points outwards is *frozen*: the step is recomputed once without it (its column of J
  dropped), so the free joints get the best step the bound leaves them. This is a one-pass active
  set; it is only evaluated when the trial leaves the limits.
- **Accept/reject**: a trial is accepted when its cost |e|^2 is lower. Then mu <- max(decrease mu,
  floor); on a rejection mu <- increase max(mu, reject_floor) (a rejected step jumps the damping
  to at least ``increase * reject_floor`` at once: a tiny mu would only creep up).
- **Stall**: the best cost of a run must fall below ``progress`` x its previous best at least once
  every ``stall`` iterations; otherwise the run has stalled (a local minimum, a limit, or a target
  out of reach). With ``max_damping`` set, a base damping above it is a stall too (the step has
  shrunk to nothing); ``stall=0`` turns the progress test off. :meth:`LevenbergMarquardt.update`
  applies the accept/reject update and the stall test after each trial.

Scalar methods take floats and (n,) arrays; their ``*_batch`` twins take (B,) and (B, n) arrays and
make the same decisions element by element (``tests/test_levenberg_marquardt.py`` checks it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dposv

from wbik.geometry import TWO_PI
from wbik.kernels.twins import chosen
from wbik.kernels.twins import compiled_twin
from wbik.solvers.check import clip_to_limits

_LM_TRIAL = compiled_twin("lm_trial", "lm_trial")
"""The compiled twin of :meth:`LevenbergMarquardt.trial` (None where it is not built)."""


class JointBounds:
    """Joint limits and the projection into them: full-turn revolute joints (``wraps``) are wrapped
    by 2 pi into their range, the others clipped. Immutable after construction (shared by threads)."""

    def __init__(self, lower: np.ndarray, upper: np.ndarray, wraps: np.ndarray | None = None):
        self.lower = np.asarray(lower, dtype=float).copy()
        self.upper = np.asarray(upper, dtype=float).copy()
        self.wraps = (np.zeros(self.lower.shape, dtype=bool) if wraps is None
                      else np.asarray(wraps, dtype=bool).copy())
        self.clipped = ~self.wraps
        self.any_wrap = bool(self.wraps.any())
        self.wrap_mask = self.wraps.astype(float) if self.any_wrap else None  # (the compiled trial's form)
        for array in (self.lower, self.upper, self.wraps, self.clipped, self.wrap_mask):
            if array is not None:
                array.flags.writeable = False

    @classmethod
    def of_chain(cls, chain) -> JointBounds:
        """A chain's limits; revolute joints whose range spans a full turn wrap."""
        wraps = (~chain.is_prismatic) & (chain.upper - chain.lower >= TWO_PI - 1e-9)
        return cls(chain.lower, chain.upper, wraps)

    def project(self, q: np.ndarray) -> np.ndarray:
        """q (n,) or (B, n) inside the limits: wrapped full-turn joints, clipped others (a new array)."""
        lower, upper = self.lower, self.upper
        inside = clip_to_limits(q, lower, upper)
        if self.any_wrap:
            outside = (inside != q) & self.wraps
            if outside.any():  # lower + (q - lower mod 2 pi) is in [lower, lower + 2 pi): clip its top
                inside = np.minimum(np.where(outside, lower + np.mod(q - lower, TWO_PI), inside), upper)
        return inside

    def blocked(self, q: np.ndarray, clipped_trial: np.ndarray) -> np.ndarray:
        """Clipped joints on a bound whose step points outwards, (n,) or (B, n): the ones to freeze.
        ``clipped_trial`` is q + dq clipped into the limits, so they are the joints it leaves at q."""
        blocked = clipped_trial == q
        if self.any_wrap:
            blocked &= self.clipped
        return blocked


@dataclass(frozen=True)
class LevenbergMarquardt:
    """The policy's numbers (see the module docstring); the methods apply them.

    cost_weight: w of lambda = w |e|^2 + mu; floor: the least (and first) base damping mu;
    decrease, increase: mu's factors on an accepted / rejected step; reject_floor: mu is raised to
    at least this before a rejection multiplies it; progress, stall: a run stalls when its best cost
    has not fallen below ``progress`` x the previous best in ``stall`` iterations (0: never);
    max_damping: a base damping above this is a stall (None: no such test); max_step: cap on the
    largest joint step (rad or m; None: no cap); start: the first base damping (None: ``floor``).
    """

    cost_weight: float = 0.01
    floor: float = 1e-6
    decrease: float = 0.3
    increase: float = 10.0
    reject_floor: float = 1e-3
    progress: float = 0.9
    stall: int = 3
    max_damping: float | None = None
    max_step: float | None = None
    start: float | None = None

    @property
    def first_damping(self) -> float:
        """The base damping mu a run starts with."""
        return self.floor if self.start is None else self.start

    # -- the damping law --------------------------------------------------------------------------
    def damping(self, cost, base):
        """lambda = w |e|^2 + mu (floats or arrays)."""
        return self.cost_weight * cost + base

    # -- one configuration ------------------------------------------------------------------------
    def trial(self, jacobian: np.ndarray, error: np.ndarray, cost: float, base: float, q: np.ndarray,
              bounds: JointBounds, workspace: Workspace | None = None) -> np.ndarray:
        """The next trial configuration, inside the limits, from J (m, n) and e (m,) at q (n,) with
        cost |e|^2 and base damping mu: damped step, cap, projection and bound freezing.
        ``workspace`` (:meth:`workspace`, one per run and thread) saves the system's allocation."""
        damping = self.cost_weight * cost + base
        descent = _descent(jacobian, error, damping, workspace)  # dq = -descent
        if self.max_step is not None:
            descent = self._capped(descent)
        trial = q - descent
        inside = clip_to_limits(trial, bounds.lower, bounds.upper)
        if inside.tobytes() != trial.tobytes():  # some joint left its range (or needs wrapping)
            blocked = bounds.blocked(q, inside)
            if blocked.any():
                free = np.flatnonzero(~blocked)
                descent = np.zeros(q.shape[0])
                if free.size:
                    descent[free] = _frozen_descent(jacobian, error, damping, free, workspace)
                trial = q - self._capped(descent)
            inside = bounds.project(trial)
        return inside

    def trial_function(self, bounds: JointBounds):
        """:meth:`trial` for one set of bounds, through the compiled twin where it is built (and not
        switched off by ``WBIK_PURE_PYTHON=1``, read here): the same decisions with the sums in C, so it
        agrees with :meth:`trial` to rounding (tests/test_lm_kernel.py). It hands the trial to
        :meth:`trial` where its Cholesky fails (least squares), for systems over 32 rows or joints, and
        for other bounds than these."""
        kernel = chosen(None, _LM_TRIAL, "lm_trial")
        if kernel is None:
            return self.trial
        captured, lower, upper, wraps = bounds, bounds.lower, bounds.upper, bounds.wrap_mask
        max_step = -1.0 if self.max_step is None else self.max_step  # (the kernel's "no cap")
        cost_weight, python_trial = self.cost_weight, self.trial
        size = lower.shape[0]

        def trial(jacobian: np.ndarray, error: np.ndarray, cost: float, base: float, q: np.ndarray,
                  bounds: JointBounds, workspace: Workspace | None = None) -> np.ndarray:
            inside, damping = np.empty(size), cost_weight * cost + base
            if bounds is captured and kernel(jacobian, error, damping, q, lower, upper, wraps, max_step,
                                             inside):
                return inside
            return python_trial(jacobian, error, cost, base, q, bounds, workspace)

        return trial

    def _capped(self, step: np.ndarray) -> np.ndarray:
        """A step (n,), or each row of steps (B, n), scaled down to a largest joint change of at most
        ``max_step``. One step is tested as a float (numpy's per-call cost is most of the time here)."""
        if self.max_step is None:
            return step
        if step.ndim == 1:
            longest = float(np.abs(step).max())
            return step * (self.max_step / longest) if longest > self.max_step else step
        longest = np.abs(step).max(axis=1)
        scale = np.where(longest > self.max_step, self.max_step / np.maximum(longest, 1e-300), 1.0)
        return step * scale[:, None]

    @staticmethod
    def workspace(rows: int, columns: int) -> Workspace:
        """Buffers for :meth:`trial` on J of shape (rows, columns): one per run, never shared."""
        return Workspace(min(rows, columns))

    def update(self, accepted: bool, base: float, cost: float, best: float, since: int
               ) -> tuple[float, float, int, bool]:
        """After a trial: (base damping, best cost, iterations since progress, stalled?).

        mu <- max(decrease mu, floor) when the trial was accepted, increase max(mu, reject_floor)
        if not; progress is a cost below ``progress`` x the best so far; the run has stalled after
        ``stall`` iterations without progress, or when mu exceeds ``max_damping``."""
        if accepted:
            base = max(base * self.decrease, self.floor)
        else:
            base = max(base, self.reject_floor) * self.increase
        if cost < self.progress * best:
            best, since = cost, 0
        else:
            since += 1
        return base, best, since, (0 < self.stall <= since) or (
            self.max_damping is not None and base > self.max_damping)

    # -- a batch of configurations, element by element the same decisions --------------------------
    def start_batch(self, error: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(costs, base dampings, best costs, iterations since progress) of fresh runs from their
        errors (B, m)."""
        cost = batch_cost(error)
        return cost, np.full(cost.shape, self.first_damping), cost.copy(), np.zeros(cost.shape, dtype=int)

    def trial_batch(self, jacobian: np.ndarray, error: np.ndarray, cost: np.ndarray, base: np.ndarray,
                    q: np.ndarray, bounds: JointBounds) -> np.ndarray:
        """:meth:`trial` for J (B, m, n), e (B, m), costs and base dampings (B,) and q (B, n). A frozen
        joint's column of J is zeroed: its step is 0 and the free joints solve the reduced system."""
        damping = self.damping(cost, base)
        step = self._capped(_damped_steps(jacobian, error, damping))
        trial = q + step
        inside = clip_to_limits(trial, bounds.lower, bounds.upper)
        if inside.tobytes() != trial.tobytes():
            blocked = bounds.blocked(q, inside)
            rows = np.flatnonzero(blocked.any(axis=1))
            if rows.size:  # re-solve those rows only, their frozen columns zeroed
                step[rows] = self._capped(_damped_steps(jacobian[rows] * ~blocked[rows, None, :],
                                                        error[rows], damping[rows]))
                trial = q + step
            inside = bounds.project(trial)
        return inside

    def update_batch(self, accepted: np.ndarray, base: np.ndarray, cost: np.ndarray, best: np.ndarray,
                     since: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`update` element by element."""
        base = np.where(accepted, np.maximum(base * self.decrease, self.floor),
                        np.maximum(base, self.reject_floor) * self.increase)
        progressed = cost < self.progress * best
        best = np.where(progressed, cost, best)
        since = np.where(progressed, 0, since + 1)
        stalled = (since >= self.stall) if self.stall > 0 else np.zeros(cost.shape, dtype=bool)
        if self.max_damping is not None:
            stalled |= base > self.max_damping
        return base, best, since, stalled


def batch_cost(error: np.ndarray) -> np.ndarray:
    """The cost |e|^2 of each row of errors (B, m)."""
    return np.einsum("bi,bi->b", error, error)


def keep_better(trial_cost: np.ndarray, cost: np.ndarray, *pairs: tuple[np.ndarray, np.ndarray]
                ) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """The batched accept step: for each row, the trial where it lowers the cost, else the current.

    ``pairs`` are (trial, current) arrays with the batch on their first axis. Returns (accepted (B,),
    the new cost, the kept arrays in the order given)."""
    accepted = trial_cost < cost
    kept = [np.where(accepted.reshape((-1,) + (1,) * (trial.ndim - 1)), trial, current)
            for trial, current in pairs]
    return accepted, np.minimum(trial_cost, cost), kept


class Workspace:
    """The damped system's buffer, a view of its diagonal and the last right-hand side (for one run
    in one thread)."""

    def __init__(self, size: int):
        self.system = np.empty((size, size))
        self.diagonal = self.system.reshape(-1)[::size + 1]
        self.right = np.empty(size)


def _descent(jacobian: np.ndarray, error: np.ndarray, damping: float,
             workspace: Workspace | None = None) -> np.ndarray:
    """(J^T J + lambda I)^-1 J^T e = J^T (J J^T + lambda I)^-1 e (the step is its negative), by the
    smaller system (Cholesky; least squares if it fails)."""
    rows, columns = jacobian.shape
    transpose = jacobian.T
    small = columns <= rows
    if workspace is None:
        system = transpose.dot(jacobian) if small else jacobian.dot(transpose)
        system.reshape(-1)[::system.shape[0] + 1] += damping
    else:
        system = workspace.system
        if small:
            np.dot(transpose, jacobian, out=system)
        else:
            np.dot(jacobian, transpose, out=system)
        workspace.diagonal += damping
    if small:
        right = transpose.dot(error)
        if workspace is not None:
            workspace.right = right
    else:
        right = error
    _, solution, info = dposv(system, right)
    if info:  # not numerically positive definite: least squares
        solution = np.linalg.lstsq(system, right, rcond=None)[0]
    return solution if small else transpose.dot(solution)


def _frozen_descent(jacobian: np.ndarray, error: np.ndarray, damping: float, free: np.ndarray,
                    workspace: Workspace | None) -> np.ndarray:
    """:func:`_descent` on the ``free`` joints only (J's other columns dropped). The normal equations
    of a run are the last system's free rows and columns: taken from the workspace, not recomputed."""
    rows, columns = jacobian.shape
    if workspace is None or columns > rows:
        return _descent(jacobian[:, free], error, damping)
    system, right = workspace.system[free[:, None], free], workspace.right[free]
    _, solution, info = dposv(system, right)
    if info:
        solution = np.linalg.lstsq(system, right, rcond=None)[0]
    return solution


def _damped_steps(jacobian: np.ndarray, error: np.ndarray, damping: np.ndarray) -> np.ndarray:
    """The steps -:func:`_descent` for J (B, m, n), e (B, m) and lambda (B,)."""
    rows, columns = jacobian.shape[1:]
    transpose = np.swapaxes(jacobian, 1, 2)
    if columns <= rows:
        system = np.matmul(transpose, jacobian)
        right = np.matmul(transpose, error[:, :, None])
    else:
        system = np.matmul(jacobian, transpose)
        right = error[:, :, None]
    diagonal = np.einsum("bii->bi", system)
    diagonal += damping[:, None]
    solution = np.linalg.solve(system, right)
    return -(solution if columns <= rows else np.matmul(transpose, solution))[..., 0]
