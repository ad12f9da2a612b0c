"""Method ``pink``: pin-pink 4.4's differential IK, and Pink's forms of wbik's tasks and constraints
(:data:`PINK`; costs the square roots of our weights, contacts and locked joints equality constraints). No
hard CoM polygon, acceleration limits, minimum distances or strict priority levels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbik.dependencies import PINK_LIBRARY, import_optional
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.contacts import PointContact
from wbik.qp.distances import MinimumDistance
from wbik.qp.limits import JointAccelerationLimits, JointPositionLimits, JointVelocityLimits, LockedJoints
from wbik.qp.peers import PeerForms, largest_weight
from wbik.qp.tasks import PositionTask, PostureTask
from wbik.solvers.method import IKMethod
from wbik.solvers.peer import (
    NO_POLYGON,
    PeerSolver,
    SolveIKProblem,
    axis_costs,
    solve_ik_forms,
    stalled,
)
from wbik.solvers.result import Candidate
from wbik.wholebody.problem import StartedProblem

__all__ = ["IK_METHODS", "PinkProblem", "PinkSolver", "pink_locked_joints", "pink_point_contact"]


# Pink's forms of tasks and constraints (a user's: @PINK.form(MyTask)); the shared ones in solve_ik_forms
PINK = solve_ik_forms(PeerForms("pink", "Pink"))


@dataclass
class PinkProblem(SolveIKProblem):
    """What Pink's forms add to, with the robot's ``model``."""

    model: pin.Model = field(kw_only=True)

    def frame_task(self, frame: str, target: pin.SE3, position_cost, orientation_cost,
                   reference: str | None = None):
        from pink.tasks import FrameTask as PinkFrameTask
        from pink.tasks import RelativeFrameTask as PinkRelativeFrameTask

        costs = {"position_cost": position_cost, "orientation_cost": orientation_cost}
        added = (PinkFrameTask(frame, **costs) if reference is None
                 else PinkRelativeFrameTask(frame, reference, **costs))
        added.set_target(target)
        return added

    def com_task(self, cost: np.ndarray):
        from pink.tasks import ComTask as PinkComTask

        return PinkComTask(cost=cost)


# -- Pink's forms of the tasks and constraints ------------------------------------------------------------
@PINK.form(PositionTask)
def _position(task: PositionTask, pink: PinkProblem) -> None:
    """A FrameTask with cost on the task's axes only, the start's rotation as the (costless) target's."""
    start = pink.kinematics.placement(task.frame_id)
    translation = start.translation.copy()
    translation[task.rows] = task.target[task.rows]
    cost = axis_costs(task, largest_weight(task, 1.0))
    pink.tasks.append(pink.frame_task(task.frame, pin.SE3(start.rotation.copy(), translation), cost, 0.0))


@PINK.form(PostureTask)
def _posture(task: PostureTask, pink: PinkProblem) -> None:
    """Pink's posture holds every tangent row but the root joint's: the task's weights on its own rows."""
    from pink.tasks import PostureTask as PinkPostureTask
    from pink.utils import get_root_joint_dim

    _, root = get_root_joint_dim(pink.model)
    cost: float | np.ndarray = math.sqrt(largest_weight(task, 1e-3))
    if task.joint_names is not None:
        cost = np.zeros(pink.model.nv - root)
        cost[task.rows - root] = np.sqrt(task.weight)
    added = PinkPostureTask(cost=cost)
    added.set_target(task.reference)
    pink.tasks.append(added)


@PINK.form(PointContact)
def _point_contact(contact: PointContact, pink: PinkProblem) -> None:
    pink.constraints.append(pink_point_contact(contact.frame, contact.position))


@PINK.form(JointPositionLimits)
def _position_limits(limits: JointPositionLimits, pink: PinkProblem) -> None:
    from pink.limits import ConfigurationLimit

    pink.limits.append(ConfigurationLimit(pink.model))


@PINK.form(JointVelocityLimits)
def _velocity_limits(limits: JointVelocityLimits, pink: PinkProblem) -> None:
    """|dq| <= limit per step (dt 1): Pink's VelocityLimit at limit / dt over its step dt."""
    from pink.limits import VelocityLimit

    velocity = np.full(pink.model.nv, np.inf)
    velocity[limits.v_index] = limits.step_limit / pink.dt
    pink.limits.append(VelocityLimit(pink.model, velocity))


@PINK.form(LockedJoints)
def _locked(locked: LockedJoints, pink: PinkProblem) -> None:
    pink.constraints.append(pink_locked_joints(locked.v_index, pink.kinematics.q.copy()))


