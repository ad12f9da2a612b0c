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
violated); the IK loop uses it to verify every configuration it returns. ``labels(k, rows)`` names
each row (:class:`wbik.qp.rows.RowLabel`: a joint's limit, a contact's axis, a polygon edge, a pair),
for the diagnoses made when a solve fails; ``stepped(dq, dt)`` tells a constraint with a memory
(acceleration limits: the previous velocity) the step that was taken.

A joint outside its position range (a start outside the limits) is not asked to be back inside in
one step: where its limit and the other bounds of the step (velocity, acceleration, the step box)
leave no room, the step takes the bound nearest to no motion, so the joint moves back as fast as they
allow (:meth:`wbik.qp.backends.StackedConstraints.close_box`), where q + dq inside the range in one
step would contradict them (Pink #206).
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
from wbik.qp.rows import RowLabel
from wbik.qp.rows import Rows
from wbik.qp.rows import as_index
from wbik.qp.support_polygon import SupportPolygon
from wbik.qp.tasks import FrameTask
from wbik.qp.tasks import PositionTask


class Constraint:
    """Base class: derive from BoundConstraint, EqualityConstraint or InequalityConstraint."""

    name = "constraint"
    label_kind = "inequality"
    """What its rows stand for in a diagnosis's labels (one of :data:`wbik.qp.rows.ROW_KINDS`)."""

    def start(self, kinematics: Kinematics) -> None:
        """Called once when a problem starts from a configuration."""

    def rows(self, kinematics: Kinematics, dt: float) -> Rows:
        """This constraint's rows at the kinematics' q (``dt``: the control period, for velocities)."""
        raise NotImplementedError(f"{type(self).__name__} must derive from BoundConstraint, "
                                  "EqualityConstraint or InequalityConstraint and implement its method")

    def labels(self, kinematics: Kinematics, rows: Rows) -> list:
        """One :class:`~wbik.qp.rows.RowLabel` per row of ``rows`` (this constraint's rows at the
        kinematics' q); a bound constraint gives a (lower, upper) pair per index. Made on failure only."""
        count = len(rows[1]) if not isinstance(rows, BoundRows) else 0
        return [RowLabel(self.name, self.label_kind, f"row {index}") for index in range(count)]

    def stepped(self, dq: np.ndarray, dt: float) -> None:
        """The step dq (over dt) was taken: a constraint with a memory updates it (default: none)."""

    def violation(self, kinematics: Kinematics) -> float:
        return 0.0

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class BoundConstraint(Constraint):
    """lower <= dq[index] <= upper."""

    label_kind = "bound"

    def rows(self, kinematics: Kinematics, dt: float) -> BoundRows:
        return self.bounds(kinematics, dt)

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        raise NotImplementedError

    def labels(self, kinematics: Kinematics, rows: Rows) -> list[tuple[RowLabel, RowLabel]]:
        """(lower, upper) labels per index of the bound rows: the tangent coordinate's name."""
        names = tangent_names(kinematics.model)
        indices = np.arange(kinematics.nv)[rows.index]
        lower, upper = (np.broadcast_to(np.asarray(v, dtype=float), indices.shape) for v in rows[1:])
        return [(RowLabel(self.name, self.label_kind, names[i], "lower", 0.0, float(low)),
                 RowLabel(self.name, self.label_kind, names[i], "upper", 0.0, float(high)))
                for i, low, high in zip(indices.tolist(), lower.tolist(), upper.tolist(), strict=True)]


class EqualityConstraint(Constraint):
    """A dq = b; the IK loop also projects its iterates onto these (Newton steps on e = 0)."""

    label_kind = "equality"

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


def tangent_names(model: pin.Model) -> list[str]:
    """A name per tangent coordinate (nv): a 1-DOF joint's name; "<joint> x" ... "<joint> rz" for a
    free flyer's six; "<joint>[i]" for another multi-DOF joint's."""
    names = [""] * model.nv
    for joint_id in range(1, model.njoints):
        joint, name = model.joints[joint_id], model.names[joint_id]
        if joint.nv == 1:
            names[joint.idx_v] = name
        else:
            axes = ("x", "y", "z", "rx", "ry", "rz") if joint.nv == 6 else None
            for offset in range(joint.nv):
                names[joint.idx_v + offset] = f"{name} {axes[offset]}" if axes else f"{name}[{offset}]"
    return names


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
    label_kind = "joint limit"

    def __init__(self, model: pin.Model, unbounded: Collection[str] = ()):
        self.q_index, self.v_index = bounded_joint_indices(model, unbounded)
        self.lower = model.lowerPositionLimit[self.q_index].copy()
        self.upper = model.upperPositionLimit[self.q_index].copy()
        self._q_rows, self._v_rows = as_index(self.q_index), as_index(self.v_index)

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        q = kinematics.q[self._q_rows]
        return BoundRows(self._v_rows, self.lower - q, self.upper - q)

    def labels(self, kinematics: Kinematics, rows: Rows) -> list[tuple[RowLabel, RowLabel]]:
        names = tangent_names(kinematics.model)
        q = kinematics.q[self.q_index]
        return [(RowLabel(self.name, self.label_kind, names[v], "lower", value, low, "rad"),
                 RowLabel(self.name, self.label_kind, names[v], "upper", value, high, "rad"))
                for v, value, low, high in zip(self.v_index.tolist(), q.tolist(), self.lower.tolist(),
                                               self.upper.tolist(), strict=True)]

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
    label_kind = "velocity limit"

    def __init__(self, model: pin.Model, velocity_limit: np.ndarray | None = None):
        limit = model.velocityLimit.copy() if velocity_limit is None else np.asarray(velocity_limit, float)
        if limit.shape != (model.nv,):
            raise ValueError(f"velocity limits need nv = {model.nv} values, got {limit.size}")
        self.v_index = np.flatnonzero(np.isfinite(limit) & (limit > 0) & (limit < 1e10))
        self.limit = limit[self.v_index]

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        step = self.limit * dt
        return BoundRows(self.v_index, -step, step)

    def labels(self, kinematics: Kinematics, rows: Rows) -> list[tuple[RowLabel, RowLabel]]:
        names = tangent_names(kinematics.model)
        return [(RowLabel(self.name, self.label_kind, names[v], "lower", math.nan, -limit, "rad/s"),
                 RowLabel(self.name, self.label_kind, names[v], "upper", math.nan, limit, "rad/s"))
                for v, limit in zip(self.v_index.tolist(), self.limit.tolist(), strict=True)]


class JointAccelerationLimits(BoundConstraint):
    """|dq/dt - v_prev| <= a_max dt on every joint with a positive finite acceleration limit, and
    room to brake before a position limit:

        dt (v_prev - a_max dt) <= dq <= dt (v_prev + a_max dt),
        -dt v_stop(q - q_min) <= dq <= dt v_stop(q_max - q)         (bounded 1-DOF joints)

    with v_stop(d) the largest velocity from which braking at a_max, one period at a time, stops within
    the distance d: the periods at v, v - a dt, v - 2 a dt, ... cover D(v) = dt sum_k max(v - k a dt, 0)
    (:func:`stopping_velocity` inverts it). Since D(v) = v dt + D(v - a dt), a velocity that could stop
    leaves one that can (v - a dt) after its period: the second line keeps each joint slow enough to stop
    before its limit, and the first line always meets it on the way there.

    ``v_prev`` (``velocity``, nv; zeros at first) is the previous step's dq / dt: the IK loop and
    ``IKProblem.step`` report every step taken to :meth:`stepped`; set ``velocity`` for a measured
    one. Bounding the change of velocity between control periods is what removes the chatter of an
    active set that switches from one period to the next near a constraint (PlaCo #7): near a joint
    limit at full stretch, velocity limits alone let a joint bounce off its limit at its velocity
    bound every period; ``benchmarks/chatter.py`` measures it.

    ``acceleration_limit``: rad/s^2 (m/s^2 for a prismatic joint), one value for every joint or nv
    values (inf or 0: none on that coordinate; the floating base has none unless given).
    """

    name = "joint acceleration limits"
    label_kind = "acceleration limit"

    def __init__(self, model: pin.Model, acceleration_limit: float | np.ndarray,
                 unbounded: Collection[str] = ()):
        limit = np.asarray(acceleration_limit, dtype=float)
        if limit.ndim == 0:
            limit = np.full(model.nv, float(limit))
            limit[:6 if model.njoints > 1 and model.joints[1].nv == 6 else 0] = np.inf
        if limit.shape != (model.nv,) or np.any(np.isnan(limit)) or np.any(limit < 0):
            raise ValueError(f"acceleration limits need one value >= 0 or nv = {model.nv} values >= 0, "
                             f"got {acceleration_limit!r}")
        self.v_index = np.flatnonzero(np.isfinite(limit) & (limit > 0))
        self.limit = limit[self.v_index]
        self.velocity = np.zeros(model.nv)
        q_index, v_index = bounded_joint_indices(model, unbounded)
        selected = np.isin(v_index, self.v_index)
        self._q_braking, self._v_braking = q_index[selected], v_index[selected]
        self._braking_rows = np.searchsorted(self.v_index, self._v_braking)
        self._lower = model.lowerPositionLimit[self._q_braking].copy()
        self._upper = model.upperPositionLimit[self._q_braking].copy()

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        previous = self.velocity[self.v_index]
        change = self.limit * dt
        lower, upper = (previous - change) * dt, (previous + change) * dt
        if self._q_braking.size:
            q = kinematics.q[self._q_braking]
            rows = self._braking_rows
            limit = self.limit[rows]
            upper[rows] = np.minimum(upper[rows], dt * stopping_velocity(self._upper - q, limit, dt))
            lower[rows] = np.maximum(lower[rows], -dt * stopping_velocity(q - self._lower, limit, dt))
        return BoundRows(self.v_index, lower, upper)

    def stepped(self, dq: np.ndarray, dt: float) -> None:
        self.velocity = np.asarray(dq, dtype=float) / dt

    def start(self, kinematics: Kinematics) -> None:
        if self.velocity.shape != (kinematics.nv,):
            self.velocity = np.zeros(kinematics.nv)

    def labels(self, kinematics: Kinematics, rows: Rows) -> list[tuple[RowLabel, RowLabel]]:
        names = tangent_names(kinematics.model)
        return [(RowLabel(self.name, self.label_kind, names[v], "lower", float(self.velocity[v]), -limit,
                          "rad/s^2"),
                 RowLabel(self.name, self.label_kind, names[v], "upper", float(self.velocity[v]), limit,
                          "rad/s^2"))
                for v, limit in zip(self.v_index.tolist(), self.limit.tolist(), strict=True)]


def stopping_velocity(distance: np.ndarray, acceleration: np.ndarray, dt: float) -> np.ndarray:
    """The largest v >= 0 with D(v) = dt sum_k max(v - k a dt, 0) <= distance (0 for distance <= 0):
    braking at ``acceleration`` a from v, one period dt at a time, stops within ``distance``.

    D is piecewise linear: on [n a dt, (n + 1) a dt), D(v) = dt ((n + 1) v - a dt n (n + 1) / 2), and
    D(n a dt) = a dt^2 n (n + 1) / 2, so n = floor((sqrt(1 + 8 d / (a dt^2)) - 1) / 2) and
    v = min((d / dt + a dt n (n + 1) / 2) / (n + 1), (n + 1) a dt)."""
    distance = np.maximum(np.asarray(distance, dtype=float), 0.0)
    step = acceleration * dt
    n = np.floor((np.sqrt(1.0 + 8.0 * distance / (step * dt)) - 1.0) / 2.0)
    return np.minimum((distance / dt + 0.5 * step * n * (n + 1.0)) / (n + 1.0), (n + 1.0) * step)


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

    label_kind = "contact"

    def error(self, kinematics: Kinematics) -> np.ndarray:
        return self._task.error(kinematics)

    def labels(self, kinematics: Kinematics, rows: Rows) -> list[RowLabel]:
        """Per axis (x, y, z, rx, ry, rz): the drift e of that axis (m or rad), held at 0."""
        error = self.error(kinematics)
        axes = ("x", "y", "z", "rx", "ry", "rz")[:len(error)]
        return [RowLabel(self.name, self.label_kind, self.frame, axis, float(value), 0.0,
                         "m" if index < 3 else "rad")
                for index, (axis, value) in enumerate(zip(axes, error.tolist(), strict=True))]

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

    label_kind = "contact"

    def error(self, kinematics: Kinematics) -> np.ndarray:
        return self._task.error(kinematics)

    def labels(self, kinematics: Kinematics, rows: Rows) -> list[RowLabel]:
        return [RowLabel(self.name, self.label_kind, self.frame, axis, float(value), 0.0, "m")
                for axis, value in zip("xyz", self.error(kinematics).tolist(), strict=True)]

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

    label_kind = "support polygon"

    def inequality(self, kinematics: Kinematics) -> InequalityRows:
        return InequalityRows(self.normals.dot(kinematics.com_jacobian()[:2]),
                              self.offsets - self.projected(kinematics))

    def labels(self, kinematics: Kinematics, rows: Rows) -> list[RowLabel]:
        """Per edge ("a-b" by its vertices' labels): the CoM's distance to it (m) and the margin."""
        inside = self.polygon.offsets - self.projected(kinematics)
        return [RowLabel(self.name, self.label_kind, self.polygon.edge_name(index), "", float(distance),
                         self.margin, "m") for index, distance in enumerate(inside.tolist())]

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

    label_kind = "distance"

    def labels(self, kinematics: Kinematics, rows: Rows) -> list[RowLabel]:
        return [RowLabel(self.name, self.label_kind, f"{self.frames[0]}-{self.frames[1]}", "",
                         self.current_distance(kinematics)[0], self.distance, "m")]

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

    label_kind = "locked joint"

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

    label_kind = "collision"

    def labels(self, kinematics: Kinematics, rows: Rows) -> list[RowLabel]:
        """Per pair within the influence distance: its distance (m) and the safety distance."""
        near = [pair for pair in self.distances(kinematics) if pair.distance < self.influence]
        if not near:
            return [RowLabel(self.name, self.label_kind, "no pair within the influence distance")]
        return [RowLabel(self.name, self.label_kind, f"{pair.a}-{pair.b}", "", float(pair.distance),
                         self.safety, "m") for pair in near]

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
