"""``thesis_legs``: the Bioloid thesis's whole-body method. Each leg's closed form from its sole to the hip,
the hip shifted horizontally (Newton on e(s) = c_xy(s) - c*, dc/ds once by finite differences) until the
CoM is over the target; the pelvis orientation, its height and the arms are kept.
"""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin

from wbik.errors import UnsupportedError
from wbik.geometry import rotation_angle
from wbik.qp.tasks import ComTask, FrameTask, OrientationTask, PositionTask, RegularizationTask, Task
from wbik.solvers.base import Solver
from wbik.solvers.method import IKMethod
from wbik.solvers.method_registry import solver
from wbik.solvers.peer import NO_POLYGON
from wbik.solvers.result import Candidate
from wbik.wholebody.problem import StartedProblem, WholeBody

LEGS = {"r": ("right_leg", "r_sole", "r_hip"), "l": ("left_leg", "l_sole", "l_hip")}
SOLES = ("r_sole", "l_sole")


class ThesisLegs(Solver):
    """The Bioloid thesis's way: closed-form legs from the feet, the hip shifted over the CoM target."""

    name = "thesis_legs"
    takes_problems = True
    # the budget's unit: one hip placement, two closed-form legs, FK, CoM (docs/measurements.md, thesis_legs)
    problem_iteration_cost_s = 1e-3
    problem_budget_s = 0.01
    finite_step = 1e-4  # m, hip shift of the one finite-difference CoM Jacobian

    def __init__(self, robot, chain=None, *, max_iterations: int | None = None, **options):
        if chain is not None:
            raise UnsupportedError(f"method 'thesis_legs' solves whole-body problems (wbik.WholeBody), not "
                                   f"targets on chain {chain!r}")
        super().__init__(robot, chain, **options)
        self.problem_max_iterations = self._iteration_budget(max_iterations, problem=True)
        legs = {chain for chain, _, _ in LEGS.values()}
        if robot.name != "bioloid" or not robot.has_floating_base or not legs <= set(robot.chains):
            raise UnsupportedError(f"method 'thesis_legs' is the Bioloid thesis's closed-form legs; it does "
                                   f"not apply to {robot.name!r}")
        self._thread_state()  # the two closed-form leg solvers now, not in the first solve

    def check_target_kind(self, kind: str) -> None:
        raise UnsupportedError(f"method {self.name!r} solves whole-body problems (wbik.WholeBody), not chain "
                               "targets")

    def _solve(self, target, q0, deadline) -> Candidate:
        self.check_target_kind("pose")

    def _new_thread_state(self):
        return {side: solver("analytic", self.robot, chain=chain, tolerances=self.tolerances)
                for side, (chain, _, _) in LEGS.items()}

    def _sole_targets(self, problem: WholeBody, q0: np.ndarray, placements: dict) -> dict[str, pin.SE3]:
        """Side -> the sole's target: where it is held, else its goal frame or position task."""
        targets = {side: placements[sole] for side, (_, sole, _) in LEGS.items() if sole in placements}
        for task in problem.tasks:
            if not task.goal or getattr(task, "frame", None) not in SOLES or task.frame[0] in targets:
                continue
            if isinstance(task, FrameTask):
                targets[task.frame[0]] = task.target.copy()
            elif isinstance(task, PositionTask) and len(task.rows) == 3:
                rotation = self.robot.frame_placement(q0, task.frame).rotation
                targets[task.frame[0]] = pin.SE3(rotation, task.target.copy())
        return targets

    def _expressed(self, problem: WholeBody, task: Task, q0: np.ndarray) -> bool:
        if isinstance(task, ComTask):
            return set(task.rows) <= {0, 1}
        if isinstance(task, FrameTask) and task.frame in SOLES:
            return task.frame not in problem.contacts
        if isinstance(task, PositionTask) and task.frame in SOLES:
            return len(task.rows) == 3 and task.frame not in problem.contacts
        if isinstance(task, OrientationTask) and task.frame == "pelvis":  # the pelvis keeps its start
            return rotation_angle(self.robot.frame_placement(q0, "pelvis").rotation, task.target) <= 1e-12
        return False

    def _not_expressed(self, problem: WholeBody, q0: np.ndarray) -> list[str]:
        """The goal tasks of ``problem`` this method cannot place from q0, by name."""
        return [task.name for task in problem.tasks if task.goal and not self._expressed(problem, task, q0)]

    def cannot_express(self, problem: WholeBody, q0=None) -> str | None:
        """Why ``problem`` is outside what the closed-form legs express (goal tasks other than sole
        placements, an xy CoM and the kept pelvis orientation), or None."""
        names = self._not_expressed(problem, problem.check_q(self.robot.nominal if q0 is None else q0))
        if not names:
            return None
        return (f"cannot express the goal task(s) {', '.join(names)} ({self.name} places the soles and the "
                "CoM only)")

    def unsupported(self, problem):
        missing = []
        for task in problem.tasks:
            if isinstance(task, RegularizationTask) or (isinstance(task, OrientationTask)
                                                        and task.frame == "pelvis"):
                continue  # the pelvis orientation is judged against the actual q0 when solving
            if not self._expressed(problem, task, self.robot.nominal):
                kind = "goal task" if task.goal else "soft task"
                missing.append(f"{kind} {task.name} (the closed-form legs place soles and the CoM only)")
        missing += [f"contact {frame} (only soles)" for frame in problem.contacts if frame not in SOLES]
        if problem.support:
            missing.append(f"{NO_POLYGON} (the CoM is placed at one point: the CoM task's target, else "
                           "where it started; the check measures the margin)")
        if problem.collisions:
            missing.append("minimum distances between frames (collisions)")
        return missing

    def _solve_problem(self, started: StartedProblem, deadline: float, max_iterations: int) -> Candidate:
        robot, problem, q0 = self.robot, started.problem, started.q0
        legs = self._thread_state()
        targets = self._sole_targets(problem, q0, started.placements)
        com_target = next((task.target[:2].copy() for task in reversed(problem.tasks)
                           if isinstance(task, ComTask) and task.goal), None)  # the last one
        if com_target is None and started.polygon is not None:
            com_target = robot.center_of_mass(q0)[:2].copy()
        for task in problem.tasks:
            if (isinstance(task, OrientationTask) and task.frame == "pelvis" and task.goal
                    and not self._expressed(problem, task, q0)):
                return Candidate(q0.copy(), 0, f"cannot express goal task {task.name}: the closed-form legs "
                                               "keep the pelvis orientation")
        cannot = self._not_expressed(problem, q0)
        ankle_in_sole = {side: robot.frame_placement(q0, sole).actInv(
                             robot.frame_placement(q0, robot.chain(chain).tip_frame))
                         for side, (chain, sole, _) in LEGS.items()}
        base = pin.XYZQUATToSE3(q0[:7])
        indices = {side: robot.chain(chain).q_index for side, (chain, _, _) in LEGS.items()}

        def place(shift: np.ndarray) -> tuple[np.ndarray | None, str]:
            """q0 with the base shifted by ``shift`` (x, y) and each leg's closed form to its sole target."""
            q = q0.copy()
            placed = base.copy()
            placed.translation = base.translation + np.array([shift[0], shift[1], 0.0])
            q[:7] = pin.SE3ToXYZQUAT(placed)
            for side, sole_target in targets.items():
                chain, _, hip = LEGS[side]
                ankle_target = robot.frame_placement(q, hip).actInv(sole_target * ankle_in_sole[side])
                answer = legs[side].solve(ankle_target, q0[indices[side]])
                if answer.q is None or not answer.success:
                    return None, (f"{chain}: the foot target is out of the closed form's reach "
                                  f"({answer.reason})")
                q[indices[side]] = answer.q
            return q, ""

        shift = np.zeros(2)
        q, reason = place(shift)
        iterations = 1
        if q is None:
            return Candidate(None, iterations, reason)
        jacobian = None
        while com_target is not None:
            error = robot.center_of_mass(q)[:2] - com_target
            if float(np.linalg.norm(error)) <= 0.5 * self.tolerances.position:
                break
            if iterations >= max_iterations:
                reason = (f"no convergence in {max_iterations} iterations (CoM "
                          f"{float(np.linalg.norm(error)):.3g} m off)")
                break
            if time.perf_counter() > deadline:
                reason = f"time budget of {self.timeout_s:g} s used up"
                break
            if jacobian is None:  # dCoM/dshift by finite differences, once (it barely changes)
                columns = []
                for axis in range(2):
                    probe = shift.copy()
                    probe[axis] += self.finite_step
                    moved, why = place(probe)
                    iterations += 1
                    if moved is None:
                        return Candidate(q, iterations, why)
                    columns.append((robot.center_of_mass(moved)[:2] - com_target - error) / self.finite_step)
                jacobian = np.column_stack(columns)
            shift = shift - np.linalg.solve(jacobian, error)
            trial, why = place(shift)
            iterations += 1
            if trial is None:
                return Candidate(q, iterations, f"the hip shift needed for the CoM target: {why}")
            q = trial
        if cannot:
            reason = f"cannot express goal task(s) {', '.join(cannot)}" + (f"; {reason}" if reason else "")
        return Candidate(q, iterations, reason, {"cannot_express": cannot})


IK_METHODS = (
    IKMethod("thesis_legs", ThesisLegs,
             "Bioloid thesis: whole bodies by closed-form legs from the feet, the hip shifted until the CoM "
             "is on target"),
)
