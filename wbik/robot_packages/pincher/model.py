"""PhantomX Pincher 4-DOF arm (seed 004) from pincher.md's standard DH table: alpha = (-90, 0, 0, 0) deg,
a = (0, 105, 105, 95) mm, d = (137, 0, 0, 0) mm, theta offsets (0, -90, 0, 0) deg, tool frame "noa" the
fixed rotation E = [[0,0,1],[-1,0,0],[0,-1,0]] after link 4, limits +-150 deg (SI here).
scripts/export_urdf.py writes the table into ``pincher.urdf`` (:data:`URDF_PATH`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wbik.data import description_file
from wbik.dh import DHJoint, DHTable, homogeneous
from wbik.robot import ChainSpec, Robot, robot_from_urdf_text
from wbik.robot_packages.pincher.closed_form import (
    BASE_HEIGHT,
    LINK,
    WRIST_TO_TOOL,
    pincher_pose,
    pincher_position,
)

LIMIT = math.radians(150.0)
AX12_SPEED = 114 * 2 * math.pi / 60  # rad/s, AX-12 no-load speed at 12 V
TOOL_ROTATION = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
URDF_PATH = description_file("pincher.urdf")
CLOSED_FORMS = {("arm", "pose"): pincher_pose, ("arm", "position"): pincher_position}
"""Closed forms of pincher.md's analytic inverse (position + tool pitch), see that module."""


def dh_table() -> DHTable:
    def row(a, alpha, d, theta, name):
        return DHJoint(a=a, alpha=alpha, d=d, theta=theta, lower=-LIMIT, upper=LIMIT,
                       velocity=AX12_SPEED, effort=1.5, name=name)

    return DHTable([
        row(0.0, -math.pi / 2, BASE_HEIGHT, 0.0, "joint1"),
        row(LINK, 0.0, 0.0, -math.pi / 2, "joint2"),
        row(LINK, 0.0, 0.0, 0.0, "joint3"),
        row(WRIST_TO_TOOL, 0.0, 0.0, 0.0, "joint4"),
    ], tool=homogeneous(TOOL_ROTATION))


@dataclass(frozen=True)
class PincherFacts:
    """``robot.facts``: ``dh``, pincher.md's DH table in SI with the tool "noa"."""

    dh: DHTable


def build() -> Robot:
    table = dh_table()
    text = table.urdf(name="pincher", base_link="base_link", tip_link="noa")
    chain = ChainSpec("arm", "base_link", "noa", ("joint1", "joint2", "joint3", "joint4"),
                      "floor base to the 'noa' tool frame (15 mm before the finger tips)")
    return robot_from_urdf_text("pincher", text, [chain], nominal=np.zeros(4),
                                closed_forms=CLOSED_FORMS, facts=PincherFacts(table))
