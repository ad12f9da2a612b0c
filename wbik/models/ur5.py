"""UR5 from example-robot-data with the riveting tool (urdf/ur5_rivet_tool.urdf.xml) appended.

Chains: ``arm`` (base_link -> tcp, the riveting task's frame) and ``ee`` (base_link -> ee_link,
the frame ur_kinematics' closed form solves for). Limits are example-robot-data's (+-2 pi,
elbow +-pi).
"""

from __future__ import annotations

import numpy as np

from wbik.models import URDF_DIR
from wbik.models.erd import package_dirs, urdf_path
from wbik.robot import ChainSpec, Robot, robot_from_urdf_text

JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
          "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
TOOL_LENGTH = 0.13
"""ee_link -> tcp along the flange normal (m): 100 mm holder + 30 mm of 5 mm cylinder (assumed)."""

CLOSED_FORMS = {
    ("ee", "pose"): "wbik.solvers.analytic.ur5:UR5EndEffector",
    ("arm", "pose"): "wbik.solvers.analytic.ur5:UR5Tool",
}
"""ur_kinematics' closed form (ur5-riveting.md 1.2) on ee_link, and composed with the tool for tcp."""


def urdf_text() -> str:
    base = urdf_path("ur_description/urdf/ur5_robot.urdf").read_text()
    tool = (URDF_DIR / "ur5_rivet_tool.urdf.xml").read_text()
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
                                info={"tool_length": TOOL_LENGTH, "tool_diameter": 0.005,
                                      "closed_forms": CLOSED_FORMS})
