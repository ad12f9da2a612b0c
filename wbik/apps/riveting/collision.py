"""Collision model of the cell (Pinocchio GeometryModel + coal) and the distance queries.

Robot: the UR5's collision meshes from example-robot-data (coal BVH models) and the tool's
primitives (urdf/ur5_rivet_tool.urdf.xml: the 40 mm holder, the 5 mm pin
whose tip is the tcp).
Cell: the workpiece and the table are GeometryObjects fixed to the universe joint of the same
GeometryModel (so a viewer or ``pin.computeDistances`` sees them too).

How the holes are modelled (coal has no boolean subtraction):

- links, holder and flange box are measured against the solid ENVELOPE of the workpiece (holes
  filled in). The envelope contains the workpiece, so these distances can only under-report the
  clearance (conservative); they are exact wherever the closest point is not over a hole opening,
  and nothing wider than 6 mm can enter a hole.
- the 5 mm pin is measured against the envelope with the hole NEAREST to the tcp cut out, built
  from 17 boxes in the hole frame (z into the hole, surface at z = 0, tile half-width h = 8 mm):
  4 boxes for the envelope beside the tile column |x|, |y| <= h, z in [0, depth]; 1 box for the
  hole's bottom (the envelope under the tile beyond ``depth``); 12 boxes around the axis whose
  inner faces are tangent to the 3 mm circle, so the hole's wall is a regular 12-gon with inradius
  3 mm (circumradius 3.106 mm). A centred 2.5 mm pin therefore has 0.5 mm of radial clearance, as
  in a round 6 mm hole; off-centre toward a 12-gon corner it may read up to 0.1 mm more than a
  round hole would. The other 32 holes are filled in (conservative).

Distances use a cheap bound first: a bounding sphere per robot geometry gives a lower bound
d >= |c - envelope| - r; only when that bound is under ``exact_below`` (default 50 mm) is the
exact coal distance computed. So every minimum under 50 mm is exact, and larger values are lower
bounds (flagged).
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import field

import coal
import numpy as np
import pinocchio as pin

from wbik.apps.riveting.scene import Hole
from wbik.apps.riveting.scene import Scene
from wbik.robot import Robot

TILE_HALF = 0.008
"""Half-width (m) of the square tile around a hole that the 12 wall boxes replace."""
WALL_SIDES = 12
EXACT_BELOW = 0.05
"""Bounding-sphere bound (m) under which a distance is computed exactly."""
TABLE_IGNORED = ("base_link_0", "shoulder_link_0")
"""Robot geometries that stand on the table (not checked against it)."""
TOOL_GEOMETRIES = ("ee_link_0", "rivet_tool_0", "rivet_tool_1")


def _box_from_bounds(low: np.ndarray, high: np.ndarray, frame: pin.SE3) -> tuple[coal.Box, coal.Transform3s]:
    """A coal box spanning [low, high] in ``frame`` coordinates, placed in the world."""
    size = np.asarray(high, float) - np.asarray(low, float)
    center = frame.act(0.5 * (np.asarray(low, float) + np.asarray(high, float)))
    return coal.Box(*size), coal.Transform3s(frame.rotation, center)


def hole_model(scene: Scene, hole: Hole, sides: int = WALL_SIDES,
               tile_half: float = TILE_HALF) -> list[tuple[coal.Box, coal.Transform3s]]:
    """The workpiece envelope with ``hole`` cut out, as boxes in the world (see the module notes)."""
    frame = hole.placement
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    world = scene.workpiece_center + corners * scene.workpiece_half
    local = (world - frame.translation) @ frame.rotation  # envelope corners in the hole frame
    low, high = local.min(axis=0), local.max(axis=0)
    low[2] = 0.0  # the surface
    h, depth, radius = tile_half, scene.hole_depth, 0.5 * scene.hole_diameter
    boxes = [
        _box_from_bounds([low[0], low[1], 0.0], [-h, high[1], high[2]], frame),
        _box_from_bounds([h, low[1], 0.0], [high[0], high[1], high[2]], frame),
        _box_from_bounds([-h, low[1], 0.0], [h, -h, high[2]], frame),
        _box_from_bounds([-h, h, 0.0], [h, high[1], high[2]], frame),
        _box_from_bounds([-h, -h, depth], [h, h, high[2]], frame),
    ]
    half_angle = np.pi / sides
    outer = np.sqrt(2.0) * h + 1e-4  # reach the tile's corners
    half_width = outer * np.sin(half_angle) + 1e-4  # cover the sector's chord at the outer radius
    for k in range(sides):
        angle = 2.0 * np.pi * k / sides
        rotation = pin.rpy.rpyToMatrix(0.0, 0.0, angle)
        wall_frame = frame * pin.SE3(rotation, np.zeros(3))
        boxes.append(_box_from_bounds([radius, -half_width, 0.0], [outer, half_width, depth], wall_frame))
    return boxes


@dataclass
class GeometryDistance:
    """Distance of one robot geometry to an obstacle at one configuration.

    ``exact`` False: ``distance`` is a lower bound (the bounding sphere's), with no points.
    ``robot_point`` / ``direction``: nearest point on the robot (world) and the unit direction in
    which moving that point increases the distance.
    """

    geometry: str
    distance: float
    exact: bool
    robot_point: np.ndarray | None = None
    direction: np.ndarray | None = None
    joint: int = 0


@dataclass
class Clearance:
    """Distances at one configuration: to the workpiece per robot geometry, and to the table."""

    workpiece: list[GeometryDistance]
    table: list[GeometryDistance] = field(default_factory=list)

    def minimum(self, which: str = "all") -> float:
        """Smallest workpiece distance over ``which``: all, tool (flange box, holder, pin) or links."""
        values = [d.distance for d in self.workpiece
                  if which == "all" or (which == "tool") == (d.geometry in TOOL_GEOMETRIES)]
        return float(min(values)) if values else float("inf")

    def table_minimum(self) -> float:
        return float(min((d.distance for d in self.table), default=float("inf")))


class CollisionModel:
    """Robot + cell geometry and the distance queries used by planners and by the cycle's check."""

    def __init__(self, robot: Robot, scene: Scene, exact_below: float = EXACT_BELOW):
        self.robot = robot
        self.scene = scene
        self.exact_below = float(exact_below)
        self.model = robot.model
        self.data = robot.model.createData()
        self.geometry = pin.buildGeomFromUrdfString(robot.model, robot.urdf_text, pin.GeometryType.COLLISION,
                                                    package_dirs=list(robot.package_dirs))
        self.robot_geometries = list(range(self.geometry.ngeoms))
        self.names = [obj.name for obj in self.geometry.geometryObjects]
        self.pin_index = self.names.index("rivet_tool_1")
        # the cell, fixed to the universe
        self.envelope = coal.Box(*scene.workpiece_size)
        self.envelope_pose = pin.SE3(np.eye(3), scene.workpiece_center)
        table_center = np.array([*scene.table_center, scene.table_top_z - 0.5 * scene.table_size[2]])
        self.table = coal.Box(*scene.table_size)
        self.table_pose = pin.SE3(np.eye(3), table_center)
        self.workpiece_id = self.geometry.addGeometryObject(
            pin.GeometryObject("workpiece", 0, 0, self.envelope_pose, self.envelope))
        self.table_id = self.geometry.addGeometryObject(
            pin.GeometryObject("table", 0, 0, self.table_pose, self.table))
        for index in self.robot_geometries:
            self.geometry.addCollisionPair(pin.CollisionPair(index, self.workpiece_id))
            if self.names[index] not in TABLE_IGNORED:
                self.geometry.addCollisionPair(pin.CollisionPair(index, self.table_id))
        self.geometry_data = pin.GeometryData(self.geometry)
        self._spheres = [self._bounding_sphere(self.geometry.geometryObjects[i].geometry)
                         for i in self.robot_geometries]
        self._envelope_transform = coal.Transform3s(np.eye(3), scene.workpiece_center)
        self._table_transform = coal.Transform3s(np.eye(3), table_center)
        self._hole_models: dict[int, list] = {}
        self._request = coal.DistanceRequest()
        self._result = coal.DistanceResult()

    # -- geometry helpers -----------------------------------------------------------------------
    @staticmethod
    def _bounding_sphere(shape) -> tuple[np.ndarray, float]:
        """(centre in the geometry frame, radius) of a sphere containing the shape."""
        if isinstance(shape, coal.BVHModelBase):
            vertices = np.asarray(shape.vertices(), dtype=float).reshape(-1, 3)
            center = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
            return center, float(np.max(np.linalg.norm(vertices - center, axis=1)))
        if isinstance(shape, coal.Box):
            return np.zeros(3), float(np.linalg.norm(shape.halfSide))
        if isinstance(shape, coal.Cylinder):
            return np.zeros(3), float(np.hypot(shape.radius, shape.halfLength))
        if isinstance(shape, coal.Sphere):
            return np.zeros(3), float(shape.radius)
        raise TypeError(f"no bounding sphere for {type(shape).__name__}")

    def joint_reach(self) -> np.ndarray:
        """R (nq,): for each joint, a bound (m) on the distance from its axis of any point of the robot
        geometry it moves, in any configuration (sum of the joint offsets down the chain plus the
        geometry's bounding sphere). Turning joint j by dq_j moves no point by more than |dq_j| R_j,
        so a joint change dq moves every point by at most sum_j |dq_j| R_j (turn the joints one at a
        time): a clearance d at q stays >= d - sum_j |dq_j| R_j (distances are 1-Lipschitz)."""
        model = self.model
        reach = np.zeros(model.nq)
        for index in self.robot_geometries:
            obj = self.geometry.geometryObjects[index]
            center, radius = self._spheres[index]
            joint = obj.parentJoint
            distance = float(np.linalg.norm(obj.placement.act(center))) + radius
            while joint > 0:
                q_index = model.joints[joint].idx_q
                reach[q_index] = max(reach[q_index], distance)
                distance += float(np.linalg.norm(model.jointPlacements[joint].translation))
                joint = model.parents[joint]
        return reach

    def hole_boxes(self, hole: Hole) -> list:
        if hole.index not in self._hole_models:
            self._hole_models[hole.index] = hole_model(self.scene, hole)
        return self._hole_models[hole.index]

    def update(self, q: np.ndarray) -> None:
        """Place the robot geometries at full configuration q."""
        pin.forwardKinematics(self.model, self.data, q)
        pin.updateGeometryPlacements(self.model, self.data, self.geometry, self.geometry_data)

    def _transform(self, index: int) -> coal.Transform3s:
        placement = self.geometry_data.oMg[index]
        return coal.Transform3s(placement.rotation, placement.translation)

    def _exact(self, index: int, obstacles) -> GeometryDistance:
        """Exact distance of robot geometry ``index`` to the nearest of ``obstacles`` [(shape, transform)]."""
        shape = self.geometry.geometryObjects[index].geometry
        transform = self._transform(index)
        best = None
        for obstacle, obstacle_transform in obstacles:
            self._result.clear()
            distance = coal.distance(shape, transform, obstacle, obstacle_transform,
                                     self._request, self._result)
            if best is None or distance < best[0]:
                result = self._result
                best = (distance, result.getNearestPoint1().copy(), result.getNearestPoint2().copy(),
                        np.array(result.normal, dtype=float))
        distance, robot_point, obstacle_point, normal = best
        offset = robot_point - obstacle_point
        norm = np.linalg.norm(offset)
        if distance > 1e-6 and norm > 1e-9:
            direction = offset / norm
        else:
            direction = -normal / max(np.linalg.norm(normal), 1e-12)
        joint = self.geometry.geometryObjects[index].parentJoint
        return GeometryDistance(self.names[index], float(distance), True, robot_point, direction, joint)

    @staticmethod
    def _box_distance(point: np.ndarray, center: np.ndarray, half: np.ndarray) -> float:
        """Euclidean distance from a point to an axis-aligned box (0 inside)."""
        return float(np.linalg.norm(np.maximum(np.abs(point - center) - half, 0.0)))

    def _bound(self, index: int, center: np.ndarray, half: np.ndarray) -> float:
        local_center, radius = self._spheres[index]
        world_center = self.geometry_data.oMg[index].act(local_center)
        return self._box_distance(world_center, center, half) - radius

    def pin_hole(self) -> Hole:
        """The hole nearest to the tcp (the one cut out of the pin's obstacle)."""
        tcp = self.geometry_data.oMg[self.pin_index].act(
            np.array([0.0, 0.0, self.geometry.geometryObjects[self.pin_index].geometry.halfLength]))
        return self.scene.nearest_hole(tcp)

    def _distances(self, center: np.ndarray, half: np.ndarray, skip, obstacles) -> list[GeometryDistance]:
        """Each robot geometry (but those named in ``skip``) against the box (``center``, ``half``):
        its sphere bound when that is above ``exact_below``, else the exact distance to
        ``obstacles(index)``."""
        distances = []
        for index in self.robot_geometries:
            name = self.names[index]
            if name in skip:
                continue
            bound = self._bound(index, center, half)
            distances.append(GeometryDistance(name, bound, False) if bound > self.exact_below
                             else self._exact(index, obstacles(index)))
        return distances

    def clearance(self, q: np.ndarray | None = None, table: bool = True,
                  skip: tuple[str, ...] = ()) -> Clearance:
        """Distances at q (or at the last ``update``); ``skip`` leaves geometries out (by name)."""
        if q is not None:
            self.update(q)
        envelope = [(self.envelope, self._envelope_transform)]

        def workpiece_obstacles(index: int) -> list:
            """The pin against the boxes around its hole (the hole is cut out), the rest the envelope."""
            return self.hole_boxes(self.pin_hole()) if index == self.pin_index else envelope

        workpiece = self._distances(self.scene.workpiece_center, self.scene.workpiece_half, skip,
                                    workpiece_obstacles)
        table_distances = []
        if table:
            table_obstacle = [(self.table, self._table_transform)]
            table_distances = self._distances(self.table_pose.translation, 0.5 * self.scene.table_size,
                                              (*TABLE_IGNORED, *skip), lambda index: table_obstacle)
        return Clearance(workpiece, table_distances)
