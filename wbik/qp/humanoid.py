"""Legged-robot helpers on top of the generic QP layer: stances (feet in contact), balance checks.

A robot that can stand lists its soles in ``robot.soles`` ({sole frame: (k, 3) contact points in
that frame}: a flat sole's corners, or a point foot's single point). A stance is the set of soles in
contact: each becomes a hard contact (:func:`contact_constraint`: a flat sole keeps its pose, a point
foot its position) and the support polygon is the convex hull of their contact points on the
ground, shrunk by the safety margin, as a hard CoM constraint.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from wbik.errors import RobotDescriptionError
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.constraint import Constraint
from wbik.qp.contacts import Contact
from wbik.qp.contacts import PointContact
from wbik.qp.kinematics import Kinematics
from wbik.qp.limits import JointPositionLimits
from wbik.qp.support_polygon import SupportPolygon
from wbik.qp.support_polygon import feet_support_polygon
from wbik.robot import Robot


def sole_corners(robot: Robot) -> dict[str, np.ndarray]:
    corners = robot.soles
    if not corners:
        raise RobotDescriptionError(
            f"{robot.name!r} lists no soles (robot.soles); balance needs them")
    return corners


def is_point_foot(robot: Robot, frame: str) -> bool:
    """Whether ``frame`` is a sole with a single contact point (a point foot): held in contact, it keeps
    its position only (a point contact transmits no moment, its rotation is free)."""
    sole = robot.soles.get(frame)
    return sole is not None and len(sole) == 1


def contact_constraint(robot: Robot, frame: str, placement: pin.SE3 | None = None) -> Contact | PointContact:
    """The hard contact of ``frame`` held at ``placement`` (default: where it is when the problem starts):
    a :class:`PointContact` for a point foot (:func:`is_point_foot`), else a 6-row :class:`Contact`."""
    if is_point_foot(robot, frame):
        return PointContact(frame, None if placement is None else placement.translation)
    return Contact(frame, placement)


def support_polygon(robot: Robot, q: np.ndarray, soles: Sequence[str]) -> SupportPolygon:
    """Support polygon of the given soles at configuration q."""
    return feet_support_polygon(Kinematics(robot.model, q), sole_corners(robot), soles)


def stance_constraints(robot: Robot, q: np.ndarray, contacts: Sequence[str],
                       support: Sequence[str] | None = None, margin: float = 0.005,
                       with_limits: bool = True) -> list[Constraint]:
    """Hard constraints of a stance at q: contacts, CoM in the shrunk support polygon, joint limits.

    ``support`` (default: the contacts) are the soles whose contact points make the polygon; an empty
    list means no balance constraint (e.g. a fixed-base robot).
    """
    constraints: list[Constraint] = [contact_constraint(robot, frame) for frame in contacts]
    support = list(contacts if support is None else support)
    if support:
        constraints.append(CoMInSupportPolygon(support_polygon(robot, q, support), margin))
    if with_limits:
        constraints.append(JointPositionLimits())
    return constraints
