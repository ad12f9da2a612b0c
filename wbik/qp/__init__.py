"""Task-based QP inverse kinematics on Pinocchio (whole body, floating base included).

>>> problem = IKProblem(robot.model, [FrameTask("r_hand", target)], [JointPositionLimits()])
>>> solution = problem.solve(robot.nominal)        # iterate to convergence (IK)
>>> dq = problem.step(q, dt=0.01)                   # or one QP step (control), v = dq / dt

Priorities are strict levels (a QP each) besides weights; contacts are held by Newton projections and
every answer is verified by FK.
"""

from wbik.qp.backends import available as available_backends
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.constraint import BoundConstraint, Constraint, EqualityConstraint, InequalityConstraint
from wbik.qp.contacts import Contact, PointContact
from wbik.qp.diagnosis import Diagnosis
from wbik.qp.distances import CollisionAvoidance, MinimumDistance
from wbik.qp.kinematics import Kinematics
from wbik.qp.limits import JointAccelerationLimits, JointPositionLimits, JointVelocityLimits, LockedJoints
from wbik.qp.problem import IKProblem, QPSolution
from wbik.qp.rows import BoundRows, EqualityRows, InequalityRows, RowLabel
from wbik.qp.support_polygon import (
    DegenerateSupport,
    DegenerateSupportPolygonError,
    SupportPolygon,
    convex_hull,
    feet_support_polygon,
)
from wbik.qp.tasks import (
    ComBoxTask,
    ComTask,
    FrameTask,
    OrientationTask,
    PositionBoxTask,
    PositionTask,
    PostureTask,
    RegularizationTask,
    RelativeFrameTask,
    Task,
)

__all__ = [
    "BoundConstraint", "BoundRows", "CoMInSupportPolygon", "CollisionAvoidance", "ComBoxTask", "ComTask",
    "Constraint", "Contact", "DegenerateSupport", "DegenerateSupportPolygonError", "Diagnosis",
    "EqualityConstraint", "EqualityRows", "FrameTask", "IKProblem", "InequalityConstraint", "InequalityRows",
    "JointAccelerationLimits", "JointPositionLimits", "JointVelocityLimits", "Kinematics", "LockedJoints",
    "MinimumDistance", "OrientationTask", "PointContact", "PositionBoxTask", "PositionTask", "PostureTask",
    "QPSolution", "RegularizationTask", "RelativeFrameTask", "RowLabel", "SupportPolygon", "Task",
    "available_backends", "convex_hull", "feet_support_polygon",
]
