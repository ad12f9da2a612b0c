"""Method ``placo``: PlaCo's KinematicsSolver on a whole body, and PlaCo's forms of wbik's tasks and
constraints (:data:`wbik.qp.peers.PLACO`).

Tasks are PlaCo's own frame / relative frame / position / orientation / CoM / joints tasks, soft,
with our weights (a position or CoM task on some axes: PlaCo's axis mask); a regularisation is
PlaCo's regularisation task. Contacts are hard frame tasks (a point foot: a hard position task); the
CoM in the support polygon is PlaCo's CoM polygon constraint with the polygon clockwise (PlaCo's
convention) and configured hard (as benchmarks/qp.py does); joint limits and velocity limits are
PlaCo's (its ``dt`` the problem's ``step_dt``). PlaCo has no acceleration limits nor minimum
distances between frames here, and hard or soft tasks only (no strict priority levels). One
``solve(True)`` per iteration of our loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from wbik.qp.constraints import CoMInSupportPolygon
from wbik.qp.constraints import Contact
from wbik.qp.constraints import JointAccelerationLimits
from wbik.qp.constraints import JointPositionLimits
from wbik.qp.constraints import JointVelocityLimits
from wbik.qp.constraints import MinimumDistance
from wbik.qp.constraints import PointContact
from wbik.qp.kinematics import Kinematics
from wbik.qp.peers import PLACO
from wbik.qp.peers import frame_weights
from wbik.qp.peers import largest_weight
from wbik.qp.tasks import ComTask
from wbik.qp.tasks import FrameTask
from wbik.qp.tasks import OrientationTask
from wbik.qp.tasks import PositionTask
from wbik.qp.tasks import PostureTask
from wbik.qp.tasks import RegularizationTask
from wbik.qp.tasks import RelativeFrameTask
from wbik.robot import Robot
from wbik.wholebody.methods import WholeBodyMethod
from wbik.wholebody.solvers import PeerWholeBody

__all__ = ["WHOLEBODY_METHODS", "PlacoProblem", "PlacoWholeBody", "clockwise"]


@dataclass
class PlacoProblem:
    """What PlaCo's forms add to: its ``solver`` (a placo.KinematicsSolver), the PlaCo robot
    (``wrapper``), our ``robot``, its ``kinematics`` at the start and the step ``dt`` (s)."""

    solver: Any
    wrapper: Any
    robot: Robot
    kinematics: Kinematics
    dt: float


def clockwise(polygon) -> list[np.ndarray]:
    """The polygon's vertices clockwise, as PlaCo's CoMPolygonConstraint wants them (wbik stores them
    counter-clockwise); the same rule as benchmarks/qp.py ``placo_polygon``."""
    vertices = [np.array(v, dtype=float) for v in polygon.vertices]
    x, y = np.array([v[0] for v in vertices]), np.array([v[1] for v in vertices])
    area = 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    return vertices[::-1] if area > 0 else vertices


def _soft_on_axes(added, task) -> None:
    """Configure PlaCo's position or CoM task ``added`` as ``task``: soft, its weight, masked to the
    axes it holds (PlaCo's masks name them "xz", ...)."""
    added.mask.set_axises("".join("xyz"[i] for i in task.rows))
    added.configure(task.name, "soft", largest_weight(task, 1.0))


# -- PlaCo's forms of the tasks -------------------------------------------------------------------------
@PLACO.form(FrameTask)
def _frame(task: FrameTask, placo: PlacoProblem) -> None:
    placo.solver.add_frame_task(task.frame, task.target.homogeneous).configure(task.name, "soft",
                                                                              *frame_weights(task))


@PLACO.form(RelativeFrameTask)
def _relative(task: RelativeFrameTask, placo: PlacoProblem) -> None:
    added = placo.solver.add_relative_frame_task(task.reference_frame, task.frame, task.target.homogeneous)
    added.configure(task.name, "soft", *frame_weights(task))


@PLACO.form(PositionTask)
def _position(task: PositionTask, placo: PlacoProblem) -> None:
    target = placo.kinematics.placement(task.frame_id).translation.copy()  # the start's, on the free axes
    target[task.rows] = task.target[task.rows]
    _soft_on_axes(placo.solver.add_position_task(task.frame, target), task)


@PLACO.form(OrientationTask)
def _orientation(task: OrientationTask, placo: PlacoProblem) -> None:
    placo.solver.add_orientation_task(task.frame, task.target).configure(task.name, "soft",
                                                                        largest_weight(task, 1.0))


@PLACO.form(ComTask)
def _com(task: ComTask, placo: PlacoProblem) -> None:
    _soft_on_axes(placo.solver.add_com_task(task.target.copy()), task)


@PLACO.form(PostureTask)
def _posture(task: PostureTask, placo: PlacoProblem) -> None:
    model = placo.robot.model
    names = task.joint_names or [model.names[j] for j in range(1, model.njoints) if model.joints[j].nq == 1]
    joints = {name: float(task.reference[model.joints[model.getJointId(name)].idx_q]) for name in names}
    added = placo.solver.add_joints_task()
    added.set_joints(joints)
    added.configure(task.name, "soft", largest_weight(task, 1e-3))


@PLACO.form(RegularizationTask)
def _regularization(task: RegularizationTask, placo: PlacoProblem) -> None:
    placo.solver.add_regularization_task(largest_weight(task, 1e-6))


# -- and of the constraints -----------------------------------------------------------------------------
@PLACO.form(Contact)
def _contact(contact: Contact, placo: PlacoProblem) -> None:
    placo.solver.add_frame_task(contact.frame, contact.placement.homogeneous).configure(contact.name, "hard",
                                                                                       1.0, 1.0)


@PLACO.form(PointContact)
def _point_contact(contact: PointContact, placo: PlacoProblem) -> None:
    added = placo.solver.add_position_task(contact.frame, contact.position.copy())
    added.configure(contact.name, "hard", 1.0)


@PLACO.form(CoMInSupportPolygon)
def _com_polygon(constraint: CoMInSupportPolygon, placo: PlacoProblem) -> None:
    added = placo.solver.add_com_polygon_constraint(clockwise(constraint.polygon), constraint.margin)
    added.configure("com_polygon", "hard", 1.0)


@PLACO.form(JointPositionLimits)
def _position_limits(limits: JointPositionLimits, placo: PlacoProblem) -> None:
    placo.solver.enable_joint_limits(True)


@PLACO.form(JointVelocityLimits)
def _velocity_limits(limits: JointVelocityLimits, placo: PlacoProblem) -> None:
    """|dq| <= limit per step (dt 1): PlaCo's velocity limits limit / dt over its step dt."""
    names = _tangent_joint_names(placo.robot.model)
    for index, limit in zip(limits.v_index.tolist(), limits.limit.tolist(), strict=True):
        if index in names:
            placo.wrapper.set_velocity_limit(names[index], limit / placo.dt)
    placo.solver.dt = placo.dt
    placo.solver.enable_velocity_limits(True)


def _tangent_joint_names(model: pin.Model) -> dict[int, str]:
    """{tangent index: joint name} of the 1-DOF joints."""
    return {model.joints[j].idx_v: model.names[j] for j in range(1, model.njoints) if model.joints[j].nv == 1}


PLACO.cannot(JointAccelerationLimits, "PlaCo 0.10 has none here; solved with position and velocity limits "
                                      "only")
PLACO.cannot(MinimumDistance, "no minimum distance between frame origins in PlaCo here; solved without it")


# -- the method -----------------------------------------------------------------------------------------
class PlacoWholeBody(PeerWholeBody):
    """PlaCo's KinematicsSolver with its own tasks, hard contacts and hard clockwise CoM polygon."""

    name = "placo"
    # the budget's unit: solve(True), read-back, convergence FK (measured: docs/measurements.md, wholebody)
    iteration_cost_s = 300e-6
    default_budget_s = 0.08
    forms = PLACO
    priorities = "PlaCo: hard or soft only; all tasks soft"

    def __init__(self, robot, *, regularization: float = 1e-6, **options):
        from wbik.solvers.placo import import_placo

        super().__init__(robot, **options)
        self.placo = import_placo()
        self.regularization = float(regularization)
        self._thread_state()  # this thread's PlaCo robot now (errors show here, its cost is not a solve's)

    def _new_thread_state(self):
        """This thread's PlaCo robot (loading the URDF costs milliseconds; a solver is built per call)."""
        from wbik.solvers.placo import placo_robot

        return placo_robot(self.robot)

    def _solve(self, problem, q0, placements, polygon, deadline):
        from wbik.solvers.placo import placo_configuration
        from wbik.solvers.placo import set_placo_configuration

        robot = self.robot
        wrapper = self._thread_state()
        set_placo_configuration(robot, wrapper, q0)
        solver = self.placo.KinematicsSolver(wrapper)
        if not robot.has_floating_base:
            solver.mask_fbase(True)
        tasks, kinematics = self.started_tasks(problem, q0)
        self.translate(self.items(problem, tasks, placements, polygon),
                       PlacoProblem(solver, wrapper, robot, kinematics, problem.step_dt))
        solver.add_regularization_task(self.regularization)

        def step(q: np.ndarray) -> tuple[np.ndarray, str]:
            try:
                solver.solve(True)
            except RuntimeError as exc:
                return q, f"PlaCo's QP failed: {exc}"
            wrapper.update_kinematics()
            previous, q = q, placo_configuration(robot, wrapper)
            if float(np.max(np.abs(pin.difference(robot.model, previous, q)))) < 1e-12:
                return q, "stalled: PlaCo's steps no longer move the robot"
            return q, ""

        return self._peer_loop(step, q0.copy(), deadline, problem, kinematics, tasks, placements, polygon)


WHOLEBODY_METHODS = (
    WholeBodyMethod(
        "placo", PlacoWholeBody,
        "PlaCo 0.10 KinematicsSolver: its tasks, hard contacts, hard clockwise CoM polygon, limits",
    ),
)
"""The method this module declares (registered through wbik.wholebody.methods.METHOD_MODULES)."""
