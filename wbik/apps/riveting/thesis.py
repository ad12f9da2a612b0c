"""The thesis's way (ur5-riveting.md section 4): closed-form UR5 IK and joint-space moves through a
fixed intermediate configuration per face.

Cycle (the code's order): rivet_home -> q_int of the hole's face (joint move, 1 s in the code) ->
sleep 2 s -> approach pose (IK nearest q_int) -> inserted pose (IK nearest the approach) ->
trigger -> back to the approach pose -> back through q_int -> rivet_home (``return_via:
intermediate``, the default). The printed code goes straight from the approach pose to rivet_home
(``return_via: direct``); in our cell that line cuts through the workpiece for the left face.
Every move is a straight line in joint space (two-point FollowJointTrajectory goals). Targets are
full 6-D frames (the thesis matched TF frames): the hole frame turned by a per-face roll.

The seed gives no q_int; we "teach" one per face as the author did by hand: the tcp
``intermediate_distance`` (0.15 m) out from the face centre along its normal, tool pointing at the
centroid of the face's holes, tool pointing at the face, with the roll (12 candidates) and IK
branch that keep >= 15 mm from workpiece and table, reach every hole of the face, move the joints
least from rivet_home, and whose joint lines home -> q_int -> each approach pose keep >= 10 mm
(checked as densely as the run).

Timing ``thesis``: fixed durations as the client sent them: 1 s to q_int, the 2 s sleep, and
``move_time`` for every move_to. The seed gives no move_to duration; the default 5.8 s is our
calibration so that a cycle lasts 33 s (1 + 2 + 5 x 5.8 + 0.5 + 0.5 s with the return through
q_int), i.e. 300 s give the thesis's 9 rivets (ur5-riveting.md 5).
A fixed duration is stretched if the limits need longer. Timing ``optimal``: the same paths at
minimum time under the limits, without the sleep.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.apps.riveting.cost import PlanningCost
from wbik.apps.riveting.moves import Move
from wbik.apps.riveting.moves import dwell
from wbik.apps.riveting.moves import sample_times
from wbik.apps.riveting.moves import timed_move
from wbik.apps.riveting.plan import TRIGGER
from wbik.apps.riveting.plan import CyclePlan
from wbik.apps.riveting.plan import Planner
from wbik.apps.riveting.scene import FACE_NORMALS
from wbik.apps.riveting.scene import Hole
from wbik.solvers.method_registry import solver

ROLL_CANDIDATES = 12
TEACH_CLEARANCE = 0.015
"""Clearance (m) to workpiece and table that a taught q_int keeps."""
LINE_CLEARANCE = 0.01
"""Clearance (m) kept along the taught lines rivet_home -> q_int -> every approach pose (sampled)."""


class ThesisPlanner(Planner):
    name = "thesis"

    def __init__(self, *args, timing: str = "thesis", intermediate_distance: float = 0.15,
                 intermediate_time: float = 1.0, sleep: float = 2.0, move_time: float = 5.8,
                 return_via: str = "intermediate", **options):
        super().__init__(*args, **options)
        if timing not in ("thesis", "optimal"):
            raise ValueError(f"thesis planner timing must be 'thesis' or 'optimal', got {timing!r}")
        if return_via not in ("direct", "intermediate"):
            raise ValueError(f"return_via must be 'direct' or 'intermediate', got {return_via!r}")
        self.timing = timing
        self.intermediate_distance = float(intermediate_distance)
        self.intermediate_time = float(intermediate_time)
        self.sleep = float(sleep)
        self.move_time = float(move_time)
        self.return_via = return_via
        self.solver = solver("analytic", self.robot, chain="arm")
        self.intermediate: dict[str, np.ndarray] = {}
        self.roll: dict[str, float] = {}

    # -- teaching -------------------------------------------------------------------------------
    def _clear(self, q: np.ndarray, minimum: float, pin_inside: bool = False) -> bool:
        skip = ("rivet_tool_1",) if pin_inside else ()
        clearance = self.collision.clearance(q, skip=skip)
        return clearance.minimum() >= minimum and clearance.table_minimum() >= minimum

    def _face_poses(self, face: str, roll: float) -> pin.SE3:
        hole_rotation = next(h for h in self.scene.holes if h.face == face).placement.rotation
        rotation = hole_rotation @ pin.rpy.rpyToMatrix(0.0, 0.0, roll)
        centroid = np.mean([hole.position for hole in self.scene.holes_of(face)], axis=0)
        position = centroid + self.intermediate_distance * FACE_NORMALS[face]
        return pin.SE3(rotation, position)

    def setup(self, q_home: np.ndarray) -> dict:
        taught = {}
        for face in self.scene.faces():
            candidates = []
            for roll in np.linspace(0.0, 2.0 * np.pi, ROLL_CANDIDATES, endpoint=False):
                for result in self.solver.solve_all(self._face_poses(face, roll)):
                    if not result.success:
                        continue
                    q_int = _nearest_turn(self.solver.chain.clip(result.q), q_home, self.chain)
                    if not self._clear(q_int, TEACH_CLEARANCE):
                        continue
                    cost = self._face_cost(face, roll, q_int, q_home)
                    if cost is not None:
                        candidates.append((cost, float(roll), q_int))
            candidates.sort(key=lambda item: item[0])
            best = next((c for c in candidates if self._lines_clear(face, c[1], c[2], q_home)), None)
            if best is None:
                raise RuntimeError(f"thesis planner: no intermediate configuration reaches every hole of "
                                   f"face {face!r} with {TEACH_CLEARANCE * 1e3:g} mm clearance")
            _, self.roll[face], self.intermediate[face] = best
            taught[face] = {"roll_rad": best[1], "q_int": best[2].tolist(), "candidates": len(candidates)}
        return {"intermediate_configurations": taught, "return_via": self.return_via}

    def _line_clear(self, q_from: np.ndarray, q_to: np.ndarray) -> bool:
        move = timed_move("probe", self.chain, np.array([q_from, q_to]), self.limits)
        for t in sample_times(move, self.chain):
            if not self._clear(move.evaluate(t)[0], LINE_CLEARANCE):
                return False
        return True

    def _lines_clear(self, face: str, roll: float, q_int: np.ndarray, q_home: np.ndarray) -> bool:
        """The taught lines keep LINE_CLEARANCE: home -> q_int, and q_int -> every approach pose."""
        if not self._line_clear(q_home, q_int):
            return False
        return all(self._line_clear(q_int, self._hole_configurations(hole, q_int, roll)[0])
                   for hole in self.scene.holes_of(face))

    def _face_cost(self, face: str, roll: float, q_int: np.ndarray, q_home: np.ndarray) -> float | None:
        cost = float(np.max(np.abs(q_int - q_home)))
        for hole in self.scene.holes_of(face):
            pair = self._hole_configurations(hole, q_int, roll)
            if pair is None or not self._clear(pair[1], 0.0, pin_inside=True):
                return None
            cost += float(np.max(np.abs(pair[0] - q_int))) / len(self.scene.holes_of(face))
        return cost

    def _hole_configurations(self, hole: Hole, q_int: np.ndarray, roll: float):
        approach = self.solver.solve(self.insertion.approach_pose(hole, roll), q_int)
        if not approach.success:
            return None
        inserted = self.solver.solve(self.insertion.inserted_pose(hole, roll), approach.q)
        if not inserted.success:
            return None
        return approach.q, inserted.q

    # -- one cycle ------------------------------------------------------------------------------
    def _move(self, name: str, q_from: np.ndarray, q_to: np.ndarray, fixed: float,
              fine: bool = False) -> Move:
        duration = fixed if self.timing == "thesis" else None
        return timed_move(name, self.chain, np.array([q_from, q_to]), self.limits, duration=duration,
                          fine=fine)

    def plan(self, hole: Hole, q_home: np.ndarray) -> CyclePlan:
        if not self.intermediate:
            self.setup(q_home)
        q_int = self.intermediate[hole.face]
        pair = self._hole_configurations(hole, q_int, self.roll[hole.face])
        if pair is None:
            return CyclePlan(hole, success=False, reason=f"closed-form IK has no solution for {hole.name}",
                             planning_cost_s=PlanningCost({"ik": 2}).seconds)
        q_approach, q_inserted = pair
        move_time = self.move_time
        moves = [self._move("to intermediate", q_home, q_int, self.intermediate_time)]
        if self.timing == "thesis" and self.sleep > 0:
            moves.append(dwell("sleep", q_int, self.sleep))
        moves += [self._move("approach", q_int, q_approach, move_time),
                  self._move("insert", q_approach, q_inserted, move_time, fine=True),
                  dwell(TRIGGER, q_inserted, self.insertion.trigger_s),
                  self._move("retract", q_inserted, q_approach, move_time, fine=True)]
        if self.return_via == "intermediate":
            moves += [self._move("back to intermediate", q_approach, q_int, move_time),
                      self._move("to rivet_home", q_int, q_home, move_time)]
        else:
            moves.append(self._move("to rivet_home", q_approach, q_home, move_time))
        cost = PlanningCost({"ik": 2})  # the approach and the inserted pose, closed form
        return CyclePlan(hole, moves, planning_cost_s=cost.seconds, info={"roll_rad": self.roll[hole.face]})


def _nearest_turn(q: np.ndarray, reference: np.ndarray, chain) -> np.ndarray:
    """q with each revolute joint shifted by 2 pi multiples toward ``reference`` (inside the limits)."""
    from wbik.solvers.analytic.closed_form import wrap_into_limits

    wrapped, _ = wrap_into_limits(q, reference, chain.lower, chain.upper, ~chain.is_prismatic)
    return wrapped
