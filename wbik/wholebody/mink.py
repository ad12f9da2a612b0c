"""Method ``mink``: mink 1.3's differential IK (MuJoCo 4.0) on a whole body, and mink's forms of wbik's
tasks and constraints (:data:`wbik.qp.peers.MINK`).

The model. MuJoCo reads the robot's own URDF with its masses (:func:`wbik.solvers.mink.mujoco_urdf`:
no visual, collision or mimic elements, every link a body, the links' inertial elements kept) and
gets, through ``mujoco.MjSpec``: a free joint on the root link for a floating base (MuJoCo welds a
URDF's root to the world; mink's humanoid examples put a ``<freejoint/>`` on the root body), and a site
``wbik:FRAME`` for every frame of wbik's model, on the body of the link that carries it at the frame's
fixed offset (:func:`wbik.solvers.mink.frame_on_body`; a joint frame on its child link, a frame of the
world on the world). A fixed base's links welded to the world get no mass (wbik's centre of mass,
Pinocchio's, is the moving links'). q between wbik and MuJoCo: the base pose (Pinocchio's quaternion
x, y, z, w; MuJoCo's w, x, y, z) and every 1-DOF joint by name. MuJoCo's CoM (``subtree_com`` of the
root body, what mink's ComTask uses) and every site must equal wbik's to 1e-9 (m, rad) on seeded
random configurations, else the robot is refused (UnsupportedError) when the method is built.

The problem, as mink states it: FrameTask on the sites for frame, orientation (position cost 0) and
relative frame tasks (RelativeFrameTask), ComTask, PostureTask (cost 0 off the task's joints), costs
the square roots of our weights; a position task on some axes is a task of our own on the site's
world position (:func:`site_position_task`: mink's FrameTask weighs its axes in the target's frame);
a regularisation raises ``solve_ik``'s damping. Contacts are equality constraints, as ``solve_ik``'s
``constraints`` take them (a FrameTask; a point foot: the site's world position, 3 rows). Limits are
ConfigurationLimit (gain ``limit_gain``, mink's default 0.95) and VelocityLimit, at dt = the problem's
``step_dt``. mink 1.3 has no support-polygon constraint: every mink result with a support polygon
lists it in ``unsupported`` (the CoM margin is only checked), as Pink's; nor acceleration limits or
minimum distances between frame origins here, nor strict priority levels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from dataclasses import field
from functools import cache
from typing import Any

import numpy as np
import pinocchio as pin

from wbik.errors import UnsupportedError
from wbik.geometry import wrap_to_pi
from wbik.qp.constraints import CoMInSupportPolygon
from wbik.qp.constraints import Contact
from wbik.qp.constraints import JointAccelerationLimits
from wbik.qp.constraints import JointPositionLimits
from wbik.qp.constraints import JointVelocityLimits
from wbik.qp.constraints import MinimumDistance
from wbik.qp.constraints import PointContact
from wbik.qp.kinematics import Kinematics
from wbik.qp.peers import MINK
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
from wbik.solvers.mink import add_site
from wbik.solvers.mink import compile_spec
from wbik.solvers.mink import frame_on_body
from wbik.solvers.mink import import_mink
from wbik.solvers.mink import mujoco_warnings
from wbik.solvers.mink import urdf_spec
from wbik.validation import check_gain
from wbik.validation import check_nonnegative_finite
from wbik.wholebody.methods import WholeBodyMethod
from wbik.wholebody.solvers import NO_POLYGON
from wbik.wholebody.solvers import PeerWholeBody
from wbik.wholebody.solvers import SolveIKProblem
from wbik.wholebody.solvers import raise_damping
from wbik.wholebody.solvers import stalled

__all__ = ["AGREEMENT_TOLERANCE", "WHOLEBODY_METHODS", "MinkProblem", "MinkWholeBody", "MuJoCoBody",
           "mujoco_body", "site_position_task"]

FREE_JOINT = "wbik_free_base"
SITE_PREFIX = "wbik:"
AGREEMENT_POSES, AGREEMENT_SEED, AGREEMENT_TOLERANCE = 4, 0, 1e-9
"""MuJoCo's CoM and sites must equal wbik's to AGREEMENT_TOLERANCE (m, rad) at the nominal and at
AGREEMENT_POSES - 1 seeded random configurations."""


@dataclass
class MuJoCoBody:
    """The robot in MuJoCo: the ``model`` (an MjModel), ``sites`` {wbik frame: site name}, and the maps
    of q: wbik's ``q_index`` and MuJoCo's ``qpos_index`` of the same coordinates (the base pose's, its
    quaternion's order changed, and each 1-DOF joint's), the 1-DOF joints' tangent indices
    (``v_index``, ``dof_index``), their names by wbik's tangent index (``joint_names``), and the
    continuous joints' q indices (``wrapped``)."""

    robot: Robot
    model: Any
    sites: dict[str, str]
    q_index: np.ndarray
    qpos_index: np.ndarray
    v_index: np.ndarray
    dof_index: np.ndarray
    joint_names: dict[int, str]
    wrapped: np.ndarray
    warnings: tuple[str, ...] = ()
    """What MuJoCo's parser and compiler warned about."""

    def qpos(self, q: np.ndarray) -> np.ndarray:
        """MuJoCo's qpos of wbik's configuration q."""
        qpos = self.model.qpos0.copy()
        qpos[self.qpos_index] = q[self.q_index]
        return qpos

    def q(self, qpos: np.ndarray) -> np.ndarray:
        """wbik's configuration of MuJoCo's qpos (continuous joints wrapped into [-pi, pi])."""
        q = self.robot.nominal.copy()
        q[self.q_index] = qpos[self.qpos_index]
        if self.wrapped.size:
            q[self.wrapped] = wrap_to_pi(q[self.wrapped])
        return q

    def dofs(self, v_index: np.ndarray) -> np.ndarray:
        """MuJoCo's DOF addresses of wbik's tangent indices of 1-DOF joints."""
        where = {int(v): int(d) for v, d in zip(self.v_index, self.dof_index, strict=True)}
        return np.array([where[int(v)] for v in v_index], dtype=int)

    def site(self, frame: str) -> str:
        """The site of a wbik frame."""
        self.robot.frame_id(frame)  # UnknownFrameError names the frames
        return self.sites[frame]


