"""3-DOF articulated arm binding (seed 001, arm3r.md; chain ``arm``: base_link -> tip): the yaw + planar
2R member of the yaw-planar family (:mod:`wbik.solvers.analytic.yaw_planar`), position targets, with the
lengths (l1, l2, l3) the robot was built with (its :class:`Arm3RFacts`)."""

from __future__ import annotations

from dataclasses import dataclass

from wbik.dh import DHTable
from wbik.robot import Chain
from wbik.solvers.analytic.yaw_planar import Yaw2RGeometry
from wbik.solvers.analytic.yaw_planar import Yaw2RPosition


@dataclass(frozen=True)
class Arm3RFacts:
    """What an arm3r robot was built with (``robot.facts``; the closed form reads ``lengths``)."""

    lengths: tuple[float, float, float]
    """(l1, l2, l3) in metres: base height d1 and the two link lengths a2, a3."""
    dh: DHTable
    """The standard DH table the URDF is written from (SI)."""


def arm3r_position(chain: Chain) -> Yaw2RPosition:
    """Position-only closed form of arm3r: 2 shoulder x 2 elbow branches (K = 4)."""
    facts = chain.robot.require_facts(Arm3RFacts, "the arm3r closed form")
    return Yaw2RPosition(chain, Yaw2RGeometry(*(float(v) for v in facts.lengths)))
