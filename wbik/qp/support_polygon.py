"""Support polygon: the convex hull of the contact points on the ground, as half-planes.

The polygon is stored counter-clockwise; edge i from v_i to v_{i+1} has the outward unit normal
n_i = (dy, -dx) / |d| and offset d_i = n_i . v_i, so the inside is {x : N x <= d}. Shrinking by a
margin m (the Minkowski erosion of a convex polygon by a disc) keeps the normals and lowers every
offset by m: {x : N x <= d - m}. ``margin_of(x) = min_i (d_i - n_i . x)`` is the distance from an
inside point to the boundary (negative outside), which is what the balance checks read.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

from wbik.errors import RobotDescriptionError
from wbik.qp.kinematics import Kinematics


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise hull vertices of 2D points (Andrew's monotone chain, collinear points dropped)."""
    unique = np.unique(np.asarray(points, dtype=float).reshape(-1, 2), axis=0)
    if len(unique) < 3:
        return unique

    def cross(o, a, b) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[np.ndarray] = []
    for point in unique:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], point) <= 1e-15:
            lower.pop()
        lower.append(point)
    upper: list[np.ndarray] = []
    for point in unique[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], point) <= 1e-15:
            upper.pop()
        upper.append(point)
    return np.array(lower[:-1] + upper[:-1])


class SupportPolygon:
    """A convex polygon in the ground plane (x, y) with its half-plane form N x <= d."""

    def __init__(self, points: np.ndarray):
        self.vertices = convex_hull(points)
        if len(self.vertices) < 3:
            raise ValueError("a support polygon needs at least three non-collinear points")
        edges = np.roll(self.vertices, -1, axis=0) - self.vertices
        lengths = np.linalg.norm(edges, axis=1)
        self.normals = np.column_stack((edges[:, 1], -edges[:, 0])) / lengths[:, None]
        self.offsets = np.einsum("ij,ij->i", self.normals, self.vertices)

    def __repr__(self) -> str:
        return f"SupportPolygon({len(self.vertices)} vertices, centroid {self.centroid.round(4).tolist()})"

    @property
    def centroid(self) -> np.ndarray:
        return self.vertices.mean(axis=0)

    def margin_of(self, point: np.ndarray) -> float:
        """Distance from ``point`` (x, y) to the boundary, positive inside, negative outside."""
        return float(np.min(self.offsets - self.normals @ np.asarray(point, dtype=float)[:2]))

    def contains(self, point: np.ndarray, margin: float = 0.0) -> bool:
        return self.margin_of(point) >= margin

    def halfplanes(self, margin: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(N, d - margin): the polygon shrunk by ``margin`` as N x <= d - margin."""
        return self.normals, self.offsets - margin


def contact_points(kinematics: Kinematics, corners: Mapping[str, np.ndarray],
                   frames: Iterable[str]) -> np.ndarray:
    """World positions (k, 3) of the sole corners of the frames in contact."""
    points = []
    for frame in frames:
        if frame not in corners:
            raise RobotDescriptionError(
                f"no sole corners for frame {frame!r}; the robot lists corners for {sorted(corners)}")
        placement = kinematics.placement(kinematics.frame_id(frame))
        local = np.asarray(corners[frame], dtype=float).reshape(-1, 3)
        points.append(local @ placement.rotation.T + placement.translation)
    return np.vstack(points)


def feet_support_polygon(kinematics: Kinematics, corners: Mapping[str, np.ndarray],
                         frames: Iterable[str]) -> SupportPolygon:
    """Support polygon of the feet in contact: hull of their corners projected on the ground."""
    return SupportPolygon(contact_points(kinematics, corners, frames)[:, :2])
