"""The one solver interface: Solver, IKResult and the shared FK check (the method registry is
:mod:`wbik.solvers.method_registry`).

Every method subclasses :class:`Solver` and implements ``_solve(target, q0, deadline)``, returning
a :class:`Candidate` (joints or None, iterations, reason). The base class validates input, times
the call, keeps joints inside the limits and decides ``success`` with one FK check shared by all
methods, so results of different methods compare like with like.
"""

from __future__ import annotations

import hashlib
import math
import threading
import time
from collections.abc import Iterable
from collections.abc import Sequence
from dataclasses import dataclass
from dataclasses import field

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidBudgetError
from wbik.errors import InvalidConfigurationError
from wbik.errors import InvalidSettingError
from wbik.errors import UnsupportedError
from wbik.geometry import error_parts
from wbik.robot import Chain
from wbik.robot import Robot
from wbik.targets import Target
from wbik.targets import as_target
from wbik.targets import pose_target
from wbik.validation import check_budget
from wbik.validation import check_count
from wbik.validation import check_seed

# numpy's clip ufunc, called directly: np.clip wraps it in Python code that costs more than the ufunc
# itself on a few joints (the measurements: docs/measurements.md, base)
try:
    from numpy._core.umath import clip as _clip_ufunc
except ImportError:  # pragma: no cover - another numpy layout
    _clip_ufunc = None


CLIPPED_REASON = "solution outside the joint limits (clipped)"


def fk_check_reason(position_norm: float, rotation_norm: float) -> str:
    """Why the shared FK check failed a candidate inside the limits."""
    return f"FK check failed: position error {position_norm:.3g} m, rotation error {rotation_norm:.3g} rad"


def invalid_joints_reason(q) -> str:
    return f"method returned invalid joints {q!r}"


