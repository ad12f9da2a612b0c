"""What the QP peers' methods (PlaCo, Pink, mink) share: a problem's tasks and constraints stated through
the peer's forms (:mod:`wbik.qp.peers`; what has none is listed in ``unsupported``), and our loop around the
peer's single QP step; a chain target is the chain's problem (:meth:`Solver.chain_problem`)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import pinocchio as pin

from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.contacts import Contact, HeldFrame
from wbik.qp.kinematics import Kinematics
from wbik.qp.peers import PeerForms, Unsupported, frame_weights, largest_weight
from wbik.qp.tasks import ComTask, FrameTask, OrientationTask, RegularizationTask, RelativeFrameTask, Task
from wbik.solvers.base import Solver
from wbik.solvers.result import Candidate
from wbik.wholebody.problem import StartedProblem, WholeBody

NO_POLYGON = "support polygon as a hard CoM constraint"  # what a method without one lists as unsupported


class PeerSolver(Solver):
    """A method solving with a peer's tasks and constraints; ``priorities``: its word on priority levels."""

    takes_problems = True
    forms: ClassVar[PeerForms]
    priorities: ClassVar[str] = "weighted costs only"

    def __init__(self, robot, chain=None, *, max_iterations: int | None = None, **options):
        super().__init__(robot, chain, **options)
        self.max_iterations = self._iteration_budget(max_iterations)
        self.problem_max_iterations = self._iteration_budget(max_iterations, problem=True)

    def unsupported(self, problem: WholeBody) -> list[Unsupported]:
        """Strict priority levels, and every task and constraint the peer has no form for."""
        missing = []
        if len({task.priority for task in problem.tasks}) > 1:
            missing.append(Unsupported(self.name, "strict priority levels", self.priorities))
        items = [(c.name, c) for c in problem.constraints] + [
            (f"task {name}", task) for name, task in zip(problem.task_names, problem.tasks, strict=True)]
        for what, item in items:
            if (why := self.forms.refusal(item)) is not None:
                missing.append(Unsupported(self.name, what, why))
        return missing

    def translate(self, started: StartedProblem, target) -> None:
        """Add every task and constraint the peer can express to ``target``, the peer's problem."""
        for _, item in started.items():
            if self.forms.refusal(item) is None:
                self.forms.build(item, target)

    def _converged(self, started: StartedProblem, monitor: Kinematics, q: np.ndarray,
                   with_polygon: bool) -> bool:
        """Goals and contacts within half the check's tolerances (and the CoM margin, ``with_polygon``)."""
        monitor.update(q)
        position_tolerance = 0.5 * self.tolerances.position
        rotation_tolerance = 0.5 * self.tolerances.rotation
        for task in started.tasks:
            if not task.goal:
                continue
            position, rotation = task.error_parts(np.asarray(task.error(monitor), dtype=float))
            if (position is not None and position > position_tolerance) or (
                    rotation is not None and rotation > rotation_tolerance):
                return False
        for constraint in started.constraints:
            if isinstance(constraint, HeldFrame):
                position, rotation = constraint.drift(monitor)
                if position > position_tolerance or rotation > rotation_tolerance:
                    return False
            elif with_polygon and isinstance(constraint, CoMInSupportPolygon):
                if constraint.polygon.margin_of(monitor.com()[:2]) < constraint.margin:
                    return False
        return True

    def _peer_loop(self, step: Callable[[np.ndarray], tuple[np.ndarray, str]], started: StartedProblem,
                   deadline: float, max_iterations: int, with_polygon: bool = True) -> Candidate:
        """Our loop around a peer's step ``step(q)`` -> (next q, a reason to stop or "")."""
        monitor = Kinematics(started.problem.robot.model, started.q0)
        q = started.q0.copy()
        for iteration in range(1, max_iterations + 1):
            if self._converged(started, monitor, q, with_polygon):
                return Candidate(q, iteration - 1)
            if time.perf_counter() > deadline:
                return Candidate(q, iteration - 1, f"time budget of {self.timeout_s:g} s used up")
            q, reason = step(q)
            if reason:
                return Candidate(q, iteration, reason)
        if self._converged(started, monitor, q, with_polygon):
            return Candidate(q, max_iterations)
        return Candidate(q, max_iterations, f"no convergence in {max_iterations} iterations")


