"""The held joint k of a 7-joint arm searched (``redundancy="search"``, the default): held at v, the other
six have a closed form, and v solves a pose when a branch is real, inside the limits and passes the FK
screen (by the model's FK). The start's value and a grid over k's range go in one batch; where none passes,
a grid :data:`DENSER` times finer; then grids zoomed on the local minima of the violation (limit excess
plus FK residual), until a branch passes or the interval is below :data:`ZOOM_FLOOR`. The passing branches
go back to the solver (the nearest the start for ``solve``, the distinct ones for ``solve_all``)."""

from __future__ import annotations

import numpy as np

from wbik.geometry import TWO_PI
from wbik.kernels import eaik as choice_kernel
from wbik.solvers.analytic.closed_form import BOUND_SLACK, LIMIT_TOLERANCE, fk_residual, wrap_into_limits
from wbik.targets import Target

DENSER = 8  # where no value of the grid passes, a grid this many times finer over the range comes next
ZOOM_CANDIDATES = 3  # local minima of the violation (the least violating) each zoom level searches around
ZOOM_POINTS = 9  # values per zoomed interval [v - h, v + h]; the next level's h is this level's spacing
ZOOM_FLOOR = 1e-6  # half-width (rad or m) below which the zoom stops: the limits and the screen are as fine
CHOICE_ROWS = 256  # real branches the compiled choice takes at once (``MAX_BRANCHES`` of ``_eaik.c``)


