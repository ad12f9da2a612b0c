"""The shared check: one rule decides ``success`` for every method, on chain targets and whole-body
problems alike. An answer succeeds when every goal is within the :class:`Tolerances` and every hard
constraint holds, both measured by forward kinematics on the model; the method's own opinion plays no
part, so methods compare like with like.

- :func:`evaluate`: a chain target (one frame task on the chain's reduced model, its joint limits): clip
  the joints into the limits, FK, the pose error of :mod:`wbik.geometry`. Written for the per-call path.
- :func:`check_problem`: a whole-body problem: every goal task's error (its position and rotation parts),
  every constraint's own :meth:`~wbik.qp.constraint.Constraint.measure` (a contact's drift against where
  it was held, the CoM margin of the support the soles make at q, the limit excess, the clearances).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from wbik.geometry import error_parts
from wbik.qp.kinematics import Kinematics
from wbik.robot import Chain
from wbik.solvers.result import NAN3
from wbik.solvers.result import Candidate
from wbik.solvers.result import IKResult
from wbik.solvers.result import Tolerances
from wbik.targets import Target
from wbik.targets import pose_target
from wbik.wholebody.problem import StartedProblem
from wbik.wholebody.problem import WholeBody

# numpy's clip ufunc, called directly: np.clip wraps it in Python code that costs more than the ufunc
# itself on a few joints (docs/measurements.md, base)
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


def check_problem(started: StartedProblem | WholeBody, q, tolerances: Tolerances | None = None, *,
                  q0: np.ndarray | None = None, method: str = "", time_s: float = math.nan,
                  iterations: int = 0, reason: str = "", unsupported: Sequence[str] = (),
                  extra: dict | None = None) -> IKResult:
    """The shared check of configuration q on a whole-body problem (see the module docstring).

    ``started``: the problem as a method started it (its contacts held where they were at the start),
    or the WholeBody itself, then started at ``q0`` (needed when it has contacts without a placement).
    Success: every goal task within the tolerances and every constraint's measure holding."""
    tolerances = tolerances or Tolerances()
    if isinstance(started, WholeBody):
        started = started.start(started.robot.nominal if q0 is None else q0, need_q0=q0 is None, strict=False)
    problem = started.problem
    unsupported, extra = list(unsupported), dict(extra or {})
    if q is not None:
        q = np.asarray(q, dtype=float).reshape(-1)
        if q.shape != (problem.robot.model.nq,) or not np.all(np.isfinite(q)):
            reason, q = invalid_joints_reason(q), None
    if q is None:
        nan = {name: math.nan for name, _ in problem.goal_tasks}
        return IKResult(None, False, reason or "no configuration", math.nan, math.nan, np.array(NAN3),
                        np.array(NAN3), time_s, iterations, method, extra, nan, dict(nan), dict(nan), {},
                        unsupported)
    if problem.robot.has_floating_base:  # a unit quaternion, whatever the method returned
        q = q.copy()
        q[3:7] /= np.linalg.norm(q[3:7])
    kinematics = Kinematics(problem.robot.model, q)
    failures: list[str] = []
    task_errors, position_errors, rotation_errors = {}, {}, {}
    for name, task in zip(problem.task_names, problem.copied_tasks(), strict=True):
        if not task.goal:
            continue
        task.start(kinematics)
        position, rotation = task.error_parts(np.asarray(task.error(kinematics), dtype=float))
        task_errors[name] = max(part for part in (position, rotation) if part is not None)
        for part, error, errors, tolerance, unit in (
                ("position", position, position_errors, tolerances.position, "m"),
                ("rotation", rotation, rotation_errors, tolerances.rotation, "rad")):
            if error is not None:
                errors[name] = error
                if error > tolerance:
                    failures.append(f"task {name} {part} error {error:.3g} {unit}")
    measures = {}
    for constraint in started.constraints:
        measure = constraint.measure(kinematics, tolerances)
        if measure is not None:
            measures[measure.constraint] = measure
            if not measure.holds:
                failures.append(measure.failure)
    if failures:
        check = "check failed: " + "; ".join(failures[:3]) + ("; ..." if len(failures) > 3 else "")
        reason = f"{reason} ({check})" if reason else check
    else:
        reason = ""
    return IKResult(q, not failures, reason, max(position_errors.values(), default=math.nan),
                    max(rotation_errors.values(), default=math.nan), np.array(NAN3), np.array(NAN3), time_s,
                    iterations, method, extra, task_errors, position_errors, rotation_errors, measures,
                    unsupported)
