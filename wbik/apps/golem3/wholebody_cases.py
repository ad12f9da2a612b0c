"""The Golem-III's seeded whole-body case for the whole-body study (registered in
:data:`wbik.wholebody.cases.CASE_MODULES`; the stream rule is :func:`wbik.wholebody.cases.case_rng`).

- ``golem3_two_grippers`` (fixed base): both grippers (r_eef, l_eef) to the positions they have at
  a uniform random configuration of all joints (the torso lift mb and the chest yaw m0 shared),
  from the nominal; joint position limits only (the lift's 5 mm/s velocity limit would make every
  IK step 5 mm long at most).
"""

from __future__ import annotations

import numpy as np

from wbik.qp.tasks import PositionTask
from wbik.wholebody.cases import CaseSampler
from wbik.wholebody.cases import WholeBodyCase
from wbik.wholebody.cases import cached_robot
from wbik.wholebody.problem import WholeBody


def two_grippers(rng: np.random.Generator, index: int) -> WholeBodyCase:
    robot = cached_robot("golem3")
    model = robot.model
    q_true = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
    right = robot.frame_placement(q_true, "r_eef").translation.copy()
    left = robot.frame_placement(q_true, "l_eef").translation.copy()
    problem = WholeBody(
        robot,
        [PositionTask("r_eef", right, name="r_eef"), PositionTask("l_eef", left, name="l_eef")],
        contacts=[],
        support=[],
        limits="position",
        name=f"golem3_two_grippers[{index}]",
    )
    return WholeBodyCase(problem, robot.nominal.copy(), right, q_true)


WHOLEBODY_CASES = (
    CaseSampler(
        "golem3_two_grippers", "golem3", two_grippers,
        "both grippers to their positions at a uniform random configuration of every joint (lift mb and "
        "chest yaw m0 shared); joint position limits; fixed base",
    ),
)
"""The Golem-III's whole-body case sampler."""
