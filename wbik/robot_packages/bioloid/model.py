"""Robotis Bioloid Premium Type A humanoid (seed 003): 18 AX-12 servos on a floating base.

:func:`urdf_text` generates the committed ``bioloid.urdf`` (:data:`URDF_PATH`); x forward, y left, z up.
Exact from the seed (bioloid.md 1.5, 3.3): the hip yaw, roll and pitch axes meet at ``r_hip``; thigh and
shank are L8 = 75 mm links whose knee sits at the servo rotor, L7 = 14.5 mm *behind* the leg line
(hip -> rotor = rotor -> ankle = Lf), so the thesis IK inverts the FK exactly on the walking branch
(knee flexion >= 2 alpha); the ankle pitch and roll axes meet at ``r_ankle``. Arm: base axis at y = -L0
(about -y, q1 = atan2(z, x)), shoulder roll at (L2, -L1), elbow L3 further, hand L4 = 0.0745 + tool.

Joints vs the thesis: right arm q = (theta1, -theta3, -theta5); legs q = (-theta7, -theta9,
theta11 - 90, 180 - theta13, theta15 - 90, theta17) deg. Both sides share axis directions, so a
mirrored pose negates the roll and yaw joints. Limits: the code's servo limits through the servo map
(bioloid.md 1.6), the left side mirrored (rolls included, which the code forgot, bioloid.md 9.6).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbik.collision import box, capsule
from wbik.data import description_file
from wbik.errors import RobotDescriptionError
from wbik.qp.support_polygon import sole_rectangle
from wbik.robot import ChainSpec, Robot, robot_from_urdf_text
from wbik.robot_packages.bioloid.closed_form import ALPHA as ALPHA
from wbik.robot_packages.bioloid.closed_form import (
    ARM_JOINTS,
    FOREARM,
    L0,
    L1,
    L2,
    L3,
    L7,
    L8,
    LEG_JOINTS,
    LF,
    MIRROR_SIGN,
    TOOL_CODE,
    ArmPosition,
    BioloidFacts,
    LegPose,
    LegPosition,
    arm_lengths,
)
from wbik.robot_packages.bioloid.closed_form import TOOL_THESIS as TOOL_THESIS
from wbik.schema import Number

# ASSUMPTIONS (not in the seed), m
HIP_LATERAL = 0.0385  # pelvis centre -> hip, sideways: the code's unlabelled L5
HIP_DROP = 0.031  # pelvis origin -> hip roll/pitch intersection, down: the code's unlabelled L6
ANKLE_HEIGHT = 0.0295  # ankle axes -> sole: the code's unlabelled L9
CHEST_HEIGHT = 0.090  # pelvis origin -> chest centre (the arm frame), up: ~0.30 m shoulders
SOLE_LENGTH, SOLE_WIDTH = 0.100, 0.060  # sole rectangle, centred under the ankle
SOLES = {sole: sole_rectangle(SOLE_LENGTH, SOLE_WIDTH) for sole in ("r_sole", "l_sole")}

SERVO_MASS = 0.0546  # AX-12A (kg), bkop/BIOLOID_TYPE_A_DYN_MODEL_RTB (bioloid.md 1.8)
AX12_SPEED = 114 * 2 * math.pi / 60  # no-load speed at 12 V (rad/s)
AX12_TORQUE = 1.5  # stall torque at 12 V (N m)
STANDING_HIP_HEIGHT = 0.14  # hip above ankle in the code's standing pose (zd, bioloid.md 4.4, m)
STANDING_PITCH = math.radians(20.0)  # torso pitch of the code's gait (hPitch)

SERVO_IDS = {
    "r_shoulder_pitch": 1, "l_shoulder_pitch": 2, "r_shoulder_roll": 3, "l_shoulder_roll": 4,
    "r_elbow": 5, "l_elbow": 6, "r_hip_yaw": 7, "l_hip_yaw": 8, "r_hip_roll": 9, "l_hip_roll": 10,
    "r_hip_pitch": 11, "l_hip_pitch": 12, "r_knee": 13, "l_knee": 14, "r_ankle_pitch": 15,
    "l_ankle_pitch": 16, "r_ankle_roll": 17, "l_ankle_roll": 18,
}
CLOSED_FORMS = {("right_arm", "position"): ArmPosition, ("left_arm", "position"): ArmPosition,
                ("right_leg", "pose"): LegPose, ("left_leg", "pose"): LegPose,
                ("right_leg", "position"): LegPosition, ("left_leg", "position"): LegPosition}

RIGHT_LIMITS_DEG = {  # degrees; the left side mirrors them
    "shoulder_pitch": (-62.0, 238.0), "shoulder_roll": (-90.0, 90.0), "elbow": (-90.0, 90.0),
    "hip_yaw": (-55.0, 50.0), "hip_roll": (-50.0, 40.0), "hip_pitch": (-100.0, 25.0),
    "knee": (-10.0, 104.0), "ankle_pitch": (-60.0, 30.0), "ankle_roll": (-30.0, 40.0),
}


def joint_limits_deg(side: str, joint: str) -> tuple[float, float]:
    """(lower, upper) in degrees of ``joint`` (e.g. "knee") on side "r" or "l"."""
    lower, upper = RIGHT_LIMITS_DEG[joint]
    if side == "l" and MIRROR_SIGN[joint] < 0:
        return -upper, -lower
    return lower, upper


def _vec(values) -> str:
    return " ".join(f"{v:.6g}" if abs(v) > 1e-15 else "0" for v in values)


class _UrdfWriter:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def comment(self, text: str) -> None:
        if "--" in text:
            raise ValueError(f"'--' is not allowed inside an XML comment: {text!r}")
        self.lines.append(f"  <!-- {text} -->")

    def link(self, name: str, mass: float = 0.0, com=(0.0, 0.0, 0.0), size=(0.03, 0.03, 0.03),
             note: str = "") -> None:
        if mass <= 0.0:
            self.lines.append(f'  <link name="{name}"/>')
            return
        x, y, z = size  # a box's inertia
        ixx, iyy, izz = mass * (y * y + z * z) / 12, mass * (x * x + z * z) / 12, mass * (x * x + y * y) / 12
        if note:
            self.comment(note)
        self.lines += [
            f'  <link name="{name}">',
            "    <inertial>",
            f'      <origin xyz="{_vec(com)}" rpy="0 0 0"/>',
            f'      <mass value="{mass:.6g}"/>',
            f'      <inertia ixx="{ixx:.6g}" ixy="0" ixz="0" iyy="{iyy:.6g}" iyz="0" izz="{izz:.6g}"/>',
            "    </inertial>",
            "    <visual>",
            f'      <origin xyz="{_vec(com)}" rpy="0 0 0"/>',
            f'      <geometry><box size="{_vec(size)}"/></geometry>',
            "    </visual>",
            "  </link>",
        ]

    def joint(self, name: str, parent: str, child: str, xyz, kind: str = "fixed", details=()) -> None:
        """A joint (fixed unless ``kind`` says otherwise; ``details``: its axis and limit lines)."""
        self.lines += [f'  <joint name="{name}" type="{kind}">', f'    <parent link="{parent}"/>',
                       f'    <child link="{child}"/>', f'    <origin xyz="{_vec(xyz)}" rpy="0 0 0"/>',
                       *details, "  </joint>"]

    def revolute(self, name: str, parent: str, child: str, xyz, axis, note: str) -> None:
        """A revolute joint "SIDE_JOINT" with :func:`joint_limits_deg`'s limits."""
        lower, upper = (math.radians(v) for v in joint_limits_deg(name[:1], name[2:]))
        self.comment(f"{name}: Dynamixel ID {SERVO_IDS[name]}. {note}")
        self.joint(name, parent, child, xyz, "revolute", (
            f'    <axis xyz="{_vec(axis)}"/>',
            f'    <limit lower="{lower:.10f}" upper="{upper:.10f}" effort="{AX12_TORQUE}" '
            f'velocity="{AX12_SPEED:.6f}"/>'))


