"""Task-based QP inverse kinematics on Pinocchio (whole body, floating base included).

>>> problem = IKProblem(robot.model, [FrameTask("r_hand", target)], [JointPositionLimits()])
>>> solution = problem.solve(robot.nominal)        # iterate to convergence (IK)
>>> dq = problem.step(q, dt=0.01)                   # or one QP step (control), v = dq / dt

Against PlaCo (method ``placo``, the reference): contacts are equality rows of every step in both, ours
add Newton projections, converge only with every contact within 1e-10 and verify the answer by FK; the
CoM rows against the shrunk polygon get a few micrometres of safety and an FK check; priorities are strict
levels (a QP each, keeping the levels above to 1e-10) besides weights, for equality and inequality tasks
alike; a failure says what blocks the goals and which rows conflict; acceleration limits leave room to
brake; the IK loop is a trust region with merit acceptance (PlaCo's solve() is one step). PlaCo's walk
pattern generator stays the reference for gait.
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
    "MinimumDistance",
    "OrientationTask", "PointContact", "PositionBoxTask", "PositionTask", "PostureTask", "QPSolution",
    "RegularizationTask", "RelativeFrameTask", "RowLabel", "SupportPolygon", "Task", "available_backends",
    "convex_hull", "feet_support_polygon",
]
