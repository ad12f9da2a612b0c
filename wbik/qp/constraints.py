"""Hard constraints of the QP over the tangent displacement dq (nv).

Each constraint derives from one of three typed bases and implements the one method of that base,
which returns its rows (:mod:`wbik.qp.rows`) at the kinematics' configuration:

- ``BoundConstraint.bounds(k, dt)``      -> BoundRows       lower <= dq[index] <= upper: joint
  position limits (q + dq inside [q_min, q_max], exact for 1-DOF joints), joint velocity limits
  (|dq| <= v_max dt), locked joints;
- ``EqualityConstraint.equality(k)``     -> EqualityRows    A dq = b: contacts (a frame keeps its
  pose, J dq = -e: a Newton step on e = 0; a point contact keeps its position only);
- ``InequalityConstraint.inequality(k)`` -> InequalityRows  G dq <= h: CoM inside the support
  polygon shrunk by a margin, minimum distances, collision avoidance.

``rows(k, dt)`` is what the QP step calls (each base forwards it to its method). ``violation(k)``
measures the constraint by forward kinematics at the current q (metres or radians, > 0 means
violated); the IK loop uses it to verify every configuration it returns.
"""

from __future__ import annotations

import math
from collections.abc import Collection

import numpy as np
import pinocchio as pin

from wbik.qp.kinematics import Kinematics
from wbik.qp.rows import BoundRows
from wbik.qp.rows import EqualityRows
from wbik.qp.rows import InequalityRows
from wbik.qp.rows import Rows
from wbik.qp.rows import as_index
from wbik.qp.support_polygon import SupportPolygon
from wbik.qp.tasks import FrameTask
from wbik.qp.tasks import PositionTask


class Constraint:
    """Base class: derive from BoundConstraint, EqualityConstraint or InequalityConstraint."""

    name = "constraint"

    def start(self, kinematics: Kinematics) -> None:
        """Called once when a problem starts from a configuration."""

    def rows(self, kinematics: Kinematics, dt: float) -> Rows:
        """This constraint's rows at the kinematics' q (``dt``: the control period, for velocities)."""
        raise NotImplementedError(f"{type(self).__name__} must derive from BoundConstraint, "
                                  "EqualityConstraint or InequalityConstraint and implement its method")

    def violation(self, kinematics: Kinematics) -> float:
        return 0.0

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class BoundConstraint(Constraint):
    """lower <= dq[index] <= upper."""

    def rows(self, kinematics: Kinematics, dt: float) -> BoundRows:
        return self.bounds(kinematics, dt)

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        raise NotImplementedError


class EqualityConstraint(Constraint):
    """A dq = b; the IK loop also projects its iterates onto these (Newton steps on e = 0)."""

    def rows(self, kinematics: Kinematics, dt: float) -> EqualityRows:
        return self.equality(kinematics)

    def equality(self, kinematics: Kinematics) -> EqualityRows:
        raise NotImplementedError


class InequalityConstraint(Constraint):
    """G dq <= h."""

    def rows(self, kinematics: Kinematics, dt: float) -> InequalityRows:
        return self.inequality(kinematics)

    def inequality(self, kinematics: Kinematics) -> InequalityRows:
        raise NotImplementedError


def bounded_joint_indices(model: pin.Model, unbounded: Collection[str] = ()) -> tuple[np.ndarray, np.ndarray]:
    """(q indices, v indices) of the 1-DOF joints (revolute, prismatic) with finite limits, but for the
    joints named in ``unbounded``."""
    q_index, v_index = [], []
    for joint_id, joint in enumerate(model.joints):
        if joint_id and joint.nq == 1 and joint.nv == 1 and model.names[joint_id] not in unbounded:
            low, high = model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
            if np.isfinite(low) and np.isfinite(high) and high - low < 1e10:
                q_index.append(joint.idx_q)
                v_index.append(joint.idx_v)
    return np.array(q_index, dtype=int), np.array(v_index, dtype=int)