def _carrier(robot: Robot, frame_id: int) -> tuple[str | None, pin.SE3]:
    """(URDF link carrying the frame, None for the world; the frame's pose in it)."""
    model = robot.model
    frame = model.frames[frame_id]
    try:
        where = frame_on_body(robot, frame.name)
        return where.body, where.placement
    except UnsupportedError:
        pass  # a joint's frame (its child link carries it), or a frame of the world
    if frame.parentJoint == 0:
        return None, frame.placement
    for candidate in model.frames:
        if candidate.type == pin.FrameType.BODY and candidate.parentJoint == frame.parentJoint:
            link = robot.renamed_frames.get(candidate.name, candidate.name)
            return link, candidate.placement.inverse() * frame.placement
    raise UnsupportedError(f"frame {frame.name!r} is carried by no URDF link MuJoCo keeps as a body")


def _massless_while_welded(body) -> None:
    """No mass on ``body`` and its descendants while no joint moves them (welded to the world)."""
    if body.joints:
        return
    body.mass, body.inertia, body.explicitinertial = 0.0, [0.0, 0.0, 0.0], True
    for child in body.bodies:
        _massless_while_welded(child)


def _compile(robot: Robot, mujoco) -> MuJoCoBody:
    model = robot.model
    spec = urdf_spec(mujoco, robot.urdf_text, masses=True)
    if robot.has_floating_base:
        root = next(frame for frame in model.frames
                    if frame.type == pin.FrameType.BODY and frame.parentJoint == 1)
        body = spec.body(robot.renamed_frames.get(root.name, root.name))
        if body is None:
            raise UnsupportedError(f"MuJoCo has no body for the root link {root.name!r}")
        body.add_freejoint(name=FREE_JOINT)
    else:
        for body in spec.worldbody.bodies:
            _massless_while_welded(body)
    sites = {}
    for name in dict.fromkeys(frame.name for frame in model.frames):
        link, placement = _carrier(robot, robot.frame_id(name))
        body = spec.worldbody if link is None else spec.body(link)
        if body is None:
            raise UnsupportedError(f"frame {name!r}: MuJoCo has no body {link!r}")
        sites[name] = SITE_PREFIX + name
        add_site(body, sites[name], placement)
    compiled = compile_spec(spec)
    slots = {int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)}
    q_index, qpos_index, v_index, dof_index, names = [], [], [], [], {}
    if robot.has_floating_base:  # x y z, then Pinocchio's quaternion x y z w is MuJoCo's w x y z
        at = int(compiled.jnt_qposadr[mujoco.mj_name2id(compiled, mujoco.mjtObj.mjOBJ_JOINT, FREE_JOINT)])
        q_index += range(7)
        qpos_index += [at, at + 1, at + 2, at + 4, at + 5, at + 6, at + 3]
    for joint_id in range(1, model.njoints):
        joint, name = model.joints[joint_id], model.names[joint_id]
        if joint_id == 1 and robot.has_floating_base:
            continue
        if joint.nq != 1 or joint.nv != 1:
            raise UnsupportedError(f"joint {name!r} ({joint.shortname()}) is neither the floating base nor "
                                   "a 1-DOF joint")
        mj_id = mujoco.mj_name2id(compiled, mujoco.mjtObj.mjOBJ_JOINT, name)
        if mj_id < 0 or int(compiled.jnt_type[mj_id]) not in slots:
            raise UnsupportedError(f"MuJoCo has no hinge or slide joint {name!r}")
        q_index.append(joint.idx_q)
        qpos_index.append(int(compiled.jnt_qposadr[mj_id]))
        v_index.append(joint.idx_v)
        dof_index.append(int(compiled.jnt_dofadr[mj_id]))
        names[joint.idx_v] = name
    wrapped = [model.joints[model.getJointId(name)].idx_q for name in robot.continuous_joints]
    return MuJoCoBody(robot, compiled, sites, *(np.array(index, dtype=int) for index in (
        q_index, qpos_index, v_index, dof_index)), names, np.array(wrapped, dtype=int))


