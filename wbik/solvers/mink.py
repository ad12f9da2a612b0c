"""Method ``mink``: mink's differential IK (mink 1.3.0 on MuJoCo 4.0) iterated on the robot's own URDF.

The model. MuJoCo reads the robot's URDF text (``mujoco.MjSpec.from_string``: MuJoCo loads URDF as well as
MJCF) for its kinematics only: the visual, collision, inertial and mimic elements are removed (MuJoCo
would resolve every mesh a URDF names, refuses some URDF inertias, and turns mimic joints into equality
constraints that mink's IK does not use; wbik locks mimic joints anyway), and MuJoCo's URDF extension is
added (MuJoCo Modeling guide, "URDF extensions": a ``<mujoco>`` element under ``<robot>`` with a
``<compiler>`` child): ``fusestatic="false"``, since it defaults to true for URDF and would merge every link
behind a fixed joint (a tool frame such as the UR5's ``tcp``) into its parent; ``discardvisual="true"``;
and ``boundmass``/``boundinertia``, which let the now massless links move (MuJoCo refuses massless moving
bodies; masses play no part in kinematics). MuJoCo names each body after its URDF link and each joint
after its URDF joint (``src/xml/xml_urdf.cc``): revolute and continuous joints are hinges (one angle, a
continuous one unlimited), prismatic joints slides, and the URDF root is welded to MuJoCo's world (a
floating base is held where it is). Two sites are added (``MjsBody.add_site``), ``wbik_base`` and
``wbik_tip``, at the chain's base and tip frames: each on the body of the link that carries the frame, at
the frame's fixed offset in Pinocchio's model. MuJoCo's warnings while it compiles are kept in
``MuJoCoChain.warnings`` (its default handler would append them to MUJOCO_LOG.TXT in the working folder).

q between wbik and MuJoCo: by joint name (``jnt_qposadr``), one value per hinge or slide on both sides;
MuJoCo's other joints take the robot's nominal values by name. A chain MuJoCo cannot load, or whose MuJoCo
FK differs from wbik's chain FK by more than 1e-9 (m, rad) on seeded random joints, is an
UnsupportedError at construction, saying which.

The problem. As mink's own arm examples run it (``examples/arm_panda.py``, ``arm_panda_dof_freezing.py``:
a ``converge_ik`` loop of ``mink.solve_ik`` and ``Configuration.integrate_inplace``): one
``mink.FrameTask`` on the tip site (position and orientation cost 1, gain 1, ``lm_damping`` 1e-3 as in
``examples/arm_iiwa.py``; orientation cost 0 for a position target), ``mink.ConfigurationLimit`` (gain
0.95) on the joint ranges, ``mink.VelocityLimit`` on the chain's joints (as in ``examples/arm_ur5e.py``),
the joints outside the chain held by a ``mink.DofFreezingTask`` passed as an equality constraint (mink's
documented way: "the frozen DOFs are held exactly and the remaining DOFs solve the same problem as if the
frozen ones were deleted"), DAQP through qpsolvers, ``damping`` 1e-3. The target, given in the chain's
base frame, goes to MuJoCo's world as T_world_base T_target, T_world_base read from the ``wbik_base`` site
with every other joint at the robot's nominal configuration.

The velocity limit is what bounds a step: |dq| <= v_max dt per joint, dt = 1 s and v_max = ``max_step``
(default 0.5 rad or m; ``math.inf``: no VelocityLimit). Without it mink's first Gauss-Newton steps from a far
start are long and often end in another basin (the measurements behind the default: docs/measurements.md,
mink). With no velocity limit dt only scales mink's velocity v = dq / dt, integrated over the same dt.

Budget. mink's loop is driven by this module, so it is budgeted in iterations like wbik's own methods
(``max_iterations``; default: the iterations that cost about 30 ms on the reference machine, as for
``qp``); the shared check's pose error (at half its tolerances, :func:`wbik.solvers.task_error.converged`)
stops it, and so do STALL_ITERATIONS iterations without progress. A single start, as mink runs: no
restarts. Each thread has its own mink Configuration (MjData), tasks and limits; the MjModel is shared, as
MuJoCo allows (the kinematics only read it).
"""

from __future__ import annotations