class JointPositionLimits(BoundConstraint):
    """q_min <= q + dq <= q_max on every bounded 1-DOF joint (linear, so exact after the step).

    ``unbounded``: names of joints left without position bounds (continuous joints, whose answers are
    wrapped instead)."""

    name = "joint position limits"

    def __init__(self, model: pin.Model, unbounded: Collection[str] = ()):
        self.q_index, self.v_index = bounded_joint_indices(model, unbounded)
        self.lower = model.lowerPositionLimit[self.q_index].copy()
        self.upper = model.upperPositionLimit[self.q_index].copy()
        self._q_rows, self._v_rows = as_index(self.q_index), as_index(self.v_index)

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        q = kinematics.q[self._q_rows]
        return BoundRows(self._v_rows, self.lower - q, self.upper - q)

    def clip(self, q: np.ndarray) -> None:
        """Clip q (nq) into the limits, in place."""
        rows = self._q_rows
        if isinstance(rows, slice):  # a view: clipped in place
            view = q[rows]
            np.maximum(view, self.lower, out=view)
            np.minimum(view, self.upper, out=view)
        else:
            q[rows] = np.minimum(np.maximum(q[rows], self.lower), self.upper)

    def violation(self, kinematics: Kinematics) -> float:
        q = kinematics.q[self._q_rows]
        if q.size == 0:
            return 0.0
        return float(max((self.lower - q).max(), (q - self.upper).max(), 0.0))


class JointVelocityLimits(BoundConstraint):
    """|dq_i| <= v_max,i dt on the joints with a positive finite velocity limit."""

    name = "joint velocity limits"

    def __init__(self, model: pin.Model, velocity_limit: np.ndarray | None = None):
        limit = model.velocityLimit.copy() if velocity_limit is None else np.asarray(velocity_limit, float)
        if limit.shape != (model.nv,):
            raise ValueError(f"velocity limits need nv = {model.nv} values, got {limit.size}")
        self.v_index = np.flatnonzero(np.isfinite(limit) & (limit > 0) & (limit < 1e10))
        self.limit = limit[self.v_index]

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        step = self.limit * dt
        return BoundRows(self.v_index, -step, step)


class Contact(EqualityConstraint):
    """A frame held at a fixed world pose (a flat foot on the ground): J dq = -e, 6 rows.

    ``placement`` defaults to the frame's pose when the problem starts. ``violation`` is the larger
    of the position error (m) and rotation error (rad).
    """

    def __init__(self, frame: str, placement: pin.SE3 | None = None):
        self.frame = frame
        self.name = f"contact[{frame}]"
        self.fixed_placement = placement
        self._task = FrameTask(frame, placement if placement is not None else pin.SE3.Identity())

    @property
    def placement(self) -> pin.SE3:
        return self._task.target

    def start(self, kinematics: Kinematics) -> None:
        self._task.start(kinematics)
        if self.fixed_placement is None:
            self._task.target = kinematics.placement(self._task.frame_id).copy()
        if getattr(self, "_jacobian", np.zeros((0, 0))).shape != (6, kinematics.nv):
            self._jacobian = np.zeros((6, kinematics.nv))
            self._rhs = np.zeros(6)
        self._version = -1

    def _rows(self, kinematics: Kinematics) -> None:
        """J and -e at the kinematics' configuration, computed once per configuration (the
        placement is fixed once started, so nothing else can change them)."""
        if self._version != kinematics.version:
            self._task.fill(kinematics, self._jacobian, self._rhs)
            np.negative(self._rhs, out=self._rhs)
            self._version = kinematics.version

    def error(self, kinematics: Kinematics) -> np.ndarray:
        return self._task.error(kinematics)

    def equality(self, kinematics: Kinematics) -> EqualityRows:
        """J dq = -e (buffers reused at the next configuration: copy them to keep them)."""
        self._rows(kinematics)
        return EqualityRows(self._jacobian, self._rhs)

    def violation(self, kinematics: Kinematics) -> float:
        self._rows(kinematics)
        # in Python floats: the same sums of squares as numpy's, without six small-array calls
        x, y, z, rx, ry, rz = self._rhs.tolist()
        return math.sqrt(max(x * x + y * y + z * z, rx * rx + ry * ry + rz * rz))


class PointContact(EqualityConstraint):
    """A frame's origin held at a fixed world position (a point foot on the ground): J_v dq = -(p - p*),
    3 rows. Its rotation is free: a point contact transmits no moment, and a 3-joint leg could not hold
    a foot's full pose while the body moves.

    ``position`` (m, world) defaults to the frame's position when the problem starts. ``violation`` is
    the position error (m).
    """

    def __init__(self, frame: str, position: np.ndarray | None = None):
        self.frame = frame
        self.name = f"point contact[{frame}]"
        self.fixed_position = None if position is None else np.array(position, dtype=float).reshape(3)
        self._task = PositionTask(frame, np.zeros(3) if position is None else self.fixed_position)

    @property
    def position(self) -> np.ndarray:
        return self._task.target

    def start(self, kinematics: Kinematics) -> None:
        self._task.start(kinematics)
        if self.fixed_position is None:
            self._task.target = kinematics.placement(self._task.frame_id).translation.copy()

    def error(self, kinematics: Kinematics) -> np.ndarray:
        return self._task.error(kinematics)

    def equality(self, kinematics: Kinematics) -> EqualityRows:
        return EqualityRows(self._task.jacobian(kinematics), -self._task.error(kinematics))

    def violation(self, kinematics: Kinematics) -> float:
        return float(np.linalg.norm(self._task.error(kinematics)))


