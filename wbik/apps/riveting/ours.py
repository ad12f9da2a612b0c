"""Our way: approach configurations over the 5-D task's free roll, routes chosen by time and
clearance, the QP layer (wbik.qp) as the fallback route.

Per hole, from rivet_home (q_home), deterministic (no random sampling):

1. approach configurations: the tool axis is a 5-D task (the roll about the axis is free), sampled
   at ``rolls`` (12) rolls; at each, every closed-form branch of the 6-D approach pose, wrapped
   nearest rivet_home; one is used only if it is ``minimum_clearance`` (10 mm) clear of workpiece
   and table.
2. routes to each: the joint line home -> approach, or one C2 spline home -> retreat -> approach
   timed as a single rest-to-rest move (no stop at the via point), the retreat configuration being
   the same roll and branch ``retreats`` (15, 30, 60 mm) further out on the hole axis, so the tool
   comes in along the axis. Every (configuration, route) pair is ranked by a closed-form time
   estimate (the sum of its two-knot line times); best first, each is timed exactly and walked
   from its end with a certified step (:meth:`QPPlanner._path_clearance`: every sample keeps
   ``line_clearance``, 5 mm, and the joint-reach bound guarantees 2 mm between samples) until one
   is clear. The retract and the return run the same motion backward.
3. insertion: knots every ``knot_spacing`` (1 mm) on the hole axis from the approach pose to the
   inserted pose, the same roll and branch by closed form (exact on the axis at every knot).
   When it is faster, the route and the insertion are one blended motion (no stop at the approach
   pose; on the default cell the top face's joint lines), cut at the approach knot into the
   ``approach`` and ``insert`` moves; the links keep ``line_clearance`` along it, and the pin's fit
   in the hole is the run's fine check.
4. fallback (not needed on the default cell): the QP trust-region path of the 5-D task under the
   workpiece clearance constraint from rivet_home to the best approach configuration.

Why routes through closed-form retreats: with only the joint line home -> approach, and a QP search
for a retreat configuration as its alternative, some holes get no clear route: the joint line grazes
the workpiece although the approach configuration itself is clear, and the QP finds no retreat, while
the closed-form retreat of the same branch exists. On a few side holes the retreat routes of the best
rolls sweep the upper arm into the workpiece, and a slower joint line of another roll is taken (the
measurements: docs/measurements.md, riveting planner).

Planning cost is counted (:mod:`wbik.apps.riveting.cost`): every IK, clearance query, timing and grid
point, deterministic for a given hole; the cycle charges it to the run's clock.
Every move is timed at minimum time under the velocity and acceleration limits (quintic law).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.apps.riveting.cost import CountingCollision
from wbik.apps.riveting.cost import PlanningCost
from wbik.apps.riveting.moves import Move
from wbik.apps.riveting.moves import backward
from wbik.apps.riveting.moves import dwell
from wbik.apps.riveting.moves import split
from wbik.apps.riveting.moves import timed_move
from wbik.apps.riveting.plan import TRIGGER
from wbik.apps.riveting.plan import CyclePlan
from wbik.apps.riveting.plan import Planner
from wbik.apps.riveting.qp_terms import ToolAxisTask
from wbik.apps.riveting.qp_terms import WorkpieceClearance
from wbik.apps.riveting.scene import Hole
from wbik.errors import NoQPSolutionError
from wbik.motion.profiles import time_law
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.qp.limits import JointPositionLimits
from wbik.qp.problem import IKProblem
from wbik.qp.tasks import RegularizationTask
from wbik.solvers.analytic.closed_form import wrap_into_limits
from wbik.solvers.method_registry import solver

TASK_TOLERANCE = 1e-8
"""|e| of the 5-D task (m, and the sine of the axis error) at which a QP configuration is accepted."""
PIN = "rivet_tool_1"
BRANCH_STEP = 0.2
"""Largest joint change (rad) between neighbouring axis points of one branch (else a branch jump)."""
CERTIFIED = 0.002
"""Clearance (m) that a checked route keeps everywhere between its samples (see _path_clearance)."""
GRID_DT = 2e-4
"""Time step (s) of the grid on which a route's joint motion is bounded between samples."""
LOOKAHEAD = 1000
"""Grid points looked ahead from a sample (bounds the work per sample)."""
MAX_ROUTE_CHECKS = 40
"""Routes densely checked per hole before falling back to the QP path."""


