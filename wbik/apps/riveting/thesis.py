"""The thesis's planner (ur5-riveting.md 4): closed-form UR5 IK and joint lines rivet_home -> q_int ->
approach -> insert -> trigger -> retract -> q_int -> rivet_home. The seed gives no q_int: one is taught per
face, ``intermediate_distance`` out from its holes' centroid, the roll and branch keeping TEACH_CLEARANCE and
LINE_CLEARANCE that move the joints least. Timing ``thesis``: the client's fixed durations (``move_time`` 5.8
s: 9 rivets in 300 s, ur5-riveting.md 5); ``optimal``: minimum time, no sleep."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.apps.riveting.collision import PIN
from wbik.apps.riveting.cost import PlanningCost
from wbik.apps.riveting.moves import Move, dwell, samples, timed_move
from wbik.apps.riveting.plan import TRIGGER, CyclePlan, Planner
from wbik.apps.riveting.scene import FACE_NORMALS, Hole
from wbik.errors import InvalidSettingError

ROLL_CANDIDATES = 12
TEACH_CLEARANCE = 0.015  # m to workpiece and table that a taught q_int keeps
LINE_CLEARANCE = 0.01  # m kept along the taught lines rivet_home -> q_int -> every approach pose (sampled)


class ThesisPlanner(Planner):
    name = "thesis"

    def __init__(self, *args, timing: str = "thesis", intermediate_distance: float = 0.15,
                 intermediate_time: float = 1.0, sleep: float = 2.0, move_time: float = 5.8,
                 return_via: str = "intermediate", **options):
        super().__init__(*args, **options)
        if timing not in ("thesis", "optimal"):
            raise InvalidSettingError(f"thesis planner timing must be 'thesis' or 'optimal', got {timing!r}")
        if return_via not in ("direct", "intermediate"):
            raise InvalidSettingError(f"return_via must be 'direct' or 'intermediate', got {return_via!r}")
        self.timing, self.return_via, self.sleep = timing, return_via, float(sleep)
        self.intermediate_distance = float(intermediate_distance)
        self.intermediate_time, self.move_time = float(intermediate_time), float(move_time)
        self.intermediate: dict[str, np.ndarray] = {}  # q_int and roll per face
        self.roll: dict[str, float] = {}

    def setup(self, q_home: np.ndarray) -> dict:
        """Teach q_int and the roll of every face."""
        taught = {}
        for face in self.scene.faces():
            hole_rotation = self.scene.holes_of(face)[0].placement.rotation
            centroid = np.mean([hole.position for hole in self.scene.holes_of(face)], axis=0)
            position = centroid + self.intermediate_distance * FACE_NORMALS[face]
            candidates = []
            for roll in np.linspace(0.0, 2.0 * np.pi, ROLL_CANDIDATES, endpoint=False):
                pose = pin.SE3(hole_rotation @ pin.rpy.rpyToMatrix(0.0, 0.0, roll), position)
                for result in (r for r in self.analytic.solve_all(pose) if r.success):
                    q_int = self.wrap(self.analytic.chain.clip(result.q), q_home)
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
        return all(self._clear(q, LINE_CLEARANCE) for q in samples(move, self.chain)[1])

    def _lines_clear(self, face: str, roll: float, q_int: np.ndarray, q_home: np.ndarray) -> bool:
        """The taught lines keep LINE_CLEARANCE: home -> q_int, and q_int -> every approach pose."""
        return self._line_clear(q_home, q_int) and all(
            self._line_clear(q_int, self._hole_configurations(hole, q_int, roll)[0])
            for hole in self.scene.holes_of(face))

    def _face_cost(self, face: str, roll: float, q_int: np.ndarray, q_home: np.ndarray) -> float | None:
        """Largest joint move home -> q_int plus the mean q_int -> approach; None if a hole is out of reach
        or touched when inserted."""
        holes = self.scene.holes_of(face)
        cost = float(np.max(np.abs(q_int - q_home)))
        for hole in holes:
            pair = self._hole_configurations(hole, q_int, roll)
            if pair is None or not self._clear(pair[1], 0.0, (PIN,)):
                return None
            cost += float(np.max(np.abs(pair[0] - q_int))) / len(holes)
        return cost

    def _hole_configurations(self, hole: Hole, q_int: np.ndarray, roll: float):
        """(approach, inserted) joints by closed form nearest q_int, or None."""
        approach = self.analytic.solve(self.insertion.approach_pose(hole, roll), q_int)
        if not approach.success:
            return None
        inserted = self.analytic.solve(self.insertion.inserted_pose(hole, roll), approach.q)
        return (approach.q, inserted.q) if inserted.success else None

    def _move(self, name: str, q_from: np.ndarray, q_to: np.ndarray, fixed: float,
              fine: bool = False) -> Move:
        """A joint line: ``fixed`` s long with the thesis's timing, else at minimum time."""
        return timed_move(name, self.chain, np.array([q_from, q_to]), self.limits, fine=fine,
                          duration=fixed if self.timing == "thesis" else None)

    def plan(self, hole: Hole, q_home: np.ndarray) -> CyclePlan:
        if not self.intermediate:
            self.setup(q_home)
        q_int = self.intermediate[hole.face]
        cost = PlanningCost({"ik": 2}).seconds  # the approach and the inserted pose, closed form
        pair = self._hole_configurations(hole, q_int, self.roll[hole.face])
        if pair is None:
            return CyclePlan(hole, success=False, reason=f"closed-form IK has no solution for {hole.name}",
                             planning_cost_s=cost)
        q_approach, q_inserted = pair
        moves = [self._move("to intermediate", q_home, q_int, self.intermediate_time)]
        if self.timing == "thesis" and self.sleep > 0:
            moves.append(dwell("sleep", q_int, self.sleep))
        moves += [self._move("approach", q_int, q_approach, self.move_time),
                  self._move("insert", q_approach, q_inserted, self.move_time, fine=True),
                  dwell(TRIGGER, q_inserted, self.insertion.trigger_s),
                  self._move("retract", q_inserted, q_approach, self.move_time, fine=True)]
        if self.return_via == "intermediate":
            moves += [self._move("back to intermediate", q_approach, q_int, self.move_time),
                      self._move("to rivet_home", q_int, q_home, self.move_time)]
        else:
            moves.append(self._move("to rivet_home", q_approach, q_home, self.move_time))
        return CyclePlan(hole, moves, planning_cost_s=cost, info={"roll_rad": self.roll[hole.face]})
