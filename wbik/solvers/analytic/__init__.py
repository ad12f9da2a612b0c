"""Method ``analytic``: closed-form IK, every branch, vectorised over batches of targets.

A closed form is a :class:`ClosedForm` registered for (robot, chain, target kind). It maps a batch
of B targets to K candidate branches per target, ``Q`` (B, K, n), with a mask ``valid`` (B, K)
of branches that exist (real square roots / cosines in [-1, 1], with a small clamp tolerance), and
provides its own vectorised FK so branches can be screened without a Python loop.
:class:`AnalyticSolver` then wraps revolute angles into the limits (nearest to q0), drops branches
outside the limits or whose closed-form FK misses the target, and picks the branch nearest to q0.
The returned joints still go through the shared Pinocchio FK check of :mod:`wbik.solvers.base`.
"""

from __future__ import annotations

import importlib
import math
import time
from collections.abc import Iterable

import numpy as np

from wbik.errors import UnsupportedError
from wbik.geometry import joint_gap
from wbik.robot import Chain
from wbik.solvers.base import Candidate, IKResult, Solver, evaluate
from wbik.targets import Target, as_target

TWO_PI = 2.0 * np.pi
LIMIT_TOLERANCE = 1e-9
"""Angle (rad) by which a closed-form joint may leave its limits and still count as inside (then set onto
the limit). Inverses of poses whose joints sit exactly at a limit come back a few 1e-12 rad outside, and
up to ~1e-8 rad near a singular pose where an arccos amplifies rounding; 1e-9 rad moves a 1 m lever by
1e-9 m, far below the screening tolerance. The old 1e-12 was only ~1e3 ulps of an angle."""
BRANCH_MERGE = 1e-6
"""Two branches whose joints differ by less than this (rad, modulo 2 pi) are one solution in
``solve_all``: at a singular pose (elbow stretched, wrist aligned) two analytic branches coincide, but
rounding through arccos splits them by up to ~1e-7 rad, machine-dependently."""


class ClosedForm:
    """Base class of closed-form solvers for one chain. Subclasses implement ``branches`` and ``fk``.

    ``target_kind`` is "pose" (position and rotation) or "position".
    """

    target_kind = "pose"
    screen_tolerance = 1e-7
    """Closed-form FK residual (m and rad) above which a branch is dropped before the shared check."""

    def __init__(self, chain: Chain):
        self.chain = chain

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Q (B, K, n), valid (B, K)) for positions (B, 3), rotations (B, 3, 3) or None."""
        raise NotImplementedError

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closed-form FK of joints (..., n): positions (..., 3) and rotations (..., 3, 3)."""
        raise NotImplementedError

    def solve_one(self, position: np.ndarray, rotation: np.ndarray | None, q0: np.ndarray):
        """Optional scalar fast path (plain floats, no array overhead) with the same screening as the
        vectorised path: (q nearest to q0 or None, number of usable branches). NotImplemented (the
        default) means: use ``branches`` with a batch of one."""
        return NotImplemented


def closed_forms(robot) -> dict[tuple[str, str], str]:
    """A robot's closed forms: ``robot.info["closed_forms"]`` maps (chain, kind) to "module:Class".

    Each built-in model declares its own; a user robot can do the same.
    """
    return dict(robot.info.get("closed_forms", {}))


def _closed_form(chain: Chain, kind: str, **options) -> ClosedForm:
    forms = closed_forms(chain.robot)
    if (chain.name, kind) not in forms:
        available = sorted(f"{c} ({k})" for c, k in forms)
        raise UnsupportedError(
            f"no closed form for {chain.robot.name}.{chain.name} with {kind} targets; available: "
            f"{', '.join(available) or '(none)'}. Use a numerical method (e.g. 'dls') instead")
    module_name, class_name = forms[(chain.name, kind)].split(":")
    return getattr(importlib.import_module(module_name), class_name)(chain, **options)


