"""Method ``placo``: the same chain targets solved by PlaCo's kinematics solver (C++), same URDF.

PlaCo loads the robot's URDF (``robot.urdf_path``) with its visual and collision geometry removed,
since PlaCo resolves every mesh a URDF names and the kinematics do not need them. PlaCo always
adds a floating base; it is masked (fixed at the robot's nominal base pose), and so is every joint
outside the chain (held at the robot's nominal), so PlaCo moves exactly the chain's joints. One
frame task (pose target) or position task (position target) on the tip, joint limits on; each
``solve(True)`` is one QP step, iterated to the shared tolerance, a stall or the deadline.
"""

from __future__ import annotations

import re
import time
from functools import lru_cache
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pinocchio as pin

from wbik.errors import MissingDependencyError
from wbik.errors import RobotDescriptionError
from wbik.robot import Robot
from wbik.robot import write_cached_urdf
from wbik.solvers.base import Candidate
from wbik.solvers.base import Solver
from wbik.solvers.method_registry import IKMethod
from wbik.targets import Target
from wbik.targets import pose_error
from wbik.urdf import continuous_as_revolute
from wbik.urdf import fixed_joints_renamed


def import_placo():
    try:
        import placo
    except ImportError as exc:  # pragma: no cover - placo is a pinned dependency
        raise MissingDependencyError(
            "PlaCo is not installed: 'pip install placo==0.10.2' (it needs pin==3.8.0 exactly)") from exc
    return placo


PLACO_CONTINUOUS_LIMIT = 100.0
"""Limits (rad) PlaCo gets for a continuous joint: wide enough never to bind in a solve (16 turns)."""
_GEOMETRY = re.compile(r"<(visual|collision)\b[^>]*?/>|<(visual|collision)\b.*?</\2\s*>", re.DOTALL)


@lru_cache(maxsize=32)
def _kinematic_urdf(name: str, text: str) -> Path:
    # a regular expression rather than an XML parser: URDF readers accept some files that a strict
    # XML parser rejects (e.g. "--" inside comments)
    # continuous joints as revolute ones with wide limits: one angle each, as in wbik's model (PlaCo would
    # store cos, sin; the answers are wrapped by the shared check); a fixed joint named like a link
    # renamed, as in wbik's model (PlaCo looks frames up by name alone)
    text = fixed_joints_renamed(continuous_as_revolute(_GEOMETRY.sub("", text), PLACO_CONTINUOUS_LIMIT))
    return write_cached_urdf(f"{name}-kinematic", text)


def kinematic_urdf_path(robot: Robot) -> Path:
    """A copy of the robot's URDF without meshes or primitive geometry (kinematics and inertias kept)."""
    return _kinematic_urdf(robot.name, robot.urdf_text)


def placo_robot(robot: Robot, q: np.ndarray | None = None, humanoid_urdf: Path | None = None):
    """A PlaCo model of the robot at configuration q (default: nominal), base pose included: a
    placo.RobotWrapper of its kinematic URDF, or with ``humanoid_urdf`` a placo.HumanoidRobot of that
    URDF (the robot's, with the frames PlaCo's humanoid looks for)."""
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
    if robot.has_floating_base:
        wrapper.set_T_world_fbase(pin.XYZQUATToSE3(q[:7]).homogeneous)
    else:
        wrapper.set_T_world_fbase(np.eye(4))
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


class PlacoSolver(Solver):
    name = "placo"

    def __init__(self, robot, chain=None, *, max_iterations: int = 300, regularization: float = 1e-9,
                 **options):
        super().__init__(robot, chain, **options)
        self.max_iterations = int(max_iterations)
        self.placo = import_placo()
        self.regularization = float(regularization)
        self._thread_state()  # build this thread's PlaCo robot and solver now (errors show here)

    def _new_thread_state(self) -> SimpleNamespace:
        """This thread's PlaCo robot wrapper and solver (they hold the configuration being solved)."""
        wrapper = placo_robot(self.robot)
        solver = self.placo.KinematicsSolver(wrapper)
        solver.mask_fbase(True)
        solver.enable_joint_limits(True)
        chain_joints = set(self.chain.joint_names)
        model = self.robot.model
        for joint_id in range(1, model.njoints):
            name = model.names[joint_id]
            if model.joints[joint_id].nq == 1 and name not in chain_joints:
                solver.mask_dof(name)
        solver.add_regularization_task(self.regularization)
        return SimpleNamespace(wrapper=wrapper, solver=solver, task=None, task_kind=None)

    @staticmethod
    def _set_task(state: SimpleNamespace, tip_frame: str, target: Target, world_target: np.ndarray) -> None:
        kind = "pose" if target.is_pose else "position"
        if state.task is not None and state.task_kind != kind:
            state.solver.remove_task(state.task)
            state.task = None
        if state.task is None:
            if kind == "pose":
                state.task = state.solver.add_frame_task(tip_frame, world_target)
            else:
                state.task = state.solver.add_position_task(tip_frame, world_target[:3, 3])
            state.task.configure("target", "soft", 1.0)
            state.task_kind = kind
        elif kind == "pose":
            state.task.T_world_frame = world_target
        else:
            state.task.target_world = world_target[:3, 3]

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        chain = self.chain
        state = self._thread_state()
        wrapper = state.wrapper
        set_placo_configuration(self.robot, wrapper, chain.full_configuration(q0))
        base = wrapper.get_T_world_frame(chain.base_frame)
        self._set_task(state, chain.tip_frame, target, base @ target.se3().homogeneous)
        tolerance = 0.5 * min(self.tolerances.position, self.tolerances.rotation)
        q = q0.copy()
        previous = np.inf
        stalled = 0
        for iteration in range(1, self.max_iterations + 1):
            position_error, rotation_error = pose_error(chain.fk(q), target)
            error = float(np.linalg.norm(position_error)) + (
                0.0 if rotation_error is None else float(np.linalg.norm(rotation_error)))
            if error <= tolerance:
                return Candidate(q, iteration - 1)
            stalled = stalled + 1 if error > previous - 1e-14 else 0
            if stalled >= 5:
                return Candidate(q, iteration - 1, "stalled: PlaCo's steps no longer reduce the error")
            if time.perf_counter() > deadline:
                return Candidate(q, iteration - 1, f"time budget of {self.timeout_s:g} s used up")
            previous = error
            try:
                state.solver.solve(True)
            except RuntimeError as exc:
                return Candidate(q, iteration, f"PlaCo's QP failed: {exc}")
            wrapper.update_kinematics()
            q = np.array([wrapper.get_joint(name) for name in chain.joint_names])
        return Candidate(q, self.max_iterations, f"no convergence in {self.max_iterations} iterations")


IK_METHODS = (
    IKMethod("placo", PlacoSolver,
             "PlaCo's kinematics solver on the same URDF"),
)
"""The methods this module declares to :mod:`wbik.solvers.method_registry`."""