def _leg(w: _UrdfWriter, side: str) -> None:
    s = -1.0 if side == "r" else 1.0  # lateral sign
    p = side + "_"
    w.comment(f"== {'right' if side == 'r' else 'left'} leg ==")
    w.comment(f"ASSUMPTION: hip {HIP_LATERAL * 1000:g} mm sideways and {HIP_DROP * 1000:g} mm below the "
              "pelvis origin (the code's unlabelled L5, L6)")
    w.joint(p + "hip_mount", "pelvis", p + "hip", (0.0, s * HIP_LATERAL, -HIP_DROP))
    w.link(p + "hip")
    w.revolute(p + "hip_yaw", p + "hip", p + "hip_yaw_link", (0, 0, 0), (0, 0, 1),
               "Vertical axis through the hip point.")
    w.link(p + "hip_yaw_link", SERVO_MASS + 0.010, (0.0, 0.0, -0.012), (0.035, 0.035, 0.025),
           f"hip roll servo (ID {SERVO_IDS[p + 'hip_roll']}) and bracket; masses are estimates")
    w.revolute(p + "hip_roll", p + "hip_yaw_link", p + "hip_roll_link", (0, 0, 0), (1, 0, 0),
               "Intersects the hip yaw and pitch axes at the hip point.")
    w.link(p + "hip_roll_link", SERVO_MASS + 0.010, (0.0, 0.0, -0.005), (0.035, 0.035, 0.025),
           f"hip pitch servo (ID {SERVO_IDS[p + 'hip_pitch']}) and bracket")
    w.revolute(p + "hip_pitch", p + "hip_roll_link", p + "thigh", (0, 0, 0), (0, 1, 0),
               "Positive bends the thigh backward.")
    w.link(p + "thigh", SERVO_MASS + 0.025, (-0.004, 0.0, -0.050), (0.035, 0.035, 0.075),
           f"thigh frames and the knee servo (ID {SERVO_IDS[p + 'knee']})")
    w.comment(f"Knee rotor: L8 = {L8 * 1000:g} mm down the thigh and L7 = {L7 * 1000:g} mm BEHIND it (seed "
              "geometry; the side makes the thesis IK exact on the walking branch)")
    w.revolute(p + "knee", p + "thigh", p + "shank", (-L7, 0, -L8), (0, 1, 0),
               "Positive flexes the knee; zero is the straight leg.")
    w.link(p + "shank", SERVO_MASS + 0.025, (0.004, 0.0, -0.030), (0.035, 0.035, 0.075),
           f"shank frames and the ankle pitch servo (ID {SERVO_IDS[p + 'ankle_pitch']})")
    w.revolute(p + "ankle_pitch", p + "shank", p + "ankle_pitch_link", (L7, 0, -L8), (0, 1, 0),
               "Shank: from the rotor L7 forward and L8 down to the ankle point.")
    w.link(p + "ankle_pitch_link", SERVO_MASS + 0.010, (0.0, 0.0, 0.0), (0.035, 0.035, 0.025),
           f"ankle roll servo (ID {SERVO_IDS[p + 'ankle_roll']}) and bracket")
    w.revolute(p + "ankle_roll", p + "ankle_pitch_link", p + "ankle", (0, 0, 0), (1, 0, 0),
               "Intersects the ankle pitch axis at the ankle point.")
    w.link(p + "ankle", 0.060, (0.0, 0.0, -0.022), (SOLE_LENGTH, SOLE_WIDTH, 0.015),
           "foot plate, foot sensor board and Sharp sensor (estimate)")
    w.comment(f"ASSUMPTION: sole {ANKLE_HEIGHT * 1000:g} mm below the ankle point (the code's unlabelled "
              f"L9), sole rectangle {SOLE_LENGTH * 1000:g} x {SOLE_WIDTH * 1000:g} mm under the ankle")
    w.joint(p + "sole_mount", p + "ankle", p + "sole", (0.0, 0.0, -ANKLE_HEIGHT))
    w.link(p + "sole")


