"""Franka Emika Panda (example-robot-data), a 7-DOF redundant reference arm; fingers locked open."""

from __future__ import annotations

import numpy as np

from wbik.models.erd import package_dirs, urdf_path
from wbik.robot import ChainSpec, Robot, robot_from_urdf_text

READY = np.array([0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398, 0.02, 0.02])


def build() -> Robot:
    path = urdf_path("panda_description/urdf/panda.urdf")
    joints = tuple(f"panda_joint{i}" for i in range(1, 8))
    chain = ChainSpec("arm", "panda_link0", "panda_hand_tcp", joints, "base to the hand's TCP")
    return robot_from_urdf_text("panda", path.read_text(), [chain], nominal=READY, urdf_path=path,
                                package_dirs=package_dirs())