def wrap_into_limits(q: np.ndarray, reference: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                     revolute: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shift revolute angles by multiples of 2 pi to lie in [lower, upper], nearest to ``reference``.

    Returns (wrapped q, in-limits mask over the last axis). Works on any leading batch shape.
    """
    best = q.copy()
    best_distance = np.full(q.shape, np.inf)
    in_limits = np.zeros(q.shape, dtype=bool)
    shifts = (0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI)
    for shift in shifts:
        shifted = np.where(revolute, q + shift, q)
        ok = (shifted >= lower - LIMIT_TOLERANCE) & (shifted <= upper + LIMIT_TOLERANCE)
        distance = np.abs(shifted - reference)
        better = ok & (distance < best_distance)
        best = np.where(better, shifted, best)
        best_distance = np.where(better, distance, best_distance)
        in_limits |= ok
    return np.clip(best, lower, upper), np.all(in_limits, axis=-1)


_SHIFTS = (0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI)


def wrap_one_into_limits(q, reference, lower, upper) -> list[float] | None:
    """:func:`wrap_into_limits` for one vector of revolute angles in plain floats (scalar fast paths):
    the 2 pi shift of each angle inside its limits nearest to ``reference``, set onto the limit when
    within LIMIT_TOLERANCE of it; None if some angle has no shift inside its limits."""
    wrapped = []
    for value, ref, low, high in zip(q, reference, lower, upper, strict=True):
        turns = round((ref - value) / TWO_PI)  # the shift nearest ref; the usual answer
        if -2 <= turns <= 2:
            shifted = value + turns * TWO_PI
            if low - LIMIT_TOLERANCE <= shifted <= high + LIMIT_TOLERANCE:
                wrapped.append(min(high, max(low, shifted)))
                continue
        best, best_distance = None, math.inf
        for shift in _SHIFTS:
            shifted = value + shift
            if (low - LIMIT_TOLERANCE <= shifted <= high + LIMIT_TOLERANCE
                    and abs(shifted - ref) < best_distance):
                best, best_distance = shifted, abs(shifted - ref)
        if best is None:
            return None
        wrapped.append(min(high, max(low, best)))
    return wrapped


class AnalyticSolver(Solver):
    """Closed-form IK behind the common interface; see the module docstring."""

    name = "analytic"
    budgeted = False

    def __init__(self, robot, chain=None, closed_form_options: dict[str, dict] | None = None, **options):
        """``closed_form_options``: keyword arguments per target kind for the closed form's
        constructor, e.g. ``{"position": {"yaw": 0.3}}`` (Golem-III's fixed wrist roll)."""
        super().__init__(robot, chain, **options)
        self._forms: dict[str, ClosedForm] = {}
        self.closed_form_options = dict(closed_form_options or {})
        self.revolute = ~self.chain.is_prismatic

    def closed_form(self, kind: str) -> ClosedForm:
        if kind not in self._forms:
            self._forms[kind] = _closed_form(self.chain, kind, **self.closed_form_options.get(kind, {}))
        return self._forms[kind]

    def _screen(self, form: ClosedForm, positions, rotations, q0s) -> tuple[np.ndarray, np.ndarray]:
        """All branches for a batch: wrapped joints (B, K, n) and usable mask (B, K)."""
        q_all, valid = form.branches(positions, rotations, q0s)
        q_all, in_limits = wrap_into_limits(q_all, q0s[:, None, :], self.chain.lower, self.chain.upper,
                                            self.revolute)
        usable = valid & in_limits & np.all(np.isfinite(q_all), axis=-1)
        reached_p, reached_r = form.fk(np.where(usable[..., None], q_all, 0.0))
        residual = np.linalg.norm(reached_p - positions[:, None, :], axis=-1)
        if rotations is not None:
            trace = np.sum(rotations[:, None] * reached_r, axis=(-2, -1))  # trace(R_target^T R_reached)
            cosine = np.clip((trace - 1.0) / 2.0, -1.0, 1.0)
            residual = np.maximum(residual, np.arccos(cosine))
        usable &= residual <= form.screen_tolerance
        return q_all, usable

    @staticmethod
    def _nearest(q_all: np.ndarray, usable: np.ndarray, q0s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        distance = np.linalg.norm(q_all - q0s[:, None, :], axis=-1)
        distance = np.where(usable, distance, np.inf)
        best = np.argmin(distance, axis=1)
        return q_all[np.arange(len(best)), best], np.any(usable, axis=1)

    def _batch(self, targets: list[Target], q0s: np.ndarray):
        kinds = {"pose" if t.is_pose else "position" for t in targets}
        if len(kinds) != 1:
            raise UnsupportedError("a batch must hold only full poses or only positions")
        form = self.closed_form(kinds.pop())
        positions = np.array([t.position for t in targets])
        rotations = np.array([t.rotation for t in targets]) if form.target_kind == "pose" else None
        return form, positions, rotations

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        fast = self.closed_form("pose" if target.is_pose else "position").solve_one(
            target.position, target.rotation, q0)
        if fast is not NotImplemented:
            q_best, count = fast
            if q_best is None:
                return Candidate(None, 1, "unreachable: no closed-form branch inside the joint limits "
                                          "reaches the target")
            return Candidate(q_best, 1, extra={"branches": count})
        form, positions, rotations = self._batch([target], q0[None])
        q_all, usable = self._screen(form, positions, rotations, q0[None])
        q_best, found = self._nearest(q_all, usable, q0[None])
        if not found[0]:
            return Candidate(None, 1, self._no_solution_reason(form, positions, rotations, q0))
        return Candidate(q_best[0], 1, extra={"branches": int(usable.sum())})

    def _no_solution_reason(self, form, positions, rotations, q0) -> str:
        q_all, valid = form.branches(positions, rotations, q0[None])
        if not valid.any():
            return "unreachable: no real closed-form branch (target outside the workspace)"
        return "every real branch is outside the joint limits"

    def solve_many(self, targets: Iterable, q0s=None) -> list[IKResult]:
        """Vectorised: one closed-form evaluation for the whole batch; per-pose time = total / B."""
        targets = [as_target(t) for t in targets]
        if not targets:
            return []
        for target in targets:
            self._check_target_kind(target)
        starts = self._batch_starts(q0s, len(targets))
        q0_array = np.array([self.chain.nominal if s is None else s for s in starts])
        start = time.perf_counter()
        form, positions, rotations = self._batch(targets, q0_array)
        q_all, usable = self._screen(form, positions, rotations, q0_array)
        q_best, found = self._nearest(q_all, usable, q0_array)
        per_pose = (time.perf_counter() - start) / len(targets)
        results = []
        for index, target in enumerate(targets):
            if found[index]:
                candidate = Candidate(q_best[index], 1, extra={"branches": int(usable[index].sum()),
                                                               "batched": True})
            else:
                reason = self._no_solution_reason(form, positions[index:index + 1],
                                                  None if rotations is None else rotations[index:index + 1],
                                                  q0_array[index])
                candidate = Candidate(None, 1, reason, extra={"batched": True})
            results.append(evaluate(self.chain, target, candidate, self.tolerances, per_pose, self.name))
        return results

    def solve_all(self, target) -> list[IKResult]:
        """Every distinct branch inside the limits that passes the shared FK check."""
        target = as_target(target)
        self._check_target_kind(target)
        q0 = self.chain.nominal[None]
        start = time.perf_counter()
        form, positions, rotations = self._batch([target], q0)
        q_all, usable = self._screen(form, positions, rotations, q0)
        elapsed = time.perf_counter() - start
        distinct: list[np.ndarray] = []
        for q in q_all[0][usable[0]]:
            if not any(joint_gap(q, other, self.revolute) < BRANCH_MERGE for other in distinct):
                distinct.append(q)
        results = [evaluate(self.chain, target, Candidate(q, 1), self.tolerances, elapsed, self.name)
                   for q in distinct]
        return [r for r in results if r.success]