def random_configurations(robot: Robot, count: int, seed: int) -> list[np.ndarray]:
    """``count`` seeded configurations inside the joint limits (a range wider than [-pi, pi] cut to
    it), the base anywhere within 1 m with any orientation."""
    rng = np.random.default_rng(seed)
    model = robot.model
    lower = np.maximum(model.lowerPositionLimit, -math.pi)
    upper = np.minimum(model.upperPositionLimit, math.pi)
    configurations = []
    for _ in range(count):
        q = rng.uniform(lower, upper)
        if robot.has_floating_base:
            q[:3] = rng.uniform(-1.0, 1.0, 3)
            quaternion = rng.normal(size=4)
            q[3:7] = quaternion / np.linalg.norm(quaternion)
        configurations.append(q)
    return configurations


def agreement(body: MuJoCoBody, configurations: list[np.ndarray], mujoco) -> float:
    """Largest difference (m, rad) between MuJoCo's CoM and sites and wbik's CoM and frames."""
    robot = body.robot
    data = mujoco.MjData(body.model)
    worst = 0.0
    for q in configurations:
        data.qpos[:] = body.qpos(q)
        mujoco.mj_kinematics(body.model, data)
        mujoco.mj_comPos(body.model, data)
        kinematics = Kinematics(robot.model, q)
        worst = max(worst, float(np.max(np.abs(data.subtree_com[1] - kinematics.com()))))
        for frame, site in body.sites.items():
            expected, reached = kinematics.placement(robot.frame_id(frame)), data.site(site)
            worst = max(worst, float(np.max(np.abs(reached.xpos - expected.translation))),
                        float(np.linalg.norm(pin.log3(expected.rotation.T @ reached.xmat.reshape(3, 3)))))
    return worst


def mujoco_body(robot: Robot) -> MuJoCoBody:
    """MuJoCo's model of ``robot`` with its sites and maps (see the module docstring), checked against
    wbik's CoM and frames; UnsupportedError saying why when MuJoCo cannot take the robot."""
    _, mujoco = import_mink()
    label = f"method 'mink' cannot solve whole bodies of {robot.name}"
    try:
        with mujoco_warnings(mujoco) as warnings:
            body = _compile(robot, mujoco)
    except UnsupportedError as refused:
        raise UnsupportedError(f"{label}: {refused}") from None
    body.warnings = tuple(warnings)
    configurations = [robot.nominal, *random_configurations(robot, AGREEMENT_POSES - 1, AGREEMENT_SEED)]
    worst = agreement(body, configurations, mujoco)
    if not worst <= AGREEMENT_TOLERANCE:
        raise UnsupportedError(f"{label}: MuJoCo's CoM or frames differ from wbik's by up to {worst:.3g} (m, "
                               f"rad) (allowed {AGREEMENT_TOLERANCE:g}): MuJoCo reads this URDF differently")
    return body


