"""The planned joint torques of a walk, to lead a compliant position servo's target by tau / kp.

tau = M(q) q'' + h(q, q') + armature q'' - J_c^T f on the 1-DOF joints (inverse dynamics of the planned
motion, q' and q'' by central differences), f the contact wrenches of the planned support that balance the
floating base's rows; in double support the load is shared by where the pendulum's ZMP lies between the
soles (f = W A^T (A W A^T)^-1 b, W the share of each sole)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from wbik.motion.walking.multibody_zmp import trajectory_derivatives
from wbik.motion.walking.pattern import WalkPattern

SHARE_MIN = 0.02  # the least share of the load on a sole pressed in double support


def planned_torques(pattern: WalkPattern, qs: np.ndarray, joints: list[int],
                    armature: float = 0.0) -> np.ndarray:
    """(K, len(joints)) torques (N m) of the 1-DOF ``joints`` along the planned configurations ``qs``."""
    last = pattern.ticks - 1
    return support_torques(pattern.robot.model, qs, pattern.dt,
                           [pattern.support[min(k, last)] for k in range(len(qs))],
                           [pattern.lipm_zmp[min(k, last)] for k in range(len(qs))], joints, armature)


def support_torques(model: pin.Model, qs: np.ndarray, dt: float, support: Sequence[Sequence[str]],
                    load_points: Sequence[np.ndarray], joints: list[int], armature: float = 0.0
                    ) -> np.ndarray:
    """(K, len(joints)) torques (N m) of the 1-DOF ``joints`` along configurations ``qs`` sampled every
    ``dt`` s, standing on the soles ``support[k]``, the load shared in double support by where
    ``load_points[k]`` (x, y) lies between the two soles."""
    data = model.createData()
    index = [model.joints[j].idx_v for j in joints]
    velocity, acceleration = trajectory_derivatives(model, qs, dt)
    torques = np.zeros((len(qs), len(joints)))
    for k, q in enumerate(qs):
        tau = pin.rnea(model, data, q, velocity[k], acceleration[k]).copy()
        tau[6:] += armature * acceleration[k, 6:]
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        frames = [model.getFrameId(frame) for frame in support[k]]
        jacobian = np.vstack([pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED)
                              for frame in frames])
        base = jacobian[:, :6].T  # A f = b: the contact wrenches carry the floating base
        weights = np.ones(jacobian.shape[0])
        if len(frames) == 2:
            first, second = (data.oMf[frame].translation[:2] for frame in frames)
            along = second - first
            share = np.clip(np.dot(load_points[k] - first, along) / np.dot(along, along), SHARE_MIN,
                            1.0 - SHARE_MIN)
            weights = np.repeat([1.0 - share, share], 6)
        wrench = weights * (base.T @ np.linalg.solve((base * weights) @ base.T, tau[:6]))
        torques[k] = tau[index] - jacobian[:, index].T @ wrench
    return torques