PINK.cannot(CoMInSupportPolygon, f"Pink 4.4 has no {NO_POLYGON}; solved without it, the CoM margin is only "
                                 "checked")
PINK.cannot(JointAccelerationLimits, "Pink's AccelerationLimit is not used here; solved with position and "
                                     "velocity limits only")
PINK.cannot(MinimumDistance, "no minimum distance between frame origins in Pink 4.4; solved without it")


def pink_point_contact(frame: str, position: np.ndarray):
    """A Pink equality-constraint task holding ``frame``'s origin at ``position`` (world, m): e = p - p*,
    J = the frame's world-aligned linear Jacobian."""
    from pink.tasks import Task as PinkTask

    class PointContactTask(PinkTask):
        def __init__(self):
            super().__init__(cost=1.0)
            self.frame, self.position = frame, np.array(position, dtype=float)

        def compute_error(self, configuration) -> np.ndarray:
            return configuration.get_transform_frame_to_world(self.frame).translation - self.position

        def compute_jacobian(self, configuration) -> np.ndarray:
            model, data = configuration.model, configuration.data
            return pin.getFrameJacobian(model, data, model.getFrameId(self.frame),
                                        pin.LOCAL_WORLD_ALIGNED)[:3]

        def __repr__(self) -> str:
            return f"PointContactTask({self.frame!r})"

    return PointContactTask()


def pink_locked_joints(v_index: np.ndarray, held: np.ndarray):
    """A Pink equality-constraint task holding the tangent coordinates ``v_index`` at ``held`` (the start
    q): e = (q (-) held)[v_index], J = those rows of the identity."""
    from pink.tasks import Task as PinkTask

    class LockedJointsTask(PinkTask):
        def __init__(self):
            super().__init__(cost=1.0)

        def compute_error(self, configuration) -> np.ndarray:
            return pin.difference(configuration.model, held, configuration.q)[v_index]

        def compute_jacobian(self, configuration) -> np.ndarray:
            return np.eye(configuration.model.nv)[v_index]

        def __repr__(self) -> str:
            return f"LockedJointsTask({len(v_index)} coordinates)"

    return LockedJointsTask()


# -- the method -----------------------------------------------------------------------------------------
class PinkSolver(PeerSolver):
    """pin-pink's differential IK, iterated by our loop (dt = the problem's step_dt per step)."""

    name = "pink"
    # solve_ik, integration, convergence FK, on an arm, on a humanoid (docs/measurements.md)
    iteration_cost_s = 150e-6
    default_budget_s = 0.03
    problem_iteration_cost_s = 500e-6
    problem_budget_s = 0.12
    forms = PINK
    priorities = "Pink: weighted costs only"

    def __init__(self, robot, chain=None, *, qp_solver: str = "daqp", damping: float = 1e-6, **options):
        super().__init__(robot, chain, **options)
        import_optional(PINK_LIBRARY, "method 'pink'", "pink")
        self.qp_solver = str(qp_solver)
        self.damping = float(damping)

    def _solve_problem(self, started: StartedProblem, deadline: float, max_iterations: int) -> Candidate:
        import pink

        model, problem = self.robot.model, started.problem
        built = PinkProblem(started.kinematics, problem.step_dt, self.damping, model=model)
        self.translate(started, built)
        configuration = pink.Configuration(model, model.createData(), started.q0.copy())

        def step(q: np.ndarray) -> tuple[np.ndarray, str]:
            try:
                velocity = pink.solve_ik(configuration, built.tasks, problem.step_dt, solver=self.qp_solver,
                                         damping=built.damping, limits=built.limits,
                                         constraints=built.constraints or None, safety_break=False)
            except Exception as exc:  # noqa: BLE001 - Pink raises its own NoSolutionFound and others
                return q, f"Pink found no step: {type(exc).__name__}: {exc}"
            q = configuration.integrate(velocity, problem.step_dt)
            configuration.update(q)
            return q, stalled(velocity, problem.step_dt, "Pink")

        # no hard polygon in Pink: the loop stops on goals and contacts only, the check judges the CoM
        return self._peer_loop(step, started, deadline, max_iterations, with_polygon=False)


IK_METHODS = (
    IKMethod("pink", PinkSolver,
             "pin-pink 4.4: chain targets; whole bodies with frame / CoM / posture tasks, contacts as "
             "constraints; no hard CoM polygon",
             needs=PINK_LIBRARY),
)