import math
import re
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidSettingError
from wbik.errors import MissingDependencyError
from wbik.errors import UnsupportedError
from wbik.qp import backends
from wbik.robot import Chain
from wbik.robot import ChainCache
from wbik.robot import Robot
from wbik.solvers.base import Candidate
from wbik.solvers.base import Solver
from wbik.solvers.method_registry import IKMethod
from wbik.solvers.task_error import converged
from wbik.solvers.task_error import task_error
from wbik.targets import Target
from wbik.validation import check_gain
from wbik.validation import check_nonnegative_finite
from wbik.validation import check_positive_finite

INSTALL = "pip install mink==1.3.0"
_DROPPED = re.compile(r"<(visual|collision|inertial|mimic)\b[^>]*?/>"
                      r"|<(visual|collision|inertial|mimic)\b.*?</\2\s*>", re.DOTALL)
_DROPPED_BUT_INERTIAL = re.compile(r"<(visual|collision|mimic)\b[^>]*?/>"
                                   r"|<(visual|collision|mimic)\b.*?</\2\s*>", re.DOTALL)
_ROBOT_TAG = re.compile(r"<robot\b[^>]*?>", re.DOTALL)
MUJOCO_EXTENSION = ('<mujoco><compiler fusestatic="false" discardvisual="true" boundmass="1e-9" '
                    'boundinertia="1e-12"/></mujoco>')
"""MuJoCo's URDF extension: keep every link a body (fixed joints not fused), no visual elements, and
bounds that let the massless links move (see the module docstring)."""
MUJOCO_MASS_EXTENSION = ('<mujoco><compiler fusestatic="false" discardvisual="true" inertiafromgeom="false" '
                         'balanceinertia="true" boundmass="1e-12" boundinertia="1e-14"/></mujoco>')
"""The extension for a URDF read with its masses: the links' own masses and centres of mass (no
inertia from geometry), inertias MuJoCo finds unphysical balanced (they play no part in kinematics nor
in a centre of mass), and bounds small enough to leave a centre of mass unchanged to 1e-12 m."""
BASE_SITE, TIP_SITE = "wbik_base", "wbik_tip"
AGREEMENT_POSES, AGREEMENT_SEED, AGREEMENT_TOLERANCE = 8, 0, 1e-9
"""MuJoCo's FK of the chain must equal wbik's to AGREEMENT_TOLERANCE (m, rad) on AGREEMENT_POSES seeded
random joint vectors inside the limits."""
STALL_ITERATIONS = 10
"""Iterations without a decrease of the pose error after which the loop stops."""
DT = 1.0


def import_mink():
    """(mink, mujoco), or MissingDependencyError with the install command."""
    try:
        import mink
        import mujoco
    except ImportError as exc:
        raise MissingDependencyError(
            f"method 'mink' needs mink and MuJoCo ({exc}); install them with: {INSTALL}") from None
    return mink, mujoco


def mujoco_urdf(text: str, masses: bool = False) -> str:
    """The robot's URDF for MuJoCo, kinematics only: no visual, collision, inertial or mimic elements, and
    MuJoCo's compiler extension added; with ``masses`` the inertial elements stay (for a centre of mass)
    and the extension is MUJOCO_MASS_EXTENSION."""
    # a regular expression rather than an XML parser, as for PlaCo (wbik.solvers.placo): URDF readers accept
    # some files a strict XML parser rejects
    text = (_DROPPED_BUT_INERTIAL if masses else _DROPPED).sub("", text)
    text = re.sub(r"<mujoco\b.*?</mujoco\s*>|<mujoco\b[^>]*/>", "", text, flags=re.DOTALL)
    match = _ROBOT_TAG.search(text)
    if match is None:
        raise UnsupportedError("the URDF has no <robot> element MuJoCo could read")
    return text[:match.end()] + (MUJOCO_MASS_EXTENSION if masses else MUJOCO_EXTENSION) + text[match.end():]


@dataclass(frozen=True)
class FrameOnBody:
    """A Pinocchio frame as MuJoCo sees it: the MuJoCo body (URDF link) carrying it, its fixed pose there."""

    body: str
    placement: pin.SE3


