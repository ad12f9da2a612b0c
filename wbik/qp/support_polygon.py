"""Support polygon: the convex hull of the contact points on the ground, as half-planes.

The contact points are those of every sole in support (``robot.soles``: a flat sole's corners, an
edge's two ends, or a point foot's single point, each in its sole frame), placed by FK and projected
on the ground: two flat soles give a hexagon or a rectangle, four point feet a quadrilateral.

The polygon is stored counter-clockwise; edge i from v_i to v_{i+1} has the outward unit normal
n_i = (dy, -dx) / |d| and offset d_i = n_i . v_i, so the inside is {x : N x <= d}. Shrinking by a
margin m (the Minkowski erosion of a convex polygon by a disc) keeps the normals and lowers every
offset by m: {x : N x <= d - m}. ``margin_of(x) = min_i (d_i - n_i . x)`` is the distance from an
inside point to the boundary (negative outside), which is what the balance checks read.

Robustness (the same verdict on every CPU): the hull is qhull's (:class:`scipy.spatial.ConvexHull`),
and every geometric decision uses one length tolerance scaled to the problem,
``tol = HULL_RELATIVE_TOLERANCE * scale``, where scale is the larger of the points' extent (the larger
side of their bounding box) and their largest coordinate (rounding noise grows with a coordinate's
magnitude: points a rounding apart far from the origin are one point, not a tiny triangle):

- a hull vertex closer than ``tol`` to the segment joining its neighbours is dropped (a corner that
  only rounding noise pushes out of a straight edge, e.g. the inner front corners of two side-by-side
  soles), and of two vertices closer than ``tol`` one is dropped (no near-zero-length edge with a
  garbage normal);
- points whose spread across their main direction is at most ``tol`` (all collinear, or fewer than
  three distinct points) are degenerate: a line or a point has no interior, so no CoM margin can be
  given. :class:`SupportPolygon` raises :class:`DegenerateSupportPolygonError` for them.

Dropping such a vertex moves the boundary by at most ``tol``, so margins are exact to ``tol`` (about
1e-10 m for a 0.14 m wide pair of soles) whatever the rounding of the corners.

Degenerate support (two point feet, feet on one line, one point foot): there is no polygon, so a
hard CoM-in-polygon constraint cannot be set up on it (``SupportPolygon`` raises, a problem that asks
for one is bad input). The checks that judge an answer (the whole-body check, a scenario's phase
check) never raise for it: :func:`support_region` gives a :class:`DegenerateSupport` (the segment or
point the points collapse to) whose ``margin_of(x)`` is minus the distance from x to that segment or
point (<= 0) and which contains no point, so the answer fails with "support polygon is degenerate"
and a margin that says how far the CoM is from the line of support. Static balance on a line or a
point is not robust to any perturbation: a CoM exactly on the segment (margin 0) still fails.
"""

from __future__ import annotations

from collections.abc import Iterable
from collections.abc import Mapping
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull
from scipy.spatial import QhullError

from wbik.errors import RobotDescriptionError
from wbik.qp.kinematics import Kinematics

HULL_RELATIVE_TOLERANCE = 1e-9
"""Hull tolerance relative to the scale of the point set (the larger of its extent and its largest
coordinate): vertices that rounding alone separates from an edge or from each other (1e-17 m on a
0.1 m sole) are merged; real corners are millimetres apart."""


class DegenerateSupportPolygonError(RobotDescriptionError):
    """Contact points that span no area (fewer than three distinct points, or all on one line)."""


