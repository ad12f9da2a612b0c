"""Batched twins for ``analytic``'s ``solve_many``, one NumPy pass per batch: :func:`batch_targets` checks
targets as ``as_target`` does, :func:`evaluate_batch` is the shared check's rule with the form's FK."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import pinocchio as pin

from wbik.errors import UnsupportedError
from wbik.geometry import batch_log3
from wbik.robot import Chain
from wbik.solvers.analytic.aligned import times
from wbik.solvers.batch_results import IKResults, SolvedRows
from wbik.solvers.check import (
    CLIPPED_REASON,
    clip_to_limits,
    fk_check_reason,
    invalid_joints_reason,
    no_joints,
)
from wbik.solvers.result import Candidate, IKResult, Tolerances
from wbik.targets import MAX_POSITION, ROTATION_TOLERANCE, as_target


def _valid_se3(matrices: np.ndarray) -> bool:
    """Every 4x4 pose passes ``as_target``'s check of an SE3, its arithmetic term by term."""
    (a, b, c, x, d, e, f, y, g, h, i, z) = matrices.reshape(-1, 16)[:, :12].T
    bound, tolerance = MAX_POSITION, ROTATION_TOLERANCE
    low, high = 1.0 - tolerance, 1.0 + tolerance

    def within(values: np.ndarray, lowest: float, highest: float) -> bool:
        return bool(np.all((lowest <= values) & (values <= highest)))  # NaN fails

    unit = np.stack((a * a + d * d + g * g, b * b + e * e + h * h, c * c + f * f + i * i))
    orthogonal = np.stack((a * b + d * e + g * h, a * c + d * f + g * i, b * c + e * f + h * i))
    determinant = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    return (within(np.stack((x, y, z)), -bound, bound) and within(unit, low, high)
            and within(orthogonal, -tolerance, tolerance) and within(determinant, low, high))


def _plain_matrices(values) -> np.ndarray | None:
    """The (B, 4, 4) float64 poses of a batch of SE3s or of 4 x 4 float64 arrays (or one such array) whose
    last rows are exactly [0, 0, 0, 1], as :func:`~wbik.targets.plain_pose_matrix` takes one; else None."""
    if type(values) is np.ndarray:
        matrices = values if values.dtype == np.float64 and values.shape[1:] == (4, 4) else None
    elif isinstance(values, np.ndarray):  # a subclass (np.matrix, a masked array): the general path
        return None
    elif all(type(value) is pin.SE3 for value in values):
        return np.array([value.homogeneous for value in values])
    elif all(type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (4, 4)
             for value in values):
        matrices = np.array(values)
    else:
        return None
    if matrices is None or not np.array_equal(matrices[:, 3], np.broadcast_to((0.0, 0.0, 0.0, 1.0),
                                                                              (len(matrices), 4))):
        return None
    return matrices


def _plain_positions(values) -> np.ndarray | None:
    """A (B, 3) float64 array of positions within the bound (NaN fails), else None."""
    if not (type(values) is np.ndarray and values.dtype == np.float64 and values.shape[1:] == (3,)):
        return None
    bound = MAX_POSITION
    return values.copy() if bool(np.all((-bound <= values) & (values <= bound))) else None


def batch_targets(values: Iterable, solver) -> tuple[np.ndarray, np.ndarray | None]:
    """(positions (B, 3), rotations (B, 3, 3) or None) of user targets (a list of them, or one array of
    (B, 4, 4) poses or (B, 3) positions); UnsupportedError for a mixed batch."""
    values = values if isinstance(values, np.ndarray) else list(values)
    if not len(values):
        return np.zeros((0, 3)), None
    matrices = _plain_matrices(values)
    if matrices is not None and _valid_se3(matrices):
        solver.check_target_kind("pose")
        return matrices[:, :3, 3].copy(), matrices[:, :3, :3].copy()
    positions = _plain_positions(values)
    if positions is not None:
        solver.check_target_kind("position")
        return positions, None
    targets = [as_target(value) for value in values]
    for kind in dict.fromkeys("pose" if target.is_pose else "position" for target in targets):
        solver.check_target_kind(kind)  # once per kind, in the order the batch first holds them
    if len({target.is_pose for target in targets}) != 1:
        raise UnsupportedError("a batch must hold only full poses or only positions")
    rotations = np.array([target.rotation for target in targets]) if targets[0].is_pose else None
    return np.array([target.position for target in targets]), rotations


def _measure(form, positions: np.ndarray, rotations: np.ndarray | None, q: np.ndarray, inside: np.ndarray,
             finite: np.ndarray, reached: tuple[np.ndarray, np.ndarray] | None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`evaluate_batch`'s errors by the form's FK: (e_p (B, 3), e_R (B, 3), their norms)."""
    if reached is None or not np.array_equal(inside, q, equal_nan=True):
        reached = form.fk(np.where(finite[:, None], inside, 0.0))
    reached_p, reached_r = reached
    position_xyz = reached_p - positions
    position_norm = np.sqrt(np.einsum("bi,bi->b", position_xyz, position_xyz))
    if rotations is None:
        count = len(positions)
        return position_xyz, np.zeros((count, 3)), position_norm, np.zeros(count)
    rotation_xyz = batch_log3(times(np.swapaxes(rotations, 1, 2), reached_r))  # R*^T R
    rotation_norm = np.sqrt(np.einsum("bi,bi->b", rotation_xyz, rotation_xyz))
    return position_xyz, rotation_xyz, position_norm, rotation_norm


def evaluate_batch(chain: Chain, form, positions: np.ndarray, rotations: np.ndarray | None, q: np.ndarray,
                   found: np.ndarray, reasons: list[str], tolerances: Tolerances, time_s: float,
                   method: str, branches: np.ndarray, reached: tuple[np.ndarray, np.ndarray] | None = None,
                   measured: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
                   ) -> IKResults:
    """:func:`wbik.solvers.check.evaluate` for a batch, by ``form.fk``: the solved rows stay columns of
    :class:`IKResults`, the others (rare) are built here. ``branches``: each row's real branches;
    ``reached``: ``form.fk(q)``, ``measured``: the errors (e_p, e_R, their norms), where already computed."""
    q = np.asarray(q, dtype=float)
    finite = np.all(np.isfinite(q), axis=1)
    inside = clip_to_limits(q, chain.lower, chain.upper)
    position_xyz, rotation_xyz, position_norm, rotation_norm = measured or _measure(
        form, positions, rotations, q, inside, finite, reached)
    success = (position_norm <= tolerances.position) & (rotation_norm <= tolerances.rotation)
    rows = SolvedRows(inside, position_norm, rotation_norm, position_xyz, rotation_xyz,
                      np.full(len(q), time_s), np.asarray(branches), method)
    answers: list[IKResult | None] = [None] * len(q)
    for index in np.flatnonzero(~(success & found & finite)).tolist():  # the rows not solved (rare)
        reason = reasons[index]
        if not found[index] or not finite[index]:
            why = (reason or "no solution") if not found[index] else invalid_joints_reason(q[index])
            extra = {"branches": int(rows.branches[index]), "batched": True}
            answers[index] = no_joints(why, time_s, Candidate(None, 1, extra=extra), method)
        else:
            if not reason and not chain.in_limits(q[index], tolerance=1e-9):  # the shared check's rule
                reason = CLIPPED_REASON
            elif not reason:
                reason = fk_check_reason(float(position_norm[index]), float(rotation_norm[index]))
            answers[index] = rows.answer(index, False, reason)
    return IKResults(answers, rows)
