"""UR5 from example-robot-data (limits +-2 pi, elbow +-pi) with the riveting tool appended; chains ``arm``
(base_link -> tcp) and ``ee`` (base_link -> ee_link, ur_kinematics' frame)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wbik.collision import Obstacle, capsule
from wbik.data import description_file
from wbik.models.erd import package_dirs, urdf_path
from wbik.robot import ChainSpec, Robot, robot_from_urdf_text
from wbik.robot_packages.ur5.closed_form import UR5EndEffector, ur5_tool

JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
          "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
TOOL_LENGTH = 0.13  # ASSUMPTION: ee_link -> tcp along the flange normal (m), 100 mm holder + 30 mm pin
TOOL_DIAMETER = 0.005  # ASSUMPTION: the rivet tool's pin (m)
TOOL_URDF_PATH = description_file("ur5_rivet_tool.urdf.xml")  # the tool, a URDF fragment
CLOSED_FORMS = {("ee", "pose"): UR5EndEffector, ("arm", "pose"): ur5_tool}
"""ur_kinematics' closed form (ur5-riveting.md 1.2) on ee_link, and composed with the tool for tcp."""


@dataclass(frozen=True)
class UR5Facts:
    """The UR5's riveting tool (``robot.facts``, ur5-riveting.md): ee_link -> tcp length, pin diameter (m)."""

    tool_length: float
    tool_diameter: float


def urdf_text() -> str:
    base = urdf_path("ur_description/urdf/ur5_robot.urdf").read_text()
    tool = TOOL_URDF_PATH.read_text()
    head, tail = base.rsplit("</robot>", 1)
    return head + tool + "\n</robot>" + tail


def build() -> Robot:
    chains = [
        ChainSpec("arm", "base_link", "tcp", JOINTS, "base_link to the riveting tool's tcp"),
        ChainSpec("ee", "base_link", "ee_link", JOINTS, "base_link to ee_link (ur_kinematics' frame)"),
    ]
    nominal = np.array([0.0, -1.5707963267948966, 1.5707963267948966, -1.5707963267948966,
                        -1.5707963267948966, 0.0])
    return robot_from_urdf_text("ur5", urdf_text(), chains, nominal=nominal,
                                package_dirs=package_dirs(),
                                closed_forms=CLOSED_FORMS, facts=UR5Facts(TOOL_LENGTH, TOOL_DIAMETER))


TABLE_SIZE = (1.4, 1.2, 0.05)  # the table under the UR5 (m), top at z = 0, centred 0.3 m ahead


def collision_primitives(robot: Robot | None = None) -> list:
    """Collision shapes: capsules along the links and the base, the tool's holder and pin. ASSUMPTION:
    radii 0.06 m (base to upper arm), 0.05 (forearm), 0.04 (wrists) round the meshes."""
    return [
        capsule("base", "base_link", (0.0, 0.0, 0.0), (0.0, 0.0, 0.06), 0.06),
        capsule("shoulder", "shoulder_link", (0.0, 0.0, -0.03), (0.0, 0.0, 0.06), 0.06),
        capsule("upper_arm", "upper_arm_link", "upper_arm_link", "forearm_link", 0.06),
        capsule("forearm", "forearm_link", "forearm_link", "wrist_1_link", 0.05),
        capsule("wrist_1", "wrist_1_link", "wrist_1_link", "wrist_2_link", 0.04),
        capsule("wrist_2", "wrist_2_link", "wrist_2_link", "wrist_3_link", 0.04),
        capsule("wrist_3", "wrist_3_link", "wrist_3_link", "ee_link", 0.04),
        capsule("tool_holder", "rivet_tool", (0.0, 0.0, 0.0), (0.1, 0.0, 0.0), 0.02),
        capsule("tool_pin", "rivet_tool", (0.1, 0.0, 0.0), "tcp", 0.5 * TOOL_DIAMETER),
    ]


def collision_obstacles() -> list:
    """The table under the UR5 (a box, top at z = 0)."""
    return [Obstacle("table", TABLE_SIZE, (0.3, 0.0, -0.5 * TABLE_SIZE[2]))]