def _arm(w: _UrdfWriter, side: str, tool_length: float) -> None:
    s = -1.0 if side == "r" else 1.0
    p = side + "_"
    forearm = FOREARM + tool_length
    w.comment(f"== {'right' if side == 'r' else 'left'} arm: L0 {L0} L1 {L1} L2 {L2} L3 {L3} "
              f"L4 {FOREARM} + tool {tool_length:g} = {forearm:g} m ==")
    w.revolute(p + "shoulder_pitch", "chest", p + "shoulder", (0, s * L0, 0), (0, -1, 0),
               "Base servo, L0 from the chest centre; about -y: q = theta1 = atan2(z, x) of the arm plane.")
    w.link(p + "shoulder", SERVO_MASS + 0.015, (L2 * 0.6, s * L1, 0.0), (0.035, 0.030, 0.030),
           f"shoulder servo (ID {SERVO_IDS[p + 'shoulder_roll']}) and bracket")
    w.revolute(p + "shoulder_roll", p + "shoulder", p + "upper_arm", (L2, s * L1, 0), (0, 0, 1),
               "L2 along the arm plane and L1 outward; q = -theta3 (right arm).")
    w.link(p + "upper_arm", SERVO_MASS + 0.015, (0.0, s * L3 * 0.6, 0.0), (0.030, L3, 0.030),
           f"upper arm frame and the elbow servo (ID {SERVO_IDS[p + 'elbow']})")
    w.revolute(p + "elbow", p + "upper_arm", p + "forearm", (0, s * L3, 0), (0, 0, 1),
               "L3 from the shoulder axis; q = -theta5 (right arm).")
    w.link(p + "forearm", 0.030, (0.0, s * forearm * 0.5, 0.0), (0.025, forearm, 0.025), "forearm and hand")
    w.joint(p + "hand_mount", p + "forearm", p + "hand", (0, s * forearm, 0))
    w.link(p + "hand")


