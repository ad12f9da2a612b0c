"""The one Levenberg-Marquardt policy of wbik's iterative methods, for one configuration and for a batch.

dq = -J^T (J J^T + lambda I)^-1 e (Cholesky on the smaller system), lambda = w |e|^2 + mu, capped at
``max_step`` and projected into the limits, a joint pushed outwards on its bound frozen. An accepted trial
(lower |e|^2) sets mu <- max(decrease mu, floor), a rejected one mu <- increase max(mu, reject_floor). A run
stalls when its best cost has not fallen below ``progress`` x its previous best in ``stall`` iterations,
or mu exceeds ``max_damping``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dposv

from wbik.geometry import TWO_PI
from wbik.kernels.twins import chosen, compiled_twin
from wbik.solvers.check import clip_to_limits

_LM_TRIAL = compiled_twin("lm_trial", "lm_trial")  # LevenbergMarquardt.trial's (None: not built)


class JointBounds:
    """Joint limits and the projection into them (full-turn ``wraps`` wrapped by 2 pi, others clipped)."""

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
        """The joints to freeze, (n,) or (B, n): clipped ones on a bound pushed outwards, those
        ``clipped_trial`` (q + dq clipped) leaves at q."""
        blocked = clipped_trial == q
        if self.any_wrap:
            blocked &= self.clipped
        return blocked


@dataclass(frozen=True)
class LevenbergMarquardt:
    """The policy's numbers: ``start``, the first mu (None: ``floor``); ``stall=0``: no progress test;
    ``max_damping``, ``max_step`` (rad or m) None: none."""

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

    def trial(self, jacobian: np.ndarray, error: np.ndarray, cost: float, base: float, q: np.ndarray,
              bounds: JointBounds, workspace: Workspace | None = None) -> np.ndarray:
        """The next trial inside the limits from J (m, n), e (m,), |e|^2 and mu at q (n,)."""
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
        """:meth:`trial` for these bounds through the compiled twin (unless ``WBIK_PURE_PYTHON=1``)."""
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
        """A step (n,), or each row of steps (B, n), scaled down to a largest joint change <= ``max_step``."""
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
        """After a trial: (base damping, best cost, iterations since progress, stalled?)."""
        base = (max(base * self.decrease, self.floor) if accepted
                else max(base, self.reject_floor) * self.increase)
        if cost < self.progress * best:
            best, since = cost, 0
        else:
            since += 1
        return base, best, since, (0 < self.stall <= since) or (
            self.max_damping is not None and base > self.max_damping)

    def start_batch(self, error: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(costs, base dampings, best costs, iterations since progress) of fresh runs, errors (B, m)."""
        cost = batch_cost(error)
        return cost, np.full(cost.shape, self.first_damping), cost.copy(), np.zeros(cost.shape, dtype=int)

    def trial_batch(self, jacobian: np.ndarray, error: np.ndarray, cost: np.ndarray, base: np.ndarray,
                    q: np.ndarray, bounds: JointBounds) -> np.ndarray:
        """:meth:`trial` for J (B, m, n), e (B, m), costs and mu (B,), q (B, n)."""
        damping = self.cost_weight * cost + base
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
    """The batched accept step: per row, the trial where it lowers the cost, else the current; ``pairs``
    (trial, current) with the batch first. Returns (accepted (B,), the new cost, the kept arrays)."""
    accepted = trial_cost < cost
    kept = [np.where(accepted.reshape((-1,) + (1,) * (trial.ndim - 1)), trial, current)
            for trial, current in pairs]
    return accepted, np.minimum(trial_cost, cost), kept


class Workspace:
    """The damped system's buffer, its diagonal and the last right-hand side (one run, one thread)."""

    def __init__(self, size: int):
        self.system = np.empty((size, size))
        self.diagonal = self.system.reshape(-1)[::size + 1]
        self.right = np.empty(size)


def _descent(jacobian: np.ndarray, error: np.ndarray, damping: float,
             workspace: Workspace | None = None) -> np.ndarray:
    """(J^T J + lambda I)^-1 J^T e = J^T (J J^T + lambda I)^-1 e (-dq) by the smaller system."""
    rows, columns = jacobian.shape
    transpose = jacobian.T
    small = columns <= rows
    if workspace is None:
        system = transpose.dot(jacobian) if small else jacobian.dot(transpose)
        system.reshape(-1)[::system.shape[0] + 1] += damping
    else:
        system = workspace.system
        np.dot(*((transpose, jacobian) if small else (jacobian, transpose)), out=system)
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
    """:func:`_descent` on the ``free`` joints: the free rows and columns of the workspace's last system."""
    rows, columns = jacobian.shape
    if workspace is None or columns > rows:
        return _descent(jacobian[:, free], error, damping)
    system, right = workspace.system[free[:, None], free], workspace.right[free]
    _, solution, info = dposv(system, right)
    return np.linalg.lstsq(system, right, rcond=None)[0] if info else solution


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
