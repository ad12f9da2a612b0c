"""The task error e(q) and its Jacobian, shared by the iterative methods.

For a full pose target (p*, R*) and tip pose (p, R) in the base frame:
    e = [p* - p ; log3(R* R^T)]   (6,)
and de/dq ~ J (the 6 x n frame Jacobian in base axes), so a Newton step solves J dq = e.
For a position target only the first three rows are used.

Besides the Pinocchio-based ``task_error`` (one configuration), this module holds the chain's
serial structure (``serial_structure``: fixed placements and joint axes, from which KDL chains and
vectorised kinematics are built). The rotation logarithm of many matrices at once is
:func:`wbik.geometry.batch_log3`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.errors import RobotDescriptionError
from wbik.robot import Chain
from wbik.targets import Target


def task_error(chain: Chain, target: Target, q: np.ndarray, with_jacobian: bool = True
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """(e, J) at q; J is None when ``with_jacobian`` is False."""
    if with_jacobian:
        pose, jacobian = chain.fk_jacobian(q)
    else:
        pose, jacobian = chain.fk(q), None
    position_error = target.position - pose.translation
    if target.rotation is None:
        return position_error, None if jacobian is None else jacobian[:3]
    rotation_error = pin.log3(target.rotation @ pose.rotation.T)
    return np.concatenate((position_error, rotation_error)), jacobian


def converged(error: np.ndarray, position_tolerance: float, rotation_tolerance: float) -> bool:
    """The iterate passes the shared check (with a small safety factor)."""
    ok = np.linalg.norm(error[:3]) <= 0.5 * position_tolerance
    if error.size == 6:
        ok = ok and np.linalg.norm(error[3:]) <= 0.5 * rotation_tolerance
    return bool(ok)


# -- serial structure --------------------------------------------------------------------------
@dataclass(frozen=True)
class SerialStructure:
    """T(q) = P_0 X_1(q_1) P_1 X_2(q_2) ... X_n(q_n) P_n, everything in the chain's base frame.

    ``placements[k]`` (k = 0..n, 4x4) are the fixed transforms: P_0 from the base frame to joint 1,
    P_k from joint k to joint k+1, P_n from joint n to the tip frame. X_k is a rotation about (or a
    translation along) the unit ``axes[k]`` (joint-k frame) by q_k.
    """

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