class CoMInSupportPolygon(InequalityConstraint):
    """The ground projection of the centre of mass stays inside the support polygon shrunk by ``margin``.

    Linearised: N (c_xy + J_com,xy dq) <= d - margin - safety, one row per polygon edge. ``safety``
    (a few micrometres) absorbs the second-order error of the linearisation, so the FK check of the
    configuration after the step still holds; the IK loop also halves a step that would break it.
    ``violation`` = margin - (distance from the CoM projection to the boundary), > 0 if too close.
    """

    def __init__(self, polygon: SupportPolygon, margin: float = 0.0, safety: float = 2e-6):
        if margin < 0:
            raise ValueError(f"the margin must be >= 0, got {margin}")
        self.polygon = polygon
        self.margin = float(margin)
        self.safety = float(safety)
        self.name = f"CoM in support polygon (margin {margin * 1e3:g} mm)"
        self.normals, self.offsets = polygon.halfplanes(self.margin + self.safety)
        self._version, self._projected = -1, np.zeros(len(self.offsets))

    def projected(self, kinematics: Kinematics) -> np.ndarray:
        """N c_xy at the kinematics' q (once per configuration: the rows and the margin share it)."""
        if self._version != kinematics.version:
            self._projected = self.normals.dot(kinematics.com()[:2])
            self._version = kinematics.version
        return self._projected

    def inequality(self, kinematics: Kinematics) -> InequalityRows:
        return InequalityRows(self.normals.dot(kinematics.com_jacobian()[:2]),
                              self.offsets - self.projected(kinematics))

    def com_margin(self, kinematics: Kinematics) -> float:
        """Distance from the CoM projection to the polygon's boundary (m, positive inside):
        SupportPolygon.margin_of, from the shared N c_xy."""
        return float((self.polygon.offsets - self.projected(kinematics)).min())

    def violation(self, kinematics: Kinematics) -> float:
        return max(self.margin - self.com_margin(kinematics), 0.0)


class MinimumDistance(InequalityConstraint):
    """|p_a - p_b| >= distance between two frame origins, linearised along u = (p_a - p_b)/|p_a - p_b|:

        -u^T (J_v,a - J_v,b) dq <= |p_a - p_b| - distance.
    """

    def __init__(self, frame_a: str, frame_b: str, distance: float):
        self.frames = (frame_a, frame_b)
        self.distance = float(distance)
        self.name = f"distance({frame_a}, {frame_b}) >= {distance:g} m"
        self.ids = (-1, -1)

    def start(self, kinematics: Kinematics) -> None:
        self.ids = (kinematics.frame_id(self.frames[0]), kinematics.frame_id(self.frames[1]))

    def current_distance(self, kinematics: Kinematics) -> tuple[float, np.ndarray]:
        offset = (kinematics.placement(self.ids[0]).translation
                  - kinematics.placement(self.ids[1]).translation)
        return float(np.linalg.norm(offset)), offset

    def inequality(self, kinematics: Kinematics) -> InequalityRows:
        distance, offset = self.current_distance(kinematics)
        direction = offset / max(distance, 1e-12)
        relative = kinematics.jacobian(self.ids[0])[:3] - kinematics.jacobian(self.ids[1])[:3]
        return InequalityRows(-(direction @ relative)[None, :], np.array([distance - self.distance]))

    def violation(self, kinematics: Kinematics) -> float:
        return max(self.distance - self.current_distance(kinematics)[0], 0.0)