@dataclass
class MinkProblem(SolveIKProblem):
    """What mink's forms add to (:class:`wbik.wholebody.solvers.SolveIKProblem`), with the robot in
    MuJoCo (``body``) and ConfigurationLimit's ``limit_gain``."""

    body: MuJoCoBody = field(kw_only=True)
    limit_gain: float = field(default=0.95, kw_only=True)


@cache
def _site_position_class():
    """mink's Task class of :func:`site_position_task` (made once, when mink is first needed)."""
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
    """A mink task on a site's world position on the axes ``rows`` (target in the world, m; ``cost``
    per row), for the tasks and as an equality constraint (a point foot: all three rows)."""
    rows = np.asarray(rows, dtype=int)
    return _site_position_class()(site, target, rows, np.full(rows.size, float(cost)))


# -- mink's forms of the tasks --------------------------------------------------------------------------
def _frame_task(mink_problem: MinkProblem, frame: str, target: pin.SE3, position_cost, orientation_cost):
    import mink

    added = mink.FrameTask(mink_problem.body.site(frame), "site", position_cost=position_cost,
                           orientation_cost=orientation_cost)
    added.set_target(mink.SE3.from_matrix(target.homogeneous))
    return added


@MINK.form(FrameTask)
def _frame(task: FrameTask, mink_problem: MinkProblem) -> None:
    position, orientation = frame_weights(task)
    mink_problem.tasks.append(_frame_task(mink_problem, task.frame, task.target, math.sqrt(position),
                                          math.sqrt(orientation)))


@MINK.form(RelativeFrameTask)
def _relative(task: RelativeFrameTask, mink_problem: MinkProblem) -> None:
    import mink

    position, orientation = frame_weights(task)
    body = mink_problem.body
    added = mink.RelativeFrameTask(body.site(task.frame), "site", body.site(task.reference_frame), "site",
                                   position_cost=math.sqrt(position), orientation_cost=math.sqrt(orientation))
    added.set_target(mink.SE3.from_matrix(task.target.homogeneous))
    mink_problem.tasks.append(added)


@MINK.form(PositionTask)
def _position(task: PositionTask, mink_problem: MinkProblem) -> None:
    target = np.zeros(3)
    target[task.rows] = task.target[task.rows]
    mink_problem.tasks.append(site_position_task(mink_problem.body.site(task.frame), target, task.rows,
                                                 math.sqrt(largest_weight(task, 1.0))))


@MINK.form(OrientationTask)
def _orientation(task: OrientationTask, mink_problem: MinkProblem) -> None:
    target = pin.SE3(task.target, mink_problem.kinematics.placement(task.frame_id).translation.copy())
    mink_problem.tasks.append(_frame_task(mink_problem, task.frame, target, 0.0,
                                          math.sqrt(largest_weight(task, 1.0))))


@MINK.form(ComTask)
def _com(task: ComTask, mink_problem: MinkProblem) -> None:
    import mink

    cost = np.zeros(3)
    cost[task.rows] = math.sqrt(largest_weight(task, 1.0))
    target = mink_problem.kinematics.com().copy()
    target[task.rows] = task.target[task.rows]
    added = mink.ComTask(cost=cost)
    added.set_target(target)
    mink_problem.tasks.append(added)


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


MINK.form(RegularizationTask)(raise_damping)


# -- and of the constraints -----------------------------------------------------------------------------
@MINK.form(Contact)
def _contact(contact: Contact, mink_problem: MinkProblem) -> None:
    mink_problem.constraints.append(_frame_task(mink_problem, contact.frame, contact.placement, 1.0, 1.0))


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
                  for index, limit in zip(limits.v_index.tolist(), limits.limit.tolist(), strict=True)
                  if index in names}
    mink_problem.limits.append(mink.VelocityLimit(mink_problem.body.model, velocities))


