"""Method ``qp``: single-chain IK through the task-based QP layer (wbik.qp).

The chain's reduced model carries one FrameTask (pose target) or PositionTask (position target)
on the tip, expressed in the world of that model: T_world = T_world_base * T_target. Hard
constraints: the joint position limits (none on continuous joints: the answer is wrapped) and, with
``velocity_dt``, the velocity limits x dt per step. Steps iterate until the shared tolerance, a stall,
the iteration budget or (when ``timeout_s`` is given) the deadline.

Options: ``backend`` (a qpsolvers name, "fastest" or "default"; default DAQP, the fastest that
``benchmarks/qp.py`` measures: see wbik.qp.backends), ``max_iterations`` (default: the iterations that
cost about 30 ms on the reference machine, well above what a converging solve needs; the measurements:
docs/measurements.md, qp), ``max_step`` (trust region per step, rad or m), ``lm_damping``, ``diagnose``.

A result that fails the shared check explains itself (``diagnose=True``, the default): the joint
limits active at the answer, ranked by how much they hold the tip back, or a stationary point (out of
reach, a local minimum), in ``result.extra["diagnosis"]`` (:class:`wbik.qp.diagnosis.Diagnosis`) and
at the end of ``result.reason``; it is made after the timed solve, on failure only. A start outside
the limits is clipped into them and listed in ``diagnosis.start``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.qp import backends
from wbik.qp.constraints import JointPositionLimits
from wbik.qp.constraints import JointVelocityLimits
from wbik.qp.diagnosis import last_solve_diagnosis
from wbik.qp.problem import IKProblem
from wbik.qp.tasks import FrameTask
from wbik.qp.tasks import PositionTask
from wbik.qp.tasks import RegularizationTask
from wbik.solvers.base import Candidate
from wbik.solvers.base import Solver
from wbik.solvers.method_registry import IKMethod
from wbik.targets import Target


class QPSolver(Solver):
    name = "qp"
    # the budget's unit: one DAQP step with its FK checks on a 6-joint arm (docs/measurements.md, qp)
    iteration_cost_s = 150e-6
    default_budget_s = 0.03

    def __init__(self, robot, chain=None, *, backend: str = backends.DEFAULT,
                 max_iterations: int | None = None, max_step: float = 0.2, lm_damping: float = 1e-3,
                 velocity_dt: float | None = None, diagnose: bool = True, **options):
        super().__init__(robot, chain, **options)
        self.backend = backends.resolve(backend)
        self.max_iterations = self._iteration_budget(max_iterations)
        self.velocity_dt = velocity_dt
        self.max_step, self.lm_damping = float(max_step), float(lm_damping)
        self.diagnose = bool(diagnose)

    def solve(self, target, q0=None):
        """The shared check's result; one that fails it gets the QP's diagnosis (after the timing)."""
        self._local.last = None
        result = super().solve(target, q0)
        diagnosis, result.reason = last_solve_diagnosis(self._local, result.success, self.diagnose,
                                                        result.reason)
        if diagnosis is not None:
            result.extra["diagnosis"] = diagnosis
        return result

    def _new_thread_state(self) -> dict:
        """Each thread's own tasks and problems (a problem holds its Pinocchio Data and iterate)."""
        model = self.chain.model
        continuous = [name for name, wraps in zip(self.chain.joint_names, self.chain.continuous, strict=True)
                      if wraps]
        constraints = [JointPositionLimits(model, unbounded=continuous)]  # continuous joints: wrapped
        if self.velocity_dt is not None:
            constraints.append(JointVelocityLimits(model))
        task_tolerance = 0.5 * min(self.tolerances.position, self.tolerances.rotation)
        regularization = RegularizationTask(1e-9)
        tip = self.chain.tip_frame
        state = {}
        for kind, task in (("pose", FrameTask(tip, pin.SE3.Identity(), tolerance=task_tolerance)),
                           ("position", PositionTask(tip, np.zeros(3), tolerance=task_tolerance))):
            state[kind] = (task, IKProblem(model, [task, regularization], constraints, backend=self.backend,
                                           max_step=self.max_step, lm_damping=self.lm_damping))
        return state

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        world_target = self.chain.base_placement * target.se3()
        task, problem = self._thread_state()["pose" if target.is_pose else "position"]
        task.target = world_target if target.is_pose else world_target.translation.copy()
        solution = problem.solve(q0, max_iterations=self.max_iterations,
                                 deadline=None if deadline == float("inf") else deadline, diagnose=False)
        self._local.last = (problem, solution)
        return Candidate(solution.q, solution.iterations, solution.reason,
                         {"backend": self.backend, "converged": solution.converged})


IK_METHODS = (
    IKMethod("qp", QPSolver,
             "task-based QP IK (qpsolvers, DAQP default) with joint limits"),
)
"""The methods this module declares to :mod:`wbik.solvers.method_registry`."""
