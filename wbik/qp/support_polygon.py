"""Support polygon: the convex hull of the soles' contact points on the ground, as half-planes.

Counter-clockwise, edge i (v_i to v_{i+1}) has the outward unit normal n_i and d_i = n_i . v_i: the inside
shrunk by a margin m is N x <= d - m, and ``margin_of(x) = min_i (d_i - n_i . x)`` (negative outside).
The hull is qhull's, pruned at :func:`hull_tolerance`; points spanning no area at it raise
:class:`DegenerateSupportPolygonError`, or give a :class:`DegenerateSupport` for the checks.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from wbik.errors import RobotDescriptionError
from wbik.qp.kinematics import Kinematics

HULL_RELATIVE_TOLERANCE = 1e-9
"""Hull tolerance relative to the points' scale: what rounding alone separates is merged."""


class DegenerateSupportPolygonError(RobotDescriptionError):
    """Contact points that span no area (fewer than three distinct points, or all on one line)."""


def _degenerate(points: np.ndarray, why: str) -> DegenerateSupportPolygonError:
    shown = points[:8].tolist()
    more = f" (first 8 of {len(points)})" if len(points) > 8 else ""
    return DegenerateSupportPolygonError(
        f"a support polygon needs at least three points that are not on one line; {why}. Points{more}: "
        f"{shown}. Check the soles' contact points (robot.soles) and which soles are in support: three "
        "point feet not on one line, or one flat sole, make a polygon")


def _deviation(before: tuple[float, float], here: tuple[float, float], after: tuple[float, float]) -> float:
    """Distance of ``here`` from the chord (before, after), or from ``before`` when that is less."""
    chord_x, chord_y, gap_x, gap_y = after[0] - before[0], after[1] - before[1], here[0] - before[0], \
        here[1] - before[1]
    chord, gap = math.hypot(chord_x, chord_y), math.hypot(gap_x, gap_y)
    return min(abs(chord_x * gap_y - chord_y * gap_x) / chord if chord > 0.0 else gap, gap)


def _prune(vertices: list[tuple[float, float]], tolerance: float) -> list[tuple[float, float]]:
    """Drop vertices within ``tolerance`` of their neighbours' segment or of the previous one, least first
    (the vertices as (x, y) floats: a few scalar operations each, cheaper in Python than in NumPy)."""
    while len(vertices) >= 3:
        count = len(vertices)
        deviations = [_deviation(vertices[i - 1], here, vertices[(i + 1) % count])
                      for i, here in enumerate(vertices)]
        worst = min(range(count), key=deviations.__getitem__)
        if deviations[worst] > tolerance:
            break
        del vertices[worst]
    return vertices


def hull_tolerance(points: np.ndarray, relative_tolerance: float = HULL_RELATIVE_TOLERANCE) -> float:
    """``relative_tolerance`` times the larger of the points' (k, 2) extent and largest coordinate (m)."""
    if points.size == 0:
        return 0.0
    return relative_tolerance * max(float(np.max(np.ptp(points, axis=0))), float(np.max(np.abs(points))))


