"""Legged-robot helpers: stances (soles in contact, ``robot.soles``) as hard contacts, a flat sole by its
pose and a point foot by its position, and the CoM in their support polygon shrunk by a margin.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from wbik.errors import RobotDescriptionError
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.constraint import Constraint
from wbik.qp.contacts import Contact, PointContact
from wbik.qp.kinematics import Kinematics
from wbik.qp.limits import JointPositionLimits
from wbik.qp.support_polygon import SupportPolygon, feet_support_polygon
from wbik.robot import Robot


def sole_corners(robot: Robot) -> dict[str, np.ndarray]:
    if not robot.soles:
        raise RobotDescriptionError(f"{robot.name!r} lists no soles (robot.soles); balance needs them")
    return robot.soles


def is_point_foot(robot: Robot, frame: str) -> bool:
    """Whether ``frame`` is a sole with a single contact point (a point foot, held by its position only)."""
    sole = robot.soles.get(frame)
    return sole is not None and len(sole) == 1


def contact_constraint(robot: Robot, frame: str, placement: pin.SE3 | None = None) -> Contact | PointContact:
    """The hard contact of ``frame`` at ``placement`` (default: at the start), a point foot's by position."""
    return (PointContact(frame, None if placement is None else placement.translation)
            if is_point_foot(robot, frame) else Contact(frame, placement))


def support_polygon(robot: Robot, q: np.ndarray, soles: Sequence[str]) -> SupportPolygon:
    """Support polygon of the given soles at configuration q."""
    return feet_support_polygon(Kinematics(robot.model, q), sole_corners(robot), soles)


def stance_constraints(robot: Robot, q: np.ndarray, contacts: Sequence[str],
                       support: Sequence[str] | None = None, margin: float = 0.005,
                       with_limits: bool = True) -> list[Constraint]:
    """A stance's hard constraints at q: contacts, CoM in the ``support`` soles' polygon, joint limits."""
    constraints: list[Constraint] = [contact_constraint(robot, frame) for frame in contacts]
    if support := list(contacts if support is None else support):
        constraints.append(CoMInSupportPolygon(support_polygon(robot, q, support), margin))
    if with_limits:
        constraints.append(JointPositionLimits())
    return constraints