class HeldJointSearch:
    """The search over the held joint of a :class:`~.redundancy.LockedJointForm` whose one 6-joint form
    serves every value (the first or last joint held)."""

    def __init__(self, form):
        self.form = form
        chain = form.chain
        self.lower, self.upper = chain.lower, chain.upper
        self.revolute = ~np.asarray(chain.is_prismatic, dtype=bool)
        self.low, self.high = float(form.range[0]), float(form.range[1])
        self.full_turn = bool(self.revolute[form.index]) and self.high - self.low >= TWO_PI - 1e-12
        # the ``eaik`` method's choice (wrapped nearest first, screened by the lines' FK) for ``nearest``,
        # on revolute joints only (it turns every joint)
        self.choose = choice_kernel.twins()[1] if self.revolute.all() else None
        self.params = choice_kernel.parameters(chain.nq, chain.lower.tolist(), chain.upper.tolist(),
                                               chain.nq * BOUND_SLACK, LIMIT_TOLERANCE, form.lines,
                                               form.screen_tolerance)

    def run(self, position: np.ndarray, rotation: np.ndarray | None, q0: np.ndarray,
            nearest: bool = False) -> tuple[np.ndarray, np.ndarray, int]:
        """(Q (K, n) wrapped nearest q0, passed (K,), outcome): the passing branches found (all passed,
        outcome their count; ``nearest``: only the one nearest q0, screened in order of distance), else every
        branch evaluated (real where real; outcome 0 without a real one, -1 without one inside the limits, -2
        without one passing the screen)."""
        k = self.form.index
        seed = min(max(float(q0[k]), float(self.lower[k])), float(self.upper[k]))
        values = np.concatenate(([seed], self.form.grid))
        spacing = (self.high - self.low) / max(len(self.form.grid), 1)
        evaluated, outcome, target = [], 0, Target(position, rotation)
        pose = None if rotation is None else np.vstack((np.c_[rotation, position], (0.0, 0.0, 0.0, 1.0)))
        choosing = nearest and self.choose is not None and pose is not None
        chosen = np.empty(len(q0) + 24)
        while True:
            raw, real = self.form.branches_at(position[None], None if rotation is None else rotation[None],
                                              q0[None], values[None], exact=True)
            raw, real = raw[0], real[0] & np.all(np.isfinite(raw[0]), axis=-1)
            by_choice = choosing and int(real.sum()) <= CHOICE_ROWS
            if by_choice and self.choose(self.params, raw[real], q0, pose, chosen):
                return chosen[None, :len(q0)].copy(), np.ones(1, dtype=bool), int(real.sum())
            wrapped, inside = wrap_into_limits(raw, q0, self.lower, self.upper, self.revolute)
            candidates = np.flatnonzero(real & inside)
            if nearest and not by_choice and len(candidates):
                squares = wrapped[candidates] - q0
                squares *= squares
                for index in candidates[np.argsort(np.sqrt(np.add.reduce(squares, axis=1)), kind="stable")]:
                    if fk_residual(self.form.chain, wrapped[index], target) <= self.form.screen_tolerance:
                        return wrapped[index][None], np.ones(1, dtype=bool), len(candidates)
            residual = np.array([fk_residual(self.form.chain, q, target) for q in wrapped[candidates]])
            screened = residual <= self.form.screen_tolerance
            if screened.any() and not by_choice:
                count = int(screened.sum())
                return wrapped[candidates[screened]], np.ones(count, dtype=bool), count
            outcome = min(outcome, -2 if len(candidates) else -1 if real.any() else 0)
            evaluated.append((wrapped, real))
            if len(evaluated) == 1:  # a feasible interval narrower than the grid: a finer grid first
                values = self._grid(DENSER * len(self.form.grid))
                spacing /= DENSER
                continue
            if spacing < ZOOM_FLOOR:
                break
            violation = self._violation(raw, real, target)
            violation[candidates] += residual  # inside the limits, real, yet off the target
            violation = violation.reshape(len(values), -1).min(axis=1)
            values = self._zoom(values, violation, spacing)
            spacing = 2.0 * spacing / (ZOOM_POINTS - 1)
        return (np.concatenate([q for q, _ in evaluated]), np.concatenate([r for _, r in evaluated]),
                outcome)

    def nearest_into(self, position: np.ndarray, rotation: np.ndarray | None, reference: np.ndarray,
                     out: np.ndarray) -> int:
        """``solve``'s kernel: the passing branch nearest ``reference`` into ``out``; the number of candidate
        branches, else 0, -1 or -2 (as :class:`~.compiled.CompiledForm`)."""
        q, _, outcome = self.run(position, rotation, reference, nearest=True)
        if outcome > 0:
            out[:] = q[0]
        return outcome

    def _grid(self, count: int) -> np.ndarray:
        """``count`` values over the held joint's range (a full turn without its last value)."""
        return np.linspace(self.low, self.high, count, endpoint=not self.full_turn)

    def _violation(self, q: np.ndarray, real: np.ndarray, target: Target) -> np.ndarray:
        """Per branch, how far it is from passing: the joints outside their limits (:func:`limit_excess`)
        plus, for an approximate branch, its FK residual (m and rad); inf for non-finite joints."""
        violation = limit_excess(q, self.lower, self.upper, self.revolute)
        approximate = ~real & np.all(np.isfinite(q), axis=-1)
        violation[approximate] += [fk_residual(self.form.chain, row, target) for row in q[approximate]]
        violation[~np.all(np.isfinite(q), axis=-1)] = np.inf
        return violation

    def _zoom(self, values: np.ndarray, violation: np.ndarray, spacing: float) -> np.ndarray:
        """The next level's values: ZOOM_POINTS over [v - h, v + h] (h = ``spacing``) around the
        ZOOM_CANDIDATES least violating local minima of the violation along the held joint's range."""
        order = np.argsort(values, kind="stable")
        ordered, along = values[order], violation[order]
        left = np.r_[np.inf, along[:-1]]
        right = np.r_[along[1:], np.inf]
        minima = np.flatnonzero((along <= left) & (along <= right) & np.isfinite(along))
        best = minima[np.argsort(along[minima], kind="stable")[:ZOOM_CANDIDATES]]
        centres = ordered[best] if len(best) else values[:1]
        offsets = np.linspace(-spacing, spacing, ZOOM_POINTS)
        zoomed = (centres[:, None] + offsets).reshape(-1)
        if self.full_turn:
            zoomed = self.low + np.mod(zoomed - self.low, TWO_PI)
        return np.clip(zoomed, self.low, self.high)


def limit_excess(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, revolute: np.ndarray) -> np.ndarray:
    """Per branch (..., n), the sum over joints of how far (rad or m) each is outside its limits, a revolute
    joint at its 2 pi shift nearest the middle of its limits."""
    below, above = lower - q, q - upper
    outside = np.maximum(np.maximum(below, above), 0.0)
    if revolute.any():
        turns = np.round((0.5 * (lower + upper) - q) / TWO_PI)
        shifted = q + np.where(np.isfinite(turns), turns, 0.0) * TWO_PI
        wrapped = np.maximum(np.maximum(lower - shifted, shifted - upper), 0.0)
        outside = np.where(revolute, np.minimum(outside, wrapped), outside)
    outside = np.maximum(outside - LIMIT_TOLERANCE, 0.0)
    return np.sum(outside, axis=-1)
