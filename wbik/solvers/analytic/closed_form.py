"""The closed-form framework: a :class:`ClosedForm` maps a batch of targets to every branch, and the
rules every closed form shares: wrapping revolute angles into the limits nearest a reference, the
screen of a branch's own FK against the target, the choice of the branch nearest the start, and the
reasons of a failure (no real branch, none inside the limits, none reaching the target).
"""

from __future__ import annotations

import math
from operator import itemgetter
from operator import mul
from typing import NamedTuple

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.geometry import TWO_PI
from wbik.geometry import joint_gap
from wbik.robot import Chain
from wbik.solvers.base import Solver
from wbik.solvers.check import evaluate
from wbik.solvers.result import Candidate
from wbik.solvers.result import IKResult
from wbik.targets import Target
from wbik.targets import pose_error

LIMIT_TOLERANCE = 1e-9
"""Angle (rad) by which a closed-form joint may leave its limits and still count as inside (then set onto
the limit). Inverses of poses whose joints sit exactly at a limit come back a few 1e-12 rad outside, and
up to ~1e-8 rad near a singular pose where an arccos amplifies rounding; 1e-9 rad moves a 1 m lever by
1e-9 m, far below the screening tolerance. A tolerance of 1e-12 would be only ~1e3 ulps of an angle."""
BRANCH_MERGE = 1e-6
"""Two branches whose joints differ by less than this (rad, modulo 2 pi) are one solution in
``solve_all``: at a singular pose (elbow stretched, wrist aligned) two analytic branches coincide, but
rounding through arccos splits them by up to ~1e-7 rad, machine-dependently."""
BOUND_SLACK = 2.0 * math.pi * LIMIT_TOLERANCE + LIMIT_TOLERANCE ** 2
"""Per joint, how much setting a wrapped angle onto its limit (<= LIMIT_TOLERANCE) can lower its squared
distance to the reference below the bound remainder(q - r, 2 pi)^2 (|remainder| <= pi)."""
_SHIFTS = (0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI)
_BOUND = itemgetter(0)


