"""Task-based QP inverse kinematics on Pinocchio (whole body, floating base included).

>>> from wbik.qp import IKProblem, FrameTask, Contact, CoMInSupportPolygon, JointPositionLimits
>>> problem = IKProblem(robot.model, [FrameTask("r_hand", target)], [JointPositionLimits(robot.model)])
>>> solution = problem.solve(robot.nominal)        # iterate to convergence (IK)
>>> dq = problem.step(q, dt=0.01)                   # or one QP step (control), v = dq / dt

Modules: ``kinematics`` (model + data at one q), ``tasks``, ``constraints``, ``support_polygon``,
``backends`` (qpsolvers names, "fastest"), ``problem`` (the QP and the IK loop), ``humanoid``
(contact/balance helpers for robots that list sole corners).
"""

from wbik.qp.backends import available as available_backends
from wbik.qp.constraints import (
    CoMInSupportPolygon,
    Constraint,
    Contact,
    JointPositionLimits,
    JointVelocityLimits,
    MinimumDistance,
)
from wbik.qp.kinematics import Kinematics
from wbik.qp.problem import IKProblem, QPSolution
from wbik.qp.support_polygon import SupportPolygon, convex_hull, feet_support_polygon
from wbik.qp.tasks import (
    ComTask,
    FrameTask,
    OrientationTask,
    PositionTask,
    PostureTask,
    RegularizationTask,
    RelativeFrameTask,
    Task,
)

__all__ = [
    "CoMInSupportPolygon", "ComTask", "Constraint", "Contact", "FrameTask", "IKProblem",
    "JointPositionLimits", "JointVelocityLimits", "Kinematics", "MinimumDistance", "OrientationTask",
    "PositionTask", "PostureTask", "QPSolution", "RegularizationTask", "RelativeFrameTask",
    "SupportPolygon", "Task", "available_backends", "convex_hull", "feet_support_polygon",
]
