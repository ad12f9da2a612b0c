"""Two QP terms for riveting, on top of :mod:`wbik.qp`: the 5-D tool-axis task and the workpiece
clearance constraint.

ToolAxisTask (5 rows): the tool is a cylinder, so rotation about its axis is free. With p the tcp
position, z the tool axis (tcp z) and (x*, y*, z*) the target frame's axes,

    e = [p - p*;  x* . z;  y* . z]

is zero exactly when the tcp is at p* and z is parallel to z* (the sign is checked separately:
z . z* > 0). Since dz/dt = w x z, d(x* . z) = x* . (w x z) = (z x x*) . w, so the Jacobian rows are
[J_v; (z x x*)^T J_w; (z x y*)^T J_w].

WorkpieceClearance: for each robot geometry whose exact distance d to the workpiece is under
``activation``, with p its nearest point and n the unit direction away from the workpiece,

    d + n^T J_p dq >= d_min + safety   <=>   -n^T J_p dq <= d - d_min - safety,

J_p = J_v(joint) - [p - o_joint]x J_w(joint) (the velocity of the material point p).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.apps.riveting.collision import CollisionModel
from wbik.qp.constraint import InequalityConstraint
from wbik.qp.kinematics import LWA
from wbik.qp.kinematics import Kinematics
from wbik.qp.rows import InequalityRows
from wbik.qp.tasks import Task


class ToolAxisTask(Task):
    """tcp at a point with its z axis along a direction; roll about the axis free (5 rows)."""

    dimension = 5

    def __init__(self, frame: str, target: pin.SE3, **options):
        self.frame = frame
        self.frame_id = -1
        options.setdefault("name", f"ToolAxisTask[{frame}]")
        super().__init__(**options)
        self.target = target.copy()

    def start(self, kinematics: Kinematics) -> None:
        self.frame_id = kinematics.frame_id(self.frame)

    def error(self, kinematics: Kinematics) -> np.ndarray:
        placement = kinematics.placement(self.frame_id)
        axis = placement.rotation[:, 2]
        target_rotation = self.target.rotation
        return np.r_[placement.translation - self.target.translation,
                     target_rotation[:, 0] @ axis, target_rotation[:, 1] @ axis]

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        placement = kinematics.placement(self.frame_id)
        jacobian = kinematics.jacobian(self.frame_id)
        axis = placement.rotation[:, 2]
        target_rotation = self.target.rotation
        rows = np.vstack((np.cross(axis, target_rotation[:, 0]), np.cross(axis, target_rotation[:, 1])))
        return np.vstack((jacobian[:3], rows @ jacobian[3:]))


class WorkpieceClearance(InequalityConstraint):
    """Every robot geometry at least ``minimum`` (m) from the workpiece (linearised, see module notes).

    ``skip``: geometry names left out (the pin while it goes into its hole).
    """

    def __init__(self, collision: CollisionModel, minimum: float, skip: tuple[str, ...] = (),
                 activation: float = 0.05, safety: float = 5e-4):
        self.collision = collision
        self.minimum = float(minimum)
        self.skip = tuple(skip)
        self.activation = float(activation)
        self.safety = float(safety)
        self.name = f"workpiece clearance >= {minimum * 1e3:g} mm"

    def _distances(self, kinematics: Kinematics):
        clearance = self.collision.clearance(kinematics.q, table=False, skip=self.skip)
        return [d for d in clearance.workpiece if d.exact and d.distance < self.activation]

    def inequality(self, kinematics: Kinematics) -> InequalityRows:
        rows, bounds = [], []
        model, data = kinematics.model, kinematics.data
        for item in self._distances(kinematics):
            jacobian = pin.getJointJacobian(model, data, item.joint, LWA)
            origin = data.oMi[item.joint].translation
            point_jacobian = jacobian[:3] - pin.skew(item.robot_point - origin) @ jacobian[3:]
            rows.append(-(item.direction @ point_jacobian))
            bounds.append(item.distance - self.minimum - self.safety)
        if not rows:
            return InequalityRows(np.zeros((1, kinematics.nv)), np.ones(1))
        return InequalityRows(np.array(rows), np.array(bounds))

    def violation(self, kinematics: Kinematics) -> float:
        distances = [d.distance for d in self._distances(kinematics)]
        return max(self.minimum - min(distances), 0.0) if distances else 0.0
