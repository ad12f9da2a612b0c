"""Per-axis errors of IK answers, in the study's own angles and in a reference's Euler angles.

For a target (p*, R*) and the pose (p, R) reached by FK of a method's joints: ``err_x, err_y, err_z`` =
p - p* (m, base axes); ``err_rot_x, err_rot_y, err_rot_z`` = log3(R*^T R) (rad, target frame);
``err_alpha, err_beta, err_gamma``: differences of the angles of R = Rz(gamma) Ry(beta) Rx(alpha),
wrapped to (-pi, pi]; ``err_<name>``: the same for the Tait-Bryan angles of a study file's
``reference.angles`` (:class:`AngleConvention`, e.g. "zyx" for R = Rz(a_z) Ry(a_y) Rx(a_x),
:func:`wbik.geometry.tait_bryan_angles`). Near the middle angle's +-pi/2 (gimbal lock) Euler angles split
one rotation arbitrarily; the rotation vector does not.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from wbik.geometry import batch_exp3, tait_bryan_angles, wrap_to_pi
from wbik.solvers.result import IKResult

POSITION_AXES = ("x", "y", "z")
ROTATION_VECTOR_AXES = ("rot_x", "rot_y", "rot_z")
ANGLE_AXES = ("alpha", "beta", "gamma")
"""The study's own angles, about x, y and z: R = Rz(gamma) Ry(beta) Rx(alpha)."""
STUDY_SEQUENCE = "zyx"
"""The sequence of the study's own angles (see ANGLE_AXES)."""
_AXIS_INDEX = {"x": 0, "y": 1, "z": 2}

AXIS_DESCRIPTIONS = {**{axis: f"{axis} (m)" for axis in POSITION_AXES},
                     **{f"rot_{axis}": f"rotation vector {axis} (rad)" for axis in POSITION_AXES},
                     **{angle: f"{angle}, about {'xyz'[i]} (rad)" for i, angle in enumerate(ANGLE_AXES)}}


@dataclass(frozen=True)
class AngleConvention:
    """A reference's Euler angles, R = R_i(a_i) R_j(a_j) R_k(a_k) for ``sequence`` "ijk", and ``names``,
    (axis, column name) pairs in x, y, z order, of the angles whose errors become columns ``err_<name>``."""

    sequence: str
    names: tuple[tuple[str, str], ...]

    @property
    def columns(self) -> list[str]:
        """The column names (without ``err_``), in x, y, z order."""
        return [name for _, name in self.names]

    def describe(self) -> str:
        """The product the angles are read from, e.g. "R = Rz(roll) Ry(pitch) Rx(yaw)"."""
        named = dict(self.names)
        return "R = " + " ".join(f"R{axis}({named.get(axis, '.')})" for axis in self.sequence)

    def study_angle(self, axis: str) -> str | None:
        """The study's own angle equal to the reference's angle about ``axis`` (None: another sequence)."""
        return ANGLE_AXES[_AXIS_INDEX[axis]] if self.sequence == STUDY_SEQUENCE else None


def axes(target_kind: str, angles: AngleConvention | None = None) -> list[str]:
    """Error axes of a case, in column order (without the ``err_`` prefix)."""
    return (list(POSITION_AXES) if target_kind != "pose"
            else [*POSITION_AXES, *ROTATION_VECTOR_AXES, *ANGLE_AXES, *(angles.columns if angles else [])])


def axis_label(axis: str, angles: AngleConvention | None = None) -> str:
    """Human label of an error axis, e.g. "alpha, about x (rad)" or "yaw (= alpha, rad)"."""
    if axis in AXIS_DESCRIPTIONS:
        return AXIS_DESCRIPTIONS[axis]
    for about, name in angles.names if angles else ():
        if name == axis:
            same = angles.study_angle(about)
            return (f"{name} (= {same}, rad)" if same
                    else f"{name} (about {about} in {angles.describe()}, rad)")
    return axis


def axis_errors(results: Sequence[IKResult], target_rotations: np.ndarray | None,
                angles: AngleConvention | None = None) -> dict[str, np.ndarray]:
    """Per-axis error columns ``err_<axis>`` of a batch of answers (NaN where no joints came back);
    ``target_rotations`` (B, 3, 3), None for position targets; ``angles``: a reference's, as more columns."""
    count = len(results)
    position = np.array([r.position_error_xyz for r in results], dtype=float).reshape(count, 3)
    columns = {f"err_{axis}": position[:, index] for index, axis in enumerate(POSITION_AXES)}
    if target_rotations is None:
        return columns
    vector = np.array([r.rotation_error_xyz for r in results], dtype=float).reshape(count, 3)
    columns.update({f"err_{axis}": vector[:, index] for index, axis in enumerate(ROTATION_VECTOR_AXES)})
    reached = target_rotations @ batch_exp3(np.nan_to_num(vector))
    missing = ~np.all(np.isfinite(vector), axis=1)

    def differences(sequence: str) -> np.ndarray:
        difference = wrap_to_pi(tait_bryan_angles(reached, sequence) - tait_bryan_angles(target_rotations,
                                                                                         sequence))
        difference[missing] = np.nan
        return difference

    own = differences(STUDY_SEQUENCE)
    columns.update({f"err_{axis}": own[:, index] for index, axis in enumerate(ANGLE_AXES)})
    if angles:
        theirs = own if angles.sequence == STUDY_SEQUENCE else differences(angles.sequence)
        columns.update({f"err_{name}": theirs[:, _AXIS_INDEX[axis]] for axis, name in angles.names})
    return columns
