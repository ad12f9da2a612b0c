"""UR5 binding: the UR-type family (:mod:`wbik.solvers.analytic.ur_type`) on chain ``ee``, composed with
the fixed ee_link -> tcp transform on chain ``arm``."""

from __future__ import annotations

from wbik.solvers.analytic.aligned import AlignedForm, with_tool
from wbik.solvers.analytic.ur_type import URArm, URGeometry

UR5 = URGeometry(d1=0.089159, a2=-0.42500, a3=-0.39225, d4=0.10915, d5=0.09465, d6=0.0823)
"""ur_kinematics' UR5 numbers (m), as example-robot-data's URDF."""


class UR5EndEffector(URArm):
    """Chain ``ee`` (base_link -> ee_link), full poses, 8 branches."""

    geometry = UR5


def ur5_tool(chain) -> AlignedForm:
    """Chain ``arm`` (base_link -> tcp): the ``ee`` closed form composed with the fixed ee_link -> tcp."""
    return with_tool(chain, UR5EndEffector, "ee")
