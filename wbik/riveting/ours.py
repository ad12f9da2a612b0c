"""Our way: direct moves planned with the QP layer (wbik.qp), the insertion as a 5-D task.

Per hole, from rivet_home (q_home):

1. approach configuration: IKProblem with the 5-D ToolAxisTask on the approach pose (priority 0;
   the roll about the tool axis is free) and a posture task toward q_home (priority 1: among the
   roll circle, the configuration nearest home), under the joint limits and the workpiece
   clearance constraint (every robot geometry >= ``minimum_clearance``, 10 mm).
2. insertion: knots every ``knot_spacing`` (1 mm) on the hole axis from the approach pose to the
   inserted pose, each solved by the same 5-D task from the previous knot (clearance constraint on
   everything but the pin, which must enter the hole); the joint path is the C2 spline through
   the knots, so the tool stays on the axis between knots too (checked densely by the cycle).
3. the way there and back: the straight joint-space line q_home -> approach (the time-optimal
   shape under box velocity limits) when its densely sampled clearance stays >= ``line_clearance``
   (5 mm); otherwise a QP path: trust-region steps (``max_step`` rad) of the same task and
   constraint from q_home, whose knots the spline follows; failing that, two joint lines through a
   retreat point on the hole axis (150 mm further out, solved by the same QP from the approach
   configuration). Retract and return replay these paths backward.

The approach IK starts from rivet_home and from up to 3 closed-form solutions of the 6-D pose at
12 rolls about the axis (clear of the workpiece, nearest rivet_home): a local QP started at home
cannot swing the arm around the workpiece to the far side on its own. The answer kept is the one
with the smallest largest joint change from rivet_home (a proxy of the move's time).

Every move is timed at minimum time under the velocity and acceleration limits (quintic law).
"""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin

import wbik
from wbik.qp.constraints import JointPositionLimits
from wbik.qp.problem import IKProblem
from wbik.qp.tasks import PostureTask, RegularizationTask
from wbik.riveting.moves import dwell, sample_times, timed_move
from wbik.riveting.plan import TRIGGER, CyclePlan, Planner
from wbik.riveting.qp_terms import ToolAxisTask, WorkpieceClearance
from wbik.riveting.scene import Hole

TASK_TOLERANCE = 1e-8
"""|e| of the 5-D task (m, and the sine of the axis error) at which a configuration is accepted."""
SEED_ROLLS = 12
SEEDS = 4
RETREAT = 0.15
"""Extra stand-off (m) of the fallback via-point on the hole axis."""
PIN = "rivet_tool_1"


