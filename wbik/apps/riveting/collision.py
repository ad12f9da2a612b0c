"""Distances of the riveting cell: the UR5's meshes and the tool's primitives (coal) against the workpiece's
solid envelope and the table; the pin against the envelope with its nearest hole cut out. A geometry whose
bounding sphere is over ``exact_below`` away reports that bound, a nearer one its exact distance (lazily)."""

from __future__ import annotations

from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

from wbik.apps.riveting.scene import Hole, Scene
from wbik.robot import Robot

EXACT_BELOW = 0.05  # m, the bounding-sphere bound under which a distance is exact
SKIP_MARGIN = 1e-4  # m a bounding box must lie beyond a minimum to skip its geometry (coal's error ~1e-10 m)
TABLE_IGNORED = ("base_link_0", "shoulder_link_0")  # they stand on the table
TOOL_GEOMETRIES = ("ee_link_0", "rivet_tool_0", "rivet_tool_1")
PIN = "rivet_tool_1"
WHICH = {"all": lambda entry: entry.obstacle == "workpiece",
         "tool": lambda entry: entry.obstacle == "workpiece" and entry.name in TOOL_GEOMETRIES,
         "links": lambda entry: entry.obstacle == "workpiece" and entry.name not in TOOL_GEOMETRIES,
         "table": lambda entry: entry.obstacle == "table",
         "cell": lambda entry: True}  # the distances each ``which`` of Clearance.minimum takes

Obstacle = tuple[coal.ShapeBase, coal.Transform3s]


def _box(low, high, frame: pin.SE3) -> Obstacle:
    """A coal box spanning [low, high] in ``frame`` coordinates, placed in the world."""
    low, high = np.asarray(low, float), np.asarray(high, float)
    return coal.Box(*(high - low)), coal.Transform3s(frame.rotation, frame.act(0.5 * (low + high)))


def hole_model(scene: Scene, hole: Hole, sides: int = 12, tile_half: float = 0.008) -> list[Obstacle]:
    """The workpiece envelope with ``hole`` cut out, as world boxes: 4 around the tile |x|, |y| <=
    ``tile_half`` (hole frame), 1 under it past the depth, ``sides`` walls of the hole's inradius."""
    frame = hole.placement
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    local = (scene.workpiece_center + corners * scene.workpiece_half - frame.translation) @ frame.rotation
    low, high = local.min(axis=0), local.max(axis=0)  # the envelope in the hole frame
    h, depth, radius = tile_half, scene.hole_depth, 0.5 * scene.hole_diameter
    boxes = [_box([low[0], low[1], 0.0], [-h, high[1], high[2]], frame),
             _box([h, low[1], 0.0], [high[0], high[1], high[2]], frame),
             _box([-h, low[1], 0.0], [h, -h, high[2]], frame),
             _box([-h, h, 0.0], [h, high[1], high[2]], frame),
             _box([-h, -h, depth], [h, h, high[2]], frame)]
    outer = np.sqrt(2.0) * h + 1e-4  # reach the tile's corners
    half_width = outer * np.sin(np.pi / sides) + 1e-4  # cover the sector's chord at the outer radius
    for k in range(sides):
        wall_frame = frame * pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, 2.0 * np.pi * k / sides), np.zeros(3))
        boxes.append(_box([radius, -half_width, 0.0], [outer, half_width, depth], wall_frame))
    return boxes


def _bounds(shape) -> tuple[np.ndarray, float, coal.Box]:
    """(centre, radius of a bounding sphere, bounding box around the centre) in the geometry frame."""
    if isinstance(shape, coal.BVHModelBase):
        vertices = np.asarray(shape.vertices(), dtype=float).reshape(-1, 3)
        low, high = vertices.min(axis=0), vertices.max(axis=0)
        center = 0.5 * (low + high)
        return center, float(np.max(np.linalg.norm(vertices - center, axis=1))), coal.Box(*(high - low))
    if isinstance(shape, coal.Box):
        return np.zeros(3), float(np.linalg.norm(shape.halfSide)), shape
    if isinstance(shape, coal.Cylinder):
        box = coal.Box(2.0 * shape.radius, 2.0 * shape.radius, 2.0 * shape.halfLength)
        return np.zeros(3), float(np.hypot(shape.radius, shape.halfLength)), box
    raise TypeError(f"no bounding sphere for {type(shape).__name__}")


