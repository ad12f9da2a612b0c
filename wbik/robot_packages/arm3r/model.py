"""The 3-DOF articulated arm of seed 001 (Newton-Raphson course project), standard DH (arm3r.md):
a = (0, l2, l3), alpha = (pi/2, 0, 0), d = (l1, 0, 0), lengths as parameters (default 3, 2, 2 m, the
worked example's), +-pi on every joint (the seed has none). scripts/export_urdf.py writes the default
table into ``arm3r.urdf`` (:data:`URDF_PATH`).
"""

from __future__ import annotations

import math

import numpy as np

from wbik.data import description_file
from wbik.dh import DHJoint, DHTable
from wbik.errors import RobotDescriptionError
from wbik.robot import ChainSpec, Robot, robot_from_urdf_text
from wbik.robot_packages.arm3r.closed_form import Arm3RFacts, arm3r_position
from wbik.validation import numeric_array

DEFAULT_LENGTHS = (3.0, 2.0, 2.0)
URDF_PATH = description_file("arm3r.urdf")
CLOSED_FORMS = {("arm", "position"): arm3r_position}


def dh_table(lengths: tuple[float, float, float] = DEFAULT_LENGTHS) -> DHTable:
    l1, l2, l3 = lengths
    return DHTable([
        DHJoint(a=0.0, alpha=math.pi / 2, d=l1, name="joint1"),
        DHJoint(a=l2, alpha=0.0, d=0.0, name="joint2"),
        DHJoint(a=l3, alpha=0.0, d=0.0, name="joint3"),
    ])


def build(lengths: tuple[float, float, float] = DEFAULT_LENGTHS) -> Robot:
    what = "arm3r lengths (three positive link lengths l1, l2, l3 in metres)"
    values = numeric_array(lengths, what, RobotDescriptionError, shape=(3,), max_abs=1e3)
    if min(values) <= 0:
        raise RobotDescriptionError(f"arm3r needs three positive link lengths, got {tuple(values.tolist())}")
    lengths = tuple(float(v) for v in values)
    table = dh_table(lengths)
    text = table.urdf(name="arm3r", base_link="base_link", tip_link="tip")
    chain = ChainSpec("arm", "base_link", "tip", ("joint1", "joint2", "joint3"),
                      "base to end point (position-only IK: 3 joints, 3 coordinates)")
    name = "arm3r" if lengths == DEFAULT_LENGTHS else "arm3r-" + "-".join(f"{v:g}" for v in lengths)
    return robot_from_urdf_text(name, text, [chain], nominal=np.full(3, math.pi / 2),
                                closed_forms=CLOSED_FORMS, facts=Arm3RFacts(lengths, table))


def start_configuration() -> np.ndarray:
    """The seed's start, theta = (pi/2, pi/2, pi/2), giving P0 = (0, -l3, l1 + l2)."""
    return np.full(3, math.pi / 2)
