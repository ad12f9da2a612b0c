"""A chain's kinematic structure as lines: T(q) = exp([xi_1] q_1) ... exp([xi_n] q_n) M, joint k turning
about (or sliding along) the line of unit direction ``axes[k]`` through ``origins[k]`` (base frame, q = 0),
M (``tip``) the tip's pose at q = 0, read from the chain's reduced model."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from wbik.robot import ChainCache
from wbik.solvers.task_error import joint_lines_at_zero, serial_structure

# axes are parallel (perpendicular) when the sine (cosine) of their angle is at most this, lines meet (a
# length is zero) within this x the chain's length: URDFs write angles to ~12 digits
STRUCTURE_TOLERANCE = 1e-9


@dataclass(frozen=True)
class ChainLines:
    """The joint lines of a chain at q = 0 in its base frame: unit ``axes`` (n, 3), a point of each line
    ``origins`` (n, 3), the ``tip`` pose (4, 4), ``prismatic`` (n,)."""

    axes: np.ndarray
    origins: np.ndarray
    tip: np.ndarray
    prismatic: np.ndarray

    @property
    def count(self) -> int:
        return len(self.axes)

    @cached_property
    def rotation_terms(self) -> tuple[np.ndarray, np.ndarray]:
        """Per joint, K = [axis]x and K @ K (n, 3, 3), as :func:`axis_rotation` builds them."""
        skews = [skew(axis) for axis in self.axes]
        return (np.array(skews).reshape(-1, 3, 3),
                np.array([matrix @ matrix for matrix in skews]).reshape(-1, 3, 3))

    @cached_property
    def length(self) -> float:
        """The chain's size (m): base origin -> each joint origin -> tip, at least 1e-3 m."""
        points = np.vstack((np.zeros(3), self.origins, self.tip[:3, 3]))
        return max(float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum()), 1e-3)

    def parallel(self, i: int, j: int) -> bool:
        """Axes i and j are parallel: sin(angle) <= STRUCTURE_TOLERANCE."""
        return float(np.linalg.norm(np.cross(self.axes[i], self.axes[j]))) <= STRUCTURE_TOLERANCE

    def meeting_point(self, i: int, j: int) -> np.ndarray | None:
        """Where lines i and j meet (their closest points' midpoint), None if parallel or apart."""
        if self.parallel(i, j):
            return None
        a, b, offset = self.axes[i], self.axes[j], self.origins[j] - self.origins[i]
        ab = float(a @ b)
        denominator = 1.0 - ab * ab
        s = (offset @ a - ab * (offset @ b)) / denominator
        t = (ab * (offset @ a) - offset @ b) / denominator
        on_i, on_j = self.origins[i] + s * a, self.origins[j] + t * b
        if np.linalg.norm(on_i - on_j) > STRUCTURE_TOLERANCE * self.length:
            return None
        return 0.5 * (on_i + on_j)

    def distance_to_line(self, point: np.ndarray, k: int) -> float:
        offset = point - self.origins[k]
        return float(np.linalg.norm(offset - (offset @ self.axes[k]) * self.axes[k]))


_LINES = ChainCache()


def chain_lines(chain) -> ChainLines:
    """The chain's lines (its own ``lines``, else read from its reduced model once per chain)."""
    own = getattr(chain, "lines", None)
    if isinstance(own, ChainLines):
        return own
    if (cached := _LINES.get(chain)) is not None:
        return cached
    structure = serial_structure(chain)
    axes, origins, tip = joint_lines_at_zero(structure)
    return _LINES.store(chain, ChainLines(axes, origins, tip, structure.prismatic.copy()))


def motion(lines: ChainLines, index: int, value: float) -> np.ndarray:
    """exp([xi_index] value) (4, 4): a turn by a about the line (h, c) is (Rot(h, a), c - Rot(h, a) c)."""
    transform = np.eye(4)
    axis = lines.axes[index]
    if lines.prismatic[index]:
        transform[:3, 3] = value * axis
        return transform
    rotation = axis_rotation(axis, value)
    transform[:3, :3] = rotation
    transform[:3, 3] = lines.origins[index] - rotation @ lines.origins[index]
    return transform


def axis_rotation(axis: np.ndarray, angle) -> np.ndarray:
    """Rot(axis, angle) = I + sin(a) K + (1 - cos(a)) K^2, K = [axis]x; angles (...) -> (..., 3, 3)."""
    cross_matrix = skew(axis)
    angle = np.asarray(angle, dtype=float)[..., None, None]
    return np.eye(3) + np.sin(angle) * cross_matrix + (1.0 - np.cos(angle)) * (cross_matrix @ cross_matrix)


def skew(axis: np.ndarray) -> np.ndarray:
    """[axis]x, the cross-product matrix."""
    x, y, z = axis
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def locked_lines(lines: ChainLines, index: int, value: float) -> ChainLines:
    """The lines with joint ``index`` held at ``value``: exp([xi_k] v) moves every line after it and the tip,
    ... exp([xi_k] v) exp([xi_k+1] q_k+1) ... M = ... exp([Ad xi_k+1] q_k+1) ... exp([xi_k] v) M."""
    moved = motion(lines, index, value)
    rotation, translation = moved[:3, :3], moved[:3, 3]
    keep = np.arange(lines.count) != index
    after = np.arange(lines.count) > index
    axes = np.where(after[:, None], lines.axes @ rotation.T, lines.axes)[keep]
    origins = np.where(after[:, None], lines.origins @ rotation.T + translation, lines.origins)[keep]
    return ChainLines(axes, origins, moved @ lines.tip, lines.prismatic[keep])


def poe_fk(lines: ChainLines, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tip positions (..., 3) and rotations (..., 3, 3) of joints q (..., n): T_1(q_1) ... T_n(q_n) M."""
    q = np.asarray(q, dtype=float)
    shape = q.shape[:-1]
    skews, squares = lines.rotation_terms
    joints_first = (slice(None),) + (None,) * len(shape)
    angles = np.moveaxis(q, -1, 0)[..., None, None]
    turns = np.eye(3) + np.sin(angles) * skews[joints_first] + (1.0 - np.cos(angles)) * squares[joints_first]
    rotation = np.broadcast_to(np.eye(3), shape + (3, 3))
    position = np.zeros(shape + (3,))
    for k in range(lines.count):
        axis = lines.axes[k]
        if lines.prismatic[k]:
            position = position + np.einsum("...ij,j->...i", rotation, axis) * q[..., k, None]
            continue
        turn = turns[k]  # axis_rotation(axis, q[..., k]), every joint's at once
        offset = lines.origins[k] - np.einsum("...ij,j->...i", turn, lines.origins[k])
        position = position + np.einsum("...ij,...j->...i", rotation, offset)
        rotation = rotation @ turn
    position = position + np.einsum("...ij,j->...i", rotation, lines.tip[:3, 3])
    return position, rotation @ lines.tip[:3, :3]


def eaik_vectors(lines: ChainLines) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """EAIK's axes H (n, 3), offsets P (n + 1, 3) between consecutive origins and tip rotation R0 at q = 0."""
    points = np.vstack((np.zeros(3), lines.origins, lines.tip[:3, 3]))
    return lines.axes.copy(), np.diff(points, axis=0), lines.tip[:3, :3].copy()


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """The angle (rad, in [0, pi]) between two vectors, accurate also near 0 and pi."""
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(np.dot(a, b)))