def urdf_text(tool_length: float = TOOL_CODE) -> str:
    """The Bioloid URDF (root ``pelvis``; pass it to Pinocchio with a free-flyer root joint)."""
    w = _UrdfWriter()
    w.lines += ['<?xml version="1.0"?>',
                "<!-- Generated by wbik.robot_packages.bioloid.model.urdf_text(); do not edit. -->",
                '<robot name="bioloid">']
    w.comment("Robotis Bioloid Premium Type A (seed 003, bioloid.md). x forward, y left, z up. SI units.")
    w.comment("Masses are estimates: AX-12A 54.6 g each plus brackets, battery, controller; total ~1.7 kg.")
    w.link("pelvis", 2 * SERVO_MASS + 0.010, (0.0, 0.0, -0.010), (0.05, 0.10, 0.03),
           "pelvis plate and the two hip yaw servos (IDs 7, 8)")
    w.comment(f"ASSUMPTION: chest centre (the arm frame) {CHEST_HEIGHT * 1000:g} mm above the pelvis origin")
    w.joint("chest_mount", "pelvis", "chest", (0.0, 0.0, CHEST_HEIGHT))
    w.link("chest", 2 * SERVO_MASS + 0.300, (-0.010, 0.0, -0.020), (0.07, 0.10, 0.10),
           "torso frame, head, battery, controller and the two base servos (IDs 1, 2)")
    for side in ("r", "l"):
        _arm(w, side, tool_length)
    for side in ("r", "l"):
        _leg(w, side)
    w.lines.append("</robot>")
    return "\n".join(w.lines) + "\n"


URDF_PATH = description_file("bioloid.urdf")


def chain_specs() -> list[ChainSpec]:
    return [spec for side, word in (("r", "right"), ("l", "left")) for spec in (
        ChainSpec(f"{word}_leg", f"{side}_hip", f"{side}_ankle", tuple(f"{side}_{j}" for j in LEG_JOINTS),
                  f"{word} hip point -> {word} ankle point (6 joints)"),
        ChainSpec(f"{word}_arm", "chest", f"{side}_hand", tuple(f"{side}_{j}" for j in ARM_JOINTS),
                  f"chest centre -> {word} hand tip (3 joints)"))]


def standing_leg_angles(hip_height: float = STANDING_HIP_HEIGHT, pitch: float = STANDING_PITCH) -> np.ndarray:
    """Leg joints (rad) of the thesis IK for the hip straight above the ankle (eq. 13-22)."""
    cos_gamma = (hip_height ** 2 - 2 * LF ** 2) / (-2 * LF ** 2)
    gamma = math.atan2(math.sqrt(1 - cos_gamma ** 2), cos_gamma)
    theta13 = gamma - 2 * ALPHA
    theta15 = -(-gamma / 2 + ALPHA)
    theta11 = -pitch + gamma / 2 - ALPHA
    return np.array([0.0, 0.0, theta11 - math.pi / 2, math.pi - theta13, theta15 - math.pi / 2, 0.0])


