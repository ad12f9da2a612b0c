"""The robot in MuJoCo (4.0) for mink, from its own URDF (docs/guide/wholebody.md): no visual, collision
or mimic elements (inertial ones only with ``masses``), a ``<mujoco><compiler>`` extension keeping every
link a body, a free joint on a floating base's root link, a site ``wbik:FRAME`` per frame of wbik's model;
refused (UnsupportedError) unless its sites and CoM equal wbik's to 1e-9 (m, rad). MuJoCo's warnings go
to ``MuJoCoBody.warnings``, not to the terminal nor MUJOCO_LOG.TXT.
"""

from __future__ import annotations

import math
import re
import threading
import weakref
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from wbik.dependencies import MINK_LIBRARY, import_optional
from wbik.errors import UnsupportedError
from wbik.geometry import wrap_to_pi
from wbik.robot import Robot

_DROPPED = re.compile(r"<(visual|collision|inertial|mimic)\b[^>]*?/>"
                      r"|<(visual|collision|inertial|mimic)\b.*?</\2\s*>", re.DOTALL)
_DROPPED_BUT_INERTIAL = re.compile(r"<(visual|collision|mimic)\b[^>]*?/>"
                                   r"|<(visual|collision|mimic)\b.*?</\2\s*>", re.DOTALL)
_ROBOT_TAG = re.compile(r"<robot\b[^>]*?>", re.DOTALL)
MUJOCO_EXTENSION = ('<mujoco><compiler fusestatic="false" discardvisual="true" boundmass="1e-9" '
                    'boundinertia="1e-12"/></mujoco>')
MUJOCO_MASS_EXTENSION = ('<mujoco><compiler fusestatic="false" discardvisual="true" inertiafromgeom="false" '
                         'balanceinertia="true" boundmass="1e-12" boundinertia="1e-14"/></mujoco>')
"""With the masses: the links' own masses and CoMs, unphysical inertias balanced (they play no part in
kinematics nor in a CoM), bounds that leave a CoM unchanged to 1e-12 m."""


def import_mink(what: str = "method 'mink'"):
    """(mink, mujoco), or MissingDependencyError naming ``what`` needs them and the extra to install."""
    return import_optional(MINK_LIBRARY, what, "mink"), import_optional(MINK_LIBRARY, what, "mujoco")


def mujoco_urdf(text: str, masses: bool = False) -> str:
    """The robot's URDF for MuJoCo (see the module docstring), read as leniently as URDF readers do."""
    text = (_DROPPED_BUT_INERTIAL if masses else _DROPPED).sub("", text)
    text = re.sub(r"<mujoco\b.*?</mujoco\s*>|<mujoco\b[^>]*/>", "", text, flags=re.DOTALL)
    match = _ROBOT_TAG.search(text)
    if match is None:
        raise UnsupportedError("the URDF has no <robot> element MuJoCo could read")
    return text[:match.end()] + (MUJOCO_MASS_EXTENSION if masses else MUJOCO_EXTENSION) + text[match.end():]


_WARNINGS_LOCK = threading.Lock()


@contextmanager
def captured_warnings(mujoco, into: list[str]) -> Iterator[None]:
    """MuJoCo's warnings appended to ``into``, not printed, inside the block."""
    with _WARNINGS_LOCK:
        previous = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(into.append)
        try:
            yield
        finally:
            mujoco.set_mju_user_warning(previous)


FREE_JOINT = "wbik_free_base"
SITE_PREFIX = "wbik:"
AGREEMENT_POSES, AGREEMENT_SEED, AGREEMENT_TOLERANCE = 4, 0, 1e-9
"""MuJoCo's CoM and sites must equal wbik's to AGREEMENT_TOLERANCE (m, rad) at the nominal and at
AGREEMENT_POSES - 1 seeded random configurations."""