@dataclass
class GeometryDistance:
    """Distance of a robot geometry to an obstacle (``exact`` False: a lower bound), its nearest point
    (world) and the unit direction that increases the distance."""

    geometry: str
    distance: float
    exact: bool
    robot_point: np.ndarray | None = None
    direction: np.ndarray | None = None
    joint: int = 0


@dataclass
class _Entry:
    """A robot geometry against an obstacle: its sphere bound (m), its box bound and distance once known."""

    name: str
    index: int
    obstacle: str  # "workpiece" or "table"
    bound: float
    box: float | None = None
    distance: GeometryDistance | None = None


@dataclass
class Clearance:
    """Distances at one configuration per robot geometry to workpiece and table, computed when needed."""

    collision: CollisionModel
    placements: list[pin.SE3]
    entries: list[_Entry]

    def _distance(self, entry: _Entry) -> GeometryDistance:
        if entry.distance is None:
            entry.distance = (GeometryDistance(entry.name, entry.bound, False)
                              if entry.bound > self.collision.exact_below
                              else self.collision.exact(entry, self.placements[entry.index]))
        return entry.distance

    def _value(self, entry: _Entry, level: float) -> float:
        """The entry's distance, or a lower bound of it when that is over ``level`` (+ SKIP_MARGIN)."""
        if entry.bound > self.collision.exact_below or entry.bound > level + SKIP_MARGIN:
            return entry.bound
        if entry.box is None:
            entry.box = self.collision.box_bound(entry, self.placements[entry.index])
        return entry.box if entry.box > level + SKIP_MARGIN else self._distance(entry).distance

    def minimum(self, which: str = "all", start: float = np.inf, floor: float = np.inf) -> float:
        """min(start, smallest distance of ``which``: a key of WHICH), exact up to ``floor`` (above it,
        some value above ``floor``)."""
        best = start
        for entry in sorted((e for e in self.entries if WHICH[which](e)), key=lambda entry: entry.bound):
            best = min(best, self._value(entry, min(best, floor)))
        return float(best)

    def touching(self) -> list[str]:
        """The geometries at distance <= 0 from the workpiece."""
        return [e.name for e in self.entries if e.obstacle == "workpiece" and self._value(e, 0.0) <= 0.0]

    @property
    def workpiece(self) -> list[GeometryDistance]:
        return [self._distance(e) for e in self.entries if e.obstacle == "workpiece"]


