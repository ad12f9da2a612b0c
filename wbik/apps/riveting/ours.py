"""Our planner, per hole, deterministic: closed-form approach configurations at ``rolls`` rolls about the
hole axis; routes (the joint line, or through a retreat out on the axis) ranked by a closed-form time
estimate and checked densely best first; the insertion by closed form along the axis, blended when faster;
fallback: the QP path under the workpiece clearance constraint (docs/measurements.md, riveting planner)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.apps.riveting.collision import PIN
from wbik.apps.riveting.cost import CountingCollision, PlanningCost
from wbik.apps.riveting.moves import Move, backward, dwell, split, timed_move
from wbik.apps.riveting.plan import TRIGGER, CyclePlan, Planner, hole_pose
from wbik.apps.riveting.qp_terms import ToolAxisTask, WorkpieceClearance
from wbik.apps.riveting.scene import Hole
from wbik.errors import NoQPSolutionError
from wbik.motion.profiles import time_law
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.qp.limits import JointPositionLimits
from wbik.qp.problem import IKProblem
from wbik.qp.tasks import RegularizationTask

TASK_TOLERANCE = 1e-8  # |e| of the 5-D task (m, and the sine of the axis error) the QP path accepts
BRANCH_STEP = 0.2  # rad, the largest joint change between neighbouring axis points of one branch
CERTIFIED = 0.002  # m a checked route keeps everywhere between its samples (see _path_clearance)
GRID_DT = 2e-4  # s, the grid on which a route's joint motion is bounded between samples
LOOKAHEAD = 1000  # grid points looked ahead from a sample
MAX_ROUTE_CHECKS = 40  # routes densely checked per hole before the QP path


@dataclass
class _Route:
    estimate: float  # s, the closed-form time estimate
    roll: float
    retreat: float
    knots: np.ndarray  # (2 or 3, 6): home, [retreat,] approach
    key: tuple  # (roll index, branch): the approach configuration


class QPPlanner(Planner):
    name = "ours"

    def __init__(self, *args, minimum_clearance: float = 0.01, line_clearance: float = 0.005,
                 knot_spacing: float = 0.001, max_step: float = 0.05, backend: str = DEFAULT_BACKEND,
                 rolls: int = 12, retreats=(0.015, 0.03, 0.06), **options):
        super().__init__(*args, **options)
        self.minimum_clearance, self.line_clearance = float(minimum_clearance), float(line_clearance)
        self.knot_spacing, self.max_step, self.backend = float(knot_spacing), float(max_step), backend
        self.rolls, self.retreats = int(rolls), tuple(float(r) for r in retreats)
        self.reach = self.collision.joint_reach()
        self.cost = PlanningCost()
        self.collision = CountingCollision(self.collision, self.cost)
        self.law = time_law(self.limits.law)

    def _branches(self, pose: pin.SE3, near: np.ndarray) -> list[tuple[int, np.ndarray]]:
        """(branch index, q wrapped nearest ``near``) of every closed-form solution of a tcp pose."""
        self.cost.add("ik")
        return [(branch, self.wrap(result.q, near))
                for branch, result in enumerate(self.analytic.solve_all(pose)) if result.success]

    def _same_branch(self, solutions: list[tuple[int, np.ndarray]], near: np.ndarray) -> np.ndarray | None:
        """The solution, wrapped nearest ``near``, nearest to it if within BRANCH_STEP per joint."""
        wrapped = [self.wrap(q, near) for _, q in solutions]
        steps = [(float(np.max(np.abs(q - near))), index) for index, q in enumerate(wrapped)]
        within = [step for step in steps if step[0] <= BRANCH_STEP]
        return wrapped[min(within)[1]] if within else None

    def _line_time(self, q_from: np.ndarray, q_to: np.ndarray) -> float:
        """Minimum time of the joint line under the limits (closed form for a two-knot path)."""
        self.cost.add("line_estimate")
        step = np.abs(q_to - q_from)
        return float(max(np.max(step * self.law.peak_velocity / self.limits.velocity),
                         np.sqrt(np.max(step) * abs(self.law.peak_acceleration) / self.limits.acceleration)))

    def _timed(self, name: str, knots: np.ndarray, fine: bool = False) -> Move:
        self.cost.add("line_timing" if len(knots) <= 2 else "spline_timing")
        return timed_move(name, self.chain, knots, self.limits, fine=fine)

    def _path_clearance(self, move: Move, minimum: float, skip: tuple[str, ...] = ()) -> tuple[bool, float]:
        """(clear, smallest sampled distance) of a move, walked from its end. Every sample keeps ``minimum``;
        the next one is the farthest grid time at which no point can have moved by more than d - CERTIFIED -
        slack (:meth:`CollisionModel.joint_reach`), so the whole move keeps CERTIFIED."""
        count = max(int(np.ceil(move.duration / GRID_DT)), 2) + 1
        self.cost.add("grid_points", count)
        times = np.linspace(0.0, move.duration, count)[::-1]
        rows, velocity, _ = move.timed.evaluate(move.local_times(times))
        slack = float((times[0] - times[1]) * np.max(np.abs(velocity), axis=0) @ self.reach)
        worst, index = np.inf, 0
        while True:
            distance = self.collision.clearance(rows[index], skip=skip).minimum("cell")
            worst = min(worst, distance)
            if distance < minimum or index == count - 1:
                return distance >= minimum, float(worst)
            moved = np.abs(rows[index + 1:index + 1 + LOOKAHEAD] - rows[index]) @ self.reach
            beyond = np.flatnonzero(moved > distance - CERTIFIED - slack)
            index += max(int(beyond[0]) if beyond.size else min(LOOKAHEAD, count - 1 - index), 1)

    def _routes(self, hole: Hole, q_home: np.ndarray) -> list[_Route]:
        """Every (approach configuration, route) pair, ranked by its time estimate."""
        routes = []
        standoff = self.insertion.standoff
        for index, roll in enumerate(np.linspace(0.0, 2.0 * np.pi, self.rolls, endpoint=False)):
            out = {}  # the closed-form solutions of each retreat pose
            for branch, q_approach in self._branches(hole_pose(hole, -standoff, roll), q_home):
                routes.append(_Route(self._line_time(q_home, q_approach), float(roll), 0.0,
                                     np.array([q_home, q_approach]), (index, branch)))
                for retreat in self.retreats:
                    if retreat not in out:
                        out[retreat] = self._branches(hole_pose(hole, -standoff - retreat, roll), q_home)
                    q_retreat = self._same_branch(out[retreat], q_approach)
                    if q_retreat is not None:
                        estimate = self._line_time(q_home, q_retreat) + self._line_time(q_retreat, q_approach)
                        knots = np.array([q_home, q_retreat, q_approach])
                        routes.append(_Route(estimate, float(roll), retreat, knots, (index, branch)))
        routes.sort(key=lambda route: (route.estimate, route.retreat, route.roll))
        return routes

    def _insertion(self, hole: Hole, roll: float, q_approach: np.ndarray) -> np.ndarray | None:
        """Knots on the axis from the approach to the inserted pose, same roll and branch; None on a branch
        jump or when the links lose ``line_clearance`` at the bottom."""
        total = self.insertion.standoff + self.insertion.depth
        count = max(int(np.ceil(total / self.knot_spacing)), 1)
        knots = [q_approach]
        for k in range(1, count + 1):
            pose = hole_pose(hole, -self.insertion.standoff + total * k / count, roll)
            q = self._same_branch(self._branches(pose, knots[-1]), knots[-1])
            if q is None:
                return None
            knots.append(q)
        return np.array(knots) if self._clear(knots[-1], self.line_clearance, skip=(PIN,)) else None

    def _blended(self, route: _Route, approach: Move, insertion: np.ndarray) -> tuple[Move, Move] | None:
        """Route and insertion as one motion split at the approach knot; None if not faster than stopping
        there or if the links lose ``line_clearance`` along it."""
        full = self._timed("approach and insert", np.vstack([route.knots, insertion[1:]]))
        if full.duration >= approach.duration + self._line_time(insertion[0], insertion[-1]):
            return None
        at = float(full.timed.knot_times[len(route.knots) - 1])
        approach, insert = split(full, at, ("approach", "insert"), (False, True))
        clear = (self._path_clearance(approach, self.line_clearance)[0]
                 and self._path_clearance(insert, self.line_clearance, skip=(PIN,))[0])
        return (approach, insert) if clear else None

    def _qp_path(self, target: pin.SE3, q_start: np.ndarray, q_end: np.ndarray) -> np.ndarray | None:
        """Trust-region QP steps from q_start toward the 5-D target under the clearance constraint."""
        task = ToolAxisTask(self.chain.tip_frame, target, tolerance=TASK_TOLERANCE)
        constraints = [JointPositionLimits(), WorkpieceClearance(self.collision, self.minimum_clearance)]
        problem = IKProblem(self.robot.model, [task, RegularizationTask(1e-9)], constraints,
                            backend=self.backend, max_step=0.2)
        problem.start(q_start)
        q = q_start.copy()
        knots = [q.copy()]
        for _ in range(400):
            self.cost.add("qp_iteration")
            try:
                dq = problem.step(q, max_step=self.max_step)
            except NoQPSolutionError:
                return None
            q = problem.clip(pin.integrate(self.robot.model, q, dq))
            knots.append(q.copy())
            problem.kinematics.update(q)
            if np.linalg.norm(task.error(problem.kinematics)) < 1e-6:
                return np.array([*knots, q_end])
        return None

    def _search(self, hole: Hole, routes: list[_Route], insertions: dict) -> tuple[tuple | None, int, float]:
        """((route, approach, insertion, clearance) of the best clear route, routes checked, best seen)."""
        checked, worst_seen, static = 0, -np.inf, {}
        for route in routes:
            if checked >= MAX_ROUTE_CHECKS:
                break
            if route.key not in static:
                static[route.key] = self._clear(route.knots[-1], self.minimum_clearance)
            if not static[route.key] or (len(route.knots) == 3
                                         and not self._clear(route.knots[1], self.line_clearance)):
                continue
            checked += 1
            move = self._timed("approach", route.knots)
            clear, worst = self._path_clearance(move, self.line_clearance)
            worst_seen = max(worst_seen, worst)
            if not clear:
                continue
            if route.key not in insertions:
                insertions[route.key] = self._insertion(hole, route.roll, route.knots[-1])
            if insertions[route.key] is not None:
                return (route, move, insertions[route.key], worst), checked, worst_seen
        return None, checked, worst_seen

    def _fallback(self, hole: Hole, route: _Route, insertion: np.ndarray | None, q_home: np.ndarray):
        if insertion is None:
            insertion = self._insertion(hole, route.roll, route.knots[-1])
        if insertion is None:
            return None
        path = self._qp_path(hole_pose(hole, -self.insertion.standoff, route.roll), q_home, route.knots[-1])
        if path is None:
            return None
        move = self._timed("approach", path)
        clear, worst = self._path_clearance(move, self.line_clearance)
        return (route, move, insertion, worst) if clear else None

    def plan(self, hole: Hole, q_home: np.ndarray) -> CyclePlan:
        started = time.perf_counter()
        self.cost = self.collision.cost = PlanningCost()
        routes = self._routes(hole, q_home)
        insertions = {}
        chosen, checked, worst_seen = self._search(hole, routes, insertions)
        qp = chosen is None and bool(routes)
        if qp:
            chosen = self._fallback(hole, routes[0], insertions.get(routes[0].key), q_home)
        info = {"routes_ranked": len(routes), "routes_checked": checked,
                "planning_counts": dict(self.cost.counts)}
        if chosen is None:
            reason = ("no approach configuration clear of the workpiece" if not routes else
                      f"no route to the approach pose clear of the workpiece ({checked} checked, best "
                      f"{worst_seen * 1e3:.2f} mm < {self.line_clearance * 1e3:g} mm)")
            return CyclePlan(hole, success=False, reason=reason, info=info, planning_cost_s=self.cost.seconds,
                             planning_time_s=time.perf_counter() - started)
        route, approach, insertion, worst = chosen
        blended = None if qp else self._blended(route, approach, insertion)
        trigger = dwell(TRIGGER, insertion[-1], self.insertion.trigger_s)
        way = "joint line" if route.retreat == 0.0 else "via retreat"
        if blended is not None:
            approach, insert = blended
            moves = [approach, insert, trigger, backward(insert, "retract", fine=True),
                     backward(approach, "to rivet_home")]
            described = f"blended {way} {route.retreat * 1e3:g} mm + insertion"
        else:
            home = approach.timed.path.q[::-1] if qp else route.knots[::-1]  # the approach's spline backward
            moves = [approach, self._timed("insert", insertion, fine=True), trigger,
                     self._timed("retract", insertion[::-1], fine=True), self._timed("to rivet_home", home)]
            described = "QP path" if qp else f"{way} {route.retreat * 1e3:g} mm" if route.retreat else way
        info.update({"route": described, "roll_rad": route.roll, "line_clearance_m": worst,
                     "planning_counts": dict(self.cost.counts)})
        return CyclePlan(hole, moves, planning_time_s=time.perf_counter() - started,
                         planning_cost_s=self.cost.seconds, info=info)