def _nominal(model: pin.Model, pitch: float, arm_q: np.ndarray) -> np.ndarray:
    """Standing pose: both soles flat on z = 0, centred on the origin, pelvis pitched by ``pitch``."""
    q = pin.neutral(model)
    q[3:7] = pin.Quaternion(pin.utils.rotate("y", pitch)).coeffs()
    legs = standing_leg_angles(pitch=pitch)
    for side in ("r", "l"):
        for name, value in zip(LEG_JOINTS, legs, strict=True):
            q[model.joints[model.getJointId(f"{side}_{name}")].idx_q] = value
        for name, value in zip(ARM_JOINTS, arm_q, strict=True):
            sign = MIRROR_SIGN[name] if side == "l" else 1.0
            q[model.joints[model.getJointId(f"{side}_{name}")].idx_q] = sign * value
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    soles = [data.oMf[model.getFrameId(f"{side}_sole")].translation for side in ("r", "l")]
    q[:3] -= 0.5 * (soles[0] + soles[1])
    return q


ARM_REST_Q = np.radians([88.0, -40.0, 90.0])  # right arm rest: the code's angDescanso {150, 110, 240}


def build(tool_length: float = TOOL_CODE, pitch: float = STANDING_PITCH) -> Robot:
    """The Bioloid on a free-flyer base: ``tool_length`` (m) 0.0255 (the code's) or 0.070 (the
    thesis's), ``pitch`` the nominal standing pose's torso pitch (rad)."""
    tool_length = Number(gt=0, unit="m").checked(tool_length, "tool_length", "bioloid", RobotDescriptionError)
    pitch = Number(gt=-math.pi / 2, lt=math.pi / 2, unit="rad").checked(pitch, "pitch", "bioloid",
                                                                       RobotDescriptionError)
    text = urdf_text(tool_length)
    committed = tool_length == TOOL_CODE and URDF_PATH.is_file() and URDF_PATH.read_text() == text
    path = URDF_PATH if committed else None
    model = pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
    nominal = _nominal(model, pitch, ARM_REST_Q)
    facts = BioloidFacts(
        servo_ids=dict(SERVO_IDS), mirror_sign=dict(MIRROR_SIGN), arm_lengths=arm_lengths(tool_length),
        tool_length=tool_length, standing_hip_height=STANDING_HIP_HEIGHT, standing_pitch=float(pitch),
        hip_lateral=HIP_LATERAL, hip_drop=HIP_DROP, ankle_height=ANKLE_HEIGHT, chest_height=CHEST_HEIGHT,
        sole_size=(SOLE_LENGTH, SOLE_WIDTH))
    return robot_from_urdf_text("bioloid", text, chain_specs(), nominal=nominal, floating_base=True,
                                urdf_path=path, soles=SOLES, closed_forms=CLOSED_FORMS, facts=facts)


def collision_primitives(robot: Robot | None = None) -> list:
    """Collision shapes: the URDF's trunk and pelvis boxes, capsules from joint to joint along the limbs,
    the foot plate. ASSUMPTION: radii 17 mm (legs), 15 mm (upper arms), 12.5 mm (forearms)."""
    shapes = [
        box("trunk", "chest", (0.07, 0.10, 0.10), (-0.010, 0.0, -0.020)),
        box("pelvis", "pelvis", (0.05, 0.10, 0.03), (0.0, 0.0, -0.010)),
    ]
    for s in ("r", "l"):
        shapes += [
            capsule(f"{s}_thigh", f"{s}_thigh", f"{s}_thigh", f"{s}_shank", 0.017),
            capsule(f"{s}_shank", f"{s}_shank", f"{s}_shank", f"{s}_ankle_pitch_link", 0.017),
            box(f"{s}_foot", f"{s}_ankle", (SOLE_LENGTH, SOLE_WIDTH, 0.015),
                (0.0, 0.0, -ANKLE_HEIGHT + 0.0075)),
            capsule(f"{s}_upper_arm", f"{s}_upper_arm", f"{s}_upper_arm", f"{s}_forearm", 0.015),
            capsule(f"{s}_forearm", f"{s}_forearm", f"{s}_forearm", f"{s}_hand", 0.0125),
        ]
    return shapes
