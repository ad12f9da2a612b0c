"""Method ``mink``: mink 1.3's differential IK on MuJoCo's model of the same URDF (:mod:`wbik.mujoco_model`),
and mink's forms of wbik's tasks and constraints (:data:`MINK`): contacts as equality constraints, locked
joints a DofFreezingTask; no support polygon, acceleration limits, minimum distances or priority levels. A
chain target runs as mink's arm examples do: a VelocityLimit of ``max_step`` per step, damping
``chain_damping`` (docs/measurements.md, mink).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cache

import numpy as np
import pinocchio as pin

import wbik.qp.backends as backends
from wbik.dependencies import MINK_LIBRARY
from wbik.mujoco_model import MuJoCoBody, import_mink, mujoco_body
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.contacts import PointContact
from wbik.qp.distances import MinimumDistance
from wbik.qp.limits import JointAccelerationLimits, JointPositionLimits, JointVelocityLimits, LockedJoints
from wbik.qp.peers import PeerForms, largest_weight
from wbik.qp.tasks import PositionTask, PostureTask
from wbik.schema import Number
from wbik.solvers.method import IKMethod
from wbik.solvers.peer import (
    NO_POLYGON,
    PeerSolver,
    SolveIKProblem,
    solve_ik_forms,
    stalled,
)
from wbik.solvers.result import Candidate
from wbik.targets import Target
from wbik.wholebody.problem import StartedProblem

__all__ = ["IK_METHODS", "MinkProblem", "MinkSolver", "site_position_task"]


# mink's forms of tasks and constraints (a user's: @MINK.form(MyTask)); the shared ones in solve_ik_forms
MINK = solve_ik_forms(PeerForms("mink", "mink"))


@dataclass
class MinkProblem(SolveIKProblem):
    """What mink's forms add to, with the robot in MuJoCo (``body``) and ConfigurationLimit's gain."""

    body: MuJoCoBody = field(kw_only=True)
    limit_gain: float = field(default=0.95, kw_only=True)

    def frame_task(self, frame: str, target: pin.SE3, position_cost, orientation_cost,
                   reference: str | None = None):
        import mink

        costs = {"position_cost": position_cost, "orientation_cost": orientation_cost}
        site = self.body.site(frame)
        added = (mink.FrameTask(site, "site", **costs) if reference is None
                 else mink.RelativeFrameTask(site, "site", self.body.site(reference), "site", **costs))
        added.set_target(mink.SE3.from_matrix(target.homogeneous))
        return added

    def com_task(self, cost: np.ndarray):
        import mink

        return mink.ComTask(cost=cost)


@cache
def _site_position_class():
    """mink's Task class of :func:`site_position_task`, made when mink is first needed."""
    import mink
    import mujoco

    class SitePositionTask(mink.Task):
        """A site's world position on some axes: e = (p - p*)[rows], J = MuJoCo's jacp[rows]."""

        def __init__(self, site: str, target: np.ndarray, rows: np.ndarray, cost: np.ndarray):
            super().__init__(cost=np.asarray(cost, dtype=float), gain=1.0)
            self.site, self.target, self.rows = site, np.array(target, dtype=float), np.asarray(rows)

        def compute_error(self, configuration) -> np.ndarray:
            return (configuration.data.site(self.site).xpos - self.target)[self.rows]

        def compute_jacobian(self, configuration) -> np.ndarray:
            model, data = configuration.model, configuration.data
            jacobian = np.zeros((3, model.nv))
            mujoco.mj_jacSite(model, data, jacobian, None, data.site(self.site).id)
            return jacobian[self.rows]

        def __repr__(self) -> str:
            return f"SitePositionTask({self.site!r}, rows={self.rows.tolist()})"

    return SitePositionTask


