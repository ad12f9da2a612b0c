"""The shared check: an answer succeeds when every goal is within the :class:`Tolerances` and every hard
constraint holds, measured by FK on the model whatever the method thinks: :func:`evaluate` for a chain
target, :func:`check_problem` for a whole-body problem.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from wbik.geometry import pose_errors
from wbik.kernels import chain_fk
from wbik.kernels.twins import chosen, compiled_twin
from wbik.qp.kinematics import Kinematics
from wbik.robot import Chain
from wbik.solvers.result import NAN3, Candidate, IKResult, Tolerances
from wbik.targets import Target, pose_target
from wbik.wholebody.problem import StartedProblem, WholeBody

try:  # numpy's clip ufunc: np.clip's Python wrapper costs more than the ufunc on a few joints
    from numpy._core.umath import clip as _clip_ufunc
except ImportError:  # pragma: no cover - another numpy layout
    _clip_ufunc = None


if chain_fk.result_type is not None:  # the answer the compiled check fills: IKResult's slots, in order
    chain_fk.result_type(IKResult, [field.name for field in dataclasses.fields(IKResult)])

CLIPPED_REASON = "solution outside the joint limits (clipped)"


def fk_check_reason(position_norm: float, rotation_norm: float) -> str:
    """Why the shared FK check failed a candidate inside the limits."""
    return f"FK check failed: position error {position_norm:.3g} m, rotation error {rotation_norm:.3g} rad"


def invalid_joints_reason(q) -> str:
    return f"method returned invalid joints {q!r}"


def no_joints(reason: str, time_s: float, candidate: Candidate, method: str) -> IKResult:
    """The failed result of a candidate without (valid) joints."""
    nan3 = np.full(3, np.nan)
    return IKResult(None, False, reason, math.nan, math.nan, nan3, nan3.copy(), time_s, candidate.iterations,
                    method, candidate.extra)


def clip_to_limits(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """min(max(q, lower), upper) element-wise (a new array; NaN stays NaN), in one ufunc call."""
    if _clip_ufunc is None:
        return np.minimum(np.maximum(q, lower), upper)
    return _clip_ufunc(q, lower, upper)


def _python_inside_limits(q, lower: np.ndarray, upper: np.ndarray) -> bool:
    """Whether ``q`` is a float64 array of the limits' shape, finite and within them (compiled twin:
    ``wbik.kernels._pose.inside_limits``)."""
    if type(q) is not np.ndarray or q.dtype != np.float64 or q.shape != lower.shape or q.ndim != 1:
        return False
    return all(low <= value <= high and math.isfinite(value)
               for value, low, high in zip(q.tolist(), lower.tolist(), upper.tolist(), strict=True))


inside_limits = chosen(_python_inside_limits, compiled_twin("pose", "inside_limits"), "pose")
"""inside_limits(q, lower, upper) -> bool: the shared check's fast-path test (see the Python twin)."""