MINK.cannot(CoMInSupportPolygon, f"mink 1.3 has no {NO_POLYGON}; solved without it, the CoM margin is only "
                                 "checked")
MINK.cannot(JointAccelerationLimits, "mink 1.3 has no acceleration limit; solved with position and velocity "
                                     "limits only")
MINK.cannot(MinimumDistance, "mink's CollisionAvoidanceLimit keeps geoms apart, not frame origins; solved "
                             "without it")


# -- the method -----------------------------------------------------------------------------------------
class MinkWholeBody(PeerWholeBody):
    """mink's differential IK on MuJoCo's model of the same URDF, iterated by our loop (dt = the
    problem's step_dt per step)."""

    name = "mink"
    # the budget's unit: solve_ik, integration, read-back, convergence FK; the same as Pink's (measured:
    # docs/measurements.md, wholebody)
    iteration_cost_s = 500e-6
    default_budget_s = 0.12
    forms = MINK
    priorities = "mink: weighted costs only"

    def __init__(self, robot, *, backend: str = "daqp", damping: float = 1e-6, limit_gain: float = 0.95,
                 **options):
        """``backend``: the qpsolvers name ``mink.solve_ik`` uses; ``damping``: its Levenberg-Marquardt
        damping on every DOF (a regularisation task raises it); ``limit_gain``: ConfigurationLimit's
        gain in (0, 1]."""
        from wbik.qp import backends

        super().__init__(robot, **options)
        self.mink, self.mujoco = import_mink()
        self.backend = backends.resolve(backend)
        self.damping = check_nonnegative_finite("damping", damping)
        self.limit_gain = check_gain("limit_gain", limit_gain)
        self.body = mujoco_body(robot)
        self._thread_state()  # this thread's configuration now (errors show here, its cost is not a solve's)

    def _new_thread_state(self):
        """This thread's mink Configuration (its own MjData; the MjModel is shared, read only)."""
        return self.mink.Configuration(self.body.model, self.body.qpos(self.robot.nominal))

    def mink_com(self, q: np.ndarray) -> np.ndarray:
        """mink's centre of mass (m, world) at wbik's configuration q, as its ComTask reads it."""
        configuration = self._thread_state()
        configuration.update(self.body.qpos(np.asarray(q, dtype=float)))
        return configuration.data.subtree_com[1].copy()

    def mink_placement(self, q: np.ndarray, frame: str) -> pin.SE3:
        """mink's world placement of a wbik frame (its site) at wbik's configuration q."""
        configuration = self._thread_state()
        configuration.update(self.body.qpos(np.asarray(q, dtype=float)))
        return pin.SE3(configuration.get_transform_frame_to_world(self.body.site(frame), "site").as_matrix())

    def _solve(self, problem, q0, placements, polygon, deadline):
        mink, body = self.mink, self.body
        configuration = self._thread_state()
        configuration.update(body.qpos(q0))
        tasks, kinematics = self.started_tasks(problem, q0)
        built = MinkProblem(kinematics, problem.step_dt, self.damping, body=body, limit_gain=self.limit_gain)
        self.translate(self.items(problem, tasks, placements, polygon), built)
        dt = problem.step_dt

        def step(q: np.ndarray) -> tuple[np.ndarray, str]:
            try:
                velocity = mink.solve_ik(configuration, built.tasks, dt, self.backend, damping=built.damping,
                                         limits=built.limits, constraints=built.constraints or None)
            except mink.NoSolutionFound as exc:
                return q, f"mink's QP found no step: {exc}"
            configuration.integrate_inplace(velocity, dt)
            return body.q(configuration.data.qpos), stalled(velocity, dt, "mink")

        # no hard polygon in mink: the loop stops on goals and contacts only, the check judges the CoM
        return self._peer_loop(step, q0.copy(), deadline, problem, kinematics, tasks, placements, None)


WHOLEBODY_METHODS = (
    WholeBodyMethod(
        "mink", MinkWholeBody,
        "mink 1.3 on MuJoCo (the same URDF, free base): frame / CoM / posture tasks, contacts as "
        "constraints; no hard CoM polygon",
    ),
)
"""The method this module declares (registered through wbik.wholebody.methods.METHOD_MODULES)."""
