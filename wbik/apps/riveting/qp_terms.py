"""Two QP terms for riveting.

ToolAxisTask: e = [p - p*; x* . z; y* . z] (tcp position p, tool axis z, target axes x*, y*; roll free),
Jacobian [J_v; (z x x*)^T J_w; (z x y*)^T J_w]. WorkpieceClearance: each geometry at exact distance d <
``activation``, nearest point p, unit direction n away, keeps -n^T J_p dq <= d - d_min - safety, J_p the
velocity Jacobian of the material point p."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.apps.riveting.collision import CollisionModel
from wbik.qp.constraint import InequalityConstraint
from wbik.qp.kinematics import LWA, Kinematics
from wbik.qp.rows import InequalityRows
from wbik.qp.tasks import Task


class ToolAxisTask(Task):
    """tcp at a point with its z axis along a direction; roll about the axis free (5 rows)."""

    dimension = 5

    def __init__(self, frame: str, target: pin.SE3, **options):
        self.frame, self.frame_id = frame, -1
        options.setdefault("name", f"ToolAxisTask[{frame}]")
        super().__init__(**options)
        self.target = target.copy()

    def start(self, kinematics: Kinematics) -> None:
        self.frame_id = kinematics.frame_id(self.frame)

    def error(self, kinematics: Kinematics) -> np.ndarray:
        placement = kinematics.placement(self.frame_id)
        z, target = placement.rotation[:, 2], self.target.rotation
        return np.r_[placement.translation - self.target.translation, target[:, 0] @ z, target[:, 1] @ z]

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        jacobian = kinematics.jacobian(self.frame_id)
        axis, target = kinematics.placement(self.frame_id).rotation[:, 2], self.target.rotation
        rows = np.cross(axis, target[:, :2].T)
        return np.vstack((jacobian[:3], rows @ jacobian[3:]))


class WorkpieceClearance(InequalityConstraint):
    """Every robot geometry but ``skip`` at least ``minimum`` (m) from the workpiece (module notes)."""

    def __init__(self, collision: CollisionModel, minimum: float, skip: tuple[str, ...] = (),
                 activation: float = 0.05, safety: float = 5e-4):
        self.collision, self.minimum, self.skip = collision, float(minimum), tuple(skip)
        self.activation, self.safety = float(activation), float(safety)
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
        return (InequalityRows(np.array(rows), np.array(bounds)) if rows
                else InequalityRows(np.zeros((1, kinematics.nv)), np.ones(1)))

    def violation(self, kinematics: Kinematics) -> float:
        distances = [d.distance for d in self._distances(kinematics)]
        return max(self.minimum - min(distances), 0.0) if distances else 0.0