def convex_hull(points: np.ndarray, relative_tolerance: float = HULL_RELATIVE_TOLERANCE) -> np.ndarray:
    """Counter-clockwise hull vertices (k, 2), k >= 3, of 2D points, starting at the lowest (x, y) (see
    the module docstring); DegenerateSupportPolygonError for points that span no area or are not finite."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if not np.all(np.isfinite(points)):
        raise _degenerate(points, "some coordinates are NaN or inf")
    if len(points) < 3:
        raise _degenerate(points, f"got {len(points)} point(s)")
    tolerance = hull_tolerance(points, relative_tolerance)
    if float(np.max(np.ptp(points, axis=0))) <= tolerance:
        raise _degenerate(points, f"they coincide (within the tolerance {tolerance:.3g} m)")
    centred = points - points.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    if (spread := float(np.ptp(centred @ axes[-1]))) <= tolerance:  # the width across the main direction
        raise _degenerate(points, f"they lie on one line (width {spread:.3g} <= tolerance {tolerance:.3g})")
    from scipy.spatial import ConvexHull, QhullError  # kept out of import wbik

    try:
        hull = ConvexHull(points)  # 2-D: vertices counter-clockwise
    except QhullError as exc:  # not expected above the width test; never let a raw qhull error out
        raise _degenerate(points, f"qhull could not build their hull ({str(exc).splitlines()[0]})") from exc
    vertices = _prune([tuple(point) for point in points[hull.vertices].tolist()], tolerance)
    if len(vertices) < 3:
        raise _degenerate(points, "their hull is a segment at the tolerance")
    first = min(range(len(vertices)), key=vertices.__getitem__)  # the lowest (x, y)
    return np.array(vertices[first:] + vertices[:first])


class SupportPolygon:
    """A convex polygon in the ground plane (x, y) with its half-plane form N x <= d."""

    def __init__(self, points: np.ndarray, labels: Sequence[str] | None = None):
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        self.vertices = convex_hull(points)
        if labels is not None and len(labels) == len(points):
            nearest = np.argmin(((self.vertices[:, None, :] - points[None, :, :]) ** 2).sum(axis=2), axis=1)
            self.vertex_labels = [str(labels[i]) for i in nearest.tolist()]
        else:
            self.vertex_labels = [f"vertex {k}" for k in range(len(self.vertices))]
        """Each vertex's name: its contact point's label (``labels``, one per point), else "vertex i"."""
        vertices = self.vertices
        edges = np.concatenate((vertices[1:], vertices[:1])) - vertices
        self.normals = np.column_stack((edges[:, 1], -edges[:, 0])) / np.linalg.norm(edges, axis=1)[:, None]
        self.offsets = np.einsum("ij,ij->i", self.normals, self.vertices)

    def __repr__(self) -> str:
        centroid = self.vertices.mean(axis=0).round(4).tolist()
        return f"SupportPolygon({len(self.vertices)} vertices, centroid {centroid})"

    def margin_of(self, point: np.ndarray) -> float:
        """Distance from ``point`` (x, y) to the boundary, positive inside, negative outside."""
        return float((self.offsets - self.normals @ np.asarray(point, dtype=float)[:2]).min())

    def halfplanes(self, margin: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(N, d - margin): the polygon shrunk by ``margin`` as N x <= d - margin."""
        return self.normals, self.offsets - margin

    def nearest_inside(self, point: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """The point of the polygon shrunk by ``margin`` nearest to ``point`` (x, y); NoQPSolutionError."""
        import wbik.qp.backends as backends

        normals, offsets = self.halfplanes(margin)
        point = np.asarray(point, dtype=float)[:2]
        if np.all(normals @ point <= offsets):
            return point.copy()
        found = backends.solve(backends.DEFAULT, np.eye(2), -point, normals, offsets, None, None, None, None)
        return np.asarray(found, dtype=float)

    def edge_name(self, index: int) -> str:
        """Edge ``index`` (from vertex i to vertex i + 1) by its two vertices' labels, "a-b"."""
        count = len(self.vertices)
        return f"{self.vertex_labels[index % count]}-{self.vertex_labels[(index + 1) % count]}"


@dataclass(frozen=True)
class DegenerateSupport:
    """Support spanning no area: ``vertices`` a segment (2, 2) or a point (1, 2), and ``why``."""

    vertices: np.ndarray
    why: str

    def margin_of(self, point: np.ndarray) -> float:
        """Minus the distance (m) from ``point`` (x, y) to the segment or point."""
        point = np.asarray(point, dtype=float)[:2]
        start = self.vertices[0]
        direction = self.vertices[-1] - start
        length_squared = float(direction @ direction)
        along = 0.0 if length_squared == 0.0 else min(max(float((point - start) @ direction) / length_squared,
                                                          0.0), 1.0)
        return 0.0 - float(np.hypot(*(point - start - along * direction)))  # (0.0, not -0.0, on it)


def support_region(points: np.ndarray) -> SupportPolygon | DegenerateSupport:
    """The support polygon of finite 2D points, else the :class:`DegenerateSupport` of their extremes."""
    try:
        return SupportPolygon(points)
    except DegenerateSupportPolygonError as exc:
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        if points.size == 0 or not np.all(np.isfinite(points)):
            raise
        centred = points - points.mean(axis=0)
        along = centred @ np.linalg.svd(centred, full_matrices=False)[2][0]
        ends = (points.mean(axis=0, keepdims=True) if float(np.ptp(along)) <= hull_tolerance(points)
                else points[[int(np.argmin(along)), int(np.argmax(along))]])
        return DegenerateSupport(ends, str(exc))


def sole_rectangle(length: float, width: float, centre=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The 4 corners (4, 3), counter-clockwise, of a ``length`` by ``width`` sole centred on ``centre``
    (m, in the sole frame): ``robot.soles`` entries for a flat foot."""
    half = np.array([[1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [-1.0, -1.0, 0.0], [1.0, -1.0, 0.0]])
    return half * [0.5 * float(length), 0.5 * float(width), 0.0] + np.asarray(centre, dtype=float).reshape(3)


def contact_points(kinematics: Kinematics, corners: Mapping[str, np.ndarray],
                   frames: Iterable[str]) -> np.ndarray:
    """World positions (k, 3) of the contact points (``robot.soles``) of the soles in contact."""
    points = []
    for frame in frames:
        if frame not in corners:
            raise RobotDescriptionError(
                f"no sole contact points for frame {frame!r}; the robot lists soles {sorted(corners)}")
        placement = kinematics.placement(kinematics.frame_id(frame))
        local = np.asarray(corners[frame], dtype=float).reshape(-1, 3)
        points.append(local @ placement.rotation.T + placement.translation)
    return np.vstack(points)


def feet_support_polygon(kinematics: Kinematics, corners: Mapping[str, np.ndarray],
                         frames: Iterable[str]) -> SupportPolygon:
    """Support polygon of the soles in contact (their contact points on the ground)."""
    frames = list(frames)
    points = contact_points(kinematics, corners, frames)
    counts = {frame: len(np.asarray(corners[frame], dtype=float).reshape(-1, 3)) for frame in frames}
    labels = [frame if counts[frame] == 1 else f"{frame}[{index}]" for frame in frames
              for index in range(counts[frame])]  # "frame[i]" per contact point, "frame" for a point foot
    try:
        return SupportPolygon(points[:, :2], labels)
    except DegenerateSupportPolygonError as exc:
        raise DegenerateSupportPolygonError(f"the support soles {frames} ({len(points)} contact points) "
                                            f"make no support polygon: {exc}") from None


def feet_support_region(kinematics: Kinematics, corners: Mapping[str, np.ndarray],
                        frames: Iterable[str]) -> SupportPolygon | DegenerateSupport:
    """:func:`feet_support_polygon`, or the :class:`DegenerateSupport` its points collapse to."""
    frames = list(frames)
    region = support_region(contact_points(kinematics, corners, frames)[:, :2])
    return (DegenerateSupport(region.vertices, f"support soles {frames}: {region.why}")
            if isinstance(region, DegenerateSupport) else region)
