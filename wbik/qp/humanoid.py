"""Humanoid helpers on top of the generic QP layer: stances (feet in contact), balance checks.

A robot that can stand lists its sole rectangles in ``robot.soles`` ({sole frame:
(k, 3) corners in that frame}). A stance is the set of soles in contact: each becomes a hard
Contact (the sole keeps its pose) and the support polygon is the convex hull of their corners on
the ground, shrunk by the safety margin, as a hard CoM constraint.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from wbik.errors import RobotDescriptionError
from wbik.qp.constraints import CoMInSupportPolygon
from wbik.qp.constraints import Constraint
from wbik.qp.constraints import Contact
from wbik.qp.constraints import JointPositionLimits
from wbik.qp.kinematics import Kinematics
from wbik.qp.support_polygon import SupportPolygon
from wbik.qp.support_polygon import feet_support_polygon
from wbik.robot import Robot


def sole_corners(robot: Robot) -> dict[str, np.ndarray]:
    corners = robot.soles
    if not corners:
        raise RobotDescriptionError(
            f"{robot.name!r} lists no sole corners (robot.soles); balance needs them")
    return corners


def support_polygon(robot: Robot, q: np.ndarray, soles: Sequence[str]) -> SupportPolygon:
    """Support polygon of the given soles at configuration q."""
    return feet_support_polygon(Kinematics(robot.model, q), sole_corners(robot), soles)


def stance_constraints(robot: Robot, q: np.ndarray, contacts: Sequence[str],
                       support: Sequence[str] | None = None, margin: float = 0.005,
                       with_limits: bool = True) -> list[Constraint]:
    """Hard constraints of a stance at q: contacts, CoM in the shrunk support polygon, joint limits.

    ``support`` (default: the contacts) are the soles whose corners make the polygon; an empty
    list means no balance constraint (e.g. a fixed-base robot).
    """
    constraints: list[Constraint] = [Contact(frame) for frame in contacts]
    support = list(contacts if support is None else support)
    if support:
        constraints.append(CoMInSupportPolygon(support_polygon(robot, q, support), margin))
    if with_limits:
        constraints.append(JointPositionLimits(robot.model))
    return constraints