def site_position_task(site: str, target: np.ndarray, rows: np.ndarray, cost: float):
    """A mink task on a site's world position (m) on the axes ``rows``, ``cost`` on each."""
    rows = np.asarray(rows, dtype=int)
    return _site_position_class()(site, target, rows, np.full(rows.size, float(cost)))


# -- mink's forms of the tasks and constraints ------------------------------------------------------------
@MINK.form(PositionTask)
def _position(task: PositionTask, mink_problem: MinkProblem) -> None:
    target = np.zeros(3)
    target[task.rows] = task.target[task.rows]
    mink_problem.tasks.append(site_position_task(mink_problem.body.site(task.frame), target, task.rows,
                                                 math.sqrt(largest_weight(task, 1.0))))


@MINK.form(PostureTask)
def _posture(task: PostureTask, mink_problem: MinkProblem) -> None:
    """mink's posture weighs each DOF (its free joint's at none): the task's weights on its own rows."""
    import mink

    body = mink_problem.body
    cost = np.zeros(body.model.nv)
    cost[body.dofs(task.rows)] = np.sqrt(task.weight)
    added = mink.PostureTask(body.model, cost=cost)
    added.set_target(body.qpos(task.reference))
    mink_problem.tasks.append(added)


@MINK.form(PointContact)
def _point_contact(contact: PointContact, mink_problem: MinkProblem) -> None:
    site = mink_problem.body.site(contact.frame)
    mink_problem.constraints.append(site_position_task(site, contact.position, np.arange(3), 1.0))


@MINK.form(JointPositionLimits)
def _position_limits(limits: JointPositionLimits, mink_problem: MinkProblem) -> None:
    import mink

    mink_problem.limits.append(mink.ConfigurationLimit(mink_problem.body.model, gain=mink_problem.limit_gain))


@MINK.form(JointVelocityLimits)
def _velocity_limits(limits: JointVelocityLimits, mink_problem: MinkProblem) -> None:
    """|dq| <= limit per step (dt 1): mink's VelocityLimit at limit / dt over its step dt, by joint."""
    import mink

    names = mink_problem.body.joint_names
    velocities = {names[index]: limit / mink_problem.dt
                  for index, limit in zip(limits.v_index.tolist(), limits.step_limit.tolist(), strict=True)
                  if index in names}
    mink_problem.limits.append(mink.VelocityLimit(mink_problem.body.model, velocities))


@MINK.form(LockedJoints)
def _locked(locked: LockedJoints, mink_problem: MinkProblem) -> None:
    """mink's documented way to hold DOFs exactly: a DofFreezingTask as an equality constraint."""
    import mink

    body = mink_problem.body
    dofs = body.dofs(locked.v_index)
    if dofs.size:
        mink_problem.constraints.append(mink.DofFreezingTask(body.model, dof_indices=dofs.tolist()))


MINK.cannot(CoMInSupportPolygon, f"mink 1.3 has no {NO_POLYGON}; solved without it, the CoM margin is only "
                                 "checked")
MINK.cannot(JointAccelerationLimits, "mink 1.3 has no acceleration limit; solved with position and velocity "
                                     "limits only")
MINK.cannot(MinimumDistance, "mink's CollisionAvoidanceLimit keeps geoms apart, not frame origins; solved "
                             "without it")


