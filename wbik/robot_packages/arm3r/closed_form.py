"""3-DOF articulated arm binding (seed 001, arm3r.md; chain ``arm``: base_link -> tip): the yaw + planar
2R member of the yaw-planar family (:mod:`wbik.solvers.analytic.yaw_planar`), position targets, with the
lengths (l1, l2, l3) the robot was built with (its :class:`Arm3RFacts`)."""

from __future__ import annotations

from dataclasses import dataclass

from wbik.dh import DHTable
from wbik.robot import Chain
from wbik.solvers.analytic.yaw_planar import Yaw2RGeometry, Yaw2RPosition


@dataclass(frozen=True)
class Arm3RFacts:
    """``robot.facts`` of arm3r: ``lengths`` (l1, l2, l3) = (d1, a2, a3) in m, and the DH table ``dh``."""

    lengths: tuple[float, float, float]
    dh: DHTable


def arm3r_position(chain: Chain) -> Yaw2RPosition:
    """Position-only closed form of arm3r: 2 shoulder x 2 elbow branches (K = 4)."""
    facts = chain.robot.require_facts(Arm3RFacts, "the arm3r closed form")
    return Yaw2RPosition(chain, Yaw2RGeometry(*(float(v) for v in facts.lengths)))
