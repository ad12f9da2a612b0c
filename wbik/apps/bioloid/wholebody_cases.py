"""The Bioloid's seeded whole-body cases (:data:`wbik.wholebody.cases.CASE_MODULES`): a 5 mm CoM margin and
the pelvis orientation kept (soft); each sampler's description says what it draws.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pinocchio as pin

from wbik.apps.bioloid.gait import OTHER, SOLE
from wbik.qp.humanoid import stance_constraints, support_polygon
from wbik.qp.problem import IKProblem
from wbik.qp.tasks import ComTask, FrameTask, OrientationTask, PositionTask, RegularizationTask
from wbik.robot import Robot
from wbik.wholebody.cases import CaseSampler, WholeBodyCase, cached_robot
from wbik.wholebody.problem import WholeBody

ROBOT = "bioloid"
MARGIN = 0.005  # m, the CoM margin every Bioloid case asks for
BOTH = ["r_sole", "l_sole"]


def _random_side(rng: np.random.Generator) -> str:
    """"r" or "l", evenly (one draw of the case's stream)."""
    return "r" if rng.random() < 0.5 else "l"


def _pelvis_keep(robot: Robot, q: np.ndarray, weight: float = 0.1) -> OrientationTask:
    return OrientationTask("pelvis", robot.frame_placement(q, "pelvis").rotation, weight=weight, goal=False)


@lru_cache(maxsize=4)
def standing_on(side: str, lift: float = 0.0) -> np.ndarray:
    """The Bioloid standing on sole ``side`` ("r" or "l"), read-only (cached): the CoM over that sole's
    centre with both soles held, then (``lift`` > 0) the other sole lifted by ``lift`` m; by our QP."""
    robot = cached_robot(ROBOT)

    def solved(q: np.ndarray, task, soles: list[str], what: str) -> np.ndarray:
        """``task`` reached from ``q`` with the pelvis kept and ``soles`` held under the CoM."""
        problem = IKProblem(robot.model, [task, _pelvis_keep(robot, q), RegularizationTask(1e-6)],
                            stance_constraints(robot, q, soles, margin=MARGIN), backend="daqp")
        solution = problem.solve(q)
        if not solution.success:  # pragma: no cover - a model change would show here
            raise RuntimeError(f"cannot {what}: {solution.reason}")
        return solution.q

    q = robot.nominal.copy()
    over = robot.frame_placement(q, SOLE[side]).translation
    q = solved(q, ComTask([over[0], over[1], 0.0], axes="xy"), BOTH, f"stand the Bioloid on {side}")
    if lift > 0:
        swing = robot.frame_placement(q, SOLE[OTHER[side]])
        swing.translation = swing.translation + np.array([0.0, 0.0, lift])
        q = solved(q, FrameTask(SOLE[OTHER[side]], swing), [SOLE[side]],
                   f"lift the Bioloid's {OTHER[side]} sole")
    q = q.copy()
    q.setflags(write=False)
    return q


def _standing_problem(robot: Robot, q0: np.ndarray, tasks: list, soles: list[str], name: str,
                      pelvis_weight: float = 0.1) -> WholeBody:
    """``tasks`` and the pelvis orientation kept (soft), ``soles`` held and supporting the CoM."""
    return WholeBody(robot, [*tasks, _pelvis_keep(robot, q0, pelvis_weight)], contacts=soles, support=soles,
                     margin=MARGIN, name=name)


def _random_arm_target(robot: Robot, q: np.ndarray, rng: np.random.Generator, side: str) -> np.ndarray:
    chain = robot.chain("right_arm" if side == "r" else "left_arm")
    moved = q.copy()
    moved[chain.q_index] = chain.random(rng)
    return robot.frame_placement(moved, f"{side}_hand").translation.copy()


def com_shift(rng: np.random.Generator, index: int) -> WholeBodyCase:
    robot = cached_robot(ROBOT)
    q0 = robot.nominal.copy()
    polygon = support_polygon(robot, q0, BOTH)
    low, high = polygon.vertices.min(axis=0), polygon.vertices.max(axis=0)
    while True:
        point = rng.uniform(low, high)
        if polygon.margin_of(point) >= 2 * MARGIN:
            break
    target = np.array([point[0], point[1], robot.center_of_mass(q0)[2]])
    problem = _standing_problem(robot, q0, [ComTask(target, axes="xy", name="com")], BOTH,
                                f"bioloid_com_shift[{index}]")
    return WholeBodyCase(problem, q0, target)


def foot_lift(rng: np.random.Generator, index: int) -> WholeBodyCase:
    robot = cached_robot(ROBOT)
    side = _random_side(rng)
    swing = OTHER[side]
    q0 = standing_on(side).copy()
    start = robot.frame_placement(q0, SOLE[swing])
    outward = 1.0 if swing == "l" else -1.0  # +y is the left
    offset = np.array([rng.uniform(-0.03, 0.03), outward * rng.uniform(0.0, 0.02), rng.uniform(0.01, 0.05)])
    target = pin.SE3(pin.utils.rotate("z", float(rng.uniform(-0.2, 0.2))) @ start.rotation,
                     start.translation + offset)
    problem = _standing_problem(robot, q0, [FrameTask(SOLE[swing], target, name=f"{swing}_sole")],
                                [SOLE[side]], f"bioloid_foot_lift[{index}]")
    return WholeBodyCase(problem, q0, target.translation.copy())


def reach_two_feet(rng: np.random.Generator, index: int) -> WholeBodyCase:
    robot = cached_robot(ROBOT)
    hand = _random_side(rng)
    q0 = robot.nominal.copy()
    target = _random_arm_target(robot, q0, rng, hand)
    problem = _standing_problem(robot, q0, [PositionTask(f"{hand}_hand", target, name=f"{hand}_hand")],
                                BOTH, f"bioloid_reach_two_feet[{index}]")
    return WholeBodyCase(problem, q0, target)


def reach_one_foot(rng: np.random.Generator, index: int) -> WholeBodyCase:
    robot = cached_robot(ROBOT)
    side, hand = _random_side(rng), _random_side(rng)  # stance side, then the reaching hand
    q0 = standing_on(side, 0.02).copy()
    target = _random_arm_target(robot, q0, rng, hand)
    swing = SOLE[OTHER[side]]
    tasks = [PositionTask(f"{hand}_hand", target, name=f"{hand}_hand"),
             FrameTask(swing, robot.frame_placement(q0, swing), weight=0.01, goal=False)]
    problem = _standing_problem(robot, q0, tasks, [SOLE[side]], f"bioloid_reach_one_foot[{index}]",
                                pelvis_weight=0.01)
    return WholeBodyCase(problem, q0, target)


WHOLEBODY_CASES = (
    CaseSampler("bioloid_com_shift", ROBOT, com_shift,
                "both soles held; the CoM (xy) to a uniform point of the two-sole polygon shrunk by 10 mm; "
                "pelvis orientation kept (soft); CoM margin 5 mm in the two-sole polygon"),
    CaseSampler("bioloid_foot_lift", ROBOT, foot_lift,
                "standing on one foot (CoM over it); the other sole to a target 10-50 mm up, +-30 mm "
                "forward, 0-20 mm outward, yaw +-0.2 rad; stance sole held; CoM margin 5 mm in it"),
    CaseSampler("bioloid_reach_two_feet", ROBOT, reach_two_feet,
                "both soles held; one hand to the position it has at a uniform random arm configuration; "
                "CoM margin 5 mm in the two-sole polygon"),
    CaseSampler("bioloid_reach_one_foot", ROBOT, reach_one_foot,
                "on one foot, the other lifted 20 mm (soft keep); one hand to a random arm configuration's "
                "position; CoM margin 5 mm in the stance sole"),
)
