"""The closed-form framework: :class:`ClosedForm` (a batch of targets to every branch), the rules every
closed form shares (wrapping angles into the limits, the reasons of a failure), the libraries' base."""

from __future__ import annotations

import math
import time
from typing import NamedTuple

import numpy as np

from wbik.geometry import TWO_PI, joint_gap
from wbik.robot import Chain
from wbik.solvers.base import Solver
from wbik.solvers.check import evaluate
from wbik.solvers.result import Candidate, IKResult
from wbik.targets import Target, as_target, pose_error

LIMIT_TOLERANCE = 1e-9  # rad a closed-form joint may leave its limits by and count as inside (set onto it)
BRANCH_MERGE = 1e-6  # branches whose joints differ by less (rad, modulo 2 pi) are one in ``solve_all``
# per joint, how much setting a wrapped angle onto its limit can lower its squared distance to the reference
# below remainder(q - r, 2 pi)^2 (the ``eaik`` method's branch and bound)
BOUND_SLACK = 2.0 * math.pi * LIMIT_TOLERANCE + LIMIT_TOLERANCE ** 2
SCREEN_TOLERANCE = 1e-7  # closed-form FK residual (m and rad) above which a branch is dropped
# a library's decomposition is kept when its branches reproduce (to PROBE_TOLERANCE, m and rad)
# PROBE_REQUIRED of PROBE_POSES FK poses of seeded random joints
PROBE_POSES, PROBE_REQUIRED, PROBE_SEED, PROBE_TOLERANCE = 8, 6, 0, 1e-6
_NEAREST_BOUND = math.pi - 1e-9  # a 2 pi shift inside the limits and nearer than this is the nearest
_SHIFTS = (0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI)


class ClosedForm:
    """A closed-form solver of one chain: ``branches`` and ``fk`` over a batch, an optional compiled
    ``kernel`` of the same choice; ``target_kind``: "pose" or "position"; ``geometry_fk``: a family's
    ``fk(geometry, q)``, which :meth:`fk` applies to ``self.geometry``."""

    target_kind = "pose"
    screen_tolerance = SCREEN_TOLERANCE
    kernel = None
    geometry_fk = None

    def __init__(self, chain: Chain, geometry=None):
        self.chain = chain
        if geometry is not None:
            self.geometry = geometry

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Q (B, K, n), real (B, K)) for positions (B, 3), rotations (B, 3, 3) or None, starts q0 (B, n)."""
        q_all, real = self.branches_by_joint(positions, rotations, q0)
        return np.ascontiguousarray(q_all.transpose(2, 1, 0)), np.ascontiguousarray(real.T)

    def branches_by_joint(self, positions: np.ndarray, rotations: np.ndarray | None,
                          q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`branches` joint-major and batch-last, (Q (n, K, B), real (K, B)); a family overrides one."""
        q_all, real = self.branches(positions, rotations, q0)
        return np.ascontiguousarray(q_all.transpose(2, 1, 0)), np.ascontiguousarray(real.T)

    def exact_branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                       q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`branches`, ``real`` False also where a branch only approximates the target."""
        return self.branches(positions, rotations, q0)

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closed-form FK of joints (..., n): positions (..., 3) and rotations (..., 3, 3)."""
        if self.geometry_fk is None:
            raise NotImplementedError
        return self.geometry_fk(self.geometry, q)

    def compiled(self, chain, alignment, screen_tolerance: float):
        """This form's compiled choice on ``chain`` through ``alignment`` (None: the identity), or None."""
        return None