class CollisionModel:
    """Robot + cell geometry and the distance queries used by planners and by the cycle's check."""

    def __init__(self, robot: Robot, scene: Scene, exact_below: float = EXACT_BELOW):
        self.robot, self.scene, self.exact_below = robot, scene, float(exact_below)
        self.model, self.data = robot.model, robot.model.createData()
        self.geometry = pin.buildGeomFromUrdfString(robot.model, robot.urdf_text, pin.GeometryType.COLLISION,
                                                    package_dirs=list(robot.package_dirs))
        self.geometry_data = pin.GeometryData(self.geometry)
        self.names = [obj.name for obj in self.geometry.geometryObjects]
        self.pin_index = self.names.index(PIN)
        self._bounds = [_bounds(obj.geometry) for obj in self.geometry.geometryObjects]
        self._radii = np.array([radius for _, radius, _ in self._bounds])
        cell = (("workpiece", scene.workpiece_size, scene.workpiece_center),
                ("table", scene.table_size, scene.table_box_center))
        self.obstacles = {kind: (coal.Box(*size), coal.Transform3s(np.eye(3), center), center, 0.5 * size)
                          for kind, size, center in cell}
        self._hole_models: dict[int, list[Obstacle]] = {}
        self._request, self._result = coal.DistanceRequest(), coal.DistanceResult()

    def joint_reach(self) -> np.ndarray:
        """R (nq,): per joint, a bound (m) on the distance from its axis of any point it moves, so a joint
        change dq moves no point by more than sum_j |dq_j| R_j."""
        model = self.model
        reach = np.zeros(model.nq)
        for obj, (center, radius, _) in zip(self.geometry.geometryObjects, self._bounds, strict=True):
            joint = obj.parentJoint
            distance = float(np.linalg.norm(obj.placement.act(center))) + radius
            while joint > 0:
                q_index = model.joints[joint].idx_q
                reach[q_index] = max(reach[q_index], distance)
                distance += float(np.linalg.norm(model.jointPlacements[joint].translation))
                joint = model.parents[joint]
        return reach

    def _distance(self, shape, placement: pin.SE3, obstacle: Obstacle) -> float:
        self._result.clear()
        return coal.distance(shape, coal.Transform3s(placement.rotation, placement.translation), *obstacle,
                             self._request, self._result)

    def box_bound(self, entry: _Entry, placement: pin.SE3) -> float:
        """Lower bound of an entry's distance: its bounding box against the obstacle ."""
        center, _, box = self._bounds[entry.index]
        return self._distance(box, placement * pin.SE3(np.eye(3), center), self.obstacles[entry.obstacle][:2])

    def exact(self, entry: _Entry, placement: pin.SE3) -> GeometryDistance:
        """Exact distance of an entry's geometry (the pin's to its nearest hole's model)."""
        obj = self.geometry.geometryObjects[entry.index]
        obstacles = [self.obstacles[entry.obstacle][:2]]
        if entry.obstacle == "workpiece" and entry.index == self.pin_index:
            hole = self.scene.nearest_hole(placement.act(np.array([0.0, 0.0, obj.geometry.halfLength])))
            if hole.index not in self._hole_models:
                self._hole_models[hole.index] = hole_model(self.scene, hole)
            obstacles = self._hole_models[hole.index]
        best = None
        for obstacle in obstacles:
            distance = self._distance(obj.geometry, placement, obstacle)
            if best is None or distance < best[0]:
                result = self._result
                best = (distance, result.getNearestPoint1().copy(), result.getNearestPoint2().copy(),
                        np.array(result.normal, dtype=float))
        distance, robot_point, obstacle_point, normal = best
        offset = robot_point - obstacle_point
        norm = np.linalg.norm(offset)
        direction = (offset / norm if distance > 1e-6 and norm > 1e-9
                     else -normal / max(np.linalg.norm(normal), 1e-12))
        return GeometryDistance(entry.name, float(distance), True, robot_point, direction, obj.parentJoint)

    def clearance(self, q: np.ndarray, table: bool = True, skip: tuple[str, ...] = ()) -> Clearance:
        """Distances at full configuration q; ``skip`` leaves geometries out (by name)."""
        pin.forwardKinematics(self.model, self.data, q)
        pin.updateGeometryPlacements(self.model, self.data, self.geometry, self.geometry_data)
        placements = [pin.SE3(placement) for placement in self.geometry_data.oMg]
        centers = np.array([placement.act(bounds[0]) for placement, bounds in zip(placements, self._bounds,
                                                                                  strict=True)])
        entries = []
        for kind in ("workpiece", "table") if table else ("workpiece",):
            *_, center, half = self.obstacles[kind]
            gap = np.maximum(np.abs(centers - center) - half, 0.0)
            bounds = np.sqrt(np.vecdot(gap, gap)) - self._radii  # vecdot: np.linalg.norm's dot, bit for bit
            left_out = (*skip, *TABLE_IGNORED) if kind == "table" else skip
            entries += [_Entry(name, i, kind, float(bounds[i])) for i, name in enumerate(self.names)
                        if name not in left_out]
        return Clearance(self, placements, entries)