@dataclass
class SolveIKProblem:
    """What the forms of a peer solving by ``solve_ik`` (Pink, mink) add to; ``dt``: the step (s)."""

    kinematics: Kinematics
    dt: float
    damping: float
    tasks: list = field(default_factory=list)
    constraints: list = field(default_factory=list)
    limits: list = field(default_factory=list)

    def frame_task(self, frame: str, target: pin.SE3, position_cost, orientation_cost,
                   reference: str | None = None):
        """The peer's frame task on ``frame`` (in ``reference``'s frame if given) toward ``target`` (costs
        per axis or one for all)."""
        raise NotImplementedError

    def com_task(self, cost: np.ndarray):
        """The peer's CoM task, ``cost`` per axis."""
        raise NotImplementedError


def frame_form(task: FrameTask | RelativeFrameTask, problem: SolveIKProblem) -> None:
    """A frame task (or a relative one) as the peer's, costs the square roots of its weights."""
    position, orientation = frame_weights(task)
    problem.tasks.append(problem.frame_task(task.frame, task.target, math.sqrt(position),
                                            math.sqrt(orientation), getattr(task, "reference_frame", None)))


def orientation_form(task: OrientationTask, problem: SolveIKProblem) -> None:
    """An orientation task as the peer's frame task, its position (the start's) at cost 0."""
    target = pin.SE3(task.target, problem.kinematics.placement(task.frame_id).translation.copy())
    problem.tasks.append(problem.frame_task(task.frame, target, 0.0, math.sqrt(largest_weight(task, 1.0))))


def com_form(task: ComTask, problem: SolveIKProblem) -> None:
    """A CoM task on its axes (the start's CoM on the others)."""
    added = problem.com_task(axis_costs(task, largest_weight(task, 1.0)))
    target = problem.kinematics.com().copy()
    target[task.rows] = task.target[task.rows]
    added.set_target(target)
    problem.tasks.append(added)


def contact_form(contact: Contact, problem: SolveIKProblem) -> None:
    """A contact as an equality constraint: the peer's frame task at its placement."""
    problem.constraints.append(problem.frame_task(contact.frame, contact.placement, 1.0, 1.0))


def axis_costs(task, weight: float) -> np.ndarray:
    """Cost sqrt(weight) on the axes a position or CoM task holds, 0 on the others."""
    cost = np.zeros(3)
    cost[task.rows] = math.sqrt(weight)
    return cost


def stalled(velocity: np.ndarray, dt: float, peer: str) -> str:
    """Why to stop after a ``solve_ik`` step that no longer moves the robot, or ""."""
    moved = float(np.max(np.abs(velocity))) * dt
    return f"stalled: {peer}'s steps no longer move the robot" if moved < 1e-12 else ""


def raise_damping(task: RegularizationTask, problem: SolveIKProblem) -> None:
    """A regularisation (w |dq|^2) as ``solve_ik``'s damping on every DOF: the larger of the two."""
    problem.damping = max(problem.damping, largest_weight(task, 0.0))


def solve_ik_forms(forms: PeerForms) -> PeerForms:
    """``forms`` with what the ``solve_ik`` peers (Pink, mink) state alike: frame, relative frame,
    orientation and CoM tasks, a regularisation as damping, contacts as equality constraints."""
    for kind, build in ((FrameTask, frame_form), (RelativeFrameTask, frame_form),
                        (OrientationTask, orientation_form), (ComTask, com_form),
                        (RegularizationTask, raise_damping), (Contact, contact_form)):
        forms.form(kind)(build)
    return forms


def lowest_priority(tasks: list[Task]) -> int:
    """The priority of the lowest level of ``tasks`` (0 without): where a regularisation goes."""
    return max((task.priority for task in tasks), default=0)