def frame_on_body(robot: Robot, frame: str) -> FrameOnBody:
    """The URDF link (a MuJoCo body) that carries ``frame``, and the frame's pose in that link.

    A link frame is its own body; another frame (a joint, a fixed joint) is placed on the first link frame
    up its parent frames that moves with the same joint (so the offset is fixed)."""
    model = robot.model
    frame_id = robot.frame_id(frame)
    target = model.frames[frame_id]
    current = frame_id
    while True:
        candidate = model.frames[current]
        if candidate.parentJoint != target.parentJoint:
            break
        if candidate.type == pin.FrameType.BODY:
            link = robot.renamed_frames.get(candidate.name, candidate.name)
            return FrameOnBody(link, candidate.placement.inverse() * target.placement)
        if candidate.parentFrame == current:
            break
        current = candidate.parentFrame
    raise UnsupportedError(f"frame {frame!r} is carried by no URDF link that MuJoCo keeps as a body")


@dataclass
class MuJoCoChain:
    """The robot in MuJoCo with the chain's sites, and the joint maps: ``chain_qpos`` / ``chain_dof`` (n,)
    the MuJoCo addresses of the chain's joints in chain order, ``nominal_qpos`` the robot's nominal in
    MuJoCo's qpos, ``frozen_dofs`` MuJoCo's DOFs outside the chain."""

    model: object
    chain_qpos: np.ndarray
    chain_dof: np.ndarray
    nominal_qpos: np.ndarray
    frozen_dofs: list[int]
    warnings: tuple[str, ...] = ()
    """What MuJoCo's parser and compiler warned about (e.g. a joint whose equal limits it ignores)."""


_MODELS = ChainCache()


def mujoco_chain(chain: Chain) -> MuJoCoChain:
    """MuJoCo's model of the chain's robot with its sites and joint maps, built and checked once per
    chain; UnsupportedError naming the chain and the reason when MuJoCo cannot take it."""
    _, mujoco = import_mink()
    if (cached := _MODELS.get(chain)) is not None:
        return cached
    label = f"method 'mink' cannot solve {chain.robot.name}.{chain.name}"
    try:
        built = _build(chain, mujoco)
    except UnsupportedError as refused:
        raise UnsupportedError(f"{label}: {refused}") from None
    worst = _agreement(chain, built, mujoco)
    if not worst <= AGREEMENT_TOLERANCE:
        raise UnsupportedError(
            f"{label}: MuJoCo's FK of the chain differs from wbik's by up to {worst:.3g} (m, rad) on "
            f"{AGREEMENT_POSES} random joint vectors (allowed {AGREEMENT_TOLERANCE:g}): MuJoCo reads this "
            "URDF differently")
    return _MODELS.store(chain, built)


_WARNINGS_LOCK = threading.Lock()


@contextmanager
def mujoco_warnings(mujoco) -> Iterator[list[str]]:
    """Collect MuJoCo's warnings in a list instead of its default handler (which prints them and appends
    them to MUJOCO_LOG.TXT in the working directory); the previous handler is restored after."""
    messages: list[str] = []
    with _WARNINGS_LOCK:
        previous = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(messages.append)
        try:
            yield messages
        finally:
            mujoco.set_mju_user_warning(previous)


def _build(chain: Chain, mujoco) -> MuJoCoChain:
    with mujoco_warnings(mujoco) as warnings:
        built = _compile(chain, mujoco)
    built.warnings = tuple(warnings)
    return built


def urdf_spec(mujoco, urdf_text: str, masses: bool = False):
    """MuJoCo's MjSpec of the robot's URDF text (as :func:`mujoco_urdf` prepares it, ``masses`` as there);
    UnsupportedError when MuJoCo cannot read it."""
    try:
        return mujoco.MjSpec.from_string(mujoco_urdf(urdf_text, masses=masses))
    except ValueError as exc:
        raise UnsupportedError(f"MuJoCo cannot read the URDF: {str(exc).strip()}") from None


def add_site(body, name: str, placement: pin.SE3) -> None:
    """A site called ``name`` on the MjSpec body ``body``, at ``placement`` in the body's frame."""
    quaternion = pin.Quaternion(placement.rotation)
    body.add_site(name=name, pos=placement.translation.tolist(),
                  quat=[quaternion.w, quaternion.x, quaternion.y, quaternion.z])


def compile_spec(spec):
    """MuJoCo's model (MjModel) of the MjSpec ``spec``; UnsupportedError when it does not compile."""
    try:
        return spec.compile()
    except ValueError as exc:
        raise UnsupportedError(f"MuJoCo cannot compile the URDF: {str(exc).strip()}") from None


