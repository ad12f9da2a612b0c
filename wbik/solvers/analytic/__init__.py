"""Method ``analytic``: closed-form IK, every branch, vectorised over batches of targets.

The closed forms are layered as IK-Geo layers its solvers:

1. **subproblems** (:mod:`.subproblems`): planar 2R, clamped cosines, shared by every family;
2. **kinematic families**: :mod:`.ur_type` (UR-type 6R, axes 2-4 parallel), :mod:`.yaw_planar` (a
   base yaw carrying a planar arm: the 3R arm, the Pincher), :mod:`.stacked_planar` (a horizontal
   planar 3R carrying a vertical planar 2R and a roll: the Golem-III arm);
3. **one binding per robot** (:mod:`.arm3r`, :mod:`.golem3`, :mod:`.pincher`, :mod:`.ur5`): the
   robot's geometry and which family solves which chain. :mod:`.bioloid` is the exception: it keeps
   the thesis's own decomposition of the arm and the leg (equation by equation, used by the Bioloid
   application) on the shared subproblems.

A chain without a binding gets its family from its structure (:mod:`.recognition`: the joint axes at
q = 0 matched against every family, the parameters and the chain's frame and joint conventions read
off them, the form held to the model's FK), else EAIK's decomposition for full poses
(:mod:`.eaik_family`), else, on a 7-joint chain, one joint held at a value (:mod:`.redundancy`);
``AnalyticSolver.families`` names what solves each target kind.

This module is the framework over them. A closed form is a :class:`ClosedForm` registered for
(robot, chain, target kind). It maps a batch of B targets to K candidate branches per target, ``Q``
(B, K, n), with a mask ``real`` (B, K) of branches that exist (real square roots / cosines in [-1, 1],
with a small clamp tolerance), and provides its own vectorised FK. :class:`AnalyticSolver` wraps
revolute angles into the limits (nearest to q0), drops branches outside the limits or whose
closed-form FK misses the target by more than ``screen_tolerance`` (the *screen*), and picks the
branch nearest to q0; the reason of a failure comes from the same masks (no real branch / none
inside the limits / none reaches the target), nothing is computed twice.

Scalar fast path: a closed form may also enumerate the branches of one target in plain floats
(``branches_one``, ``fk_one``); ``solve`` and ``solve_all`` then avoid NumPy's per-call cost. The
choice is the same rule (:func:`nearest_branch`), and tests check that both paths agree.

The result goes through the shared check of :mod:`wbik.solvers.base` (``solve``, and ``solve_all`` on
the Python path) or its batched twin :func:`wbik.solvers.analytic.batch.evaluate_batch` (``solve_many``):
the same rule (clip, position and rotation error, tolerances), with the closed form's FK in place of
Pinocchio's, which :mod:`.model_agreement` holds to the model's when the form is built.

Compiled kernel: a family may provide one (``ClosedForm.kernel``; the UR-type family's is
:mod:`.ur_kernel`), the scalar path in C with the same bits, used by ``solve``, ``solve_many`` and
``solve_all`` (see their docstrings) unless ``WBIK_PURE_PYTHON=1`` (:mod:`wbik.compiled`).
"""

from __future__ import annotations

import importlib
import math
import time
from collections.abc import Iterable
from operator import itemgetter
from operator import mul
from typing import NamedTuple

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.errors import UnsupportedError
from wbik.geometry import TWO_PI
from wbik.geometry import joint_gap
from wbik.robot import Chain
from wbik.solvers.analytic.model_agreement import check_fk_against_model
from wbik.solvers.base import Candidate
from wbik.solvers.base import IKResult
from wbik.solvers.base import Solver
from wbik.solvers.base import evaluate
from wbik.solvers.method_registry import IKMethod
from wbik.targets import Target
from wbik.targets import as_target

LIMIT_TOLERANCE = 1e-9
"""Angle (rad) by which a closed-form joint may leave its limits and still count as inside (then set onto
the limit). Inverses of poses whose joints sit exactly at a limit come back a few 1e-12 rad outside, and
up to ~1e-8 rad near a singular pose where an arccos amplifies rounding; 1e-9 rad moves a 1 m lever by
1e-9 m, far below the screening tolerance. The old 1e-12 was only ~1e3 ulps of an angle."""
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


