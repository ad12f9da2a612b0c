"""Golem-III service robot (UNAM), upper body, from the thesis DH table (seed 000, golem3.md).

Tree: base_link -mb (torso lift)-> torso_link -m0 (chest yaw)-> chest_link, then the arms m10..m14 ->
r_eef and m20..m24 -> l_eef (fingers m15, m17 and m25, m27); torso_link -m1, m2-> head_link. The right
arm is the thesis table, A = Rz(theta) Tz(d) Tx(a) Rx(alpha) (m)::

    row  alpha   a            d          theta
    1    0       l1 = 0.1225  h = 1.283  t1 - 90 deg     (t1 = m0)
    2    0       l2 = 0.212   0          t2              (m10)
    3    90 deg  0            0          t3 + 90 deg     (m11)
    4    0       l4 = 0.256   0          t4 - 90 deg + rho (m12)
    5    -90 deg l5 = 0.034   0          t5 - rho        (m13), rho = 13.43 deg
    6    90 deg  0            l6 = 0.4   t6 - 90 deg     (m14)
    6'   tool: Rz(90 deg)

so r_eef's rotation in torso_link is Rz(t1+t2+t3) Ry(-t4-t5) Rx(t6). ASSUMPTION: the left arm mirrors the
right across y = 0 of torso_link, T_left(m0, q) = M T_right(-m0, q) M, M = diag(1, -1, 1) (:data:`HEADER`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from wbik.collision import box, capsule, sphere
from wbik.data import description_file
from wbik.dh import DHJoint, joint_xml, link_xml, rot_z, trans, urdf_document
from wbik.robot import ChainSpec, Robot
from wbik.robot_packages.golem3.closed_form import (
    LEFT_JOINTS,
    RIGHT_JOINTS,
    Golem3Facts,
    golem3_pose,
    golem3_position,
)
from wbik.solvers.analytic.stacked_planar import StackedPlanarGeometry
from wbik.urdf import parse_urdf

L1, L2, L4, L5, L6, H = 0.1225, 0.212, 0.256, 0.034, 0.4, 1.283  # the thesis table's lengths (m)
RHO = math.radians(13.43)
WRIST_TO_EEF = 0.2  # m14 sits 0.2 m before the gripper centre on its own axis (kinematically free)

# joint limits (golem3.md, the robot's control software) of (m0, m10..m14), rad; the left arm's too
ARM_LOWER = (-1.00, -1.14, -3.00, -1.55, -1.67, -1.50)
ARM_UPPER = (1.00, 1.75, 3.00, 1.55, 1.67, 1.50)
ARM_VELOCITY = 1.0  # rad/s, every arm joint (the robot's planner)
LIFT_RANGE = (0.0, 0.55)  # m
LIFT_VELOCITY = 0.005  # m/s
FINGER_RANGE = (0.0, 1.6)  # rad
HEAD_RANGE = (-1.0, 1.0)  # rad

MIRROR = np.diag([1.0, -1.0, 1.0, 1.0])  # sagittal mirror (y -> -y) of torso_link
URDF_PATH = description_file("golem3.urdf")  # the committed URDF, written by write_urdf
CLOSED_FORMS = {("right_arm", "pose"): golem3_pose, ("right_arm", "position"): golem3_position,
                ("left_arm", "pose"): golem3_pose, ("left_arm", "position"): golem3_position}
"""Closed forms of golem3.md ch. 4.1 (pose, up to 4 real branches) and 4.2.1 (position, yaw fixed)."""

# ASSUMPTIONS (not in the thesis): masses in kg, head and finger geometry in m
MASSES = {
    "base_link": 40.0, "torso_link": 12.0, "chest_link": 6.0,
    "arm_link1": 1.2, "arm_link2": 1.5, "arm_link3": 1.4, "arm_link4": 1.0, "arm_link5": 0.6,
    "finger": 0.05, "head_pan_link": 0.4, "head_link": 1.5,
}
HEAD_PAN_HEIGHT = 1.55  # m above torso_link (above the shoulders at h = 1.283)
HEAD_TILT_OFFSET = 0.08  # m above the pan joint
FINGER_BASE = 0.15  # m from the wrist roll joint along the forearm, 0.05 m before the gripper centre
FINGER_SPREAD = 0.03  # m either side of the forearm axis


def arm_dh_rows() -> list[DHJoint]:
    """The thesis table (right arm), rows 1..6; row 6 keeps only 0.2 m of l6, the tool the rest."""
    def row(i: int, a: float, alpha: float, d: float, theta: float, name: str) -> DHJoint:
        return DHJoint(a=a, alpha=alpha, d=d, theta=theta, lower=ARM_LOWER[i], upper=ARM_UPPER[i],
                       velocity=ARM_VELOCITY, effort=30.0, name=name)

    half_pi = math.pi / 2
    return [
        row(0, L1, 0.0, H, -half_pi, "m0"),
        row(1, L2, 0.0, 0.0, 0.0, "m10"),
        row(2, 0.0, half_pi, 0.0, half_pi, "m11"),
        row(3, L4, 0.0, 0.0, -half_pi + RHO, "m12"),
        row(4, L5, -half_pi, 0.0, -RHO, "m13"),
        row(5, 0.0, half_pi, L6 - WRIST_TO_EEF, -half_pi, "m14"),
    ]


def _inertial_link(name: str, mass: float, com: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> str:
    """A link of ``mass`` (kg) as a solid of about 10 cm: I ~ m (0.1 m)^2 / 6."""
    moment = mass * 0.01 / 6.0
    return link_xml(name, mass, com, (moment, moment, moment))


def _arm_elements(side: str) -> list[str]:
    """URDF elements of one arm (joints m10..m14 or m20..m24) and its fingers, from chest_link."""
    rows = arm_dh_rows()
    names = RIGHT_JOINTS if side == "r" else LEFT_JOINTS
    mirror = side == "l"
    axis = np.array([0.0, 0.0, 1.0])

    def place(transform: np.ndarray) -> np.ndarray:
        return MIRROR @ transform @ MIRROR if mirror else transform

    def turn(vector: np.ndarray) -> np.ndarray:
        return -(MIRROR[:3, :3] @ vector) if mirror else vector

    parts = [f"<!-- {'right' if side == 'r' else 'left'} arm -->"]
    carry = rows[0].post("standard")  # Tx(l1): chest axis -> shoulder, in the chest frame
    # left arm: the chest frame is shared, M C(-t1) = C(t1) Rz(180 deg) M (see the module docstring)
    prefix = rot_z(math.pi) if mirror else np.eye(4)
    parent = "chest_link"
    for index, (row, joint) in enumerate(zip(rows[1:], names, strict=True)):
        child = f"{side}_arm_link{index + 1}"
        parts.append(_inertial_link(child, MASSES[f"arm_link{index + 1}"]))
        origin = prefix @ place(carry @ row.pre("standard"))
        parts.append(joint_xml(joint, "revolute", parent, child, origin, turn(axis),
                               (row.lower, row.upper, row.velocity, row.effort)))
        carry = row.post("standard")
        prefix = np.eye(4)
        parent = child
    eef = f"{side}_eef"
    parts.append(link_xml(eef, 0.0))
    tool = trans(y=WRIST_TO_EEF) @ rot_z(math.pi / 2)  # the rest of l6 (y after Post_6), then row 6'
    parts.append(joint_xml(f"{eef}_fixed", "fixed", parent, eef, place(carry @ tool)))
    fingers = ("m15", "m17") if side == "r" else ("m25", "m27")
    for finger, sign in zip(fingers, (1.0, -1.0), strict=True):
        link = f"{side}_finger_{finger}_link"
        parts.append(_inertial_link(link, MASSES["finger"], (0.0, 0.0, 0.03)))
        origin = trans(x=sign * FINGER_SPREAD, z=FINGER_BASE)
        parts.append(joint_xml(finger, "revolute", parent, link, place(origin),
                               turn(np.array([0.0, sign, 0.0])), (*FINGER_RANGE, 1.0, 2.0)))
    return parts


HEADER = """<!--
  Golem-III upper body (UNAM service robot), generated by
  wbik.robot_packages.golem3.model.urdf_text(); do not edit.
  Right arm: the DH table of the thesis (seed 000, golem3.md), m0 = theta1, m10..m14 = theta2..theta6,
  gripper centre r_eef. m14 is placed 0.2 m before r_eef on the forearm axis (the thesis' l6 = 0.4 m
  is measured from the wrist pitch m13; where m14 sits on its own axis does not change the kinematics).
  Limits (rad) from the robot's control software: m0 +-1.00, m10 -1.14..1.75, m11 +-3.00,
  m12 +-1.55, m13 +-1.67, m14 +-1.50; arm velocity 1.0 rad/s; torso lift mb 0..0.55 m at 0.005 m/s.
  ASSUMPTION (left arm): mirror image of the right arm across the sagittal plane y = 0 of torso_link:
  fixed transforms X -> M X M with M = diag(1, -1, 1), joint axes a -> -M a, so equal joint values give
  mirrored poses; the shared chest yaw m0 is not mirrored: T_left(m0, q) = M T_right(-m0, q) M.
  Left limits m20..m24 = right limits m10..m14.
  ASSUMPTIONS (not in the thesis): all masses and inertias; head pan m1 1.55 m above torso_link and
  tilt m2 0.08 m above it (+-1 rad); fingers m15/m17 (m25/m27) hinged 0.15 m past m14, 0.03 m either
  side of the forearm axis (0..1.6 rad).
