"""The Golem-III's seeded whole-body case (:data:`WHOLEBODY_CASES`), from the nominal; joint position limits
only (the lift's 5 mm/s velocity limit would cap every IK step at 5 mm)."""

from __future__ import annotations

import numpy as np

from wbik.qp.tasks import PositionTask
from wbik.wholebody.cases import CaseSampler, WholeBodyCase, cached_robot
from wbik.wholebody.problem import WholeBody


def two_grippers(rng: np.random.Generator, index: int) -> WholeBodyCase:
    robot = cached_robot("golem3")
    q_true = rng.uniform(robot.model.lowerPositionLimit, robot.model.upperPositionLimit)
    right, left = (robot.frame_placement(q_true, frame).translation.copy() for frame in ("r_eef", "l_eef"))
    tasks = [PositionTask("r_eef", right, name="r_eef"), PositionTask("l_eef", left, name="l_eef")]
    problem = WholeBody(robot, tasks, contacts=[], support=[], limits="position",
                        name=f"golem3_two_grippers[{index}]")
    return WholeBodyCase(problem, robot.nominal.copy(), right, q_true)


WHOLEBODY_CASES = (
    CaseSampler("golem3_two_grippers", "golem3", two_grippers,
                "both grippers to their positions at a uniform random configuration of every joint "
                "(lift mb and chest yaw m0 shared); joint position limits; fixed base"),
)
