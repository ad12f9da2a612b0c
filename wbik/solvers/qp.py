"""Method ``qp``: single-chain IK through the task-based QP layer (wbik.qp).

The chain's reduced model carries one FrameTask (pose target) or PositionTask (position target)
on the tip, expressed in the world of that model: T_world = T_world_base * T_target. Hard
constraints: the joint position limits (and, with ``velocity_dt``, the velocity limits x dt per
step). Steps iterate until the shared tolerance, a stall or the deadline.

Options: ``backend`` (a qpsolvers name, "fastest" or "default"; default OSQP), ``max_iterations``,
``max_step`` (trust region per step, rad or m), ``lm_damping``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.qp import backends
from wbik.qp.constraints import JointPositionLimits, JointVelocityLimits
from wbik.qp.problem import IKProblem
from wbik.qp.tasks import FrameTask, PositionTask, RegularizationTask
from wbik.solvers.base import Candidate, Solver
from wbik.targets import Target


class QPSolver(Solver):
    name = "qp"

    def __init__(self, robot, chain=None, *, backend: str = backends.DEFAULT, max_iterations: int = 300,
                 max_step: float = 0.2, lm_damping: float = 1e-3, velocity_dt: float | None = None,
                 **options):
        super().__init__(robot, chain, **options)
        model = self.chain.model
        self.backend = backends.resolve(backend)
        self.max_iterations = int(max_iterations)
        constraints = [JointPositionLimits(model)]
        if velocity_dt is not None:
            constraints.append(JointVelocityLimits(model))
        self.velocity_dt = velocity_dt
        task_tolerance = 0.5 * min(self.tolerances.position, self.tolerances.rotation)
        self._pose_task = FrameTask(self.chain.tip_frame, pin.SE3.Identity(), tolerance=task_tolerance)
        self._position_task = PositionTask(self.chain.tip_frame, np.zeros(3), tolerance=task_tolerance)
        self._regularization = RegularizationTask(1e-9)
        self._problems = {
            kind: IKProblem(model, [task, self._regularization], constraints, backend=self.backend,
                            max_step=max_step, lm_damping=lm_damping)
            for kind, task in (("pose", self._pose_task), ("position", self._position_task))}

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        world_target = self.chain.base_placement * target.se3()
        if target.is_pose:
            self._pose_task.target = world_target
            problem = self._problems["pose"]
        else:
            self._position_task.target = world_target.translation.copy()
            problem = self._problems["position"]
        solution = problem.solve(q0, max_iterations=self.max_iterations, deadline=deadline)
        return Candidate(solution.q, solution.iterations, solution.reason,
                         {"backend": self.backend, "converged": solution.converged})
