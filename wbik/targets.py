"""IK targets: a position p (3,) and, for a full pose, a rotation R (3, 3), in the chain's base frame
(SI), and their error e_p = p_reached - p_target, e_R = log3(R_target^T R_reached) (:mod:`wbik.geometry`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidRotationError, InvalidTargetError
from wbik.geometry import rotation_error
from wbik.kernels.twins import chosen, compiled_twin
from wbik.validation import numeric_array

ROTATION_TOLERANCE = 1e-6
"""How far R^T R may be from identity (max abs entry) and det(R) from 1 for R to count as a rotation."""
MAX_POSITION = 1e6
"""Largest target coordinate accepted (m)."""

TARGET_FORMS = ("a pinocchio.SE3, a 4x4 homogeneous matrix, a 3-vector position (m) or a "
                "wbik.Target")


@dataclass(frozen=True)
class Target:
    """A position (3,) and an optional rotation (3, 3). ``rotation is None`` means position only."""

    position: np.ndarray
    rotation: np.ndarray | None = None

    @property
    def is_pose(self) -> bool:
        return self.rotation is not None

    def se3(self) -> pin.SE3:
        """The target as an SE3 (identity rotation for a position only)."""
        return pin.SE3(np.eye(3) if self.rotation is None else self.rotation, self.position)


def check_rotation(rotation, tolerance: float = ROTATION_TOLERANCE) -> np.ndarray:
    """``rotation`` as a float array, or InvalidRotationError if it is not in SO(3)."""
    matrix = numeric_array(rotation, "rotation", InvalidTargetError, shape=(3, 3))
    with np.errstate(over="ignore", invalid="ignore"):  # huge entries: inf, still refused below
        orthogonality = float(np.max(np.abs(matrix.T @ matrix - np.eye(3))))
        determinant = float(np.linalg.det(matrix))
    if orthogonality > tolerance or abs(determinant - 1.0) > tolerance:
        raise InvalidRotationError(
            f"not a rotation matrix: max|R^T R - I| = {orthogonality:.3g}, det R = {determinant:.6g}; "
            "pass an orthonormal matrix with det +1 (e.g. pinocchio.rpy.rpyToMatrix(r, p, y))"
        )
    return matrix


def plain_pose_matrix(value) -> np.ndarray | None:
    """A private copy of a full-pose target as a 4 x 4 matrix, on :func:`as_target`'s fast path: an SE3
    or a float64 4 x 4 array with last row [0, 0, 0, 1] that passes the plain-float pose test; None for
    anything else (the general path then decides and says what is wrong)."""
    kind = type(value)
    if kind is pin.SE3:
        matrix = value.homogeneous  # a new array
    elif kind is np.ndarray and value.dtype == np.float64 and value.shape == (4, 4) \
            and value[3].tolist() == [0.0, 0.0, 0.0, 1.0]:
        matrix = value.copy()
    else:
        return None
    return matrix if _accepts_plain_se3(matrix, MAX_POSITION, ROTATION_TOLERANCE) else None


def pose_target(matrix: np.ndarray) -> Target:
    """The Target whose position and rotation are views of a :func:`plain_pose_matrix` matrix."""
    return checked_target(matrix[:3, 3], matrix[:3, :3])


_new_object = object.__new__


def checked_target(position: np.ndarray, rotation: np.ndarray | None) -> Target:
    """The Target of arrays the fast path has checked, built without the frozen dataclass's per-field
    ``object.__setattr__`` (half the cost of constructing it; the instance is the same)."""
    target = _new_object(Target)
    fields = target.__dict__
    fields["position"], fields["rotation"] = position, rotation
    return target


def _plain_array_target(value: np.ndarray) -> Target | None:
    """The fast path for a float64 array (a 3-vector within the bound, or a 4x4 pose), None otherwise."""
    if value.dtype != np.float64:
        return None
    if value.shape == (3,):
        bound = MAX_POSITION
        x, y, z = value.tolist()
        inside = -bound <= x <= bound and -bound <= y <= bound and -bound <= z <= bound  # (False for NaN)
        return checked_target(value.copy(), None) if inside else None
    matrix = plain_pose_matrix(value)
    return None if matrix is None else pose_target(matrix)


def _plain_given_target(value: Target) -> Target | None:
    """The fast path for a Target: a copy when its float64 arrays pass the plain-float test, else None."""
    position, rotation = value.position, value.rotation
    if type(position) is not np.ndarray:
        return None
    if rotation is None:
        return _plain_array_target(position)
    if type(rotation) is not np.ndarray or position.shape != (3,) or rotation.shape != (3, 3) \
            or position.dtype != np.float64 or rotation.dtype != np.float64:
        return None
    matrix = np.zeros((4, 4))
    matrix[:3, :3], matrix[:3, 3], matrix[3, 3] = rotation, position, 1.0
    return pose_target(matrix) if _accepts_plain_se3(matrix, MAX_POSITION, ROTATION_TOLERANCE) else None


def _python_accepts_plain_se3(matrix: np.ndarray, bound: float, tolerance: float) -> bool:
    """The fast-path test of a 4x4 pose in plain floats: position within ``bound``; unit, orthogonal
    columns and det +1 within ``tolerance`` (compiled twin: ``wbik.kernels._pose.plain_se3``)."""
    (a, b, c, x), (d, e, f, y), (g, h, i, z), _ = matrix.tolist()
    if not (-bound <= x <= bound and -bound <= y <= bound and -bound <= z <= bound):
        return False  # NaN fails every comparison
    low, high = 1.0 - tolerance, 1.0 + tolerance
    return (low <= a * a + d * d + g * g <= high and low <= b * b + e * e + h * h <= high
            and low <= c * c + f * f + i * i <= high and -tolerance <= a * b + d * e + g * h <= tolerance
            and -tolerance <= a * c + d * f + g * i <= tolerance
            and -tolerance <= b * c + e * f + h * i <= tolerance
            and low <= a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) <= high)


_compiled_accepts_plain_se3 = compiled_twin("pose", "plain_se3")
_accepts_plain_se3 = chosen(_python_accepts_plain_se3, _compiled_accepts_plain_se3, "pose")


def as_target(value, rotation=None) -> Target:
    """A user target as a Target: a Target, an SE3 or a 4x4 homogeneous matrix (full pose), or a
    3-vector (a position; ``rotation`` optionally adds an orientation)."""
    if rotation is None:
        kind = type(value)
        if kind is pin.SE3:  # the most common path, inline
            matrix = plain_pose_matrix(value)
            if matrix is not None:
                return checked_target(matrix[:3, 3], matrix[:3, :3])
        plain = _plain_array_target(value) if kind is np.ndarray else \
            _plain_given_target(value) if kind is Target else None
        if plain is not None:
            return plain
    if isinstance(value, Target | pin.SE3):
        position, given = value.position if isinstance(value, Target) else value.translation, value.rotation
    else:
        array = numeric_array(value, f"a target ({TARGET_FORMS})", InvalidTargetError)
        if array.shape not in ((3,), (4, 4)):
            raise InvalidTargetError(f"a target must be {TARGET_FORMS}; got an array of shape {array.shape}")
        if array.shape == (4, 4) and not np.allclose(array[3], [0.0, 0.0, 0.0, 1.0]):
            raise InvalidTargetError(f"last row of a 4x4 pose must be [0, 0, 0, 1], got {array[3]}")
        position, given = (array[:3, 3], array[:3, :3]) if array.shape == (4, 4) else (array, None)
    if rotation is not None and (given is not None or isinstance(value, Target)):
        raise InvalidTargetError("the rotation is given twice, inside the target (a Target, an SE3 or a 4x4 "
                                 "matrix) and as rotation=; give it once")
    given = given if rotation is None else rotation
    return Target(numeric_array(position, "position", InvalidTargetError, shape=(3,), max_abs=MAX_POSITION),
                  None if given is None else check_rotation(given))


def pose_error(reached: pin.SE3, target: Target) -> tuple[np.ndarray, np.ndarray | None]:
    """(e_p, e_R) of ``geometry.pose_error``, e_R None for a position-only target."""
    position_error = reached.translation - target.position
    if target.rotation is None:
        return position_error, None
    return position_error, rotation_error(reached.rotation, target.rotation)
