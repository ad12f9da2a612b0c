"""A small floating-base biped for the QP tests (independent of the Bioloid model).

Pelvis 0.6 kg; each leg: hip yaw (z), hip roll (x), hip pitch (y), knee (y), ankle pitch (y),
ankle roll (x), thigh and shank 0.10 m, ankle 0.03 m above the sole; feet 0.10 x 0.06 m;
hips 0.05 m either side of the pelvis. A chest on the pelvis carries a 2-joint right arm.
"""

from __future__ import annotations

import numpy as np

from wbik.robot import ChainSpec, robot_from_urdf_text

THIGH = SHANK = 0.10
ANKLE_HEIGHT = 0.03
HIP_Y = 0.05
FOOT = (0.10, 0.06)


def _inertial(mass: float, xyz: str = "0 0 0") -> str:
    i = 1e-4 * mass
    return (f'<inertial><origin xyz="{xyz}"/><mass value="{mass}"/>'
            f'<inertia ixx="{i}" iyy="{i}" izz="{i}" ixy="0" ixz="0" iyz="0"/></inertial>')


def _joint(name, parent, child, xyz, axis, lower=-1.5, upper=1.5):
    return (f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>'
            f'<limit lower="{lower}" upper="{upper}" effort="10" velocity="5"/></joint>')


def biped_urdf() -> str:
    parts = ['<robot name="biped">', f'<link name="pelvis">{_inertial(0.6)}</link>']
    for side, sign in (("r", -1), ("l", 1)):
        parts.append(f'<link name="{side}_hip"/>')
        parts.append(f'<joint name="{side}_hip_fixed" type="fixed"><parent link="pelvis"/>'
                     f'<child link="{side}_hip"/><origin xyz="0 {sign * HIP_Y} 0"/></joint>')
        links = [f"{side}_{n}" for n in ("yaw_link", "roll_link", "thigh", "shank", "ankle_link", "ankle")]
        joints = [("hip_yaw", "0 0 1", "0 0 0"), ("hip_roll", "1 0 0", "0 0 0"),
                  ("hip_pitch", "0 1 0", "0 0 0"), ("knee", "0 1 0", f"0 0 {-THIGH}"),
                  ("ankle_pitch", "0 1 0", f"0 0 {-SHANK}"), ("ankle_roll", "1 0 0", "0 0 0")]
        parent = f"{side}_hip"
        for link, (joint, axis, xyz) in zip(links, joints, strict=True):
            mass = {"thigh": 0.2, "shank": 0.15}.get(link.split("_", 1)[1], 0.05)
            com = f"0 0 {-0.05}" if link.endswith(("thigh", "shank")) else "0 0 0"
            parts.append(f'<link name="{link}">{_inertial(mass, com)}</link>')
            lower, upper = (-2.0, 0.0) if joint == "knee" else (-1.5, 1.5)
            parts.append(_joint(f"{side}_{joint}", parent, link, xyz, axis, lower, upper))
            parent = link
        parts.append(f'<link name="{side}_sole">{_inertial(0.1)}</link>')
        parts.append(f'<joint name="{side}_sole_fixed" type="fixed"><parent link="{parent}"/>'
                     f'<child link="{side}_sole"/><origin xyz="0 0 {-ANKLE_HEIGHT}"/></joint>')
    parts.append(f'<link name="chest">{_inertial(0.4)}</link>')
    parts.append('<joint name="chest_fixed" type="fixed"><parent link="pelvis"/><child link="chest"/>'
                 '<origin xyz="0 0 0.1"/></joint>')
    parts.append(f'<link name="r_upper_arm">{_inertial(0.1, "0 0 -0.04")}</link>')
    parts.append(_joint("r_shoulder", "chest", "r_upper_arm", "0 -0.06 0", "0 1 0", -3.0, 3.0))
    parts.append(f'<link name="r_forearm">{_inertial(0.1, "0 0 -0.04")}</link>')
    parts.append(_joint("r_elbow", "r_upper_arm", "r_forearm", "0 0 -0.08", "0 1 0", -2.5, 0.0))
    parts.append('<link name="r_hand"/>')
    parts.append('<joint name="r_hand_fixed" type="fixed"><parent link="r_forearm"/><child link="r_hand"/>'
                 '<origin xyz="0 0 -0.08"/></joint>')
    parts.append("</robot>")
    return "\n".join(parts)


def sole_corners() -> np.ndarray:
    half_x, half_y = FOOT[0] / 2, FOOT[1] / 2
    return np.array([[half_x, half_y, 0], [-half_x, half_y, 0], [-half_x, -half_y, 0], [half_x, -half_y, 0]])


def build_biped():
    """The biped standing with bent knees: soles flat on z = 0, pelvis level above them."""
    text = biped_urdf()
    chains = [ChainSpec("right_leg", "r_hip", "r_sole",
                        tuple(f"r_{j}" for j in ("hip_yaw", "hip_roll", "hip_pitch", "knee",
                                                 "ankle_pitch", "ankle_roll")))]
    robot = robot_from_urdf_text("biped", text, chains, floating_base=True,
                                 soles={"r_sole": sole_corners(), "l_sole": sole_corners()})
    q = robot.nominal.copy()
    bend = 0.4
    for side in ("r", "l"):
        for joint, value in (("hip_pitch", bend), ("knee", -2 * bend), ("ankle_pitch", bend)):
            q[robot.model.joints[robot.model.getJointId(f"{side}_{joint}")].idx_q] = value
    q[robot.model.joints[robot.model.getJointId("r_elbow")].idx_q] = -0.3
    # pelvis height so that the soles touch z = 0: hip-to-ankle = 2 L cos(bend), plus the ankle height
    q[2] = 2 * THIGH * np.cos(bend) + ANKLE_HEIGHT
    robot.nominal = q
    return robot
