"""The ZMP of the whole robot along a joint trajectory, from its centroidal dynamics: with the contact
wrench f = m c'' - m g, n = dL/dt about the CoM c, p_x = c_x - ((c_z - z_g) f_x + n_y) / f_z,
p_y = c_y - ((c_z - z_g) f_y - n_x) / f_z (NaN when f_z <= 0)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError


def actuated_joints(model: pin.Model) -> list[int]:
    """The ids of the model's 1-DOF joints."""
    return [j for j in range(1, model.njoints) if model.joints[j].nq == 1]


def limit_excess(model: pin.Model, q: np.ndarray, index=None) -> float:
    """How far the worst entry ``index`` (default the 1-DOF joints') of q (..., nq) is outside its limits
    (rad, m for a prismatic joint; 0 inside)."""
    index = [model.joints[j].idx_q for j in actuated_joints(model)] if index is None else index
    joints = q[..., index]
    return float(max(np.max(model.lowerPositionLimit[index] - joints),
                     np.max(joints - model.upperPositionLimit[index]), 0.0))


def trajectory_derivatives(model: pin.Model, qs: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(v, a), each (K, nv), of configurations ``qs`` (K, nq) sampled every ``dt`` s."""
    qs = np.asarray(qs, dtype=float)
    if qs.ndim != 2 or qs.shape[1] != model.nq or len(qs) < 3:
        raise InvalidConfigurationError(f"a trajectory of at least 3 configurations of {model.nq} values is "
                                        f"needed, got shape {qs.shape}")
    if not dt > 0:
        raise InvalidConfigurationError(f"dt must be > 0, got {dt}")
    velocity, acceleration = np.zeros((len(qs), model.nv)), np.zeros((len(qs), model.nv))
    for k in range(1, len(qs) - 1):
        ahead = pin.difference(model, qs[k], qs[k + 1])
        behind = pin.difference(model, qs[k], qs[k - 1])
        velocity[k] = (ahead - behind) / (2.0 * dt)
        acceleration[k] = (ahead + behind) / (dt * dt)
    velocity[0] = pin.difference(model, qs[0], qs[1]) / dt
    velocity[-1] = pin.difference(model, qs[-2], qs[-1]) / dt
    acceleration[0], acceleration[-1] = acceleration[1], acceleration[-2]
    return velocity, acceleration


def zmp_of_wrench(force: np.ndarray, moment: np.ndarray, point: np.ndarray, ground_z: float) -> np.ndarray:
    """The ZMP (x, y) on z = ``ground_z`` of a contact wrench (``moment`` about ``point``, world)."""
    fx, fy, fz = force
    if not fz > 0:
        return np.array([np.nan, np.nan])
    height = point[2] - ground_z
    return np.array([point[0] - (height * fx + moment[1]) / fz, point[1] - (height * fy - moment[0]) / fz])


def multibody_zmp(model: pin.Model, qs: np.ndarray, velocities: np.ndarray, accelerations: np.ndarray,
                  ground_z=0.0, data: pin.Data | None = None) -> np.ndarray:
    """The ZMP (K, 2) of each sample; ``ground_z``: the ground's height, one value or one per sample (m)."""
    data = model.createData() if data is None else data
    count = len(qs)
    heights = np.broadcast_to(np.asarray(ground_z, dtype=float), (count,))
    gravity = model.gravity.linear
    zmp = np.zeros((count, 2))
    for k in range(count):
        pin.computeCentroidalMomentumTimeVariation(model, data, qs[k], velocities[k], accelerations[k])
        force = data.dhg.linear - data.mass[0] * gravity
        zmp[k] = zmp_of_wrench(force, data.dhg.angular, data.com[0], float(heights[k]))
    return zmp