class QPPlanner(Planner):
    name = "ours"

    def __init__(self, *args, minimum_clearance: float = 0.01, line_clearance: float = 0.005,
                 knot_spacing: float = 0.001,
                 max_step: float = 0.05, backend: str = "daqp", **options):
        super().__init__(*args, **options)
        self.minimum_clearance = float(minimum_clearance)
        self.line_clearance = float(line_clearance)
        self.knot_spacing = float(knot_spacing)
        self.max_step = float(max_step)
        self.backend = backend
        self.model = self.robot.model
        self.tcp = self.chain.tip_frame
        self.analytic = wbik.solver("analytic", self.robot, chain="arm")

    # -- QP pieces ------------------------------------------------------------------------------
    def _problem(self, target: pin.SE3, posture: np.ndarray | None,
                 skip_pin: bool) -> tuple[IKProblem, ToolAxisTask]:
        task = ToolAxisTask(self.tcp, target, tolerance=TASK_TOLERANCE)
        tasks = [task, RegularizationTask(1e-9)]
        if posture is not None:
            tasks.append(PostureTask(posture, weight=1.0, priority=1))
        constraints = [JointPositionLimits(self.model),
                       WorkpieceClearance(self.collision, self.minimum_clearance,
                                          skip=(PIN,) if skip_pin else ())]
        return IKProblem(self.model, tasks, constraints, backend=self.backend, max_step=0.2), task

    def _solve(self, target: pin.SE3, q0: np.ndarray, posture: np.ndarray | None = None,
               skip_pin: bool = False) -> tuple[np.ndarray | None, str]:
        """5-D IK from q0: with ``posture``, first a best effort that also pulls toward it (priority 1),
        then the 5-D task alone from there (the hierarchy's second level keeps the loop from
        declaring convergence, so the polish decides)."""
        q_start = q0
        if posture is not None:
            problem, _ = self._problem(target, posture, skip_pin)
            q_start = problem.solve(q0, max_iterations=100).q
        problem, _ = self._problem(target, None, skip_pin)
        solution = problem.solve(q_start, max_iterations=300)
        if not solution.success:
            return None, solution.reason or "QP IK did not converge"
        if ToolAxisTask.axis_alignment(self.chain.fk(solution.q).rotation, target) < 0.0:
            return None, "the tool points out of the hole (wrong sign of the axis)"
        return solution.q, ""

    def _seeds(self, target: pin.SE3, q_home: np.ndarray) -> list[np.ndarray]:
        """Starts for the approach IK: rivet_home, then closed-form solutions of the 6-D pose at
        SEED_ROLLS rolls about the axis, clear of the workpiece, nearest to rivet_home first."""
        from wbik.solvers.analytic import wrap_into_limits

        candidates = []
        for roll in np.linspace(0.0, 2.0 * np.pi, SEED_ROLLS, endpoint=False):
            pose = pin.SE3(target.rotation @ pin.rpy.rpyToMatrix(0.0, 0.0, roll), target.translation)
            for result in self.analytic.solve_all(pose):
                if not result.success:
                    continue
                q, _ = wrap_into_limits(result.q, q_home, self.chain.lower, self.chain.upper,
                                        ~self.chain.is_prismatic)
                clearance = self.collision.clearance(q)
                if min(clearance.minimum(), clearance.table_minimum()) >= self.minimum_clearance:
                    candidates.append((float(np.max(np.abs(q - q_home))), q))
        candidates.sort(key=lambda item: item[0])
        return [q_home] + [q for _, q in candidates[:SEEDS - 1]]

    def _approach(self, target: pin.SE3, q_home: np.ndarray) -> tuple[np.ndarray | None, str]:
        """The approach configuration: the solution nearest rivet_home (max joint change) over the seeds."""
        best, reasons = None, []
        for seed in self._seeds(target, q_home):
            q, reason = self._solve(target, seed, posture=q_home)
            if q is None:
                reasons.append(reason)
            elif best is None or np.max(np.abs(q - q_home)) < np.max(np.abs(best - q_home)):
                best = q
        return best, "; ".join(dict.fromkeys(reasons))

    def _qp_path(self, target: pin.SE3, q_start: np.ndarray, q_end: np.ndarray) -> np.ndarray | None:
        """Trust-region QP steps from q_start toward the 5-D target under the clearance constraint."""
        problem, task = self._problem(target, q_start, skip_pin=False)
        problem.start(q_start)
        q = q_start.copy()
        knots = [q.copy()]
        for _ in range(400):
            dq = problem.step(q, max_step=self.max_step)
            if dq is None:
                return None
            q = problem.clip(pin.integrate(self.model, q, dq))
            knots.append(q.copy())
            problem.kinematics.update(q)
            if np.linalg.norm(task.error(problem.kinematics)) < 1e-6:
                break
        else:
            return None
        knots.append(q_end)  # the polished approach configuration (within 1e-6 of the last knot)
        return np.array(knots)

    def _line_is_clear(self, q_from: np.ndarray, q_to: np.ndarray) -> tuple[bool, float]:
        move = timed_move("probe", self.chain, np.array([q_from, q_to]), self.limits)
        worst = np.inf
        for t in sample_times(move, self.chain):
            clearance = self.collision.clearance(move.evaluate(t)[0])
            worst = min(worst, clearance.minimum(), clearance.table_minimum())
            if worst < self.line_clearance:
                return False, worst
        return True, worst

    def _route(self, hole: Hole, approach_pose: pin.SE3, q_home: np.ndarray, q_approach: np.ndarray):
        """(knot arrays, one per move; route name; clearance of the line probe), or (None, reason, .)."""
        clear, worst = self._line_is_clear(q_home, q_approach)
        if clear:
            return [np.array([q_home, q_approach])], "joint line", worst
        path = self._qp_path(approach_pose, q_home, q_approach)
        if path is not None and self._path_is_clear(path):
            return [path], "QP path", worst
        retreat_point = hole.point_at_depth(-self.insertion.standoff - RETREAT)
        retreat_pose = pin.SE3(approach_pose.rotation, retreat_point)
        q_retreat, reason = self._solve(retreat_pose, q_approach, posture=q_approach)
        if q_retreat is None:
            q_retreat, reason = self._approach(retreat_pose, q_home)
        if q_retreat is None:
            return None, f"no route to the approach pose (retreat point: {reason})", worst
        if self._line_is_clear(q_home, q_retreat)[0] and self._line_is_clear(q_retreat, q_approach)[0]:
            ways = [np.array([q_home, q_retreat]), np.array([q_retreat, q_approach])]
            return ways, "via retreat point", worst
        return None, "no route to the approach pose clear of the workpiece", worst

    def _path_is_clear(self, knots: np.ndarray) -> bool:
        move = timed_move("probe", self.chain, knots, self.limits)
        for t in sample_times(move, self.chain):
            clearance = self.collision.clearance(move.evaluate(t)[0])
            if min(clearance.minimum(), clearance.table_minimum()) < self.line_clearance:
                return False
        return True

    # -- one cycle ------------------------------------------------------------------------------
    def plan(self, hole: Hole, q_home: np.ndarray) -> CyclePlan:
        started = time.perf_counter()
        approach_pose = self.insertion.approach_pose(hole)
        q_approach, reason = self._approach(approach_pose, q_home)
        if q_approach is None:
            return CyclePlan(hole, success=False, reason=f"approach: {reason}",
                             planning_time_s=time.perf_counter() - started)
        knots = [q_approach]
        total = self.insertion.standoff + self.insertion.depth
        count = max(int(np.ceil(total / self.knot_spacing)), 1)
        for k in range(1, count + 1):
            depth = -self.insertion.standoff + total * k / count
            pose = pin.SE3(approach_pose.rotation, hole.point_at_depth(depth))
            q_next, reason = self._solve(pose, knots[-1], skip_pin=True)
            if q_next is None:
                return CyclePlan(hole, success=False, reason=f"insertion knot {k}: {reason}",
                                 planning_time_s=time.perf_counter() - started)
            knots.append(q_next)
        insertion = np.array(knots)
        ways, route, worst = self._route(hole, approach_pose, q_home, q_approach)
        if ways is None:
            return CyclePlan(hole, success=False, reason=route, planning_time_s=time.perf_counter() - started)
        moves = [timed_move(f"approach {k + 1}" if len(ways) > 1 else "approach", self.chain, way,
                            self.limits) for k, way in enumerate(ways)]
        moves += [timed_move("insert", self.chain, insertion, self.limits, fine=True),
                  dwell(TRIGGER, insertion[-1], self.insertion.trigger_s),
                  timed_move("retract", self.chain, insertion[::-1], self.limits, fine=True)]
        moves += [timed_move(f"to rivet_home {len(ways) - k}" if len(ways) > 1 else "to rivet_home",
                             self.chain, way[::-1], self.limits) for k, way in enumerate(reversed(ways))]
        return CyclePlan(hole, moves, planning_time_s=time.perf_counter() - started,
                         info={"route": route, "line_clearance_m": float(worst)})
