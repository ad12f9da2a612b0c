"""What both planners share: the insertion geometry, the plan of one cycle, the planner interface.

One cycle, from rivet_home back to rivet_home (the cycle runner adds load_rivet at home):

    [planner's way to the hole] -> approach pose -> insert (tool tip ``depth`` inside the hole,
    along the hole axis) -> trigger_rivet (dwell) -> retract to the approach pose -> [way home]

The approach pose ("posicion de encare") faces the hole on its axis, the tool tip ``standoff``
metres outside the opening. The seed gives neither number; ours: standoff 20 mm, depth 6 mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import field

import numpy as np
import pinocchio as pin

from wbik.apps.riveting.collision import CollisionModel
from wbik.apps.riveting.moves import Limits
from wbik.apps.riveting.moves import Move
from wbik.apps.riveting.scene import Hole
from wbik.apps.riveting.scene import Scene
from wbik.robot import Robot

TRIGGER = "trigger_rivet"
INSERT = "insert"


@dataclass(frozen=True)
class Insertion:
    """Approach stand-off, insertion depth (m) and the dwell times of the two services (s)."""

    standoff: float = 0.02
    depth: float = 0.006
    trigger_s: float = 0.5
    load_s: float = 0.5

    def approach_pose(self, hole: Hole, roll: float = 0.0) -> pin.SE3:
        """tcp pose facing the hole (tcp z = hole z), turned by ``roll`` about the hole axis."""
        return self._pose(hole, -self.standoff, roll)

    def inserted_pose(self, hole: Hole, roll: float = 0.0) -> pin.SE3:
        return self._pose(hole, self.depth, roll)

    @staticmethod
    def _pose(hole: Hole, depth: float, roll: float) -> pin.SE3:
        rotation = hole.placement.rotation @ pin.rpy.rpyToMatrix(0.0, 0.0, roll)
        return pin.SE3(rotation, hole.point_at_depth(depth))


@dataclass
class CyclePlan:
    """The moves of one cycle (home -> hole -> home) or a failure with its reason."""

    hole: Hole
    moves: list[Move] = field(default_factory=list)
    success: bool = True
    reason: str = ""
    planning_time_s: float = 0.0
    """Measured wall time of the planning (s): reported, never charged (it depends on the load)."""
    planning_cost_s: float = 0.0
    """Planning time charged to the run (s): counted operations x calibrated costs (apps.riveting.cost)."""
    info: dict = field(default_factory=dict)

    @property
    def duration(self) -> float:
        return float(sum(move.duration for move in self.moves))


class Planner:
    """Base class: ``setup(q_home)`` once, then ``plan(hole, q_home)`` per cycle and
    ``go_home(q_from, q_home)`` for the first move of the run."""

    name = "planner"

    def __init__(self, robot: Robot, scene: Scene, collision: CollisionModel, limits: Limits,
                 insertion: Insertion, **options):
        self.robot = robot
        self.scene = scene
        self.collision = collision
        self.limits = limits
        self.insertion = insertion
        self.chain = robot.chain("arm")
        self.options = options

    def setup(self, q_home: np.ndarray) -> dict:
        """Prepare (e.g. teach intermediate configurations); returns facts for the report."""
        return {}

    def plan(self, hole: Hole, q_home: np.ndarray) -> CyclePlan:
        raise NotImplementedError

    def go_home(self, q_from: np.ndarray, q_home: np.ndarray) -> list[Move]:
        from wbik.apps.riveting.moves import timed_move

        return [timed_move("to rivet_home", self.chain, np.array([q_from, q_home]), self.limits)]


def tcp_errors(chain, q: np.ndarray, wanted: pin.SE3) -> tuple[float, float, float, float]:
    """(position error, lateral error, depth error along the axis (+ = too deep), axis angle) of the
    tcp at q against ``wanted`` (m, m, m, rad); roll about the tool axis is not an error."""
    reached = chain.fk(q)
    axis = wanted.rotation[:, 2]
    offset = reached.translation - wanted.translation
    along = float(offset @ axis)
    lateral = float(np.linalg.norm(offset - along * axis))
    angle = float(np.arccos(np.clip(reached.rotation[:, 2] @ axis, -1.0, 1.0)))
    return float(np.linalg.norm(offset)), lateral, along, angle