def closed_forms(robot) -> dict[tuple[str, str], str]:
    """A robot's closed forms bound by hand: ``robot.closed_forms`` maps (chain, kind) to "module:Class".

    Each robot package declares its own; a user robot passes ``closed_forms=`` to ``wbik.load``. A chain
    and kind without one gets the form recognised from its structure (:mod:`.recognition`).
    """
    return dict(robot.closed_forms)


def _closed_form(chain: Chain, kind: str, **options) -> ClosedForm:
    """The closed form bound to (chain, kind) by the robot (built here, checked by the caller), else the
    one recognised from the chain's structure (:func:`.recognition.recognise`; checked there)."""
    forms = closed_forms(chain.robot)
    if (chain.name, kind) not in forms:
        from wbik.solvers.analytic.recognition import recognise

        return recognise(chain, kind, options).form
    module_name, class_name = forms[(chain.name, kind)].split(":")
    return getattr(importlib.import_module(module_name), class_name)(chain, **options)


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


TARGET_KINDS = ("pose", "position")


class AnalyticSolver(Solver):
    """Closed-form IK behind the common interface; see the module docstring.

    Which closed form: the one the robot binds to (chain, kind), else the one recognised from the
    chain's structure (:mod:`.recognition`: a family of wbik, EAIK's decomposition for full poses, a
    7-joint chain with one joint held). ``families`` says, per target kind, which solves the chain
    ("bound:<module:Class>", "ur_type", "yaw_planar", "stacked_planar", "eaik:<EAIK's class>", with the
    held joint where one is); a chain with neither kind is refused when the solver is built
    (UnsupportedError saying what was tried), a missing kind when it is asked for.
    """

    name = "analytic"
    budgeted = False

    def __init__(self, robot, chain=None, closed_form_options: dict[str, dict] | None = None,
                 redundant_joint: str | int | None = None, redundancy: str = "seed",
                 grid_size: int = 16, **options):
        """``closed_form_options``: keyword arguments per target kind for the closed form's
        constructor, e.g. ``{"position": {"yaw": 0.3}}`` (Golem-III's fixed wrist roll).

        A chain with one joint too many for a closed form (7 joints) holds one at a value
        (:mod:`.redundancy`): ``redundant_joint`` (its name or index; default: the first of the last, the
        first, then the others from the tip whose holding leaves a chain with a closed form), held at the
        start's value (``redundancy="seed"``) or, besides it, at ``grid_size`` values over its range
        (``"grid"``), the branch nearest q0 over all of them returned.
        """
        from wbik.solvers.analytic.redundancy import check_redundancy_options

        super().__init__(robot, chain, **options)
        self._forms: dict[str, ClosedForm] = {}
        self.closed_form_options = dict(closed_form_options or {})
        held = check_redundancy_options(self.chain, redundant_joint, redundancy, grid_size)
        self.redundancy = {"joint": held, "mode": redundancy, "grid_size": int(grid_size)}
        self.families: dict[str, str] = {}
        """Per target kind, the family of the closed form that solves the chain (see the class)."""
        self._refusals: dict[str, str] = {}
        self._recognise_forms()
        self.revolute = ~self.chain.is_prismatic
        self._lower, self._upper = self.chain.lower.tolist(), self.chain.upper.tolist()
        self._limits_by_joint = (self.chain.lower[:, None, None], self.chain.upper[:, None, None],
                                 self.revolute[:, None, None])
        """(lower, upper, revolute), each (n, 1, 1): the limits of a joint-major (n, K, B) batch."""
        self._finite_limits = bool(np.isfinite(self._limits_by_joint[:2]).all())
        """Then a branch inside the limits is finite (no isfinite pass)."""

    def _recognise_forms(self) -> None:
        """Per target kind: the bound form's name (built on first use), or the form recognised from the
        chain's structure (built and checked now), or why there is none; UnsupportedError when no kind
        has one."""
        from wbik.solvers.analytic.recognition import refusal
        from wbik.solvers.analytic.recognition import refusal_reasons

        bound = closed_forms(self.robot)
        reasons = {}
        for kind in TARGET_KINDS:
            where = bound.get((self.chain.name, kind))
            if where is not None and self.redundancy["joint"] is None:
                self.families[kind] = f"bound:{where}"
                continue
            found = refusal_reasons(self.chain, kind, self.closed_form_options.get(kind, {}), self.redundancy)
            if isinstance(found, list):
                reasons[kind] = found
                self._refusals[kind] = refusal(self.chain, {kind: found})
                continue
            self._forms[kind] = found.form
            self.families[kind] = found.family
        if not self.families:
            raise UnsupportedError(refusal(self.chain, reasons))

    @property
    def family(self) -> str:
        """The family of the full-pose closed form, else of the position one (see ``families``)."""
        return self.families.get("pose") or self.families["position"]

    def check_target_kind(self, kind: str) -> None:
        """Also an UnsupportedError when the chain has no closed form of this kind."""
        super().check_target_kind(kind)
        self.closed_form(kind)

    def _form_of(self, target: Target) -> ClosedForm:
        """The closed form of the target's kind: cached after the kind's first call, which runs the
        detailed checks (:meth:`check_target_kind`; ``solve`` has run the interface's already)."""
        kind = "position" if target.rotation is None else "pose"
        form = self._forms.get(kind)
        if form is None:
            self.check_target_kind(kind)  # builds and caches the form
            form = self._forms[kind]
        return form

    def closed_form(self, kind: str) -> ClosedForm:
        """The closed form of ``kind`` targets (the bound one built and checked on first use);
        UnsupportedError saying why where the chain has none."""
        if kind not in self._forms:
            if kind in self._refusals:
                raise UnsupportedError(self._refusals[kind])
            form = _closed_form(self.chain, kind, **self.closed_form_options.get(kind, {}))
            check_fk_against_model(form)
            self._forms[kind] = form
        return self._forms[kind]

    # -- vectorised ---------------------------------------------------------------------------
    def _wrapped_by_joint(self, form: ClosedForm, positions, rotations, q0s):
        """Every branch of a batch wrapped into the limits, joint-major and batch-last: (Q (n, K, B),
        real (K, B), usable (K, B)) with usable = real, inside the limits and finite (not yet screened)."""
        q_all, real = form.branches_by_joint(positions, rotations, q0s)
        lower, upper, revolute = self._limits_by_joint
        q_all, in_limits = wrap_into_limits(q_all, _by_joint(q0s), lower, upper, revolute, axis=0)
        usable = real & in_limits
        if not self._finite_limits:
            usable &= np.all(np.isfinite(q_all), axis=0)
        return q_all, real, usable

    def _wrapped(self, form: ClosedForm, positions, rotations, q0s):
        """:meth:`_wrapped_by_joint` target by target: (Q (B, K, n), real (B, K), usable (B, K))."""
        q_all, real, usable = self._wrapped_by_joint(form, positions, rotations, q0s)
        return q_all.transpose(2, 1, 0), real.T, usable.T

    @staticmethod
    def _screen(form: ClosedForm, q: np.ndarray, positions, rotations):
        """Closed-form FK of joints q (..., n) and its residual max(|p - p*|, angle(R*^T R)) against the
        targets: (residual, reached positions, reached rotations)."""
        reached_p, reached_r = form.fk(q)
        residual = np.linalg.norm(reached_p - positions, axis=-1)
        if rotations is not None:
            trace = np.sum(rotations * reached_r, axis=(-2, -1))  # trace(R_target^T R_reached)
            residual = np.maximum(residual, np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0)))
        return residual, reached_p, reached_r

    def _choose(self, form: ClosedForm, positions, rotations, q0s) -> Choice:
        """The nearest screened branch per target (see :class:`Choice`).

        Same answer as screening every branch and taking the nearest (ties: the first branch), but the
        nearest branch of every target is screened at once (its FK is kept for the batched check), and
        only the targets where it misses have their branches sorted and the next ones screened (rare).
        """
        q_all, real, usable = self._wrapped_by_joint(form, positions, rotations, q0s)
        squares = q_all - _by_joint(q0s)
        squares *= squares
        distance = np.sqrt(np.add.reduce(squares, axis=0))  # |q - q0| per branch (K, B)
        distance[~usable] = np.inf
        targets = np.arange(len(q0s))
        nearest = np.argmin(distance, axis=0)  # the first nearest, as a stable sort's first
        chosen = q_all[:, nearest, targets].T.copy()
        with np.errstate(invalid="ignore"):  # a target without a usable branch may bring NaN joints
            residual, reached_p, reached_r = self._screen(form, chosen, positions, rotations)
        found = usable[nearest, targets]
        screened = residual <= form.screen_tolerance
        retry = np.flatnonzero(found & ~screened)
        found &= screened
        if not found.all():
            missed = ~found
            chosen[missed], reached_p[missed], reached_r[missed] = 0.0, 0.0, 0.0
            order = np.argsort(distance[:, retry], axis=0, kind="stable")  # order[rank, i]: of retry[i]
            for rank in range(1, len(order)):
                keep = usable[order[rank], retry]
                retry, order = retry[keep], order[:, keep]
                if not len(retry):
                    break
                candidates = q_all[:, order[rank], retry].T
                residual, candidate_p, candidate_r = self._screen(
                    form, candidates, positions[retry], None if rotations is None else rotations[retry])
                passed = residual <= form.screen_tolerance
                done = retry[passed]
                chosen[done], found[done] = candidates[passed], True
                reached_p[done], reached_r[done] = candidate_p[passed], candidate_r[passed]
                retry, order = retry[~passed], order[:, ~passed]
        return Choice(chosen, found, real.T, usable.T, reached_p, reached_r)

    @staticmethod
    def _reasons(choice: Choice) -> list[str]:
        """The failure reason of each target from the choice's masks ("" where found)."""
        any_real, any_usable = choice.real.any(axis=1).tolist(), choice.usable.any(axis=1).tolist()
        return ["" if ok else no_solution_reason(r, u)
                for ok, r, u in zip(choice.found.tolist(), any_real, any_usable, strict=True)]

    # -- the interface --------------------------------------------------------------------------
    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        rotation = target.rotation
        form = self._form_of(target)
        if form.target_kind == "position":
            rotation = None
        kernel = form.kernel
        if kernel is not None:
            q = np.empty(len(q0))
            status = kernel.nearest_into(target.position, rotation, q0, q)
            if status <= 0:
                return Candidate(None, 1, kernel_failure_reason(status))
            return Candidate(q, 1, extra={"branches": status})
        if form.has_scalar_path:
            position = target.position.tolist()
            if rotation is not None:
                rotation = rotation.ravel().tolist()
            reference = q0.tolist()
            bounded = form.branches_one(position, rotation, reference)
            q, inside = nearest_branch(form, bounded, position, rotation, reference, self._lower, self._upper)
            if q is None:
                return Candidate(None, 1, no_solution_reason(bool(bounded), inside))
            return Candidate(np.array(q), 1, extra={"branches": len(bounded)})
        choice = self._choose(form, target.position[None], None if rotation is None else rotation[None],
                              q0[None])
        if not choice.found[0]:
            return Candidate(None, 1, no_solution_reason(bool(choice.real.any()), bool(choice.usable.any())))
        return Candidate(choice.q[0], 1, extra={"branches": int(choice.real.sum())})

    def solve_many(self, targets: Iterable, q0s=None) -> list[IKResult]:
        """Vectorised: one closed-form evaluation and one batched FK check (the closed form's FK, held to
        the model by :mod:`.model_agreement`) for the whole batch; per-pose time = closed-form
        time / B (the check is not counted, as in ``solve``). With a compiled kernel: one kernel call
        for the batch, the same choice as ``solve`` (same bits), its time per pose with the check."""
        from wbik.solvers.analytic.batch import batch_targets
        from wbik.solvers.analytic.batch import evaluate_batch

        positions, rotations = batch_targets(targets, self)
        count = len(positions)
        if not count:
            return []
        q0_array = self._start_array(q0s, count)
        form = self.closed_form("position" if rotations is None else "pose")
        form_rotations = rotations if form.target_kind == "pose" else None
        if form.kernel is not None and form_rotations is not None:
            return self._many_compiled(form, positions, rotations, q0_array)
        start = time.perf_counter()
        choice = self._choose(form, positions, form_rotations, q0_array)
        per_pose = (time.perf_counter() - start) / count
        extras = [{"branches": branches, "batched": True} for branches in choice.real.sum(axis=1).tolist()]
        return evaluate_batch(self.chain, form, positions, rotations, choice.q, choice.found,
                              self._reasons(choice), self.tolerances, per_pose, self.name, extras,
                              reached=(choice.reached_p, choice.reached_r))

    def _many_compiled(self, form: ClosedForm, positions: np.ndarray, rotations: np.ndarray,
                       q0_array: np.ndarray) -> list[IKResult]:
        """:meth:`solve_many` through the kernel: every target's choice and its errors (closed-form FK,
        :func:`.batch.evaluate_batch`'s rule: the joints are inside the limits already) in one call.
        ``time_s`` is the kernel's time per pose, its check included."""
        from wbik.solvers.analytic.batch import evaluate_batch

        start = time.perf_counter()
        joints, errors, info = form.kernel.nearest_many(positions, rotations, q0_array)
        per_pose = (time.perf_counter() - start) / len(positions)
        branches, outcomes = info.T.astype(int).tolist()
        reasons = ["" if outcome == 1 else kernel_failure_reason(outcome) for outcome in outcomes]
        extras = [{"branches": count, "batched": True} for count in branches]
        measured = (errors[:, :3], errors[:, 3:6], errors[:, 6], errors[:, 7])
        return evaluate_batch(self.chain, form, positions, rotations, joints, info[:, 1] == 1, reasons,
                              self.tolerances, per_pose, self.name, extras, measured=measured)

    def _start_array(self, q0s, count: int) -> np.ndarray:
        """Start configurations (count, n): the chain's nominal, one start for all, or one per target."""
        if q0s is None:
            return np.broadcast_to(self.chain.nominal, (count, self.chain.nq)).copy()
        starts = self._batch_starts(q0s, count)
        return np.array(starts)

    def solve_all(self, target) -> list[IKResult]:
        """Every distinct branch inside the limits that passes the FK check (wrapped nearest to the
        chain's nominal configuration, in branch order): the shared check (Pinocchio) on the Python
        path; with a compiled kernel the batched rule of ``solve_many`` (the closed form's FK, held to
        the model by :mod:`.model_agreement`; the branches are inside the limits already,
        nothing to clip), and the kernel builds the results: their arrays are row views of three
        buffers, ``time_s`` the kernel's time with its check."""
        target = as_target(target)
        form = self._form_of(target)
        nominal = self.chain.nominal
        if form.kernel is not None:  # the kernel builds the results (the same rule, see the docstring)
            return form.kernel.results(target.position, target.rotation, nominal, self.name, self.tolerances)
        start = time.perf_counter()
        if form.has_scalar_path:
            distinct = self._distinct_one(form, target, nominal)
        else:
            positions = target.position[None]
            rotations = None if form.target_kind == "position" else target.rotation[None]
            q_all, _, usable = self._wrapped(form, positions, rotations, nominal[None])
            q_all = q_all[0][usable[0]]
            passed = self._screen(form, q_all, positions, rotations)[0] <= form.screen_tolerance
            distinct = []
            for q in q_all[passed]:
                if not any(joint_gap(q, other, self.revolute) < BRANCH_MERGE for other in distinct):
                    distinct.append(q)
        elapsed = time.perf_counter() - start
        results = [evaluate(self.chain, target, Candidate(q, 1), self.tolerances, elapsed, self.name)
                   for q in distinct]
        return [r for r in results if r.success]

    def _distinct_one(self, form: ClosedForm, target: Target, nominal: np.ndarray) -> list[np.ndarray]:
        """Every branch wrapped into the limits nearest to ``nominal`` that passes the screen and is not
        within BRANCH_MERGE of an earlier one, in branch order (the scalar path of :meth:`solve_all`)."""
        position = target.position.tolist()
        rotation = None if form.target_kind == "position" else target.rotation.ravel().tolist()
        reference = nominal.tolist()
        screened: list[list[float]] = []
        for _, raw in form.branches_one(position, rotation, reference):
            q = wrap_one_into_limits(raw, reference, self._lower, self._upper)
            if (q is not None and not any(_same_branch(q, other) for other in screened)
                    and screen_residual(form.fk_one(q), position, rotation) <= form.screen_tolerance):
                screened.append(q)
        return [np.array(q) for q in screened]


def _by_joint(q: np.ndarray) -> np.ndarray:
    """Joints (B, n) as the reference of a joint-major batch: (n, 1, B), contiguous along B."""
    return np.ascontiguousarray(q.T)[:, None, :]


def _same_branch(q: list[float], other: list[float]) -> bool:
    """Every revolute angle within BRANCH_MERGE of the other's modulo 2 pi (geometry.joint_gap's rule,
    in plain floats, stopping at the first joint that differs)."""
    remainder = math.remainder
    return all(abs(remainder(a - b, TWO_PI)) < BRANCH_MERGE for a, b in zip(q, other, strict=True))


IK_METHODS = (
    IKMethod("analytic", AnalyticSolver,
             "closed-form IK: every branch, nearest to q0, vectorised batches"),
)
"""The methods this module declares to :mod:`wbik.solvers.method_registry`."""