@dataclass
class MuJoCoBody:
    """The robot in MuJoCo: ``model`` (an MjModel), ``sites`` {wbik frame: site name}, wbik's ``q_index``
    and MuJoCo's ``qpos_index`` of the same coordinates (base pose, quaternion reordered, and 1-DOF
    joints), the 1-DOF joints' ``v_index`` and ``dof_index``, ``joint_names`` by wbik's tangent index,
    the continuous joints' q indices (``wrapped``) and the free base's first DOF (``base_dof``)."""

    robot: Robot
    model: Any
    sites: dict[str, str]
    q_index: np.ndarray
    qpos_index: np.ndarray
    v_index: np.ndarray
    dof_index: np.ndarray
    joint_names: dict[int, str]
    wrapped: np.ndarray
    base_dof: int | None = None
    warnings: tuple[str, ...] = ()
    agreed: list = field(default_factory=list)
    """The frame lists whose sites were checked against wbik's."""

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
        """MuJoCo's DOF addresses of wbik's tangent indices (the free base's six and 1-DOF joints')."""
        where = {int(v): int(d) for v, d in zip(self.v_index, self.dof_index, strict=True)}
        if self.base_dof is not None:
            where.update({v: self.base_dof + v for v in range(6)})
        return np.array([where[int(v)] for v in v_index], dtype=int)

    def site(self, frame: str) -> str:
        """The site of a wbik frame."""
        self.robot.frame_id(frame)  # UnknownFrameError names the frames
        return self.sites[frame]


def carrier(robot: Robot, frame_id: int) -> tuple[str | None, pin.SE3]:
    """(URDF link carrying the frame, None for the world; the frame's pose in it): the first link frame up
    its parent frames on the same joint, else a link frame on its joint."""
    model = robot.model
    frame = model.frames[frame_id]
    current = frame_id
    while model.frames[current].parentJoint == frame.parentJoint:
        candidate = model.frames[current]
        if candidate.type == pin.FrameType.BODY:
            link = robot.renamed_frames.get(candidate.name, candidate.name)
            return link, candidate.placement.inverse() * frame.placement
        if candidate.parentFrame == current:
            break
        current = candidate.parentFrame
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


def robot_spec(robot: Robot, mujoco, masses: bool):
    """(MjSpec of the robot, {wbik frame: site name}), not compiled: a scene may add to it."""
    model = robot.model
    try:
        spec = mujoco.MjSpec.from_string(mujoco_urdf(robot.urdf_text, masses=masses))
    except ValueError as exc:
        raise UnsupportedError(f"MuJoCo cannot read the URDF: {str(exc).strip()}") from None
    if robot.has_floating_base:
        root = next(frame for frame in model.frames
                    if frame.type == pin.FrameType.BODY and frame.parentJoint == 1)
        body = spec.body(robot.renamed_frames.get(root.name, root.name))
        if body is None:
            raise UnsupportedError(f"MuJoCo has no body for the root link {root.name!r}")
        body.add_freejoint(name=FREE_JOINT)
    elif masses:
        for body in spec.worldbody.bodies:
            _massless_while_welded(body)
    sites = {}
    for name in dict.fromkeys(frame.name for frame in model.frames):
        link, placement = carrier(robot, robot.frame_id(name))
        body = spec.worldbody if link is None else spec.body(link)
        if body is None:
            raise UnsupportedError(f"frame {name!r}: MuJoCo has no body {link!r}")
        sites[name] = SITE_PREFIX + name
        quaternion = pin.Quaternion(placement.rotation)
        body.add_site(name=sites[name], pos=placement.translation.tolist(),
                      quat=[quaternion.w, quaternion.x, quaternion.y, quaternion.z])
    return spec, sites