def _compile(chain: Chain, mujoco) -> MuJoCoChain:
    robot = chain.robot
    spec = urdf_spec(mujoco, robot.urdf_text)
    for site, frame in ((BASE_SITE, chain.base_frame), (TIP_SITE, chain.tip_frame)):
        where = frame_on_body(robot, frame)
        body = spec.body(where.body)
        if body is None:
            raise UnsupportedError(f"frame {frame!r}: MuJoCo has no body {where.body!r}")
        add_site(body, site, where.placement)
    model = compile_spec(spec)
    slots = {int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)}
    chain_qpos, chain_dof = [], []
    for name in chain.joint_names:
        joint_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if joint_id < 0:
            raise UnsupportedError(f"MuJoCo's model has no joint {name!r}")
        if int(model.jnt_type[joint_id]) not in slots:
            raise UnsupportedError(f"MuJoCo reads joint {name!r} as neither a hinge nor a slide")
        chain_qpos.append(int(model.jnt_qposadr[joint_id]))
        chain_dof.append(int(model.jnt_dofadr[joint_id]))
    nominal = model.qpos0.copy()
    pin_model = robot.model
    for joint_id in range(1, pin_model.njoints):
        if pin_model.joints[joint_id].nq != 1:
            continue
        mj_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, pin_model.names[joint_id])
        if mj_id >= 0 and int(model.jnt_type[mj_id]) in slots:
            nominal[model.jnt_qposadr[mj_id]] = robot.nominal[pin_model.joints[joint_id].idx_q]
    frozen = sorted(set(range(model.nv)) - set(chain_dof))
    return MuJoCoChain(model, np.array(chain_qpos), np.array(chain_dof), nominal, frozen)


def _agreement(chain: Chain, built: MuJoCoChain, mujoco) -> float:
    """Largest difference (m or rad) between MuJoCo's and wbik's base -> tip pose on seeded random joints."""
    data = mujoco.MjData(built.model)
    worst = 0.0
    for q in chain.random(np.random.default_rng(AGREEMENT_SEED), AGREEMENT_POSES):
        reached = site_pose(built, data, q, mujoco)
        expected = chain.fk(q)
        worst = max(worst, float(np.linalg.norm(reached.translation - expected.translation)),
                    float(np.linalg.norm(pin.log3(expected.rotation.T @ reached.rotation))))
    return worst


def site_pose(built: MuJoCoChain, data, q: np.ndarray, mujoco) -> pin.SE3:
    """MuJoCo's pose of the tip site in the base site at chain joints q (others at the nominal)."""
    data.qpos[:] = built.nominal_qpos
    data.qpos[built.chain_qpos] = q
    mujoco.mj_kinematics(built.model, data)
    return _site(data, BASE_SITE).actInv(_site(data, TIP_SITE))


def _site(data, name: str) -> pin.SE3:
    site = data.site(name)
    return pin.SE3(site.xmat.reshape(3, 3).copy(), site.xpos.copy())


