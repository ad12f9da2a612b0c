"""Rotations, angle wrapping, rotation logarithm/exponential and the pose error: one convention each.

Angles wrap into (-pi, pi] (``wrap_to_pi``). Rotations are 3x3 matrices on column vectors. The pose
error of a reached pose (R, p) against a target (R*, p*) in the same base frame is
e = [p - p*; log3(R*^T R)] (m, rad; rotation vector in the target's axes), driven to 0 by
dq = -J_e^+ e with de_p/dq = J_v and de_R/dq = Jlog3(R*^T R) R^T J_w (J_w in base axes);
position-only targets use the first three rows.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidSettingError
from wbik.kernels.twins import chosen, compiled_twin


def wrap_to_pi(angle):
    """a - 2 pi k in (-pi, pi] (element-wise on arrays)."""
    return np.pi - np.mod(np.pi - np.asarray(angle, dtype=float), 2.0 * np.pi)


def joint_gap(q: np.ndarray, other: np.ndarray, revolute: np.ndarray) -> float | np.ndarray:
    """max |q_i - other_i| over the last axis (float for (n,), array for (..., n)), revolute modulo 2 pi."""
    difference = np.asarray(q, dtype=float) - other
    return np.max(np.where(revolute, np.abs(wrap_to_pi(difference)), np.abs(difference)), axis=-1)


TWO_PI = 2.0 * math.pi
"""One turn (rad): the period of every revolute joint's wrap."""


def _rotation(angle, rows) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    one, zero = np.ones_like(c), np.zeros_like(c)
    values = {"c": c, "s": s, "-s": -s, "1": one, "0": zero}
    return np.stack([np.stack([values[entry] for entry in row], -1) for row in rows], -2)


def rot_x(angle) -> np.ndarray:
    """Rotation about x by ``angle`` (scalar -> (3, 3), array (...) -> (..., 3, 3))."""
    return _rotation(angle, (("1", "0", "0"), ("0", "c", "-s"), ("0", "s", "c")))


def rot_y(angle) -> np.ndarray:
    return _rotation(angle, (("c", "0", "s"), ("0", "1", "0"), ("-s", "0", "c")))


def rot_z(angle) -> np.ndarray:
    return _rotation(angle, (("c", "-s", "0"), ("s", "c", "0"), ("0", "0", "1")))


TAIT_BRYAN_SEQUENCES = ("xyz", "xzy", "yxz", "yzx", "zxy", "zyx")
"""Euler-angle sequences with three distinct axes: R = R_i R_j R_k for the sequence "ijk"."""


def tait_bryan_angles(rotations: np.ndarray, sequence: str = "zyx") -> np.ndarray:
    """(..., 3) angles about x, y, z of rotations (..., 3, 3) R = R_i(a_i) R_j(a_j) R_k(a_k), ``sequence``
    "ijk" ("zyx": R = Rz(gamma) Ry(beta) Rx(alpha) gives (alpha, beta, gamma))."""
    if sequence not in TAIT_BRYAN_SEQUENCES:
        raise InvalidSettingError(f"sequence must be one of {', '.join(TAIT_BRYAN_SEQUENCES)}, "
                                  f"got {sequence!r}")
    i, j, k = ("xyz".index(axis) for axis in sequence)
    sign = 1.0 if sequence in ("zyx", "yxz", "xzy") else -1.0  # even permutations of (z, y, x)
    r = rotations
    outer = np.arctan2(r[..., j, k], r[..., k, k])
    middle = np.arctan2(-r[..., i, k], np.hypot(r[..., k, k], r[..., j, k]))
    inner = np.arctan2(r[..., i, j], r[..., i, i])
    angles = np.empty(np.shape(r)[:-2] + (3,))
    angles[..., i], angles[..., j], angles[..., k] = outer, middle, inner
    return angles if sign > 0 else -angles


_LOG3_ENTRIES = np.array([7, 2, 3, 5, 6, 1, 0, 4, 8])  # R21 R02 R10, R12 R20 R01, R00 R11 R22


def batch_log3(rotations: np.ndarray) -> np.ndarray:
    """Rotation vectors (B, 3) of rotations (B, 3, 3): vee(R - R^T) angle / |vee|, angle =
    atan2(|vee| / 2, (trace - 1) / 2); Pinocchio's log3 near pi."""
    entries = rotations.reshape(-1, 9).take(_LOG3_ENTRIES, axis=1)
    vee = entries[:, :3] - entries[:, 3:6]
    twice_sine = np.sqrt(np.einsum("bi,bi->b", vee, vee))
    cosine = 0.5 * (entries[:, 6] + entries[:, 7] + entries[:, 8] - 1.0)
    angle = np.arctan2(0.5 * twice_sine, cosine)
    result = vee * (angle / np.maximum(twice_sine, 1e-300))[:, None]  # -> vee / 2 as angle -> 0
    if twice_sine.min(initial=np.inf) < 1e-6:
        for index in np.flatnonzero((twice_sine < 1e-6) & (cosine < 0.0)):  # near pi, vee loses the axis
            result[index] = pin.log3(rotations[index])
    return result


