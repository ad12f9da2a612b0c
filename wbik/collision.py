"""Collision geometry of a robot as coal primitives in a Pinocchio GeometryModel, and pair distances.

A robot package lists its :class:`Primitive` shapes (capsule, box, sphere on a frame) in its model's
``collision_primitives()`` and fixed boxes of its cell in ``collision_obstacles()``. Pairs checked: not
on the same joint, not both fixed, not adjacent links, not in contact (distance <= ``contact_distance``)
at the reference configuration. Distances are signed (negative on overlap) with witness points p_a, p_b
(world) and the unit normal n from a to b: dd = n^T (J_b(p_b) - J_a(p_a)) dq, J_x(p) the linear
Jacobian (world axes) of p moving with x's joint. SI units.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

from wbik.errors import RobotDescriptionError, UnknownFrameError, UnsupportedError
from wbik.kinematic_tree import frame_index
from wbik.models import robot_entries
from wbik.validation import finite_vector

SHAPES = ("capsule", "box", "sphere")
LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

Point = str | Sequence[float]
"""A capsule end: a frame's origin (its name) or a point (x, y, z) in the primitive's frame (m)."""


@dataclass(frozen=True)
class Primitive:
    """One collision shape moving with ``frame``: "capsule" (``size`` (radius,), axis ``start`` to
    ``end``), "box" (``size`` full side lengths, centre ``xyz``, orientation ``rpy`` in the frame) or
    "sphere" (``size`` (radius,), centre ``xyz``). m, rad."""

    name: str
    frame: str
    shape: str
    size: tuple[float, ...]
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    start: Point | None = None
    end: Point | None = None


def capsule(name: str, frame: str, start: Point, end: Point, radius: float) -> Primitive:
    """A capsule of ``radius`` around the segment start-end (frame names or points in ``frame``)."""
    return Primitive(name, frame, "capsule", (float(radius),), start=start, end=end)


def box(name: str, frame: str, size: Sequence[float], xyz: Sequence[float] = (0.0, 0.0, 0.0),
        rpy: Sequence[float] = (0.0, 0.0, 0.0)) -> Primitive:
    return Primitive(name, frame, "box", tuple(float(v) for v in size), tuple(xyz), tuple(rpy))


def sphere(name: str, frame: str, radius: float, xyz: Sequence[float] = (0.0, 0.0, 0.0)) -> Primitive:
    return Primitive(name, frame, "sphere", (float(radius),), tuple(xyz))


@dataclass(frozen=True)
class Obstacle:
    """A box fixed in the world: full side lengths ``size``, centre ``xyz`` (m), orientation ``rpy`` (rad)."""

    name: str
    size: tuple[float, float, float]
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass
class PairDistance:
    """Signed distance of one pair (negative: overlap), witness points (world) and the normal a -> b."""

    a: str
    b: str
    distance: float
    point_a: np.ndarray
    point_b: np.ndarray
    normal: np.ndarray
    joint_a: int
    joint_b: int


def _numbers(values, count: int, what: str, positive: bool = False) -> np.ndarray:
    return finite_vector(values, count, f"{what} (m / rad)", RobotDescriptionError, positive)


class CollisionModel:
    """Robot primitives and world obstacles in one ``pin.GeometryModel`` (``geometry``) and the pairs to
    check: ``pairs`` (names) overrides the choice, ``self_collision`` False keeps robot-obstacle pairs
    only; ``excluded`` says why each left-out pair is out."""

    def __init__(self, model: pin.Model, primitives: Iterable[Primitive], obstacles: Iterable[Obstacle] = (),
                 *, reference: np.ndarray | None = None, pairs: Sequence[tuple[str, str]] | None = None,
                 self_collision: bool = True, contact_distance: float = 0.0):
        self.model = model
        self.data = model.createData()
        self.reference = pin.neutral(model) if reference is None else np.array(reference, dtype=float)
        if self.reference.shape != (model.nq,):
            raise RobotDescriptionError(f"the reference configuration needs nq = {model.nq} values, "
                                        f"got {self.reference.size}")
        pin.framesForwardKinematics(model, self.data, self.reference)
        self.geometry = pin.GeometryModel()
        self.obstacle_names: set[str] = set()
        for primitive in primitives:
            self._add(self._geometry_object(primitive))
        for obstacle in obstacles:  # a box on the world frame
            world_box = Primitive(obstacle.name, model.frames[0].name, "box", obstacle.size, obstacle.xyz,
                                  obstacle.rpy)
            self._add(self._geometry_object(world_box, "obstacle"))
            self.obstacle_names.add(obstacle.name)
        self.names = [g.name for g in self.geometry.geometryObjects]
        self.excluded: dict[tuple[str, str], str] = {}
        if pairs is None:
            pairs = self._default_pairs(self_collision, float(contact_distance))
        for a, b in pairs:
            for name in (a, b):
                if name not in self.names:
                    raise UnknownFrameError(name, self.names, hint="a collision pair names two geometries")
            self.geometry.addCollisionPair(pin.CollisionPair(self.names.index(a), self.names.index(b)))
        self.pairs = [(self.names[p.first], self.names[p.second]) for p in self.geometry.collisionPairs]
        self.geometry_data = pin.GeometryData(self.geometry)

    def _add(self, obj: pin.GeometryObject) -> None:
        if self.geometry.existGeometryName(obj.name):
            raise RobotDescriptionError(f"two collision geometries are named {obj.name!r}")
        self.geometry.addGeometryObject(obj)

    def _point(self, point: Point, frame_id: int, what: str) -> np.ndarray:
        """A capsule end in the frame ``frame_id``: a point, or the origin of a frame fixed in it."""
        if not isinstance(point, str):
            return _numbers(point, 3, what)
        other = frame_index(self.model, point)
        local = self.data.oMf[frame_id].actInv(self.data.oMf[other].translation)
        data = self.model.createData()
        q = pin.integrate(self.model, self.reference, np.full(self.model.nv, 0.37))
        pin.framesForwardKinematics(self.model, data, q)
        moved = data.oMf[frame_id].actInv(data.oMf[other].translation)
        if np.linalg.norm(moved - local) > 1e-9:
            raise RobotDescriptionError(
                f"{what}: frame {point!r} moves relative to {self.model.frames[frame_id].name!r}; a "
                "capsule end must be fixed on its link (the child joint's origin or a point)")
        return local

    def _geometry_object(self, primitive: Primitive, kind: str = "collision primitive") -> pin.GeometryObject:
        what = f"{kind} {primitive.name!r}"
        if primitive.shape not in SHAPES:
            raise RobotDescriptionError(f"{what}: shape {primitive.shape!r} is not one of "
                                        f"{', '.join(SHAPES)}")
        frame_id = frame_index(self.model, primitive.frame)
        frame = self.model.frames[frame_id]
        rotation = pin.rpy.rpyToMatrix(*_numbers(primitive.rpy, 3, f"{what} rpy"))
        center = _numbers(primitive.xyz, 3, f"{what} xyz")
        if primitive.shape == "capsule":
            (radius,) = _numbers(primitive.size, 1, f"{what} size (radius)", positive=True)
            if primitive.start is None or primitive.end is None:
                raise RobotDescriptionError(f"{what}: a capsule needs a start and an end")
            start = self._point(primitive.start, frame_id, f"{what} start")
            end = self._point(primitive.end, frame_id, f"{what} end")
            axis = end - start
            length = float(np.linalg.norm(axis))
            rotation = (pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), axis / length).matrix()
                        if length > 1e-12 else np.eye(3))
            center = 0.5 * (start + end)
            shape = coal.Capsule(radius, length)
        elif primitive.shape == "box":
            shape = coal.Box(*_numbers(primitive.size, 3, f"{what} size", positive=True))
        else:
            (radius,) = _numbers(primitive.size, 1, f"{what} size (radius)", positive=True)
            shape = coal.Sphere(radius)
        placement = frame.placement * pin.SE3(rotation, center)
        return pin.GeometryObject(primitive.name, frame.parentJoint, frame_id, placement, shape)

    def _default_pairs(self, self_collision: bool, contact_distance: float) -> list[tuple[str, str]]:
        objects, parents = self.geometry.geometryObjects, self.model.parents
        candidates = []
        for i in range(len(objects)):
            for j in range(i + 1, len(objects)):
                a, b = objects[i], objects[j]
                key = (a.name, b.name)
                robot_pair = a.name not in self.obstacle_names and b.name not in self.obstacle_names
                if a.parentJoint == b.parentJoint:
                    self.excluded[key] = "same joint"
                elif robot_pair and not self_collision:
                    self.excluded[key] = "self-collision off"
                elif robot_pair and (parents[a.parentJoint] == b.parentJoint
                                     or parents[b.parentJoint] == a.parentJoint):
                    self.excluded[key] = "adjacent links"
                else:
                    candidates.append((i, j))
        probe = self.geometry.copy()  # no pairs yet
        for i, j in candidates:
            probe.addCollisionPair(pin.CollisionPair(i, j))
        probe_data = pin.GeometryData(probe)
        pin.updateGeometryPlacements(self.model, self.data, probe, probe_data, self.reference)
        pin.computeDistances(probe, probe_data)
        pairs = []
        for index, (i, j) in enumerate(candidates):
            distance = probe_data.distanceResults[index].min_distance
            if distance <= contact_distance:
                self.excluded[(objects[i].name, objects[j].name)] = (
                    f"in contact at the reference configuration (d = {distance:.4g} m)")
            else:
                pairs.append((objects[i].name, objects[j].name))
        return pairs

    def create_data(self) -> pin.GeometryData:
        return pin.GeometryData(self.geometry)

    def compute(self, data: pin.Data, geometry_data: pin.GeometryData | None = None) -> list[PairDistance]:
        """Distances of every pair, with ``data.oMi`` already computed."""
        geometry_data = self.geometry_data if geometry_data is None else geometry_data
        pin.updateGeometryPlacements(self.model, data, self.geometry, geometry_data)
        pin.computeDistances(self.geometry, geometry_data)
        objects = self.geometry.geometryObjects
        results = []
        for pair, result in zip(self.geometry.collisionPairs, geometry_data.distanceResults, strict=True):
            a, b = objects[pair.first], objects[pair.second]
            results.append(PairDistance(a.name, b.name, float(result.min_distance),
                                        result.getNearestPoint1().copy(), result.getNearestPoint2().copy(),
                                        np.array(result.normal, dtype=float), a.parentJoint, b.parentJoint))
        return results

    def distances(self, q: np.ndarray) -> list[PairDistance]:
        """Distances of every pair at configuration q (forward kinematics here)."""
        pin.forwardKinematics(self.model, self.data, np.asarray(q, dtype=float))
        return self.compute(self.data)

    def minimum(self, q: np.ndarray) -> PairDistance | None:
        """The closest pair at q (None without pairs)."""
        return min(self.distances(q), key=lambda d: d.distance, default=None)

    def point_jacobian(self, data: pin.Data, joint: int, point: np.ndarray) -> np.ndarray:
        """3 x nv linear Jacobian (world axes) of ``point`` (world) moving with ``joint`` (0: zero); needs
        ``pin.computeJointJacobians`` in ``data``."""
        if joint == 0:
            return np.zeros((3, self.model.nv))
        jacobian = pin.getJointJacobian(self.model, data, joint, LWA)
        arm = point - data.oMi[joint].translation
        return jacobian[:3] - pin.skew(arm) @ jacobian[3:]

    def distance_gradient(self, data: pin.Data, pair: PairDistance) -> np.ndarray:
        """dd/dq (nv,) of one pair: n^T (J_b(p_b) - J_a(p_a))."""
        return pair.normal @ (self.point_jacobian(data, pair.joint_b, pair.point_b)
                              - self.point_jacobian(data, pair.joint_a, pair.point_a))


def robot_collision_model(robot, *, self_collision: bool = True, robot_obstacles: bool = True,
                          obstacles: Iterable[Obstacle] = (),
                          contact_distance: float = 0.0) -> CollisionModel:
    """The collision model of a built-in robot: its ``collision_primitives(robot)``, its
    ``collision_obstacles()`` when ``robot_obstacles``, and ``obstacles``; pairs chosen at the nominal."""
    entry = robot_entries().get(robot.name)
    if entry is None:
        raise UnsupportedError(f"robot {robot.name!r} has no collision primitives; pass a list of "
                               "wbik.collision.Primitive to CollisionModel")
    module = entry.module()
    table = getattr(module, "collision_primitives", None)
    if table is None:
        raise UnsupportedError(f"robot {robot.name!r} lists no collision primitives "
                               f"({module.__name__}.collision_primitives)")
    fixed = list(getattr(module, "collision_obstacles", lambda: [])()) if robot_obstacles else []
    return CollisionModel(robot.model, table(robot), [*fixed, *obstacles], reference=robot.nominal,
                          self_collision=self_collision, contact_distance=contact_distance)