# --- wrapping into the limits --------------------------------------------------------------------
def wrap_into_limits(q: np.ndarray, reference: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                     revolute: np.ndarray, axis: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """Revolute angles shifted into [lower, upper] nearest ``reference`` and the in-limits mask over the
    joint ``axis``: of the shifts 0, +-2 pi, +-4 pi inside the limits (within LIMIT_TOLERANCE), the nearest
    (the first on a tie), set into the limits; an angle without one stays (mask False)."""
    q = np.asarray(q, dtype=float)
    low, high = lower - LIMIT_TOLERANCE, upper + LIMIT_TOLERANCE
    fixed = None if np.all(revolute) else ~np.asarray(revolute, dtype=bool)
    wrapped = np.subtract(reference, q, out=np.empty_like(q))  # -> turns -> shift -> wrapped q
    wrapped *= 1.0 / TWO_PI
    np.rint(wrapped, out=wrapped)
    np.clip(wrapped, -2.0, 2.0, out=wrapped)
    wrapped *= TWO_PI  # exactly the shift constants; + 0.0 turns -0.0 into the rule's q + 0.0
    wrapped += 0.0
    wrapped += q
    if fixed is not None:
        np.copyto(wrapped, q, where=fixed)
    distance = np.subtract(wrapped, reference)
    np.abs(distance, out=distance)
    if fixed is not None:
        np.copyto(distance, 0.0, where=fixed)  # a prismatic joint has one "shift"
    inside = np.less_equal(distance, _NEAREST_BOUND)
    check = np.greater_equal(wrapped, low)
    inside &= check
    inside &= np.less_equal(wrapped, high, out=check)
    if not inside.all():
        slow = np.flatnonzero(~inside)
        slow_wrapped, slow_inside = _wrap_by_shifts(
            *(np.broadcast_to(values, q.shape).flat[slow] for values in (q, reference, low, high)),
            None if fixed is None else np.broadcast_to(fixed, q.shape).flat[slow])
        wrapped.flat[slow], inside.flat[slow] = slow_wrapped, slow_inside
    return np.clip(wrapped, lower, upper, out=wrapped), np.all(inside, axis=axis)


def _wrap_by_shifts(q: np.ndarray, reference: np.ndarray, low: np.ndarray, high: np.ndarray,
                    fixed: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`wrap_into_limits`'s rule on angles (m,), bounds widened: (nearest shift inside, any inside)."""
    best = q.copy()
    best_distance = np.full(q.shape, np.inf)
    in_limits = np.zeros(q.shape, dtype=bool)
    for shift in _SHIFTS:
        shifted = q + shift
        if fixed is not None:
            np.copyto(shifted, q, where=fixed)
        ok = (shifted >= low) & (shifted <= high)
        if shift and not ok.any():
            continue
        distance = np.abs(shifted - reference)
        better = (distance < best_distance) & ok
        np.copyto(best, shifted, where=better)
        np.copyto(best_distance, distance, where=better)
        in_limits |= ok
    return best, in_limits


def stacked_branches(parts: list[tuple[np.ndarray, np.ndarray]], joints: int
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Per-row branches (K_i, n) and real flags (K_i,) as one batch (B, max(K_i, 1), n), padded with NaN."""
    width = max((len(q) for q, _ in parts), default=0) or 1
    q_all, real = np.full((len(parts), width, joints), np.nan), np.zeros((len(parts), width), dtype=bool)
    for row, (q, flags) in enumerate(parts):
        q_all[row, :len(q)], real[row, :len(q)] = q, flags
    return q_all, real


# --- reasons, and the choice among a library's branches (eaik, ik_geo) ------------------------------
def kernel_failure_reason(outcome: int) -> str:
    """:func:`no_solution_reason` of a kernel's code: 0 (no real branch), -1 (none in the limits), -2."""
    return no_solution_reason(outcome != 0, outcome == -2)


def no_solution_reason(real: bool, in_limits: bool) -> str:
    """Why no branch was returned."""
    if not real:
        return "unreachable: no real closed-form branch (target outside the workspace)"
    if not in_limits:
        return "every real branch is outside the joint limits"
    return "unreachable: no closed-form branch inside the joint limits reaches the target"


def fk_residual(chain: Chain, q: np.ndarray, target: Target) -> float:
    """max(|e_p|, |e_R|) of joints q against the target by the chain's FK (inf for non-finite joints)."""
    if not np.all(np.isfinite(q)):
        return math.inf
    position_xyz, rotation_xyz = pose_error(chain.fk(q), target)
    rotation = 0.0 if rotation_xyz is None else float(np.linalg.norm(rotation_xyz))
    return max(float(np.linalg.norm(position_xyz)), rotation)


class BranchLibrarySolver(Solver):
    """A method choosing among a closed-form library's branches (``eaik``, ``ik_geo``) by the FK screen."""

    budgeted = False
    supports_position_only = False
    library = ""

    def _library_branches(self, target: Target) -> np.ndarray:
        """The library's branches (K, n) of a target as it returns them (not wrapped, not screened)."""
        raise NotImplementedError

    def _pick(self, q_all: np.ndarray, target: Target, q0: np.ndarray) -> Candidate:
        """The branch nearest q0, wrapped into the limits, that passes the FK screen; else why none."""
        chain, library = self.chain, self.library
        outside = "(target outside the workspace)"
        if len(q_all) == 0:
            return Candidate(None, 1, f"unreachable: {library} returns no branch {outside}",
                             extra={"branches": 0})
        wrapped, in_limits = wrap_into_limits(q_all, q0[None], chain.lower, chain.upper, ~chain.is_prismatic)
        usable = in_limits & np.all(np.isfinite(wrapped), axis=-1)
        distance = np.where(usable, np.linalg.norm(wrapped - q0, axis=-1), np.inf)
        for index in np.argsort(distance, kind="stable"):
            if not usable[index]:
                break
            if fk_residual(chain, wrapped[index], target) <= SCREEN_TOLERANCE:
                return Candidate(wrapped[index], 1, extra={"branches": int(usable.sum())})
        if usable.any():
            reason = f"unreachable: no {library} branch inside the joint limits reaches the target"
        elif any(fk_residual(chain, q, target) <= SCREEN_TOLERANCE for q in q_all):
            reason = f"every exact {library} branch is outside the joint limits"
        else:
            reason = f"unreachable: {library} returns only least-squares branches {outside}"
        return Candidate(None, 1, reason, extra={"branches": len(q_all)})

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        return self._pick(self._library_branches(target), target, q0)

    def solve_all(self, target) -> list[IKResult]:
        """Every distinct branch, wrapped into the limits nearest the nominal, passing the shared check."""
        target = as_target(target)
        self._check_target_kind(target)
        start = time.perf_counter()
        q_all = self._library_branches(target)
        elapsed = time.perf_counter() - start
        chain, revolute = self.chain, ~self.chain.is_prismatic
        wrapped, in_limits = wrap_into_limits(q_all, chain.nominal[None], chain.lower, chain.upper, revolute)
        results: list[IKResult] = []
        for q in wrapped[in_limits & np.all(np.isfinite(wrapped), axis=-1)]:
            result = evaluate(chain, target, Candidate(q, 1), self.tolerances, elapsed, self.name)
            if result.success and not any(joint_gap(result.q, other.q, revolute) < BRANCH_MERGE
                                          for other in results):
                results.append(result)
        return results


class Choice(NamedTuple):
    """The vectorised choice: ``q`` (B, n) where ``found``, masks (B, K), the form's FK of q."""

    q: np.ndarray
    found: np.ndarray
    real: np.ndarray
    usable: np.ndarray
    reached_p: np.ndarray
    reached_r: np.ndarray
