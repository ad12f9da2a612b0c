"""Method ``placo``: PlaCo's KinematicsSolver on the robot's URDF (without geometry), and PlaCo's forms of
wbik's tasks and constraints (:data:`PLACO`): soft tasks with our weights, hard contacts, the hard CoM
polygon, its limits, locked joints masked; no acceleration limits, minimum distances or priority levels.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from wbik.dependencies import PLACO_LIBRARY, import_optional
from wbik.errors import RobotDescriptionError
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.contacts import Contact, PointContact
from wbik.qp.distances import MinimumDistance
from wbik.qp.kinematics import Kinematics
from wbik.qp.limits import JointAccelerationLimits, JointPositionLimits, JointVelocityLimits, LockedJoints
from wbik.qp.peers import PeerForms, frame_weights, largest_weight
from wbik.qp.tasks import (
    ComTask,
    FrameTask,
    OrientationTask,
    PositionTask,
    PostureTask,
    RegularizationTask,
    RelativeFrameTask,
)
from wbik.robot import Robot, write_cached_urdf
from wbik.solvers.method import IKMethod
from wbik.solvers.peer import PeerSolver
from wbik.solvers.result import Candidate
from wbik.urdf import continuous_as_revolute, fixed_joints_renamed
from wbik.wholebody.problem import StartedProblem


def import_placo(what: str = "method 'placo'"):
    """The placo module, or MissingDependencyError naming ``what`` needs it and the extra to install."""
    return import_optional(PLACO_LIBRARY, what, "placo")


PLACO_CONTINUOUS_LIMIT = 100.0  # rad, a continuous joint's limits in PlaCo: 16 turns, never binding
_GEOMETRY = re.compile(r"<(visual|collision)\b[^>]*?/>|<(visual|collision)\b.*?</\2\s*>", re.DOTALL)


@lru_cache(maxsize=32)
def _kinematic_urdf(name: str, text: str) -> Path:
    # a regular expression: URDF readers accept files a strict XML parser rejects ("--" in comments);
    # one angle per continuous joint and fixed joints named like a link renamed, as in wbik's model
    text = fixed_joints_renamed(continuous_as_revolute(_GEOMETRY.sub("", text), PLACO_CONTINUOUS_LIMIT))
    return write_cached_urdf(f"{name}-kinematic", text)


def kinematic_urdf_path(robot: Robot) -> Path:
    """A copy of the robot's URDF without meshes or primitive geometry (kinematics and inertias kept)."""
    return _kinematic_urdf(robot.name, robot.urdf_text)


def placo_robot(robot: Robot, q: np.ndarray | None = None, humanoid_urdf: Path | None = None):
    """A placo.RobotWrapper of the robot's kinematic URDF at q (default: nominal), base pose included; with
    ``humanoid_urdf``, a placo.HumanoidRobot of that URDF (with the frames PlaCo's humanoid looks for)."""
    placo = import_placo()
    model, path = ((placo.RobotWrapper, kinematic_urdf_path(robot)) if humanoid_urdf is None
                   else (placo.HumanoidRobot, humanoid_urdf))
    try:
        wrapper = model(str(path), placo.Flags.ignore_collisions)
    except RuntimeError as exc:
        raise RobotDescriptionError(f"PlaCo cannot load {robot.name!r}: {exc}") from exc
    set_placo_configuration(robot, wrapper, robot.nominal if q is None else q)
    return wrapper


def set_placo_configuration(robot: Robot, wrapper, q: np.ndarray) -> None:
    """Copy a full wbik configuration into PlaCo (joint by joint, by name; base pose if floating)."""
    model = robot.model
    wrapper.set_T_world_fbase(pin.XYZQUATToSE3(q[:7]).homogeneous if robot.has_floating_base else np.eye(4))
    for joint_id in range(1, model.njoints):
        joint = model.joints[joint_id]
        if joint.nq == 1:
            wrapper.set_joint(model.names[joint_id], float(q[joint.idx_q]))
    wrapper.update_kinematics()