def batch_exp3(vectors: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of rotation vectors (..., 3) (Rodrigues' formula)."""
    angle = np.linalg.norm(vectors, axis=-1)[..., None, None]
    x, y, z = vectors[..., 0], vectors[..., 1], vectors[..., 2]
    zero = np.zeros_like(x)
    skew = np.stack((np.stack((zero, -z, y), -1), np.stack((z, zero, -x), -1),
                     np.stack((-y, x, zero), -1)), -2)
    small = angle < 1e-8
    safe = np.where(small, 1.0, angle)
    first = np.where(small, 1.0 - angle ** 2 / 6.0, np.sin(safe) / safe)
    second = np.where(small, 0.5 - angle ** 2 / 24.0, (1.0 - np.cos(safe)) / safe ** 2)
    return np.eye(3) + first * skew + second * (skew @ skew)


def rotation_error(reached: np.ndarray, target: np.ndarray) -> np.ndarray:
    """e_R = log3(R*^T R): the rotation vector (target axes, rad) taking the target onto the reached."""
    return pin.log3(target.T.dot(reached))


def plain_pose_errors(reached: list[float], position: list[float], rotation: list[float] | None
                      ) -> tuple[list[float], bool]:
    """((e_p (3), e_R (3), |e_p|, |e_R|), exact) of a tip pose (its 4x4 matrix's first 12 values, row by
    row) on a target (rotation: 9 values row by row, None for a position): e_R = log3(R*^T R) in
    :func:`batch_log3`'s formula (0 without a rotation), operation by operation as ``_pose_errors.h``.
    ``exact`` is False where that formula loses the axis (|vee| < 1e-6 near a half turn)."""
    r00, r01, r02, x, r10, r11, r12, y, r20, r21, r22, z = reached[:12]
    ex, ey, ez = x - position[0], y - position[1], z - position[2]
    position_norm = math.sqrt(ex * ex + ey * ey + ez * ez)
    if rotation is None:
        return [ex, ey, ez, 0.0, 0.0, 0.0, position_norm, 0.0], True
    t00, t01, t02, t10, t11, t12, t20, t21, t22 = rotation
    m = [t00 * r00 + t10 * r10 + t20 * r20, t00 * r01 + t10 * r11 + t20 * r21,
         t00 * r02 + t10 * r12 + t20 * r22, t01 * r00 + t11 * r10 + t21 * r20,
         t01 * r01 + t11 * r11 + t21 * r21, t01 * r02 + t11 * r12 + t21 * r22,
         t02 * r00 + t12 * r10 + t22 * r20, t02 * r01 + t12 * r11 + t22 * r21,
         t02 * r02 + t12 * r12 + t22 * r22]
    vee = (m[7] - m[5], m[2] - m[6], m[3] - m[1])
    twice_sine = math.sqrt(vee[0] * vee[0] + vee[1] * vee[1] + vee[2] * vee[2])
    cosine = 0.5 * (m[0] + m[4] + m[8] - 1.0)
    scale = math.atan2(0.5 * twice_sine, cosine) / max(twice_sine, 1e-300)
    rx, ry, rz = vee[0] * scale, vee[1] * scale, vee[2] * scale
    return ([ex, ey, ez, rx, ry, rz, position_norm, math.sqrt(rx * rx + ry * ry + rz * rz)],
            not (twice_sine < 1e-6 and cosine < 0.0))


def _python_pose_errors(reached: np.ndarray, position: np.ndarray, rotation: np.ndarray | None,
                        position_error: np.ndarray, rotation_error: np.ndarray,
                        base_inverse: np.ndarray | None) -> tuple[float, float, bool]:
    """The shared FK check's errors of a reached 4x4 pose (taken as ``base_inverse`` @ ``reached`` where
    that 4x4 rigid transform is given) on a target, as :func:`plain_pose_errors` gives them: e_p into
    ``position_error``, e_R into ``rotation_error``; returns (|e_p|, |e_R|, exact). Compiled twin:
    ``wbik.kernels._pose.pose_errors``, the same bits."""
    pose = reached.ravel().tolist()
    if base_inverse is not None:
        pose = plain_composed(base_inverse.ravel().tolist(), pose)
    values, exact = plain_pose_errors(pose, position.tolist(),
                                      None if rotation is None else rotation.ravel().tolist())
    position_error[:], rotation_error[:] = values[:3], values[3:6]
    return values[6], values[7], exact


def plain_composed(first: list[float], second: list[float]) -> list[float]:
    """The top 12 values (row by row) of the product of two 4x4 rigid transforms given row by row: each
    entry sum_k a_ik b_kj over k = 0, 1, 2 in order, the translation a_i3 added last."""
    composed = []
    for i in range(3):
        a0, a1, a2, a3 = first[4 * i:4 * i + 4]
        composed += [a0 * second[j] + a1 * second[4 + j] + a2 * second[8 + j] for j in range(3)]
        composed.append(a0 * second[3] + a1 * second[7] + a2 * second[11] + a3)
    return composed


_compiled_pose_errors = compiled_twin("pose", "pose_errors")
pose_errors = chosen(_python_pose_errors, _compiled_pose_errors, "pose")
"""pose_errors(reached, position, rotation, position_error, rotation_error, base_inverse) -> (|e_p|, |e_R|,
exact), see the Python twin."""


def rotation_angle(reached: np.ndarray, target: np.ndarray) -> float:
    """|log3(R*^T R)|: the angle (rad, in [0, pi]) between two rotations."""
    return math.hypot(*pin.log3(target.T.dot(reached)).tolist())


def pose_error(reached_rotation: np.ndarray, reached_position: np.ndarray,
               target_rotation: np.ndarray | None, target_position: np.ndarray) -> np.ndarray:
    """e = [p - p*; log3(R*^T R)] (6,), or p - p* (3,) when the target has no rotation."""
    position = reached_position - target_position
    if target_rotation is None:
        return position
    return np.concatenate((position, pin.log3(target_rotation.T.dot(reached_rotation))))


def rotation_error_jacobian(reached: np.ndarray, target: np.ndarray,
                            angular_jacobian: np.ndarray) -> np.ndarray:
    """d log3(R*^T R) / dq = Jlog3(R*^T R) R^T J_w for angular rows J_w in base axes."""
    return pin.Jlog3(target.T.dot(reached)).dot(reached.T.dot(angular_jacobian))