def evaluate(chain: Chain, target: Target, candidate: Candidate, tolerances: Tolerances,
             time_s: float, method: str, reached: np.ndarray | None = None) -> IKResult:
    """The shared FK check: clip into the limits, e_p = p - p* (base axes), e_R = log3(R*^T R), success.
    ``reached``: ``chain.fk(candidate.q).homogeneous`` as the method computed it, used only when the
    joints checked are ``candidate.q`` bit for bit."""
    q = candidate.q
    if reached is None and not chain.any_continuous:
        if (compiled := chain.compiled_fk) is not None and chain_fk.checked_result is not None:
            # a passing answer's whole check in one call (None for every other case, judged below)
            result = chain_fk.checked_result(compiled, q, target.position, target.rotation,
                                             tolerances.position, tolerances.rotation, time_s,
                                             candidate.iterations, method, candidate.extra)
            if result is not None:
                return result
    if reached is None and not chain.any_continuous and inside_limits(q, chain.lower, chain.upper):
        inside = q.copy()  # the common case: finite joints inside the limits, checked as they are
        return judged(target, inside, None, candidate, candidate.reason, tolerances, time_s, method,
                      chain=chain)
    if q is None:
        return no_joints(candidate.reason or "no solution", time_s, candidate, method)
    if type(q) is not np.ndarray or q.dtype != np.float64:
        q = np.asarray(q, dtype=float)
    lower, upper = chain.lower, chain.upper
    if q.shape != lower.shape:
        return no_joints(invalid_joints_reason(q), time_s, candidate, method)
    reason = candidate.reason
    if chain.any_continuous:  # an angle of a continuous joint is in range modulo 2 pi
        unwrapped, q = q, chain.wrap_continuous(q)
        if reached is not None and q.tobytes() != unwrapped.tobytes():
            reached = None
    inside = clip_to_limits(q, lower, upper)
    if inside.tobytes() != q.tobytes():  # outside the limits, or infinite (NaN passes: see below)
        reached = None
        if not np.all(np.isfinite(q)):
            return no_joints(invalid_joints_reason(q), time_s, candidate, method)
        if not reason and not chain.in_limits(q, tolerance=1e-9):
            reason = CLIPPED_REASON
    if reached is None:
        reached = chain.fk(inside).homogeneous
    result = judged(target, inside, reached, candidate, reason, tolerances, time_s, method)
    if result.position_error != result.position_error and not np.all(np.isfinite(q)):
        return no_joints(invalid_joints_reason(q), time_s, candidate, method)  # NaN joints, a NaN pose
    return result


def judged(target: Target, inside: np.ndarray, reached: np.ndarray | None, candidate: Candidate, reason: str,
           tolerances: Tolerances, time_s: float, method: str, base_inverse: np.ndarray | None = None,
           chain: Chain | None = None) -> IKResult:
    """The result of joints ``inside`` the limits whose tip pose is ``reached`` (4 x 4; in the base frame
    after ``base_inverse`` where given; None: ``chain``'s FK of ``inside``, in the base frame): their errors
    (:func:`wbik.geometry.pose_errors`; Pinocchio's log3 near a half turn) against the tolerances."""
    position_xyz, rotation_xyz, rotation = np.empty(3), np.empty(3), target.rotation
    position = target.position
    if reached is None:
        position_norm, rotation_norm, exact = chain.tip_errors(inside, position, rotation, position_xyz,
                                                               rotation_xyz)
    else:
        position_norm, rotation_norm, exact = pose_errors(reached, position, rotation, position_xyz,
                                                          rotation_xyz, base_inverse)
    if not exact:  # the formula lost the axis near a half turn
        if reached is None:
            reached, base_inverse = chain.root_tip(inside), chain.base_inverse_matrix
        turned = reached[:3, :3] if base_inverse is None else base_inverse[:3, :3].dot(reached[:3, :3])
        rotation_xyz = pin.log3(rotation.T.dot(turned))
        rotation_norm = math.hypot(*rotation_xyz.tolist())
    success = position_norm <= tolerances.position and rotation_norm <= tolerances.rotation
    if not success:
        reason = reason or fk_check_reason(position_norm, rotation_norm)
    return IKResult(inside, success, "" if success else reason, position_norm, rotation_norm, position_xyz,
                    rotation_xyz, time_s, candidate.iterations, method, candidate.extra)


def evaluate_screened(chain: Chain, target: Target | np.ndarray, parts: np.ndarray, extra: dict,
                      tolerances: Tolerances, time_s: float, method: str) -> IKResult:
    """The shared check of joints a compiled choice wrote: ``parts`` (n + 24) holds q, their 4 x 4 tip pose
    and the batched check's errors (e_p, e_R, |e_p|, |e_R|); ``target``: a Target or a pose's matrix."""
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


def check_problem(started: StartedProblem | WholeBody, q, tolerances: Tolerances | None = None, *,
                  q0: np.ndarray | None = None, method: str = "", time_s: float = math.nan,
                  iterations: int = 0, reason: str = "", unsupported: Sequence[str] = (),
                  extra: dict | None = None) -> IKResult:
    """The shared check of q on a whole-body problem as started, or a WholeBody started at ``q0``."""
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
        if (measure := constraint.measure(kinematics, tolerances)) is not None:
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
