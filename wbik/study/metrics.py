"""Per-axis errors of IK answers, and the angle names of the Golem-III thesis.

For a target (p*, R*) and the pose (p, R) reached by FK of a method's joints:

- ``err_x, err_y, err_z`` = p - p* (m, base-frame axes);
- ``err_rot_x, err_rot_y, err_rot_z`` = log3(R*^T R) (rad, rotation vector in the target frame);
- ``err_alpha, err_beta, err_gamma``: differences of the angles of R = Rz(gamma) Ry(beta) Rx(alpha),
  wrapped to (-pi, pi], with gamma = atan2(r21, r11), beta = atan2(-r31, sqrt(r11^2 + r21^2)),
  alpha = atan2(r32, r33). Near beta = +-pi/2 (gimbal lock) these split one rotation between alpha
  and gamma arbitrarily; the rotation vector does not.

The Golem-III thesis names alpha (about the tool's x axis) "yaw", beta "pitch" and gamma (about z)
"roll", the reverse of the usual words; a case's ``angle_names`` adds columns under such names.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from wbik.geometry import batch_exp3
from wbik.geometry import wrap_to_pi as wrap_angle  # angles to (-pi, pi]
from wbik.solvers.base import IKResult

POSITION_AXES = ("x", "y", "z")
ROTATION_VECTOR_AXES = ("rot_x", "rot_y", "rot_z")
ANGLE_AXES = ("alpha", "beta", "gamma")
THESIS_ANGLE_NAMES = {"alpha": "thesis_yaw", "beta": "thesis_pitch", "gamma": "thesis_roll"}
"""Golem-III thesis naming of the Rz(gamma) Ry(beta) Rx(alpha) angles (see the module docstring)."""

AXIS_DESCRIPTIONS = {
    "x": "x (m)", "y": "y (m)", "z": "z (m)",
    "rot_x": "rotation vector x (rad)",
    "rot_y": "rotation vector y (rad)", "rot_z": "rotation vector z (rad)",
    "alpha": "alpha, about x (rad)", "beta": "beta, about y (rad)", "gamma": "gamma, about z (rad)",
}


def axes(target_kind: str, angle_names: dict | None = None) -> list[str]:
    """Error axes of a case, in column order (without the ``err_`` prefix)."""
    names = list(POSITION_AXES)
    if target_kind == "pose":
        names += list(ROTATION_VECTOR_AXES) + list(ANGLE_AXES)
        names += [angle_names[key] for key in ANGLE_AXES if angle_names and key in angle_names]
    return names


def axis_label(axis: str, angle_names: dict | None = None) -> str:
    """Human label of an error axis, e.g. "alpha, about x (rad); thesis 'yaw'"."""
    if axis in AXIS_DESCRIPTIONS:
        return AXIS_DESCRIPTIONS[axis]
    for key, name in (angle_names or {}).items():
        if name == axis:
            return f"{name} (= {key}, rad)"
    return axis


def euler_zyx(rotations: np.ndarray) -> np.ndarray:
    """(..., 3) angles (alpha, beta, gamma) with R = Rz(gamma) Ry(beta) Rx(alpha), for R (..., 3, 3)."""
    r11, r21, r31 = rotations[..., 0, 0], rotations[..., 1, 0], rotations[..., 2, 0]
    gamma = np.arctan2(r21, r11)
    beta = np.arctan2(-r31, np.hypot(r11, r21))
    alpha = np.arctan2(rotations[..., 2, 1], rotations[..., 2, 2])
    return np.stack((alpha, beta, gamma), axis=-1)


def axis_errors(results: Sequence[IKResult], target_rotations: np.ndarray | None,
                angle_names: dict | None = None) -> dict[str, np.ndarray]:
    """Per-axis error columns ``err_<axis>`` for a batch of answers (NaN where no joints came back).

    ``target_rotations`` (B, 3, 3) for pose targets, None for position-only ones.
    """
    count = len(results)
    columns: dict[str, np.ndarray] = {}
    position = np.array([r.position_error_xyz for r in results], dtype=float).reshape(count, 3)
    for index, axis in enumerate(POSITION_AXES):
        columns[f"err_{axis}"] = position[:, index]
    if target_rotations is None:
        return columns
    vector = np.array([r.rotation_error_xyz for r in results], dtype=float).reshape(count, 3)
    for index, axis in enumerate(ROTATION_VECTOR_AXES):
        columns[f"err_{axis}"] = vector[:, index]
    reached = target_rotations @ batch_exp3(np.nan_to_num(vector))
    difference = wrap_angle(euler_zyx(reached) - euler_zyx(target_rotations))
    difference[~np.all(np.isfinite(vector), axis=1)] = np.nan
    for index, axis in enumerate(ANGLE_AXES):
        columns[f"err_{axis}"] = difference[:, index]
    for index, axis in enumerate(ANGLE_AXES):
        if angle_names and axis in angle_names:
            columns[f"err_{angle_names[axis]}"] = difference[:, index]
    return columns