-->"""


def urdf_text() -> str:
    """The upper body as URDF text (the committed :data:`URDF_PATH`)."""
    rows = arm_dh_rows()
    chest = rows[0]
    parts = [
        HEADER,
        "<!-- base_footprint: a massless root (KDL and TRAC-IK ignore a root link's inertia) -->",
        link_xml("base_footprint", 0.0),
        joint_xml("base_fixed", "fixed", "base_footprint", "base_link", np.eye(4)),
        _inertial_link("base_link", MASSES["base_link"], (0.0, 0.0, 0.3)),
        _inertial_link("torso_link", MASSES["torso_link"], (0.0, 0.0, 0.9)),
        joint_xml("mb", "prismatic", "base_link", "torso_link", np.eye(4), (0.0, 0.0, 1.0),
                  (*LIFT_RANGE, LIFT_VELOCITY, 500.0)),
        "<!-- chest yaw m0 (theta1), shared by both arms: DH row 1, Rz(-90 deg) Tz(h) -->",
        _inertial_link("chest_link", MASSES["chest_link"]),
        joint_xml("m0", "revolute", "torso_link", "chest_link", chest.pre("standard"), (0.0, 0.0, 1.0),
                  (chest.lower, chest.upper, chest.velocity, 60.0)),
        *_arm_elements("r"),
        *_arm_elements("l"),
        "<!-- head (ASSUMPTION: geometry and masses) -->",
        _inertial_link("head_pan_link", MASSES["head_pan_link"]),
        joint_xml("m1", "revolute", "torso_link", "head_pan_link", trans(z=HEAD_PAN_HEIGHT),
                  (0.0, 0.0, 1.0), (*HEAD_RANGE, 1.0, 5.0)),
        _inertial_link("head_link", MASSES["head_link"], (0.05, 0.0, 0.05)),
        joint_xml("m2", "revolute", "head_pan_link", "head_link", trans(z=HEAD_TILT_OFFSET),
                  (0.0, 1.0, 0.0), (*HEAD_RANGE, 1.0, 5.0)),
    ]
    return urdf_document("golem3", "\n".join(parts))


def write_urdf(path: Path = URDF_PATH) -> Path:
    """Regenerate the committed golem3.urdf (:data:`URDF_PATH`)."""
    path.write_text(urdf_text())
    return path


NOMINAL_ARM = (0.0, 0.0, 0.0, 0.0, 0.5, 0.0)  # (m0, arm): upper arm hanging, elbow bent 0.5 rad


def build() -> Robot:
    text = urdf_text()
    chains = [
        ChainSpec("right_arm", "torso_link", "r_eef", ("m0", *RIGHT_JOINTS),
                  "chest yaw + right arm, gripper centre in torso_link (the thesis' 6-DOF arm)"),
        ChainSpec("left_arm", "torso_link", "l_eef", ("m0", *LEFT_JOINTS),
                  "chest yaw + left arm (mirror of the right), gripper centre in torso_link"),
        ChainSpec("right_arm_lift", "base_link", "r_eef", ("mb", "m0", *RIGHT_JOINTS),
                  "torso lift + chest yaw + right arm, in base_link (7 DOF, redundant)"),
    ]
    model = parse_urdf(text, source="golem3").model
    nominal = np.zeros(model.nq)
    for joint_names in (("m0", *RIGHT_JOINTS), ("m0", *LEFT_JOINTS)):
        for name, value in zip(joint_names, NOMINAL_ARM, strict=True):
            nominal[model.joints[model.getJointId(name)].idx_q] = value
    urdf_path = URDF_PATH if URDF_PATH.is_file() and URDF_PATH.read_text() == text else None
    facts = Golem3Facts(StackedPlanarGeometry(l1=L1, l2=L2, l4=L4, l5=L5, l6=L6, h=H, rho=RHO))
    return Robot("golem3", model, text, {spec.name: spec for spec in chains}, nominal, urdf_path=urdf_path,
                 closed_forms=CLOSED_FORMS, facts=facts)


def collision_primitives(robot: Robot | None = None) -> list:
    """Collision shapes: capsules along the arm links, chest and torso, a box base, a sphere head.
    ASSUMPTION (the thesis gives no volumes): radii 0.045..0.06 m arms, 0.11 m torso, 0.12 m head."""
    shapes = [
        box("base", "base_link", (0.55, 0.55, 0.35), (0.0, 0.0, 0.175)),
        capsule("torso", "torso_link", (0.0, 0.0, 0.45), (0.0, 0.0, 1.10), 0.11),
        capsule("chest", "chest_link", "r_arm_link1", "l_arm_link1", 0.09),
        sphere("head", "head_link", 0.12, (0.05, 0.0, 0.08)),
    ]
    for side in ("r", "l"):
        link = f"{side}_arm_link"
        shapes += [
            capsule(f"{side}_shoulder", f"{link}1", f"{link}1", f"{link}2", 0.06),
            capsule(f"{side}_upper_arm", f"{link}3", f"{link}3", f"{link}4", 0.055),
            capsule(f"{side}_forearm", f"{link}4", f"{link}4", f"{link}5", 0.05),
            capsule(f"{side}_hand", f"{link}5", f"{link}5", f"{side}_eef", 0.045),
        ]
    return shapes