class MinkSolver(Solver):
    """mink's differential IK loop on MuJoCo's model of the same URDF; see the module docstring."""

    name = "mink"
    # the budget's unit: one mink step (DAQP, both limits, FK check); its measured cost:
    # docs/measurements.md, mink
    iteration_cost_s = 120e-6
    default_budget_s = 0.03

    def __init__(self, robot, chain=None, *, max_iterations: int | None = None, backend: str = "daqp",
                 damping: float = 1e-3, lm_damping: float = 1e-3, limit_gain: float = 0.95,
                 max_step: float = 0.5, **options):
        """``backend``: the qpsolvers name mink.solve_ik uses; ``damping``: solve_ik's Levenberg-Marquardt
        damping on every DOF; ``lm_damping``: the frame task's (scaled by its squared error);
        ``limit_gain``: ConfigurationLimit's gain in (0, 1]; ``max_step``: the VelocityLimit's bound on
        one step of each chain joint (rad or m; ``math.inf``: no VelocityLimit)."""
        super().__init__(robot, chain, **options)
        self.max_iterations = self._iteration_budget(max_iterations)
        self.backend = backends.resolve(backend)
        self.damping = check_positive_finite("damping", damping)
        self.lm_damping = check_nonnegative_finite("lm_damping", lm_damping)
        self.limit_gain = check_gain("limit_gain", limit_gain)
        self.max_step = float(max_step)
        if not self.max_step > 0.0:  # NaN, zero or negative
            raise InvalidSettingError(f"max_step must be a number > 0 (math.inf: no bound), got {max_step!r}")
        self.mink, self.mujoco = import_mink()
        self.built = mujoco_chain(self.chain)
        self._thread_state()  # build this thread's configuration and tasks now (errors show here)

    def _new_thread_state(self) -> SimpleNamespace:
        """This thread's mink Configuration (its own MjData), tasks, limits and freezing constraint."""
        mink, model = self.mink, self.built.model
        configuration = mink.Configuration(model, self.built.nominal_qpos.copy())
        pose = mink.FrameTask(TIP_SITE, "site", position_cost=1.0, orientation_cost=1.0,
                              lm_damping=self.lm_damping)
        position = mink.FrameTask(TIP_SITE, "site", position_cost=1.0, orientation_cost=0.0,
                                  lm_damping=self.lm_damping)
        limits = [mink.ConfigurationLimit(model, gain=self.limit_gain)]
        if math.isfinite(self.max_step):
            bounds = {name: self.max_step / DT for name in self.chain.joint_names}  # |dq| <= v_max dt
            limits.append(mink.VelocityLimit(model, bounds))
        frozen = self.built.frozen_dofs
        constraints = [mink.DofFreezingTask(model, dof_indices=frozen)] if frozen else []
        return SimpleNamespace(configuration=configuration, pose=pose, position=position, limits=limits,
                               constraints=constraints)

    def mink_fk(self, q: np.ndarray) -> pin.SE3:
        """MuJoCo's pose of the chain's tip in its base frame at chain joints q (the others at the nominal),
        through this thread's mink Configuration."""
        state = self._thread_state()
        qpos = self.built.nominal_qpos.copy()
        qpos[self.built.chain_qpos] = self.chain.check_q(q)
        state.configuration.update(qpos)
        reached = state.configuration.get_transform(TIP_SITE, "site", BASE_SITE, "site")
        return pin.SE3(reached.as_matrix())

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        chain, built, mink = self.chain, self.built, self.mink
        state = self._thread_state()
        configuration = state.configuration
        q = chain.clip(q0)
        qpos = built.nominal_qpos.copy()
        qpos[built.chain_qpos] = q
        configuration.update(qpos)
        base = configuration.get_transform_frame_to_world(BASE_SITE, "site").as_matrix()
        world_target = base @ target.se3().homogeneous
        task = state.pose if target.is_pose else state.position  # a position: orientation cost 0
        task.set_target(mink.SE3.from_matrix(world_target))
        tolerance_p, tolerance_r = self.tolerances.position, self.tolerances.rotation
        best, stalled = math.inf, 0
        for iteration in range(self.max_iterations + 1):
            error, _ = task_error(chain, target, q, with_jacobian=False)
            if converged(error, tolerance_p, tolerance_r):
                return Candidate(q, iteration)
            if iteration == self.max_iterations:
                break
            size = float(np.linalg.norm(error))
            stalled = 0 if size < best * (1.0 - 1e-9) else stalled + 1
            best = min(best, size)
            if stalled >= STALL_ITERATIONS:
                return Candidate(q, iteration, f"stalled: {STALL_ITERATIONS} mink steps without progress")
            if deadline != math.inf and time.perf_counter() > deadline:
                return Candidate(q, iteration, f"time budget of {self.timeout_s:g} s used up")
            try:
                velocity = mink.solve_ik(configuration, [task], DT, self.backend, damping=self.damping,
                                         limits=state.limits, constraints=state.constraints)
            except mink.NoSolutionFound as exc:
                return Candidate(q, iteration, f"mink's QP found no step: {exc}")
            configuration.integrate_inplace(velocity, DT)
            q = configuration.data.qpos[built.chain_qpos].copy()
        return Candidate(q, self.max_iterations, f"no convergence in {self.max_iterations} iterations")


IK_METHODS = (
    IKMethod("mink", MinkSolver,
             "mink 1.3.0's differential IK (MuJoCo) on the same URDF: frame task, joint limits"),
)
"""The methods this module declares to :mod:`wbik.solvers.method_registry`."""