def placo_configuration(robot: Robot, wrapper) -> np.ndarray:
    """The wbik full configuration of a PlaCo robot state."""
    q = robot.nominal.copy()
    model = robot.model
    if robot.has_floating_base:
        q[:7] = pin.SE3ToXYZQUAT(pin.SE3(wrapper.get_T_world_fbase()))
    for joint_id in range(1, model.njoints):
        joint = model.joints[joint_id]
        if joint.nq == 1:
            q[joint.idx_q] = wrapper.get_joint(model.names[joint_id])
    return q


PLACO = PeerForms("placo", "PlaCo")  # PlaCo's forms of tasks and constraints (a user's: @PLACO.form(MyTask))


@dataclass
class PlacoProblem:
    """What PlaCo's forms add to: its solver, robot (``wrapper``), our robot, the start, step ``dt`` (s)."""

    solver: Any
    wrapper: Any
    robot: Robot
    kinematics: Kinematics
    dt: float


def clockwise(polygon) -> list[np.ndarray]:
    """The polygon's vertices clockwise, as PlaCo's CoMPolygonConstraint wants them."""
    vertices = np.array(polygon.vertices, dtype=float)
    x, y = vertices[:, 0], vertices[:, 1]
    area = 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    return list(vertices[::-1] if area > 0 else vertices)


def _soft_on_axes(added, task) -> None:
    """Configure PlaCo's position or CoM task ``added`` as ``task``: soft, its weight, its axes masked."""
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
    model = placo.robot.model
    names = {model.joints[j].idx_v: model.names[j] for j in range(1, model.njoints)
             if model.joints[j].nv == 1}
    for index, limit in zip(limits.v_index.tolist(), limits.step_limit.tolist(), strict=True):
        if index in names:
            placo.wrapper.set_velocity_limit(names[index], limit / placo.dt)
    placo.solver.dt = placo.dt
    placo.solver.enable_velocity_limits(True)


@PLACO.form(LockedJoints)
def _locked(locked: LockedJoints, placo: PlacoProblem) -> None:
    model = placo.robot.model
    for name in locked.joints:
        if model.joints[model.getJointId(name)].nv == 6:
            placo.solver.mask_fbase(True)
        else:
            placo.solver.mask_dof(name)


PLACO.cannot(JointAccelerationLimits, "PlaCo 0.10 has none here; solved with position and velocity limits "
                                      "only")
PLACO.cannot(MinimumDistance, "no minimum distance between frame origins in PlaCo here; solved without it")


# -- the method -----------------------------------------------------------------------------------------
class PlacoSolver(PeerSolver):
    """PlaCo's KinematicsSolver with its own tasks, hard contacts and hard clockwise CoM polygon."""

    name = "placo"
    # solve(True), read-back, convergence FK, on an arm, on a humanoid (docs/measurements.md)
    iteration_cost_s = 40e-6
    default_budget_s = 0.005
    problem_iteration_cost_s = 300e-6
    problem_budget_s = 0.08
    forms = PLACO
    priorities = "PlaCo: hard or soft only; all tasks soft"

    def __init__(self, robot, chain=None, *, regularization: float = 1e-6, **options):
        super().__init__(robot, chain, **options)
        self.placo = import_placo()
        self.regularization = float(regularization)
        self._thread_state()  # this thread's PlaCo robot now (errors show here, not in a solve)

    def _new_thread_state(self):
        """This thread's PlaCo robot (loading the URDF costs milliseconds)."""
        return placo_robot(self.robot)

    def _solve_problem(self, started: StartedProblem, deadline: float, max_iterations: int) -> Candidate:
        robot = self.robot
        wrapper = self._thread_state()
        set_placo_configuration(robot, wrapper, started.q0)
        solver = self.placo.KinematicsSolver(wrapper)
        if not robot.has_floating_base:
            solver.mask_fbase(True)
        self.translate(started, PlacoProblem(solver, wrapper, robot, started.kinematics,
                                             started.problem.step_dt))
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

        return self._peer_loop(step, started, deadline, max_iterations)


IK_METHODS = (
    IKMethod("placo", PlacoSolver,
             "PlaCo 0.10 KinematicsSolver on the same URDF: chain targets; whole bodies with its tasks, hard "
             "contacts, hard clockwise CoM polygon, limits",
             needs=PLACO_LIBRARY),
)