class LockedJoints(BoundConstraint):
    """Named 1-DOF joints keep their value: 0 <= dq_i <= 0 (e.g. the arms alone, without the lift)."""

    def __init__(self, model: pin.Model, joints: list[str]):
        from wbik.errors import RobotDescriptionError

        indices = []
        for name in joints:
            if not model.existJointName(name):
                raise RobotDescriptionError(f"cannot lock joint {name!r}: the model has no such joint")
            joint = model.joints[model.getJointId(name)]
            indices.extend(range(joint.idx_v, joint.idx_v + joint.nv))
        self.v_index = np.array(indices, dtype=int)
        self.name = f"locked joints {', '.join(joints)}"

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        return BoundRows(self.v_index, 0.0, 0.0)


class CollisionAvoidance(InequalityConstraint):
    """Every checked pair of a :class:`wbik.collision.CollisionModel` keeps ``safety_distance`` (m).

    Rows only for the pairs closer than ``influence_distance`` (m): with the coal distance d, its
    witness points p_a, p_b and normal n (a -> b), the distance after the step, linearised, must keep

        d + n^T (J_b(p_b) - J_a(p_a)) dq >= safety + padding + (1 - gain) (d - safety - padding),

    i.e.  n^T (J_a - J_b) dq <= gain (d - safety - padding): the velocity-damper form of Pink /
    mink / PlaCo, a full step (gain 1) may close the whole gap, a smaller gain a fraction of it.
    ``padding`` (m) absorbs the linearisation's second-order error so the FK check after the step
    holds; the IK loop halves a step that breaks it. A pair already under ``safety`` asks for half
    the repair (the QP's relaxation). ``violation`` = safety - (minimum distance over all pairs by FK,
    coal), > 0 if too close; ``minimum(kinematics)`` gives that pair and distance.
    """

    def __init__(self, pairs, safety_distance: float = 0.01, influence_distance: float = 0.1,
                 gain: float = 1.0, padding: float = 1e-6):
        from wbik.errors import InvalidSettingError
        from wbik.validation import check_positive_finite

        self.collision_model = pairs
        if isinstance(safety_distance, bool) or not isinstance(safety_distance, int | float) \
                or not np.isfinite(safety_distance) or safety_distance < 0:
            raise InvalidSettingError("safety_distance must be a finite number >= 0 (m), "
                                      f"got {safety_distance!r}")
        self.safety = float(safety_distance)
        self.influence = check_positive_finite("influence_distance", influence_distance,
                                               InvalidSettingError, "m")
        if self.influence <= self.safety:
            raise InvalidSettingError(f"influence_distance ({self.influence:g} m) must exceed the safety "
                                      f"distance ({self.safety:g} m)")
        self.gain = check_positive_finite("gain", gain, InvalidSettingError)
        if self.gain > 1.0:
            raise InvalidSettingError(f"gain must be in (0, 1], got {gain!r}")
        self.padding = float(padding)
        self.name = f"collision avoidance (safety {self.safety * 1e3:g} mm)"
        self.geometry_data = pairs.create_data()
        self._distances = []
        self._q = None

    def start(self, kinematics: Kinematics) -> None:
        if kinematics.model.nq != self.collision_model.model.nq or \
                kinematics.model.nv != self.collision_model.model.nv:
            from wbik.errors import RobotDescriptionError

            raise RobotDescriptionError(
                "the collision model was built on another robot model (nq "
                f"{self.collision_model.model.nq}, problem nq {kinematics.model.nq})")
        self._q = None

    def distances(self, kinematics: Kinematics) -> list:
        """Pair distances at the kinematics' q (computed once per configuration)."""
        if self._q is None or not np.array_equal(self._q, kinematics.q):
            self._distances = self.collision_model.compute(kinematics.data, self.geometry_data)
            self._q = kinematics.q.copy()
        return self._distances

    def minimum(self, kinematics: Kinematics):
        """The closest pair (a wbik.collision.PairDistance) at the current q, or None."""
        return min(self.distances(kinematics), key=lambda d: d.distance, default=None)

    def inequality(self, kinematics: Kinematics) -> InequalityRows:
        rows, bounds = [], []
        target = self.safety + self.padding
        for pair in self.distances(kinematics):
            if pair.distance >= self.influence:
                continue
            rows.append(-self.collision_model.distance_gradient(kinematics.data, pair))
            bounds.append(self.gain * (pair.distance - target))
        if not rows:  # nothing near: one row that always holds
            return InequalityRows(np.zeros((1, kinematics.nv)), np.ones(1))
        return InequalityRows(np.array(rows), np.array(bounds))

    def violation(self, kinematics: Kinematics) -> float:
        closest = self.minimum(kinematics)
        return 0.0 if closest is None else max(self.safety - closest.distance, 0.0)
