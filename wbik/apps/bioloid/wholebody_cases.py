"""The Bioloid's seeded whole-body cases for the whole-body study (registered in
:data:`wbik.wholebody.cases.CASE_MODULES`; the stream rule is :func:`wbik.wholebody.cases.case_rng`).

Floating base, 24 DOF; soles 100 x 60 mm; CoM margin 5 mm:

- ``bioloid_com_shift``: both soles held, the CoM (xy) to a uniform point of the two-sole polygon
  shrunk by 10 mm; the pelvis keeps its orientation (soft).
- ``bioloid_foot_lift``: standing on one foot (the CoM already over it, both soles on the ground,
  solved once by our QP from the nominal), the other sole to a target 10-50 mm up, +-30 mm
  forward, 0-20 mm outward, yaw +-0.2 rad; stance sole held, support = stance sole.
- ``bioloid_reach_two_feet``: both soles held, one hand (random side) to the position of that hand
  at a uniform random arm configuration from the nominal (reachable by the arm alone; the CoM may
  then need the body to move).
- ``bioloid_reach_one_foot``: standing on one foot with the other lifted 20 mm (solved once), one
  hand to a random arm configuration's position; the lifted sole keeps its pose (soft).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pinocchio as pin

from wbik.qp.tasks import ComTask
from wbik.qp.tasks import FrameTask
from wbik.qp.tasks import OrientationTask
from wbik.qp.tasks import PositionTask
from wbik.robot import Robot
from wbik.wholebody.cases import CaseSampler
from wbik.wholebody.cases import WholeBodyCase
from wbik.wholebody.cases import cached_robot
from wbik.wholebody.problem import WholeBody

ROBOT = "bioloid"
MARGIN = 0.005
"""The CoM margin (m) every Bioloid case asks for."""


def _sole(side: str) -> str:
    return f"{side}_sole"


def _other(side: str) -> str:
    return "l" if side == "r" else "r"


def _random_side(rng: np.random.Generator) -> str:
    """"r" or "l", evenly (one draw of the case's stream)."""
    return "r" if rng.random() < 0.5 else "l"


def _pelvis_keep(robot: Robot, q: np.ndarray, weight: float = 0.1) -> OrientationTask:
    return OrientationTask("pelvis", robot.frame_placement(q, "pelvis").rotation, weight=weight, goal=False)


@lru_cache(maxsize=4)
def standing_on(side: str, lift: float = 0.0) -> np.ndarray:
    """The Bioloid standing on sole ``side`` ("r" or "l"): the CoM over that sole's centre with both
    soles held, then (``lift`` > 0) the other sole lifted by ``lift`` m; solved by our QP (DAQP).
    Read-only (cached)."""
    from wbik.qp.humanoid import stance_constraints
    from wbik.qp.problem import IKProblem
    from wbik.qp.tasks import RegularizationTask

    robot = cached_robot(ROBOT)

    def solved(q: np.ndarray, task, soles: list[str], what: str) -> np.ndarray:
        """``task`` reached from ``q`` with the pelvis kept and ``soles`` held under the CoM."""
        problem = IKProblem(
            robot.model,
            [task, _pelvis_keep(robot, q), RegularizationTask(1e-6)],
            stance_constraints(robot, q, soles, margin=MARGIN),
            backend="daqp",
        )
        solution = problem.solve(q)
        if not solution.success:  # pragma: no cover - a model change would show here
            raise RuntimeError(f"cannot {what}: {solution.reason}")
        return solution.q

    q = robot.nominal.copy()
    over = robot.frame_placement(q, _sole(side)).translation
    q = solved(q, ComTask([over[0], over[1], 0.0], axes="xy"), ["r_sole", "l_sole"],
               f"stand the Bioloid on {side}")
    if lift > 0:
        swing = robot.frame_placement(q, _sole(_other(side)))
        swing.translation = swing.translation + np.array([0.0, 0.0, lift])
        q = solved(q, FrameTask(_sole(_other(side)), swing), [_sole(side)],
                   f"lift the Bioloid's {_other(side)} sole")
    q = q.copy()
    q.setflags(write=False)
    return q


def _standing_problem(robot: Robot, q0: np.ndarray, tasks: list, soles: list[str], name: str,
                      pelvis_weight: float = 0.1) -> WholeBody:
    """A Bioloid case: ``tasks``, then the pelvis orientation kept (soft, ``pelvis_weight``);
    ``soles`` held and supporting the CoM with ``MARGIN``."""
    return WholeBody(robot, [*tasks, _pelvis_keep(robot, q0, pelvis_weight)], contacts=soles, support=soles,
                     margin=MARGIN, name=name)


def _random_arm_target(robot: Robot, q: np.ndarray, rng: np.random.Generator, side: str) -> np.ndarray:
    chain = robot.chain("right_arm" if side == "r" else "left_arm")
    moved = q.copy()
    moved[chain.q_index] = chain.random(rng)
    return robot.frame_placement(moved, f"{side}_hand").translation.copy()


def com_shift(rng: np.random.Generator, index: int) -> WholeBodyCase:
    from wbik.qp.humanoid import support_polygon

    robot = cached_robot(ROBOT)
    q0 = robot.nominal.copy()
    soles = ["r_sole", "l_sole"]
    polygon = support_polygon(robot, q0, soles)
    low, high = polygon.vertices.min(axis=0), polygon.vertices.max(axis=0)
    while True:
        point = rng.uniform(low, high)
        if polygon.margin_of(point) >= 2 * MARGIN:
            break
    com = robot.center_of_mass(q0)
    target = np.array([point[0], point[1], com[2]])
    problem = _standing_problem(robot, q0, [ComTask(target, axes="xy", name="com")], soles,
                                f"bioloid_com_shift[{index}]")
    return WholeBodyCase(problem, q0, target)


def foot_lift(rng: np.random.Generator, index: int) -> WholeBodyCase:
    robot = cached_robot(ROBOT)
    side = _random_side(rng)
    swing = _other(side)
    q0 = standing_on(side).copy()
    start = robot.frame_placement(q0, _sole(swing))
    outward = 1.0 if swing == "l" else -1.0  # +y is the left
    offset = np.array([rng.uniform(-0.03, 0.03), outward * rng.uniform(0.0, 0.02), rng.uniform(0.01, 0.05)])
    target = pin.SE3(
        pin.utils.rotate("z", float(rng.uniform(-0.2, 0.2))) @ start.rotation, start.translation + offset
    )
    problem = _standing_problem(robot, q0, [FrameTask(_sole(swing), target, name=f"{swing}_sole")],
                                [_sole(side)], f"bioloid_foot_lift[{index}]")
    return WholeBodyCase(problem, q0, target.translation.copy())


def reach_two_feet(rng: np.random.Generator, index: int) -> WholeBodyCase:
    robot = cached_robot(ROBOT)
    hand = _random_side(rng)
    q0 = robot.nominal.copy()
    target = _random_arm_target(robot, q0, rng, hand)
    problem = _standing_problem(robot, q0, [PositionTask(f"{hand}_hand", target, name=f"{hand}_hand")],
                                ["r_sole", "l_sole"], f"bioloid_reach_two_feet[{index}]")
    return WholeBodyCase(problem, q0, target)


def reach_one_foot(rng: np.random.Generator, index: int) -> WholeBodyCase:
    robot = cached_robot(ROBOT)
    side, hand = _random_side(rng), _random_side(rng)  # stance side, then the reaching hand
    q0 = standing_on(side, 0.02).copy()
    target = _random_arm_target(robot, q0, rng, hand)
    swing = _sole(_other(side))
    tasks = [PositionTask(f"{hand}_hand", target, name=f"{hand}_hand"),
             FrameTask(swing, robot.frame_placement(q0, swing), weight=0.01, goal=False)]
    problem = _standing_problem(robot, q0, tasks, [_sole(side)], f"bioloid_reach_one_foot[{index}]",
                                pelvis_weight=0.01)
    return WholeBodyCase(problem, q0, target)


WHOLEBODY_CASES = (
    CaseSampler(
        "bioloid_com_shift", ROBOT, com_shift,
        "both soles held; the CoM (xy) to a uniform point of the two-sole polygon shrunk by 10 mm; pelvis "
        "orientation kept (soft); CoM margin 5 mm in the two-sole polygon",
    ),
    CaseSampler(
        "bioloid_foot_lift", ROBOT, foot_lift,
        "standing on one foot (CoM over it); the other sole to a target 10-50 mm up, +-30 mm forward, "
        "0-20 mm outward, yaw +-0.2 rad; stance sole held; CoM margin 5 mm in it",
    ),
    CaseSampler(
        "bioloid_reach_two_feet", ROBOT, reach_two_feet,
        "both soles held; one hand to the position it has at a uniform random arm configuration; CoM margin "
        "5 mm in the two-sole polygon",
    ),
    CaseSampler(
        "bioloid_reach_one_foot", ROBOT, reach_one_foot,
        "on one foot, the other lifted 20 mm (soft keep); one hand to a random arm configuration's position; "
        "CoM margin 5 mm in the stance sole",
    ),
)
"""The Bioloid's whole-body case samplers."""