def compiled_body(robot: Robot, spec, sites: dict[str, str], mujoco) -> MuJoCoBody:
    """The compiled ``spec`` of ``robot`` (:func:`robot_spec`, perhaps in a scene) with its index maps."""
    model = robot.model
    try:
        compiled = spec.compile()
    except ValueError as exc:
        raise UnsupportedError(f"MuJoCo cannot compile the URDF: {str(exc).strip()}") from None
    slots = {int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)}
    q_index, qpos_index, v_index, dof_index, names, base_dof = [], [], [], [], {}, None
    if robot.has_floating_base:  # x y z, then Pinocchio's quaternion x y z w is MuJoCo's w x y z
        free = mujoco.mj_name2id(compiled, mujoco.mjtObj.mjOBJ_JOINT, FREE_JOINT)
        at, base_dof = int(compiled.jnt_qposadr[free]), int(compiled.jnt_dofadr[free])
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
        q_index, qpos_index, v_index, dof_index)), names, np.array(wrapped, dtype=int), base_dof=base_dof)


def random_configurations(robot: Robot, count: int, seed: int) -> list[np.ndarray]:
    """``count`` seeded configurations in the limits cut to [-pi, pi]; the base within 1 m, any rotation."""
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


def agreement(body: MuJoCoBody, configurations: list[np.ndarray], mujoco, frames, with_com: bool) -> float:
    """Largest difference (m, rad) between MuJoCo's sites of ``frames`` (and CoM) and wbik's."""
    robot = body.robot
    data, pin_data = mujoco.MjData(body.model), robot.model.createData()
    worst = 0.0
    for q in configurations:
        data.qpos[:] = body.qpos(q)
        mujoco.mj_kinematics(body.model, data)
        pin.framesForwardKinematics(robot.model, pin_data, q)
        if with_com:
            mujoco.mj_comPos(body.model, data)
            com = pin.centerOfMass(robot.model, pin_data, q)
            worst = max(worst, float(np.max(np.abs(data.subtree_com[1] - com))))
        for frame in frames:
            site = body.sites[frame]
            expected, reached = pin_data.oMf[robot.frame_id(frame)], data.site(site)
            worst = max(worst, float(np.max(np.abs(reached.xpos - expected.translation))),
                        float(np.linalg.norm(pin.log3(expected.rotation.T @ reached.xmat.reshape(3, 3)))))
    return worst


_BODIES: dict[tuple[int, bool], tuple[weakref.ref, MuJoCoBody]] = {}
_BODIES_LOCK = threading.Lock()


def mujoco_body(robot: Robot, masses: bool = True, frames=None) -> MuJoCoBody:
    """MuJoCo's model of ``robot``, built once per robot and ``masses``, checked against wbik's ``frames``
    (default all; with ``masses`` also the CoM); UnsupportedError saying why MuJoCo cannot take it."""
    _, mujoco = import_mink()
    key = (id(robot), bool(masses))
    with _BODIES_LOCK:
        known = _BODIES.get(key)
    if known is not None and known[0]() is robot:
        body = known[1]
    else:
        warnings: list[str] = []
        try:
            with captured_warnings(mujoco, warnings):
                body = compiled_body(robot, *robot_spec(robot, mujoco, masses), mujoco)
        except UnsupportedError as refused:
            raise UnsupportedError(f"MuJoCo cannot take {robot.name}: {refused}") from None
        body.warnings = tuple(warnings)
        with _BODIES_LOCK:
            _BODIES[key] = (weakref.ref(robot), body)
    frames = list(body.sites) if frames is None else list(frames)
    if frames not in body.agreed:
        configurations = [robot.nominal, *random_configurations(robot, AGREEMENT_POSES - 1, AGREEMENT_SEED)]
        worst = agreement(body, configurations, mujoco, frames, masses)
        if not worst <= AGREEMENT_TOLERANCE:
            what = "CoM or frames" if masses else f"frames {', '.join(frames)}"
            raise UnsupportedError(f"MuJoCo's {what} of {robot.name} differ from wbik's by up to {worst:.3g} "
                                   f"(m, rad) (allowed {AGREEMENT_TOLERANCE:g}): MuJoCo reads this URDF "
                                   "differently")
        body.agreed.append(frames)
    return body