# -- the method -----------------------------------------------------------------------------------------
class MinkSolver(PeerSolver):
    """mink's differential IK on MuJoCo's model of the same URDF, iterated by our loop."""

    name = "mink"
    # solve_ik, integration, read-back, convergence FK, on an arm, on a humanoid (docs/measurements.md)
    iteration_cost_s = 120e-6
    default_budget_s = 0.03
    problem_iteration_cost_s = 500e-6
    problem_budget_s = 0.12
    forms = MINK
    priorities = "mink: weighted costs only"

    def __init__(self, robot, chain=None, *, backend: str = "daqp", damping: float = 1e-6,
                 chain_damping: float = 1e-3, limit_gain: float = 0.95, max_step: float = 0.5, **options):
        """``backend``: ``mink.solve_ik``'s qpsolvers name; ``damping``: its damping on every DOF,
        ``chain_damping`` on chain targets; ``limit_gain``: ConfigurationLimit's gain in (0, 1]; ``max_step``:
        a chain joint's largest step on chain targets (rad or m; ``math.inf``: none)."""
        super().__init__(robot, chain, **options)
        self.mink, self.mujoco = import_mink()
        self.backend = backends.resolve(backend)
        self.damping = Number(ge=0, as_float=True).checked(damping, "damping", "MinkSolver")
        self.chain_damping = Number(ge=0, as_float=True).checked(chain_damping, "chain_damping", "MinkSolver")
        self.limit_gain = Number(gt=0, le=1, as_float=True).checked(limit_gain, "limit_gain", "MinkSolver")
        self.max_step = Number(gt=0, as_float=True, finite=False).checked(max_step, "max_step", "MinkSolver")
        chain = self._chain if self._chain is not None or len(robot.chains) != 1 else self.chain
        self.built = (mujoco_body(robot) if chain is None else
                      mujoco_body(robot, masses=False, frames=[chain.base_frame, chain.tip_frame]))
        self._configuration(self.built)  # this thread's configuration now (errors show here, not in a solve)

    def _new_thread_state(self) -> dict:
        return {}

    def _configuration(self, body: MuJoCoBody):
        """This thread's mink Configuration of a MuJoCo model (its own MjData; the MjModel is shared)."""
        state = self._thread_state()
        if id(body) not in state:
            state[id(body)] = self.mink.Configuration(body.model, body.qpos(self.robot.nominal))
        return state[id(body)]

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        chain = self.chain
        body = mujoco_body(self.robot, masses=False, frames=[chain.base_frame, chain.tip_frame])
        constraints = []
        if math.isfinite(self.max_step):
            limit = np.full(self.robot.model.nv, np.inf)
            limit[chain.v_index] = self.max_step
            constraints.append(JointVelocityLimits(limit))
        problem = self.chain_problem(target, constraints, regularization=self.chain_damping)
        started = problem.start(chain.full_configuration(chain.clip(q0)))
        candidate = self._solve_on(body, started, deadline, self.max_iterations)
        if candidate.q is not None:
            candidate.q = candidate.q[chain.q_index]
        return candidate

    def _solve_problem(self, started: StartedProblem, deadline: float, max_iterations: int) -> Candidate:
        return self._solve_on(mujoco_body(self.robot), started, deadline, max_iterations)

    def _solve_on(self, body: MuJoCoBody, started: StartedProblem, deadline: float,
                  max_iterations: int) -> Candidate:
        mink = self.mink
        configuration = self._configuration(body)
        configuration.update(body.qpos(started.q0))
        dt = started.problem.step_dt
        built = MinkProblem(started.kinematics, dt, self.damping, body=body, limit_gain=self.limit_gain)
        self.translate(started, built)

        def step(q: np.ndarray) -> tuple[np.ndarray, str]:
            try:
                velocity = mink.solve_ik(configuration, built.tasks, dt, self.backend, damping=built.damping,
                                         limits=built.limits, constraints=built.constraints or None)
            except mink.NoSolutionFound as exc:
                return q, f"mink's QP found no step: {exc}"
            configuration.integrate_inplace(velocity, dt)
            return body.q(configuration.data.qpos), stalled(velocity, dt, "mink")

        # no hard polygon in mink: the loop stops on goals and contacts only, the check judges the CoM
        return self._peer_loop(step, started, deadline, max_iterations, with_polygon=False)


IK_METHODS = (
    IKMethod("mink", MinkSolver,
             "mink 1.3 on MuJoCo (the same URDF): chain targets as its arm examples; whole bodies with "
             "frame / CoM / posture tasks, contacts as constraints; no hard CoM polygon",
             needs=MINK_LIBRARY),
)