def _degenerate(points: np.ndarray, why: str) -> DegenerateSupportPolygonError:
    shown = points[:8].tolist()
    more = f" (first 8 of {len(points)})" if len(points) > 8 else ""
    return DegenerateSupportPolygonError(
        f"a support polygon needs at least three points that are not on one line; {why}. Points{more}: "
        f"{shown}. Check the soles' contact points (robot.soles) and which soles are in support: three "
        "point feet not on one line, or one flat sole, make a polygon")


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def _prune(vertices: list[np.ndarray], tolerance: float) -> list[np.ndarray]:
    """Drop, one at a time and the least significant first, vertices within ``tolerance`` of the segment
    joining their neighbours or of the previous vertex (the polygon stays convex and counter-clockwise)."""
    while len(vertices) >= 3:
        count = len(vertices)
        worst, worst_index = np.inf, -1
        for i in range(count):
            before, here, after = vertices[i - 1], vertices[i], vertices[(i + 1) % count]
            chord = float(np.hypot(*(after - before)))
            gap = float(np.hypot(*(here - before)))
            # distance of `here` from the chord (before, after); a near-duplicate has gap <= tolerance
            height = abs(_cross(before, after, here)) / chord if chord > 0.0 else gap
            deviation = min(height, gap)
            if deviation < worst:
                worst, worst_index = deviation, i
        if worst > tolerance:
            break
        del vertices[worst_index]
    return vertices


def hull_tolerance(points: np.ndarray, relative_tolerance: float = HULL_RELATIVE_TOLERANCE) -> float:
    """The length tolerance of a point set (k, 2): ``relative_tolerance`` times the larger of its extent
    and its largest coordinate (m); 0 only for points that are all at the origin."""
    if points.size == 0:
        return 0.0
    scale = max(float(np.max(np.ptp(points, axis=0))), float(np.max(np.abs(points))))
    return relative_tolerance * scale


def convex_hull(points: np.ndarray, relative_tolerance: float = HULL_RELATIVE_TOLERANCE) -> np.ndarray:
    """Counter-clockwise hull vertices (k, 2), k >= 3, of 2D points, starting at the lowest (x, y).

    qhull's hull, then vertices within the tolerance (:func:`hull_tolerance`) of a straight edge or of
    each other are dropped (see the module docstring). Raises :class:`DegenerateSupportPolygonError`
    when the points span no area at that tolerance (fewer than three distinct points, coincident or
    collinear points) or are not finite.
    """
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
    spread = float(np.ptp(centred @ axes[-1]))  # width across the main direction
    if spread <= tolerance:
        raise _degenerate(points, f"they lie on one line (width {spread:.3g} <= tolerance {tolerance:.3g})")
    try:
        hull = ConvexHull(points)  # 2-D: vertices counter-clockwise
    except QhullError as exc:  # not expected above the width test; never let a raw qhull error out
        raise _degenerate(points, f"qhull could not build their hull ({str(exc).splitlines()[0]})") from exc
    vertices = _prune([points[i] for i in hull.vertices], tolerance)
    if len(vertices) < 3:
        raise _degenerate(points, "their hull is a segment at the tolerance")
    vertices = np.array(vertices)
    first = np.lexsort((vertices[:, 1], vertices[:, 0]))[0]
    return np.roll(vertices, -first, axis=0)