def clip_to_limits(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """min(max(q, lower), upper) element-wise (a new array; NaN stays NaN), in one ufunc call."""
    if _clip_ufunc is None:
        return np.minimum(np.maximum(q, lower), upper)
    return _clip_ufunc(q, lower, upper)


DEFAULT_TIMEOUT_S = 0.005
"""Default time budget of iterative methods (TRAC-IK's benchmark protocol and MoveIt's KDL default)."""


@dataclass(frozen=True)
class Tolerances:
    """The shared FK check: a solution succeeds when both errors are at or below these."""

    position: float = 1e-6  # metres (norm of the position error)
    rotation: float = 1e-6  # radians (angle of the rotation error)

    def __post_init__(self) -> None:
        from wbik.errors import InvalidToleranceError
        from wbik.validation import check_positive_finite

        for name, unit in (("position", "m"), ("rotation", "rad")):
            value = check_positive_finite(f"tolerances.{name}", getattr(self, name), InvalidToleranceError,
                                          unit)
            object.__setattr__(self, name, value)


def checked_tolerances(tolerances: Tolerances | None) -> Tolerances:
    """``tolerances``, or the default Tolerances() for None; InvalidSettingError for anything else."""
    if tolerances is None:
        return Tolerances()
    if not isinstance(tolerances, Tolerances):
        raise InvalidSettingError(
            f"tolerances must be wbik.Tolerances(position=..., rotation=...), got {tolerances!r}")
    return tolerances


def iterations_costing(timeout_s: float, iteration_cost_s: float) -> int:
    """The iteration budget that costs about ``timeout_s`` at ``iteration_cost_s`` per iteration
    (the cost measured on the reference machine): ceil(timeout / cost), at least 1."""
    return max(1, math.ceil(check_budget("timeout_s", timeout_s) / iteration_cost_s))


@dataclass(slots=True)
class Candidate:
    """What a method found, before the shared check."""

    q: np.ndarray | None
    iterations: int = 0
    reason: str = ""
    extra: dict = field(default_factory=dict)


@dataclass(slots=True)
class IKResult:
    """The answer of every method.

    ``q`` is None only when the method produced no joint values at all (e.g. a closed form for an
    unreachable target); otherwise it is inside the joint limits and the errors are measured on it
    through FK. ``position_error_xyz`` is reached - target in base-frame axes (m);
    ``rotation_error_xyz`` is log3(R_target^T R_reached) (rad), zeros for position-only targets.
    """

    q: np.ndarray | None
    success: bool
    reason: str
    position_error: float
    rotation_error: float
    position_error_xyz: np.ndarray
    rotation_error_xyz: np.ndarray
    time_s: float
    iterations: int
    method: str = ""
    extra: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        """JSON-friendly dictionary."""
        return {
            "method": self.method,
            "success": self.success,
            "reason": self.reason,
            "q": None if self.q is None else [float(v) for v in self.q],
            "position_error": self.position_error,
            "rotation_error": self.rotation_error,
            "position_error_xyz": [float(v) for v in self.position_error_xyz],
            "rotation_error_xyz": [float(v) for v in self.rotation_error_xyz],
            "time_s": self.time_s,
            "iterations": self.iterations,
        }


def evaluate(chain: Chain, target: Target, candidate: Candidate, tolerances: Tolerances,
             time_s: float, method: str, reached: np.ndarray | None = None) -> IKResult:
    """The shared FK check: clip into the limits, measure the errors, decide success.

    The errors are the pose error of :mod:`wbik.geometry`: e_p = p - p* (base axes) and
    e_R = log3(R*^T R) (target axes; ``geometry.error_parts`` gives p - p*, its norm and R*^T R,
    Pinocchio the log3). Written for the per-call path (its cost: docs/benchmarks.md): one clip, one FK, one
    call for the arithmetic (compiled where built), one log3; the detailed checks run only when
    something is off.

    ``reached``: optional, ``chain.fk(candidate.q).homogeneous`` as the method already computed it
    (e.g. for its own screen). It stands for the FK only when the joints checked are ``candidate.q``
    unchanged, bit for bit (inside the limits, no continuous joint wrapped), so the IKResult is the one
    computed without it; otherwise the FK is computed as usual.
    """
    q = candidate.q
    if q is None:
        nan3 = np.full(3, np.nan)
        return IKResult(None, False, candidate.reason or "no solution", math.nan, math.nan,
                        nan3, nan3.copy(), time_s, candidate.iterations, method, candidate.extra)
    if type(q) is not np.ndarray or q.dtype != np.float64:
        q = np.asarray(q, dtype=float)
    lower, upper = chain.lower, chain.upper
    if q.shape != lower.shape:
        return _invalid_joints(q, time_s, candidate, method)
    reason = candidate.reason
    if chain.any_continuous:  # an angle of a continuous joint is in range modulo 2 pi
        unwrapped, q = q, chain.wrap_continuous(q)
        if reached is not None and q.tobytes() != unwrapped.tobytes():
            reached = None
    inside = clip_to_limits(q, lower, upper)
    if inside.tobytes() != q.tobytes():  # outside the limits, or infinite (NaN passes: see below)
        reached = None
        if not np.all(np.isfinite(q)):
            return _invalid_joints(q, time_s, candidate, method)
        if not reason and not chain.in_limits(q, tolerance=1e-9):
            reason = CLIPPED_REASON
    target_rotation = target.rotation
    position_xyz = np.empty(3)
    relative = None if target_rotation is None else np.empty((3, 3))
    if reached is None:
        reached = chain.fk(inside).homogeneous
    position_norm = error_parts(reached, target.position, target_rotation, position_xyz, relative)
    if relative is None:
        rotation_xyz, rotation_norm = np.zeros(3), 0.0
    else:
        rotation_xyz = pin.log3(relative)  # e_R = log3(R*^T R): geometry.rotation_error's
        rotation_norm = math.hypot(*rotation_xyz.tolist())
    if position_norm <= tolerances.position and rotation_norm <= tolerances.rotation:
        return IKResult(inside, True, "", position_norm, rotation_norm, position_xyz, rotation_xyz,
                        time_s, candidate.iterations, method, candidate.extra)
    if position_norm != position_norm and not np.all(np.isfinite(q)):  # NaN joints give a NaN pose
        return _invalid_joints(q, time_s, candidate, method)
    reason = reason or fk_check_reason(position_norm, rotation_norm)
    return IKResult(inside, False, reason, position_norm, rotation_norm, position_xyz, rotation_xyz,
                    time_s, candidate.iterations, method, candidate.extra)


def evaluate_screened(chain: Chain, target: Target | np.ndarray, parts: np.ndarray, extra: dict,
                      tolerances: Tolerances, time_s: float, method: str) -> IKResult:
    """The shared check of joints a compiled closed form chose and screened, with the errors it already
    computed: ``parts`` (n + 24 values) holds the joints q (n), their 4 x 4 tip pose (16, the form's FK)
    and the batched check's errors of that pose (8: e_p, e_R, |e_p|, |e_R|; the rule of
    :func:`wbik.solvers.analytic.batch.evaluate_batch`, e_R in :func:`wbik.geometry.batch_log3`'s
    formula, which agrees with Pinocchio's log3 to rounding away from a half turn). ``target``: the
    Target, or the 4 x 4 matrix of a full pose (:func:`wbik.targets.plain_pose_matrix`).

    For a full pose on a chain without continuous joints, whose joints the choice wrote inside the
    limits (their clip is themselves), the IKResult is built from ``parts`` (its arrays are views of
    it) when both errors are within the tolerances. Anything else goes to :func:`evaluate` with the
    tip pose as ``reached``.
    """
    joints = len(chain.lower)
    q = parts[:joints]
    if not chain.any_continuous and (type(target) is np.ndarray or target.rotation is not None):
        position_norm, rotation_norm = parts.item(joints + 22), parts.item(joints + 23)
        if position_norm <= tolerances.position and rotation_norm <= tolerances.rotation:
            return IKResult(q, True, "", position_norm, rotation_norm, parts[joints + 16:joints + 19],
                            parts[joints + 19:joints + 22], time_s, 1, method, extra)
    if type(target) is np.ndarray:
        target = pose_target(target)
    return evaluate(chain, target, Candidate(q, 1, extra=extra), tolerances, time_s, method,
                    parts[joints:joints + 16].reshape(4, 4))


def _invalid_joints(q: np.ndarray, time_s: float, candidate: Candidate, method: str) -> IKResult:
    nan3 = np.full(3, np.nan)
    return IKResult(None, False, invalid_joints_reason(q), math.nan, math.nan,
                    nan3, nan3.copy(), time_s, candidate.iterations, method, candidate.extra)


class PerThreadState:
    """Mutable working objects kept per thread: :meth:`_thread_state` builds this thread's with
    :meth:`_new_thread_state` on first use. The owner sets ``self._local = threading.local()``."""

    _local: threading.local

    def _thread_state(self):
        """This thread's mutable state (built by :meth:`_new_thread_state` on first use)."""
        state = getattr(self._local, "state", None)
        if state is None:
            state = self._local.state = self._new_thread_state()
        return state

    def _new_thread_state(self):
        """Subclasses with mutable working objects (peer solvers, QP problems, buffers) build them here."""
        return None


class IterationBudget:
    """The iteration budget of a method whose loop is ours (``iteration_cost_s`` set): ``max_iterations``
    if given, else the iterations that cost about ``timeout_s`` (or ``default_budget_s`` without one)
    on the machine the costs were measured on. The owner sets ``name`` and ``timeout_s``."""

    iteration_cost_s: float | None = None
    """Ours: the time one iteration costs (s) on the reference machine, the budget's unit (the machine and
    each method's measured cost: docs/measurements.md); it turns a time budget into an iteration budget.
    None: a wall-clock method."""
    default_budget_s: float = DEFAULT_TIMEOUT_S
    """Ours: the time the default iteration budget is equivalent to."""

    @classmethod
    def iterations_for(cls, timeout_s: float) -> int:
        """The iteration budget that costs about ``timeout_s`` on the reference machine (ours only)."""
        if cls.iteration_cost_s is None:
            raise UnsupportedError(f"method {cls.name!r} is budgeted by wall-clock time only")
        return iterations_costing(timeout_s, cls.iteration_cost_s)

    def _iteration_budget(self, max_iterations: int | None) -> int:
        """``max_iterations`` checked, or the budget equivalent to ``timeout_s`` or ``default_budget_s``."""
        if max_iterations is None:
            return self.iterations_for(self.timeout_s or self.default_budget_s)
        return check_count("max_iterations", max_iterations, InvalidBudgetError)


class Solver(PerThreadState, IterationBudget):
    """Base class of every IK method on one chain of one robot.

    Subclasses set ``name`` and implement ``_solve``; they should stop at ``deadline`` (a
    ``time.perf_counter()`` value, ``math.inf`` when there is no wall-clock budget) and return their
    best effort with a reason.

    Budgets. A method whose loop is ours (``iteration_cost_s`` set) is budgeted in iterations, so its
    answer does not depend on how busy the machine is: ``max_iterations`` if given, else
    ceil(``default_budget_s`` / ``iteration_cost_s``), the iterations that cost about that long (5 ms
    unless the method says otherwise) on the machine the costs were measured on. Such a method has no
    wall clock unless ``timeout_s`` is given; then both apply, whichever ends first (and its iteration
    budget, if not given, follows ``timeout_s``). Methods that live in another library (KDL, TRAC-IK,
    PlaCo) are budgeted by ``timeout_s`` (default ``DEFAULT_TIMEOUT_S``) only.

    Thread safety. Mutable state (Pinocchio Data, a peer library's solver object) is kept per thread
    (:meth:`_thread_state`); random restarts draw from a generator seeded by ``seed`` and the call's
    own input (:meth:`_call_rng`), so an answer depends on (seed, target, q0) only: the same in any
    order and from any thread.
    """

    name = "base"
    supports_position_only = True
    supports_pose = True
    pose_only_because = ""
    """Why a method that takes full poses only (``supports_position_only = False``) does: the end of
    its refusal message (what it lacks, what to use instead)."""
    budgeted: bool = True
    """False for closed forms: a fixed amount of work per call, no budget of any kind applies."""

    def __init__(self, robot: Robot, chain: str | None = None, *,
                 tolerances: Tolerances | None = None, timeout_s: float | None = None,
                 seed: int | None = 0):
        self.robot = robot
        self.chain = robot.chain(chain)
        self.tolerances = checked_tolerances(tolerances)
        if timeout_s is None and self.iteration_cost_s is None:
            timeout_s = DEFAULT_TIMEOUT_S
        self.timeout_s = None if timeout_s is None else check_budget("timeout_s", timeout_s)
        self.seed = None if check_seed(seed) is None else int(seed)
        self._local = threading.local()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.robot.name}.{self.chain.name})"

    @property
    def budget(self) -> str:
        """The budget in words, e.g. "200 iterations" or "0.005 s"."""
        parts = []
        if self.iteration_cost_s is not None:
            parts.append(f"{self.max_iterations} iterations")
        if self.timeout_s is not None:
            parts.append(f"{self.timeout_s:g} s")
        return " or ".join(parts)

    # -- the interface ------------------------------------------------------------------------
    def solve(self, target, q0: Sequence[float] | None = None) -> IKResult:
        """Solve one target (SE3, 4x4, 3-vector or Target) from q0 (default: the chain's nominal)."""
        target = as_target(target)
        if not (self.supports_pose if target.rotation is not None else self.supports_position_only):
            self._check_target_kind(target)  # raises the detailed UnsupportedError
        chain = self.chain
        q_start = chain.nominal.copy() if q0 is None else chain.check_q(q0)
        start = time.perf_counter()
        deadline = math.inf if self.timeout_s is None else start + self.timeout_s
        candidate = self._solve(target, q_start, deadline)
        elapsed = time.perf_counter() - start
        return evaluate(chain, target, candidate, self.tolerances, elapsed, self.name)

    def solve_many(self, targets: Iterable, q0s: np.ndarray | Sequence | None = None) -> list[IKResult]:
        """Solve a batch; ``q0s`` is one start for all, one per target, or None."""
        targets = list(targets)
        starts = self._batch_starts(q0s, len(targets))
        return [self.solve(target, q0) for target, q0 in zip(targets, starts, strict=True)]

    def solve_all(self, target) -> list[IKResult]:
        """Every distinct solution (closed-form methods only)."""
        raise UnsupportedError(f"method {self.name!r} finds one solution; use 'analytic' for all branches")

    # -- state that must not be shared between calls ---------------------------------------------
    def _call_rng(self, target: Target, q0: np.ndarray) -> np.random.Generator:
        """The random stream of one call: seeded by (seed, target, q0), so restarts repeat exactly
        whatever the order of calls or the thread; fresh entropy when ``seed`` is None."""
        if self.seed is None:
            return np.random.default_rng()
        digest = hashlib.blake2b(target.position.tobytes(), digest_size=8)
        if target.rotation is not None:
            digest.update(target.rotation.tobytes())
        digest.update(np.ascontiguousarray(q0, dtype=float).tobytes())
        return np.random.default_rng([self.seed, int.from_bytes(digest.digest(), "little")])

    # -- for subclasses ------------------------------------------------------------------------
    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        raise NotImplementedError

    def check_target_kind(self, kind: str) -> None:
        """UnsupportedError, saying why, if this solver cannot take ``kind`` ("pose" or "position")
        targets on its chain (the study asks this before solving a case)."""
        if kind == "pose" and not self.supports_pose:
            raise UnsupportedError(f"method {self.name!r} on {self.chain.name!r} takes position targets only")
        if kind == "position" and not self.supports_position_only:
            because = f": {self.pose_only_because}" if self.pose_only_because else ""
            raise UnsupportedError(
                f"method {self.name!r} on {self.chain.name!r} needs a full pose target{because}")

    def _check_target_kind(self, target: Target) -> None:
        self.check_target_kind("pose" if target.is_pose else "position")

    def _batch_starts(self, q0s, count: int) -> list[np.ndarray | None]:
        if q0s is None:
            return [None] * count
        array = np.asarray(q0s, dtype=float)
        if array.ndim == 1:
            return [self.chain.check_q(array)] * count
        if array.shape[0] != count:
            raise InvalidConfigurationError(f"{count} targets but {array.shape[0]} start configurations")
        return [self.chain.check_q(row) for row in array]