@dataclass
class _Route:
    estimate: float
    roll: float
    retreat: float
    knots: np.ndarray  # (2 or 3, 6): home, [retreat,] approach
    kind: tuple = ()  # (roll index, branch, retreat)


class QPPlanner(Planner):
    name = "ours"

    def __init__(self, *args, minimum_clearance: float = 0.01, line_clearance: float = 0.005,
                 knot_spacing: float = 0.001, max_step: float = 0.05, backend: str = DEFAULT_BACKEND,
                 rolls: int = 12, retreats=(0.015, 0.03, 0.06), **options):
        super().__init__(*args, **options)
        self.minimum_clearance = float(minimum_clearance)
        self.line_clearance = float(line_clearance)
        self.knot_spacing = float(knot_spacing)
        self.max_step = float(max_step)
        self.backend = backend
        self.rolls = int(rolls)
        self.retreats = tuple(float(r) for r in retreats)
        self.model = self.robot.model
        self.tcp = self.chain.tip_frame
        self.analytic = solver("analytic", self.robot, chain="arm")
        self.cost = PlanningCost()
        self.counted = CountingCollision(self.collision, self.cost)
        self.reach = self.collision.joint_reach()
        self.law = time_law(self.limits.law)

    # -- counted primitives ---------------------------------------------------------------------
    def _branches(self, pose: pin.SE3, near: np.ndarray, numbered: bool = False) -> list:
        """Every closed-form solution of a 6-D tcp pose, wrapped nearest ``near`` (with ``numbered``:
        (branch index in the solver's order, q) pairs)."""
        self.cost.add("ik")
        out = []
        for branch, result in enumerate(self.analytic.solve_all(pose)):
            if result.success:
                q, _ = wrap_into_limits(result.q, near, self.chain.lower, self.chain.upper,
                                        ~self.chain.is_prismatic)
                out.append((branch, q) if numbered else q)
        return out

    def _same_branch(self, pose: pin.SE3, near: np.ndarray,
                     solutions: list[np.ndarray] | None = None) -> np.ndarray | None:
        """The solution of ``pose`` (or of the given ``solutions``), wrapped nearest ``near``, if
        within BRANCH_STEP (rad) of it per joint."""
        if solutions is None:
            solutions = self._branches(pose, near)
        best = None
        for q in solutions:
            q, _ = wrap_into_limits(q, near, self.chain.lower, self.chain.upper, ~self.chain.is_prismatic)
            step = float(np.max(np.abs(q - near)))
            if step <= BRANCH_STEP and (best is None or step < best[0]):
                best = (step, q)
        return None if best is None else best[1]

    def _clear(self, q: np.ndarray, minimum: float, skip: tuple[str, ...] = ()) -> bool:
        clearance = self.counted.clearance(q, skip=skip)
        return min(clearance.minimum(), clearance.table_minimum()) >= minimum

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
        """(clear, smallest sampled distance) of a move, certified between samples.

        Every sample must keep ``minimum``; from a sample at distance d the next one is the farthest
        grid time at which no robot point can have moved by more than d - CERTIFIED - slack (the
        joint-reach bound of :meth:`CollisionModel.joint_reach`), so the whole move keeps at least
        CERTIFIED (2 mm) from workpiece and table, not only the samples. The move is walked from its
        end (the tool near the workpiece) backward, where a bad route fails soonest.
        """
        count = max(int(np.ceil(move.duration / GRID_DT)), 2) + 1
        self.cost.add("grid_points", count)
        times = np.linspace(0.0, move.duration, count)[::-1]
        rows = move.evaluate(times)
        speed = np.max(np.abs(move.timed.evaluate(move.local_times(times))[1]), axis=0)
        slack = float((times[0] - times[1]) * speed @ self.reach)
        worst, index = np.inf, 0
        while True:
            clearance = self.counted.clearance(rows[index], skip=skip)
            distance = min(clearance.minimum(), clearance.table_minimum())
            worst = min(worst, distance)
            if distance < minimum:
                return False, float(worst)
            if index == count - 1:
                return True, float(worst)
            budget = distance - CERTIFIED - slack
            moved = np.abs(rows[index + 1:index + 1 + LOOKAHEAD] - rows[index]) @ self.reach
            beyond = np.flatnonzero(moved > budget)
            step = int(beyond[0]) if beyond.size else min(LOOKAHEAD, count - 1 - index)
            index += max(step, 1)

    # -- approach configurations and routes -----------------------------------------------------
    def _pose(self, hole: Hole, depth: float, roll: float) -> pin.SE3:
        rotation = hole.placement.rotation @ pin.rpy.rpyToMatrix(0.0, 0.0, roll)
        return pin.SE3(rotation, hole.point_at_depth(depth))

    def _routes(self, hole: Hole, q_home: np.ndarray) -> list[_Route]:
        """Every (approach configuration, route) pair, ranked by its time estimate."""
        routes = []
        standoff = self.insertion.standoff
        for index, roll in enumerate(np.linspace(0.0, 2.0 * np.pi, self.rolls, endpoint=False)):
            retreat_solutions = {}
            approach_pose = self._pose(hole, -standoff, roll)
            for branch, q_approach in self._branches(approach_pose, q_home, numbered=True):
                direct = self._line_time(q_home, q_approach)
                routes.append(_Route(direct, float(roll), 0.0, np.array([q_home, q_approach]),
                                     (index, branch, 0.0)))
                for retreat in self.retreats:
                    if retreat not in retreat_solutions:
                        retreat_solutions[retreat] = self._branches(
                            self._pose(hole, -standoff - retreat, roll), q_home)
                    q_retreat = self._same_branch(None, q_approach, retreat_solutions[retreat])
                    if q_retreat is None:
                        continue
                    estimate = self._line_time(q_home, q_retreat) + self._line_time(q_retreat, q_approach)
                    routes.append(_Route(estimate, float(roll), retreat,
                                         np.array([q_home, q_retreat, q_approach]), (index, branch, retreat)))
        routes.sort(key=lambda route: (route.estimate, route.retreat, route.roll))
        return routes

    def _insertion(self, hole: Hole, roll: float, q_approach: np.ndarray) -> np.ndarray | None:
        """Knots on the axis from the approach pose to the inserted pose, same roll and branch."""
        total = self.insertion.standoff + self.insertion.depth
        count = max(int(np.ceil(total / self.knot_spacing)), 1)
        knots = [q_approach]
        for k in range(1, count + 1):
            depth = -self.insertion.standoff + total * k / count
            q = self._same_branch(self._pose(hole, depth, roll), knots[-1])
            if q is None:
                return None
            knots.append(q)
        # the links (not the pin, which enters the hole) keep the planning clearance at the bottom
        if not self._clear(knots[-1], self.line_clearance, skip=(PIN,)):
            return None
        return np.array(knots)

    def _blended(self, route: _Route, approach: Move, insertion: np.ndarray) -> tuple[Move, Move] | None:
        """The route and the insertion as one motion (no stop at the approach pose), cut at the
        approach knot into the approach and the insertion moves; None if that is not faster than
        stopping at the approach pose (one global time law slows a path with a sharp turn at the
        retreat point) or if the blend loses clearance (the links keep ``line_clearance``; the
        pin's fit in the hole is the run's fine check)."""
        knots = np.vstack([route.knots, insertion[1:]])
        full = self._timed("approach and insert", knots)
        if full.duration >= approach.duration + self._line_time(insertion[0], insertion[-1]):
            return None
        at = float(full.timed.knot_times[len(route.knots) - 1])
        approach, insert = split(full, at, ("approach", "insert"), (False, True))
        if not self._path_clearance(approach, self.line_clearance)[0]:
            return None
        if not self._path_clearance(insert, self.line_clearance, skip=(PIN,))[0]:
            return None
        return approach, insert

    # -- QP fallback ----------------------------------------------------------------------------
    def _qp_path(self, target: pin.SE3, q_start: np.ndarray, q_end: np.ndarray) -> np.ndarray | None:
        """Trust-region QP steps from q_start toward the 5-D target under the clearance constraint."""
        task = ToolAxisTask(self.tcp, target, tolerance=TASK_TOLERANCE)
        constraints = [JointPositionLimits(),
                       WorkpieceClearance(self.counted, self.minimum_clearance)]
        problem = IKProblem(self.model, [task, RegularizationTask(1e-9)], constraints, backend=self.backend,
                            max_step=0.2)
        problem.start(q_start)
        q = q_start.copy()
        knots = [q.copy()]
        for _ in range(400):
            self.cost.add("qp_iteration")
            try:
                dq = problem.step(q, max_step=self.max_step)
            except NoQPSolutionError:
                return None
            q = problem.clip(pin.integrate(self.model, q, dq))
            knots.append(q.copy())
            problem.kinematics.update(q)
            if np.linalg.norm(task.error(problem.kinematics)) < 1e-6:
                break
        else:
            return None
        knots.append(q_end)
        return np.array(knots)

    # -- one cycle ------------------------------------------------------------------------------
    def plan(self, hole: Hole, q_home: np.ndarray) -> CyclePlan:
        started = time.perf_counter()
        self.cost = PlanningCost()
        self.counted.cost = self.cost
        routes = self._routes(hole, q_home)
        chosen, checked, insertions, worst_seen = None, 0, {}, -np.inf
        static: dict[tuple, bool] = {}
        for route in routes:
            if checked >= MAX_ROUTE_CHECKS:
                break
            key = route.kind[:2]
            if key not in static:
                static[key] = self._clear(route.knots[-1], self.minimum_clearance)
            if not static[key]:
                continue
            if len(route.knots) == 3 and not self._clear(route.knots[1], self.line_clearance):
                continue
            checked += 1
            move = self._timed("approach", route.knots)
            clear, worst = self._path_clearance(move, self.line_clearance)
            worst_seen = max(worst_seen, worst)
            if not clear:
                continue
            if key not in insertions:
                insertions[key] = self._insertion(hole, route.roll, route.knots[-1])
            if insertions[key] is not None:
                chosen = (route, move, insertions[key], worst)
                break
        name = "route search"
        if chosen is None and routes:
            route = routes[0]
            insertion = insertions.get(route.kind[:2])
            if insertion is None:
                insertion = self._insertion(hole, route.roll, route.knots[-1])
            path = None
            if insertion is not None:
                path = self._qp_path(self._pose(hole, -self.insertion.standoff, route.roll), q_home,
                                     route.knots[-1])
            if path is not None:
                move = self._timed("approach", path)
                clear, worst = self._path_clearance(move, self.line_clearance)
                if clear:
                    chosen, name = (route, move, insertion, worst), "QP path"
        info = {"routes_ranked": len(routes), "routes_checked": checked,
                "planning_counts": dict(self.cost.counts)}
        if chosen is None:
            reason = ("no approach configuration clear of the workpiece" if not routes else
                      f"no route to the approach pose clear of the workpiece ({checked} checked, best "
                      f"{worst_seen * 1e3:.2f} mm < {self.line_clearance * 1e3:g} mm)")
            return CyclePlan(hole, success=False, reason=reason,
                             planning_time_s=time.perf_counter() - started,
                             planning_cost_s=self.cost.seconds, info=info)
        route, approach, insertion, worst = chosen
        blended = self._blended(route, approach, insertion) if name == "route search" else None
        if blended is not None:
            approach, insert = blended
            moves = [approach, insert, dwell(TRIGGER, insertion[-1], self.insertion.trigger_s),
                     backward(insert, "retract", fine=True), backward(approach, "to rivet_home")]
            described = (f"blended {'joint line' if route.retreat == 0.0 else 'via retreat'} "
                         f"{route.retreat * 1e3:g} mm + insertion")
        else:
            moves = [approach,
                     self._timed("insert", insertion, fine=True),
                     dwell(TRIGGER, insertion[-1], self.insertion.trigger_s),
                     self._timed("retract", insertion[::-1], fine=True),
                     self._timed("to rivet_home", approach_knots_back(approach, route, name))]
            unblended = "joint line" if route.retreat == 0.0 else f"via retreat {route.retreat * 1e3:g} mm"
            described = name if name != "route search" else unblended
        info.update({"route": described, "roll_rad": route.roll, "line_clearance_m": worst,
                     "planning_counts": dict(self.cost.counts)})
        return CyclePlan(hole, moves, planning_time_s=time.perf_counter() - started,
                         planning_cost_s=self.cost.seconds, info=info)


def approach_knots_back(approach: Move, route: _Route, name: str) -> np.ndarray:
    """The knots of the way back home: the approach's knots reversed (the same spline backward)."""
    return approach.timed.path.q[::-1] if name == "QP path" else route.knots[::-1]
