"""What both planners share: the insertion geometry, the plan of one cycle and the planner interface. A
cycle: rivet_home -> approach pose (tip ``standoff`` outside) -> insert (tip ``depth`` inside) ->
trigger_rivet -> retract -> rivet_home."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbik.apps.riveting.collision import CollisionModel
from wbik.apps.riveting.moves import Limits, Move, timed_move
from wbik.apps.riveting.scene import Hole, Scene
from wbik.robot import Robot
from wbik.solvers.analytic.closed_form import wrap_into_limits
from wbik.solvers.method_registry import solver

TRIGGER = "trigger_rivet"


def hole_pose(hole: Hole, depth: float, roll: float = 0.0) -> pin.SE3:
    """tcp pose on the hole axis ``depth`` m inside the opening (tcp z = hole z), turned by ``roll``."""
    rotation = hole.placement.rotation @ pin.rpy.rpyToMatrix(0.0, 0.0, roll)
    return pin.SE3(rotation, hole.point_at_depth(depth))


@dataclass(frozen=True)
class Insertion:
    """Approach stand-off, insertion depth (m) and the dwell times of the two services (s)."""

    standoff: float = 0.02
    depth: float = 0.006
    trigger_s: float = 0.5
    load_s: float = 0.5

    def approach_pose(self, hole: Hole, roll: float = 0.0) -> pin.SE3:
        return hole_pose(hole, -self.standoff, roll)

    def inserted_pose(self, hole: Hole, roll: float = 0.0) -> pin.SE3:
        return hole_pose(hole, self.depth, roll)


@dataclass
class CyclePlan:
    """The moves of one cycle or a failure's reason; planning wall time (reported), counted cost (charged)."""

    hole: Hole
    moves: list[Move] = field(default_factory=list)
    success: bool = True
    reason: str = ""
    planning_time_s: float = 0.0
    planning_cost_s: float = 0.0
    info: dict = field(default_factory=dict)


class Planner:
    """``setup(q_home)`` once, ``go_home`` as the run's first move, then ``plan(hole, q_home)`` per cycle."""

    name = "planner"

    def __init__(self, robot: Robot, scene: Scene, collision: CollisionModel, limits: Limits,
                 insertion: Insertion, **options):
        self.robot, self.scene, self.collision, self.limits = robot, scene, collision, limits
        self.insertion = insertion
        self.chain = robot.chain("arm")
        self.analytic = solver("analytic", robot, chain="arm")

    def setup(self, q_home: np.ndarray) -> dict:
        """Prepare (e.g. teach intermediate configurations); returns facts for the report."""
        return {}

    def plan(self, hole: Hole, q_home: np.ndarray) -> CyclePlan:
        raise NotImplementedError

    def go_home(self, q_from: np.ndarray, q_home: np.ndarray) -> list[Move]:
        return [timed_move("to rivet_home", self.chain, np.array([q_from, q_home]), self.limits)]

    def wrap(self, q: np.ndarray, near: np.ndarray) -> np.ndarray:
        """q with each revolute joint turned by 2 pi multiples toward ``near`` (inside the limits)."""
        return wrap_into_limits(q, near, self.chain.lower, self.chain.upper, ~self.chain.is_prismatic)[0]

    def _clear(self, q: np.ndarray, minimum: float, skip: tuple[str, ...] = ()) -> bool:
        """Every geometry (but ``skip``) at least ``minimum`` (m) from the workpiece and the table."""
        return self.collision.clearance(q, skip=skip).minimum("cell", floor=minimum) >= minimum


def tcp_errors(chain, q: np.ndarray, wanted: pin.SE3) -> tuple[float, float, float, float]:
    """(position, lateral, depth (+ too deep) errors (m), axis angle (rad)) of the tcp at q vs ``wanted``."""
    reached = chain.fk(q)
    axis = wanted.rotation[:, 2]
    offset = reached.translation - wanted.translation
    along = float(offset @ axis)
    lateral = float(np.linalg.norm(offset - along * axis))
    angle = float(np.arccos(np.clip(reached.rotation[:, 2] @ axis, -1.0, 1.0)))
    return float(np.linalg.norm(offset)), lateral, along, angle