class ClosedForm:
    """Base class of closed-form solvers for one chain. Subclasses implement ``branches`` and ``fk``,
    and optionally the scalar fast path ``branches_one`` and ``fk_one``.

    ``target_kind`` is "pose" (position and rotation) or "position".
    """

    target_kind = "pose"
    screen_tolerance = 1e-7
    """Closed-form FK residual (m and rad) above which a branch is dropped before the shared check."""

    def __init__(self, chain: Chain):
        self.chain = chain

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Q (B, K, n), real (B, K)) for positions (B, 3), rotations (B, 3, 3) or None, starts q0 (B, n)."""
        raise NotImplementedError

    def branches_by_joint(self, positions: np.ndarray, rotations: np.ndarray | None,
                          q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`branches` joint-major and batch-last, the layout of ``solve_many``'s choice:
        (Q (n, K, B), real (K, B)). This default transposes ``branches``; a family whose intermediates
        are batch-last (:mod:`.ur_type`) computes it directly and derives ``branches`` from it."""
        q_all, real = self.branches(positions, rotations, q0)
        return np.ascontiguousarray(q_all.transpose(2, 1, 0)), np.ascontiguousarray(real.T)

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closed-form FK of joints (..., n): positions (..., 3) and rotations (..., 3, 3)."""
        raise NotImplementedError

    has_scalar_path = False
    """True when the subclass implements ``branches_one`` and ``fk_one`` (revolute joints only)."""

    def branches_one(self, position: list[float], rotation: list[float] | None,
                     reference: list[float]) -> list[tuple[float, list[float]]]:
        """Scalar fast path: the real branches of one target in plain floats, in the order of
        ``branches``, each as (bound, q) with bound <= sum_i remainder(q_i - r_i, 2 pi)^2, a lower bound
        of its squared distance to ``reference`` once wrapped (:func:`nearest_branch`). ``rotation`` is
        the target rotation row by row (9 floats) or None."""
        raise NotImplementedError

    def fk_one(self, q: list[float]) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """:meth:`fk` of one joint vector in plain floats: (position (3), rotation row by row (9))."""
        raise NotImplementedError

    kernel = None
    """The compiled twin of the scalar path (:class:`.ur_kernel.URKernel`) or None: ``solve`` calls its
    ``nearest_into`` in place of ``branches_one`` and the Python choice (same bits), ``solve_many`` its
    ``nearest_many`` and ``solve_all`` its ``results`` (the same choice and branches, checked with the
    closed form's FK as ``solve_many`` always checks)."""

    def compiled_kernel(self, tool: tuple[np.ndarray, np.ndarray] | None = None,
                        screen_tolerance: float | None = None):
        """A compiled scalar path of this form on its chain, composed with a fixed tool (rotation,
        translation) when given, screening at ``screen_tolerance`` (default: this form's); None where
        the form has none (the default) or it is not built."""
        return None


class ToolClosedForm(ClosedForm):
    """A chain ending at a tool rigidly fixed to the tip of a chain with a closed form (the *flange*):
    T_tool = T_flange X with X read from the model, so T_flange = T_tool X^-1 and FK_tool = FK_flange X.

    Subclasses name ``flange_form`` (the flange's ClosedForm class) and ``flange_chain`` (its chain,
    over the same joints).
    """

    flange_form: type[ClosedForm]
    flange_chain: str

    def __init__(self, chain: Chain):
        super().__init__(chain)
        flange_chain = chain.robot.chain(self.flange_chain)
        if flange_chain.joint_names != chain.joint_names or flange_chain.base_frame != chain.base_frame:
            raise InvalidConfigurationError(
                f"{chain.name!r} ({chain.base_frame} -> {chain.tip_frame} over {chain.joint_names}) is not "
                f"{flange_chain.name!r} ({flange_chain.base_frame} -> {flange_chain.tip_frame} over "
                f"{flange_chain.joint_names}) with a tool: a tool closed form needs the same base and joints")
        self.flange = self.flange_form(flange_chain)
        self.target_kind = self.flange.target_kind
        self.has_scalar_path = self.flange.has_scalar_path
        tool = flange_chain.fk(flange_chain.nominal).inverse() * chain.fk(chain.nominal)
        self.tool_rotation = tool.rotation.copy()
        self.tool_translation = tool.translation.copy()
        self._tool_r, self._tool_p = self.tool_rotation.tolist(), self.tool_translation.tolist()
        self.kernel = self.flange.compiled_kernel((self.tool_rotation, self.tool_translation),
                                                  self.screen_tolerance)

    def _flange_targets(self, positions: np.ndarray, rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(flange positions, flange rotations) of tool targets: R X_R^T, p - R X_R^T X_p."""
        flange_rotations = rotations @ self.tool_rotation.T
        return positions - flange_rotations @ self.tool_translation, flange_rotations

    def branches(self, positions, rotations, q0):
        return self.flange.branches(*self._flange_targets(positions, rotations), q0)

    def branches_by_joint(self, positions, rotations, q0):
        return self.flange.branches_by_joint(*self._flange_targets(positions, rotations), q0)

    def fk(self, q):
        position, rotation = self.flange.fk(q)
        return position + rotation @ self.tool_translation, rotation @ self.tool_rotation

    def branches_one(self, position, rotation, reference):
        """R_flange = R R_X^T, p_flange = p - R_flange p_X (plain floats)."""
        tool_rows = self._tool_r
        flange_r = tuple(row[0] * tool[0] + row[1] * tool[1] + row[2] * tool[2]
                         for row in (rotation[0:3], rotation[3:6], rotation[6:9]) for tool in tool_rows)
        px, py, pz = self._tool_p
        flange_p = tuple(p - (flange_r[i] * px + flange_r[i + 1] * py + flange_r[i + 2] * pz)
                         for p, i in zip(position, (0, 3, 6), strict=True))
        return self.flange.branches_one(flange_p, flange_r, reference)

    def fk_one(self, q):
        """FK_tool = FK_flange X: p + R p_X, R R_X (plain floats, R row by row)."""
        position, rotation = self.flange.fk_one(q)
        (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = self._tool_r
        px, py, pz = self._tool_p
        rows = (rotation[0:3], rotation[3:6], rotation[6:9])
        return (tuple(p + r0 * px + r1 * py + r2 * pz
                      for p, (r0, r1, r2) in zip(position, rows, strict=True)),
                tuple(value for r0, r1, r2 in rows for value in (r0 * a0 + r1 * b0 + r2 * c0,
                                                                  r0 * a1 + r1 * b1 + r2 * c1,
                                                                  r0 * a2 + r1 * b2 + r2 * c2)))


# --- wrapping into the limits --------------------------------------------------------------------
NEAREST_MARGIN = 1e-9
"""Below pi by this much (rad), the distance of the shift nearest the reference proves that every other
2 pi shift is farther (beyond pi + NEAREST_MARGIN), whatever the rounding of the distances (~1e-15 rad
for angles inside limits of a few turns): :func:`wrap_into_limits` takes that shift without trying the
others. Nearer ties go through the five shifts."""
_NEAREST_BOUND = math.pi - NEAREST_MARGIN


def wrap_into_limits(q: np.ndarray, reference: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                     revolute: np.ndarray, axis: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """Shift revolute angles by multiples of 2 pi to lie in [lower, upper], nearest to ``reference``.

    Returns (wrapped q, in-limits mask over the joint ``axis``). Works on any batch shape: the
    reference broadcasts to q's, and so do ``lower``, ``upper`` and ``revolute`` (shaped along the
    joint axis, e.g. (n, 1, 1) for q (n, K, B) and axis 0). Shifts 0, 2 pi, -2 pi, 4 pi, -4 pi are
    tried in that order; among those inside the limits (within LIMIT_TOLERANCE) the nearest to the
    reference is kept (the first on a tie) and set into the limits; angles with no such shift stay as
    they are (in-limits mask False).

    Each angle first takes the shift nearest the reference, round((reference - q) / 2 pi) turns; where
    that is one of the five, inside the limits and nearer than pi - NEAREST_MARGIN, it is the rule's
    answer (every other shift is farther than pi). The other angles (the nearest shift outside the
    limits or beyond 4 pi, a near tie, NaN) go through :func:`_wrap_by_shifts`, the rule itself.
    """
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
    if not inside.all():  # the others: every shift, in order
        slow = np.flatnonzero(~inside)  # flat indices: cheaper than a boolean mask per array
        slow_wrapped, slow_inside = _wrap_by_shifts(
            *(np.broadcast_to(values, q.shape).flat[slow] for values in (q, reference, low, high)),
            None if fixed is None else np.broadcast_to(fixed, q.shape).flat[slow])
        wrapped.flat[slow], inside.flat[slow] = slow_wrapped, slow_inside
    return np.clip(wrapped, lower, upper, out=wrapped), np.all(inside, axis=axis)


def _wrap_by_shifts(q: np.ndarray, reference: np.ndarray, low: np.ndarray, high: np.ndarray,
                    fixed: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`wrap_into_limits`'s rule for angles (m,) with their reference, bounds [low, high] (the
    limits widened by LIMIT_TOLERANCE) and prismatic mask (None: all revolute): every shift in the
    rule's order, the nearest inside kept (the first on a tie). Returns (wrapped q, not yet set into the
    limits; whether some shift is inside)."""
    best = q.copy()
    best_distance = np.full(q.shape, np.inf)
    in_limits = np.zeros(q.shape, dtype=bool)
    for shift in _SHIFTS:
        shifted = q + shift
        if fixed is not None:
            np.copyto(shifted, q, where=fixed)
        ok = (shifted >= low) & (shifted <= high)
        if shift and not ok.any():  # no angle can take this shift
            continue
        distance = np.abs(shifted - reference)
        better = (distance < best_distance) & ok
        np.copyto(best, shifted, where=better)
        np.copyto(best_distance, distance, where=better)
        in_limits |= ok
    return best, in_limits


def wrap_one_into_limits(q, reference, lower, upper) -> list[float] | None:
    """:func:`wrap_into_limits` for one vector of revolute angles in plain floats (scalar fast paths):
    the 2 pi shift of each angle inside its limits nearest to ``reference``, set onto the limit when
    within LIMIT_TOLERANCE of it; None if some angle has no shift inside its limits."""
    wrapped = []
    append = wrapped.append
    for value, ref, low, high in zip(q, reference, lower, upper, strict=True):
        turns = round((ref - value) / TWO_PI)  # the shift nearest ref; the usual answer
        shifted = value + turns * TWO_PI
        if -2 <= turns <= 2 and low - LIMIT_TOLERANCE <= shifted <= high + LIMIT_TOLERANCE:
            append(high if shifted > high else low if shifted < low else shifted)
            continue
        best, best_distance = None, math.inf
        for shift in _SHIFTS:
            shifted = value + shift
            if (low - LIMIT_TOLERANCE <= shifted <= high + LIMIT_TOLERANCE
                    and abs(shifted - ref) < best_distance):
                best, best_distance = shifted, abs(shifted - ref)
        if best is None:
            return None
        append(min(high, max(low, best)))
    return wrapped


# --- the choice of a branch, in plain floats ----------------------------------------------------
def screen_residual(reached: tuple, position: list[float], rotation: list[float] | None) -> float:
    """max(|p - p*|, angle(R*^T R)) of a reached (position, rotation row by row) against the target:
    the screen of :class:`AnalyticSolver` in plain floats (trace(R*^T R) = sum_ij R*_ij R_ij)."""
    (px, py, pz), reached_r = reached
    dx, dy, dz = px - position[0], py - position[1], pz - position[2]
    error = math.sqrt(dx * dx + dy * dy + dz * dz)
    if rotation is None:
        return error
    trace = sum(map(mul, reached_r, rotation))
    return max(error, math.acos(min(1.0, max(-1.0, 0.5 * (trace - 1.0)))))


def squared_distance(q: list[float], reference: list[float]) -> float:
    """sum_i (q_i - r_i)^2, added in joint order (plain floats; the compiled kernels add alike)."""
    total = 0.0
    for value, ref in zip(q, reference, strict=True):
        difference = value - ref
        total += difference * difference
    return total


def nearest_branch(form: ClosedForm, bounded: list[tuple[float, list[float]]], position: list[float],
                   rotation: list[float] | None, reference: list[float], lower: list[float],
                   upper: list[float]) -> tuple[list[float] | None, bool]:
    """The branch :class:`AnalyticSolver` picks, in plain floats: each branch wrapped into the limits
    nearest to ``reference``, kept when its closed-form FK passes the screen, the nearest kept one.

    Branch and bound: a branch's squared distance to the reference once wrapped is at least its
    ``bound`` less ``BOUND_SLACK`` per joint, so the branches are taken in the order of their bounds
    and wrapped and screened only while one could still be nearer than the best so far.
    Returns (q or None, whether some branch has a shift inside the limits; meaningful for None).
    """
    bounded.sort(key=_BOUND)  # stable: ties keep the branch order
    slack = len(reference) * BOUND_SLACK
    best, best_distance, inside = None, math.inf, False
    tolerance = form.screen_tolerance
    for bound, raw in bounded:
        if bound - slack >= best_distance:
            break
        if not bound < math.inf:  # NaN or inf joints (bounds are sums of their remainders)
            continue
        q = wrap_one_into_limits(raw, reference, lower, upper)
        if q is None:
            continue
        inside = True
        distance = squared_distance(q, reference)
        if distance < best_distance and screen_residual(form.fk_one(q), position, rotation) <= tolerance:
            best, best_distance = q, distance
    return best, inside


def kernel_failure_reason(outcome: int) -> str:
    """:func:`no_solution_reason` of a compiled kernel's failure code: 0 (no real branch), -1 (real
    branches, none inside the limits) or -2 (some inside the limits, none passes the screen)."""
    return no_solution_reason(outcome != 0, outcome == -2)


def no_solution_reason(real: bool, in_limits: bool) -> str:
    """Why no branch was returned, from what the choice already knows."""
    if not real:
        return "unreachable: no real closed-form branch (target outside the workspace)"
    if not in_limits:
        return "every real branch is outside the joint limits"
    return "unreachable: no closed-form branch inside the joint limits reaches the target"


def checked_branches(solver: Solver, target: Target, q_all: np.ndarray, revolute: np.ndarray,
                     elapsed: float) -> list[IKResult]:
    """``solve_all``'s answer from a closed form's raw branches (K, n) of one target: each wrapped into
    the limits nearest the chain's nominal configuration, those inside held to the shared check, and
    the passing ones kept unless within BRANCH_MERGE of one kept before (the same solution twice)."""
    chain = solver.chain
    wrapped, in_limits = wrap_into_limits(q_all, chain.nominal[None], chain.lower, chain.upper, revolute)
    results: list[IKResult] = []
    for q in wrapped[in_limits & np.all(np.isfinite(wrapped), axis=-1)]:
        result = evaluate(chain, target, Candidate(q, 1), solver.tolerances, elapsed, solver.name)
        if result.success and not any(joint_gap(result.q, other.q, revolute) < BRANCH_MERGE
                                      for other in results):
            results.append(result)
    return results


def fk_residual(chain: Chain, q: np.ndarray, target: Target) -> float:
    """max(|e_p|, |e_R|) of joints q against the target through the chain's FK (inf for non-finite
    joints): the screen of a library's branch."""
    if not np.all(np.isfinite(q)):
        return math.inf
    position_xyz, rotation_xyz = pose_error(chain.fk(q), target)
    return max(float(np.linalg.norm(position_xyz)), float(np.linalg.norm(rotation_xyz)))


def pick_reaching(chain: Chain, q_all: np.ndarray, target: Target, q0: np.ndarray, revolute: np.ndarray,
                  tolerance: float, library: str) -> Candidate:
    """Of a library's raw branches (K, n), the one nearest q0 once wrapped into the limits whose FK
    reaches the target within ``tolerance`` (:func:`fk_residual`); where none does, why: no branch,
    none inside the limits reaching it, every exact one outside the limits, or only least-squares ones
    (``library`` names the library in the reason)."""
    if len(q_all) == 0:
        return Candidate(None, 1, f"unreachable: {library} returns no branch (target outside the workspace)",
                         extra={"branches": 0})
    wrapped, in_limits = wrap_into_limits(q_all, q0[None], chain.lower, chain.upper, revolute)
    usable = in_limits & np.all(np.isfinite(wrapped), axis=-1)
    distance = np.where(usable, np.linalg.norm(wrapped - q0, axis=-1), np.inf)
    for index in np.argsort(distance, kind="stable"):
        if not usable[index]:
            break
        if fk_residual(chain, wrapped[index], target) <= tolerance:
            return Candidate(wrapped[index], 1, extra={"branches": int(usable.sum())})
    if usable.any():
        reason = f"unreachable: no {library} branch inside the joint limits reaches the target"
    elif any(fk_residual(chain, q, target) <= tolerance for q in q_all):
        reason = f"every exact {library} branch is outside the joint limits"
    else:
        reason = f"unreachable: {library} returns only least-squares branches (target outside the workspace)"
    return Candidate(None, 1, reason, extra={"branches": len(q_all)})


class Choice(NamedTuple):
    """What the vectorised choice knows per target: the joints ``q`` (B, n) where ``found`` (B,), the
    masks ``real`` and ``usable`` (real, in the limits, finite) over the branches (B, K) for the
    failure reason, and the closed-form FK of the chosen joints (``reached_p`` (B, 3), ``reached_r``
    (B, 3, 3); zeros where not found) for the batched check."""

    q: np.ndarray
    found: np.ndarray
    real: np.ndarray
    usable: np.ndarray
    reached_p: np.ndarray
    reached_r: np.ndarray