class SupportPolygon:
    """A convex polygon in the ground plane (x, y) with its half-plane form N x <= d.

    Raises :class:`DegenerateSupportPolygonError` (a ``RobotDescriptionError``, hence a ``ValueError``)
    for points that span no area; see :func:`convex_hull`.
    """

    def __init__(self, points: np.ndarray, labels: Sequence[str] | None = None):
        self.vertices = convex_hull(points)
        self.vertex_labels = _vertex_labels(np.asarray(points, dtype=float).reshape(-1, 2), self.vertices,
                                            labels)
        """Each vertex's name: the label of the contact point it is (``labels``, one per point, e.g.
        "left_sole_link[2]": a sole's corner), else "vertex i"."""
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
        return float((self.offsets - self.normals @ np.asarray(point, dtype=float)[:2]).min())

    def contains(self, point: np.ndarray, margin: float = 0.0) -> bool:
        return self.margin_of(point) >= margin

    def halfplanes(self, margin: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(N, d - margin): the polygon shrunk by ``margin`` as N x <= d - margin."""
        return self.normals, self.offsets - margin

    def nearest_inside(self, point: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """The point (x, y) of the polygon shrunk by ``margin`` nearest to ``point``: ``point`` itself when
        inside, else the answer of a 2-variable QP (NoQPSolutionError when the shrunk polygon is empty)."""
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


def _vertex_labels(points: np.ndarray, vertices: np.ndarray, labels: Sequence[str] | None) -> list[str]:
    """The label of the input point each hull vertex is (the nearest: a vertex is one of the points)."""
    if labels is None or len(labels) != len(points):
        return [f"vertex {index}" for index in range(len(vertices))]
    nearest = np.argmin(((vertices[:, None, :] - points[None, :, :]) ** 2).sum(axis=2), axis=1)
    return [str(labels[index]) for index in nearest]


def degenerate_hull(points: np.ndarray, relative_tolerance: float = HULL_RELATIVE_TOLERANCE) -> np.ndarray:
    """What finite 2D points that span no area collapse to: the two extreme points along their main
    direction (2, 2), or one point (1, 2) when they are within the tolerance of each other."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    centred = points - points.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    along = centred @ axes[0]
    ends = points[[int(np.argmin(along)), int(np.argmax(along))]]
    if float(np.ptp(along)) <= hull_tolerance(points, relative_tolerance):
        return points.mean(axis=0, keepdims=True)
    return ends


@dataclass(frozen=True)
class DegenerateSupport:
    """Support that spans no area: ``vertices`` (2, 2) a segment or (1, 2) a point, and ``why``.

    ``margin_of(x)`` = -(distance from x to the segment or point), <= 0; it contains no point
    (see the module docstring: balance on a line or a point is not robust)."""

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

    def contains(self, point: np.ndarray, margin: float = 0.0) -> bool:
        return False


def support_region(points: np.ndarray) -> SupportPolygon | DegenerateSupport:
    """The support polygon of finite 2D contact points, or the :class:`DegenerateSupport` they collapse to
    (for checks that report a margin instead of raising); non-finite points raise."""
    try:
        return SupportPolygon(points)
    except DegenerateSupportPolygonError as exc:
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        if points.size == 0 or not np.all(np.isfinite(points)):
            raise
        return DegenerateSupport(degenerate_hull(points), str(exc))


def sole_rectangle(length: float, width: float, centre=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The 4 corners (4, 3), counter-clockwise, of a ``length`` (x) by ``width`` (y) sole rectangle
    centred on ``centre`` in its sole frame (m): ``robot.soles`` entries for a flat foot."""
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


def contact_point_labels(corners: Mapping[str, np.ndarray], frames: Iterable[str]) -> list[str]:
    """"frame[i]" for each contact point of the soles ``frames`` (a point foot: "frame"), in
    :func:`contact_points`' order."""
    labels = []
    for frame in frames:
        count = len(np.asarray(corners[frame], dtype=float).reshape(-1, 3))
        labels += [frame] if count == 1 else [f"{frame}[{index}]" for index in range(count)]
    return labels


def feet_support_polygon(kinematics: Kinematics, corners: Mapping[str, np.ndarray],
                         frames: Iterable[str]) -> SupportPolygon:
    """Support polygon of the feet in contact: hull of their contact points projected on the ground.
    DegenerateSupportPolygonError names the soles when they span no area (e.g. two point feet)."""
    frames = list(frames)
    points = contact_points(kinematics, corners, frames)
    try:
        return SupportPolygon(points[:, :2], contact_point_labels(corners, frames))
    except DegenerateSupportPolygonError as exc:
        raise DegenerateSupportPolygonError(f"the support soles {frames} ({len(points)} contact points) "
                                            f"make no support polygon: {exc}") from None


def feet_support_region(kinematics: Kinematics, corners: Mapping[str, np.ndarray],
                        frames: Iterable[str]) -> SupportPolygon | DegenerateSupport:
    """:func:`feet_support_polygon`, or the :class:`DegenerateSupport` its points collapse to."""
    frames = list(frames)
    region = support_region(contact_points(kinematics, corners, frames)[:, :2])
    if isinstance(region, DegenerateSupport):
        return DegenerateSupport(region.vertices, f"support soles {frames}: {region.why}")
    return region
