"""The task error of the iterative methods and the chain's serial structure. ``dls`` and ``newton`` iterate
on e = [p - p* ; log3(R*^T R)] (:func:`task_error`; 3 rows for a position) with the Jacobian [J_v ;
Jlog3(R*^T R) R^T J_w]; ``bounded_lm`` on the SE(3) form e = log6(T*^-1 T) = [V(phi)^-1 R*^T (p - p*) ;
phi], phi = log3(R*^T R): the same rotation part, both vanishing together.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.errors import RobotDescriptionError
from wbik.geometry import batch_log3, pose_error, rotation_error_jacobian
from wbik.robot import Chain
from wbik.targets import Target


def task_error(chain: Chain, target: Target, q: np.ndarray, with_jacobian: bool = True
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """(e, de/dq) at q in the convention's form; the Jacobian is None when ``with_jacobian`` is False."""
    pose, jacobian = chain.fk_jacobian(q) if with_jacobian else (chain.fk(q), None)
    rotation = pose.rotation
    error = pose_error(rotation, pose.translation, target.rotation, target.position)
    if jacobian is None:
        return error, None
    if target.rotation is None:
        return error, jacobian[:3]
    jacobian[3:] = rotation_error_jacobian(rotation, target.rotation, jacobian[3:])
    return error, jacobian


def batch_se3_error(rotation: np.ndarray, translation: np.ndarray, target_rotation: np.ndarray,
                    target_position: np.ndarray) -> np.ndarray:
    """log6(T*^-1 T) (B, 6) of reached poses against one target or one each: t = R*^T (p - p*), V(phi)^-1 t
    = (1 - c theta^2) t - (phi x t) / 2 + c (phi . t) phi, c = (1 - (theta / 2) cot(theta / 2)) / theta^2."""
    if target_rotation.ndim == 2:
        phi = batch_log3(np.matmul(target_rotation.T, rotation))
        offset = (translation - target_position) @ target_rotation  # R*^T (p - p*), row by row
    else:
        phi = batch_log3(np.matmul(np.swapaxes(target_rotation, 1, 2), rotation))
        offset = np.einsum("bi,bij->bj", translation - target_position, target_rotation)
    theta2 = np.einsum("bi,bi->b", phi, phi)
    half = 0.5 * np.sqrt(theta2)
    small = theta2 < 1e-6
    safe = np.where(small, 1.0, half)
    # c and its series 1/12 + theta^2/720 near 0 (where the closed form loses its digits)
    coefficient = np.where(small, 1.0 / 12.0 + theta2 / 720.0,
                           (1.0 - safe / np.tan(safe)) / (4.0 * safe * safe))
    along = coefficient * np.einsum("bi,bi->b", phi, offset)
    cross = (phi[:, :, None] * offset[:, None, :]).reshape(-1, 9) @ LEVI_CIVITA
    result = np.empty((len(phi), 6))
    result[:, :3] = offset * (1.0 - coefficient * theta2)[:, None] - 0.5 * cross + along[:, None] * phi
    result[:, 3:] = phi
    return result


LEVI_CIVITA = np.array([[0, 0, 0], [0, 0, 1], [0, -1, 0], [0, 0, -1], [0, 0, 0], [1, 0, 0], [0, 1, 0],
                        [-1, 0, 0], [0, 0, 0]], dtype=float)
"""E (9, 3) = epsilon_ijk at (3 i + j, k): (a outer b).flat @ E = a x b."""


def converged(error: np.ndarray, position_tolerance: float, rotation_tolerance: float) -> bool:
    """The iterate passes the shared check safely: |e_p| and |e_R| at most half their tolerances."""
    values = error.tolist()
    if math.hypot(*values[:3]) > 0.5 * position_tolerance:
        return False
    return len(values) < 6 or math.hypot(*values[3:]) <= 0.5 * rotation_tolerance


@dataclass(frozen=True)
class SerialStructure:
    """T(q) = P_0 X_1(q_1) P_1 ... X_n(q_n) P_n in the chain's base frame: ``placements`` P_0 (base to
    joint 1) .. P_n (joint n to the tip), X_k a turn about (or a slide along) the unit ``axes[k]`` by q_k."""

    placements: np.ndarray  # (n + 1, 4, 4)
    axes: np.ndarray  # (n, 3)
    prismatic: np.ndarray  # (n,) bool


def serial_structure(chain: Chain) -> SerialStructure:
    """Read the fixed placements and joint axes of a chain's reduced Pinocchio model."""
    model = chain.model
    joint_ids = [model.getJointId(name) for name in chain.joint_names]
    for previous, joint_id in zip([0, *joint_ids[:-1]], joint_ids, strict=True):
        if model.parents[joint_id] != previous:
            raise RobotDescriptionError(
                f"chain {chain.name!r}: joint {model.names[joint_id]!r} does not follow the previous "
                "chain joint directly; a serial structure needs consecutive joints")
    tip_frame = model.frames[chain.tip_id]
    if tip_frame.parentJoint != joint_ids[-1]:
        raise RobotDescriptionError(
            f"chain {chain.name!r}: tip frame {chain.tip_frame!r} is not carried by the last chain joint")
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    axes, prismatic = [], []
    for joint_id in joint_ids:
        subspace = np.asarray(data.joints[joint_id].S).reshape(6)
        linear, angular = subspace[:3], subspace[3:]
        is_prismatic = np.linalg.norm(angular) < 1e-12
        axis = linear if is_prismatic else angular
        axes.append(axis / np.linalg.norm(axis))
        prismatic.append(is_prismatic)
    placements = [(chain.base_placement.inverse() * model.jointPlacements[joint_ids[0]]).homogeneous]
    placements += [model.jointPlacements[j].homogeneous for j in joint_ids[1:]]
    placements.append(tip_frame.placement.homogeneous)
    return SerialStructure(np.array(placements), np.array(axes), np.array(prismatic, dtype=bool))


def joint_lines_at_zero(structure: SerialStructure) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(axes (n, 3), origins (n, 3), tip (4, 4)) at q = 0 in the base frame: joint k's line."""
    transform = structure.placements[0].copy()
    axes, origins = [], []
    for k, axis in enumerate(structure.axes):
        axes.append(transform[:3, :3] @ axis)
        origins.append(transform[:3, 3].copy())
        transform = transform @ structure.placements[k + 1]
    return np.array(axes).reshape(-1, 3), np.array(origins).reshape(-1, 3), transform
