"""Task-based QP inverse kinematics on Pinocchio (whole body, floating base included).

>>> from wbik.qp import IKProblem, FrameTask, Contact, CoMInSupportPolygon, JointPositionLimits
>>> problem = IKProblem(robot.model, [FrameTask("r_hand", target)], [JointPositionLimits()])
>>> solution = problem.solve(robot.nominal)        # iterate to convergence (IK)
>>> dq = problem.step(q, dt=0.01)                   # or one QP step (control), v = dq / dt
>>> # (a step whose constraints conflict raises wbik.errors.NoQPSolutionError with the backend's status)
>>> # self-collision / environment: CollisionAvoidance(wbik.collision.robot_collision_model(robot), 0.02)

Modules: ``kinematics`` (model + data at one q), ``tasks``, ``rows`` (the typed rows a constraint
contributes: EqualityRows, InequalityRows, BoundRows; RowLabel names a row), ``constraint`` (what every
constraint is: its rows, its measure for the shared check, its words), the constraints ``limits``,
``contacts``, ``balance`` and ``distances``,
``support_polygon``, ``backends`` (qpsolvers names, "fastest"; DAQP on reused buffers), ``step`` (one
QP step: any number of priority levels of equality and inequality tasks), ``problem`` (the IK loop:
IKProblem), ``humanoid`` (contact/balance helpers for robots that list sole corners); when a solve
fails: ``hard_rows`` (a step's rows, each labelled), ``elastic`` (the rows of an infeasible step that
conflict), ``diagnosis`` (what blocks the goals at the answer, what conflicts with them, what to do).

Where ours differs from PlaCo (the reference, method ``placo``):
- Contacts: both make them equality rows of every step (PlaCo: a "hard" frame task), so a step's
  contact drift is of second order and the next step removes it; ours add Newton projections where
  that is not enough (from q0, a rejected step, goals met first, a best-effort answer), converge
  only with every contact within 1e-10, and verify the answer by FK.
- Support polygon: both use the linearised CoM rows against the polygon shrunk by the margin;
  ours add a few micrometres of safety and reject (by FK) a step whose CoM breaks the margin.
- Priorities: PlaCo has hard/soft; ours have weights plus strict levels (a QP per level; each keeps
  what the levels above achieved to 1e-10 per row), equality and inequality tasks alike.
- Failures: ours say what blocks the goals (the active constraints by name, the tasks in conflict,
  ranked by how much they hold the goals back) and which rows of an infeasible step conflict.
- Acceleration limits (JointAccelerationLimits) with room to brake before the joint limits.
- The IK loop: a trust region with merit acceptance and best-effort stall detection (PlaCo's
  solve() is one step; the loop is the caller's). No walk pattern generator here: PlaCo's
  WalkPatternGenerator / LIPM stay the reference for gait.
"""

from wbik.qp.backends import available as available_backends
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.constraint import BoundConstraint
from wbik.qp.constraint import Constraint
from wbik.qp.constraint import EqualityConstraint
from wbik.qp.constraint import InequalityConstraint
from wbik.qp.contacts import Contact
from wbik.qp.contacts import PointContact
from wbik.qp.diagnosis import Diagnosis
from wbik.qp.distances import CollisionAvoidance
from wbik.qp.distances import MinimumDistance
from wbik.qp.kinematics import Kinematics
from wbik.qp.limits import JointAccelerationLimits
from wbik.qp.limits import JointPositionLimits
from wbik.qp.limits import JointVelocityLimits
from wbik.qp.limits import LockedJoints
from wbik.qp.problem import IKProblem
from wbik.qp.problem import QPSolution
from wbik.qp.rows import BoundRows
from wbik.qp.rows import EqualityRows
from wbik.qp.rows import InequalityRows
from wbik.qp.rows import RowLabel
from wbik.qp.support_polygon import DegenerateSupport
from wbik.qp.support_polygon import DegenerateSupportPolygonError
from wbik.qp.support_polygon import SupportPolygon
from wbik.qp.support_polygon import convex_hull
from wbik.qp.support_polygon import feet_support_polygon
from wbik.qp.tasks import ComBoxTask
from wbik.qp.tasks import ComTask
from wbik.qp.tasks import FrameTask
from wbik.qp.tasks import OrientationTask
from wbik.qp.tasks import PositionBoxTask
from wbik.qp.tasks import PositionTask
from wbik.qp.tasks import PostureTask
from wbik.qp.tasks import RegularizationTask
from wbik.qp.tasks import RelativeFrameTask
from wbik.qp.tasks import Task

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
