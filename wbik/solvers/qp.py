"""Method ``qp``: our task QP (:class:`wbik.qp.problem.IKProblem`) on chain targets and whole bodies (goals
at half the check's tolerances, a ``regularization`` on the lowest level). Options: ``backend`` (a
qpsolvers name, "fastest" or "default": DAQP), ``max_step`` (per step, rad or m), ``lm_damping``,
``velocity_dt``, ``diagnose`` (a failed result's :class:`wbik.qp.diagnosis.Diagnosis`).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

import wbik.qp.backends as backends
from wbik.qp.diagnosis import last_solve_diagnosis
from wbik.qp.limits import JointPositionLimits, JointVelocityLimits
from wbik.qp.problem import IKProblem
from wbik.qp.tasks import FrameTask, PositionTask, RegularizationTask
from wbik.solvers.base import Solver
from wbik.solvers.method import IKMethod
from wbik.solvers.peer import lowest_priority
from wbik.solvers.result import Candidate, IKResult
from wbik.targets import Target
from wbik.wholebody.problem import StartedProblem, WholeBody


class QPSolver(Solver):
    name = "qp"
    takes_problems = True
    # a DAQP step with its FK checks on a 6-joint arm, on a humanoid (docs/measurements.md, qp, wholebody)
    iteration_cost_s = 150e-6
    default_budget_s = 0.03
    problem_iteration_cost_s = 800e-6
    problem_budget_s = 0.08

    def __init__(self, robot, chain=None, *, backend: str = backends.DEFAULT,
                 max_iterations: int | None = None, max_step: float = 0.2, lm_damping: float = 1e-3,
                 regularization: float = 1e-6, velocity_dt: float | None = None, diagnose: bool = True,
                 **options):
        super().__init__(robot, chain, **options)
        self.backend = backends.resolve(backend)
        self.max_iterations = self._iteration_budget(max_iterations)
        self.problem_max_iterations = self._iteration_budget(max_iterations, problem=True)
        self.velocity_dt = velocity_dt
        self.max_step, self.lm_damping = float(max_step), float(lm_damping)
        self.regularization = float(regularization)
        self.diagnose = bool(diagnose)

    def solve(self, target, q0=None) -> IKResult:
        """The shared check's result with the QP's diagnosis (see the module docstring)."""
        if isinstance(target, WholeBody):
            return self.solve_problem(target, q0)
        return self._diagnosed(super().solve, target, q0)

    def solve_problem(self, problem: WholeBody, q0=None) -> IKResult:
        return self._diagnosed(super().solve_problem, problem, q0)

    def _diagnosed(self, solve, goal, q0) -> IKResult:
        self._local.last = None
        result = solve(goal, q0)
        result.diagnosis, result.reason = last_solve_diagnosis(self._local, result.success, self.diagnose,
                                                               result.reason)
        return result

    def _new_thread_state(self) -> dict:
        """This thread's chain tasks and problems (a problem holds its Pinocchio Data and iterate)."""
        chain = self.chain
        continuous = [name for name, wraps in zip(chain.joint_names, chain.continuous, strict=True) if wraps]
        constraints = [JointPositionLimits(unbounded=continuous)]  # continuous joints: wrapped
        if self.velocity_dt is not None:
            constraints.append(JointVelocityLimits())
        tolerance = 0.5 * min(self.tolerances.position, self.tolerances.rotation)
        regularization = RegularizationTask(1e-9)
        tasks = {"pose": FrameTask(chain.tip_frame, pin.SE3.Identity(), tolerance=tolerance),
                 "position": PositionTask(chain.tip_frame, np.zeros(3), tolerance=tolerance)}
        return {kind: (task, IKProblem(chain.model, [task, regularization], constraints, backend=self.backend,
                                       max_step=self.max_step, lm_damping=self.lm_damping))
                for kind, task in tasks.items()}

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        world_target = self.chain.base_placement * target.se3()
        task, problem = self._thread_state()["pose" if target.is_pose else "position"]
        task.target = world_target if target.is_pose else world_target.translation.copy()
        return self._run(problem, q0, deadline, self.max_iterations)

    def _solve_problem(self, started: StartedProblem, deadline: float, max_iterations: int) -> Candidate:
        tasks = started.problem.copied_tasks()
        tolerance = 0.5 * min(self.tolerances.position, self.tolerances.rotation)
        for task in tasks:
            if task.goal:
                task.tolerance = min(task.tolerance, tolerance)
        # on the lowest level: on a level above others, its kept rows sqrt(w) dq would pin the step for them
        tasks.append(RegularizationTask(self.regularization, priority=lowest_priority(tasks)))
        problem = IKProblem(started.problem.robot.model, tasks, started.constraints, backend=self.backend,
                            max_step=self.max_step, lm_damping=self.lm_damping)
        return self._run(problem, started.q0, deadline, max_iterations)

    def _run(self, problem: IKProblem, q0: np.ndarray, deadline: float, max_iterations: int) -> Candidate:
        solution = problem.solve(q0, max_iterations=max_iterations,
                                 deadline=None if deadline == math.inf else deadline, diagnose=False)
        self._local.last = (problem, solution)
        return Candidate(solution.q, solution.iterations, solution.reason,
                         {"backend": self.backend, "converged": solution.converged})


IK_METHODS = (
    IKMethod("qp", QPSolver,
             "task-based QP IK (qpsolvers, DAQP default): chain targets with joint limits; whole bodies "
             "with hard contacts, hard CoM polygon, limits"),
)
