"""The whole-body solver interface and the base of the peers' methods:
``wholebody_solver(method, robot).solve(problem, q0)`` (the registry is :mod:`wbik.wholebody.methods`).

Every method builds its own formulation of a :class:`~wbik.wholebody.problem.WholeBody`, lists in
``unsupported`` what it cannot express (it then solves the problem without it, and says so), and
its answer is judged by the one shared check, :func:`~wbik.wholebody.problem.check_wholebody`.

Contacts on a point foot (``problem.point_contacts``) hold its position only, in every method.

- ``qp`` (:mod:`wbik.wholebody.qp`): our task QP (:class:`wbik.qp.IKProblem`), contacts as
  equalities, the CoM in the shrunk support polygon as hard rows, limits as bounds (and acceleration limits,
  ``acceleration_limit``): the problem's own constraints (:meth:`WholeBody.constraints`);
  ``backend=`` any installed qpsolvers backend. A result that fails the check carries a
  ``diagnosis`` (what blocks the goals, what conflicts with them, what to change: its summary ends
  the reason), made after the timed solve (``diagnose=False`` leaves it out).
- the peers ``placo``, ``pink`` and ``mink`` (:mod:`wbik.wholebody.placo`, :mod:`wbik.wholebody.pink`,
  :mod:`wbik.wholebody.mink`) derive from :class:`PeerWholeBody`: each task and each of the
  problem's constraints is stated through the peer's forms (:mod:`wbik.qp.peers`); what has no form
  is listed in ``unsupported`` as a :class:`wbik.qp.peers.Unsupported`, and so are strict priority
  levels, which no peer has. Our loop iterates the peer's single QP step.

Methods of applications are declared in their own modules (:mod:`wbik.wholebody.methods` lists
them); a method that can only express some goal tasks says so through
:meth:`WholeBodySolver.cannot_express`.

Budgets: every loop here is ours, so every method is budgeted in iterations (``max_iterations``,
default the iterations that cost ``default_budget_s`` on the reference machine at
``iteration_cost_s`` each); ``timeout_s`` adds a wall clock. Thread safety: per-thread state
(:meth:`WholeBodySolver._thread_state`), task copies per call.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from dataclasses import field
from typing import ClassVar

import numpy as np

from wbik.errors import InvalidOptionError
from wbik.errors import InvalidSettingError
from wbik.qp.kinematics import Kinematics
from wbik.qp.peers import PeerForms
from wbik.qp.peers import Unsupported
from wbik.qp.peers import largest_weight
from wbik.qp.support_polygon import DegenerateSupportPolygonError
from wbik.qp.tasks import RegularizationTask
from wbik.qp.tasks import Task
from wbik.robot import Robot
from wbik.solvers.base import Candidate
from wbik.solvers.base import IterationBudget
from wbik.solvers.base import PerThreadState
from wbik.solvers.base import Tolerances
from wbik.solvers.base import checked_tolerances
from wbik.validation import check_budget
from wbik.validation import check_seed
from wbik.wholebody.problem import WholeBody
from wbik.wholebody.problem import WholeBodyResult
from wbik.wholebody.problem import check_wholebody
from wbik.wholebody.problem import task_error_parts

NO_POLYGON = "support polygon as a hard CoM constraint"
"""What a method without a hard CoM-in-polygon constraint lists in ``unsupported`` (Pink, and
application methods that place the CoM at one point)."""


WholeBodyCandidate = Candidate
"""What a whole-body method found, before the shared check (the chain solvers' Candidate)."""


class WholeBodySolver(PerThreadState, IterationBudget):
    """Base class of the whole-body methods (see the module docstring for budgets)."""

    name = "base"
    iteration_cost_s: float = 1e-3
    default_budget_s: float = 0.1

    def __init__(
        self,
        robot: Robot,
        *,
        tolerances: Tolerances | None = None,
        max_iterations: int | None = None,
        timeout_s: float | None = None,
        seed: int | None = 0,
    ):
        if not isinstance(robot, Robot):
            raise InvalidOptionError(
                f"robot must be a wbik.Robot, got {type(robot).__name__}", option="robot"
            )
        self.robot = robot
        self.tolerances = checked_tolerances(tolerances)
        self.timeout_s = None if timeout_s is None else check_budget("timeout_s", timeout_s)
        self.max_iterations = self._iteration_budget(max_iterations)
        self.seed = check_seed(seed)
        self._local = threading.local()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.robot.name}, {self.max_iterations} iterations)"

    # -- the interface ------------------------------------------------------------------------------
    def unsupported(self, problem: WholeBody) -> list[str]:
        """What of ``problem`` this method cannot express (solved without it)."""
        return []

    def cannot_express(self, problem: WholeBody, q0=None) -> str | None:
        """Why ``problem`` (from q0, default the nominal) is outside what this method can solve at
        all - goal tasks it has no way to state - or None when it can take the problem (what it
        leaves out is then listed by :meth:`unsupported`). The study marks such a method "not
        applicable" to the case with this text. The generic methods take every problem."""
        return None

    def solve(self, problem: WholeBody, q0=None) -> WholeBodyResult:
        """Solve ``problem`` from q0 (default the robot's nominal); judged by the shared check."""
        if not isinstance(problem, WholeBody):
            raise InvalidSettingError(f"solve() takes a wbik.WholeBody problem, got {type(problem).__name__}")
        if problem.robot.name != self.robot.name or problem.robot.model.nq != self.robot.model.nq:
            raise InvalidSettingError(
                f"the problem is on {problem.robot.name!r}, this solver on {self.robot.name!r}"
            )
        q_start = problem.check_q(self.robot.nominal if q0 is None else q0)
        placements = problem.contact_placements(q_start)
        polygon = problem.support_polygon(q_start)
        unsupported = self.unsupported(problem)
        start = time.perf_counter()
        deadline = math.inf if self.timeout_s is None else start + self.timeout_s
        candidate = self._solve(problem, q_start, placements, polygon, deadline)
        elapsed = time.perf_counter() - start
        return check_wholebody(
            problem,
            candidate.q,
            self.tolerances,
            contact_placements=placements,
            method=self.name,
            time_s=elapsed,
            iterations=candidate.iterations,
            reason=candidate.reason,
            unsupported=unsupported,
            extra=candidate.extra,
        )

    def _solve(self, problem, q0, placements, polygon, deadline) -> WholeBodyCandidate:
        raise NotImplementedError

    # -- for loops around a peer's single QP step ----------------------------------------------------
    def _goal_tolerance(self) -> tuple[float, float]:
        return 0.5 * self.tolerances.position, 0.5 * self.tolerances.rotation

    def _converged(
        self, problem: WholeBody, monitor: Kinematics, tasks: list[Task], placements: dict, polygon,
        q: np.ndarray
    ) -> bool:
        """Goals and contacts within half the check's tolerances (and the CoM margin, with a polygon)."""
        monitor.update(q)
        position_tolerance, rotation_tolerance = self._goal_tolerance()
        for task in tasks:
            if not task.goal:
                continue
            position, rotation = task_error_parts(task, monitor)
            if (position is not None and position > position_tolerance) or (
                rotation is not None and rotation > rotation_tolerance
            ):
                return False
        for frame, held in placements.items():
            position, rotation = problem.contact_error(monitor, frame, held)
            if position > position_tolerance or rotation > rotation_tolerance:
                return False
        return polygon is None or polygon.margin_of(monitor.com()[:2]) >= problem.margin

    def _peer_loop(
        self,
        step: Callable[[np.ndarray], tuple[np.ndarray, str]],
        q: np.ndarray,
        deadline: float,
        *converged_on,
    ) -> WholeBodyCandidate:
        """Our loop around a peer's single QP step from q: stop when :meth:`_converged` (given
        ``converged_on``: problem, monitor, tasks, placements, polygon) holds, when the time budget is
        used up, or when ``step(q)`` (the next q and a reason to stop, "" to go on) gives a reason;
        else after ``max_iterations`` steps."""

        def converged(q: np.ndarray) -> bool:
            return self._converged(*converged_on, q)

        for iteration in range(1, self.max_iterations + 1):
            if converged(q):
                return WholeBodyCandidate(q, iteration - 1)
            if time.perf_counter() > deadline:
                return WholeBodyCandidate(q, iteration - 1, f"time budget of {self.timeout_s:g} s used up")
            q, reason = step(q)
            if reason:
                return WholeBodyCandidate(q, iteration, reason)
        if converged(q):
            return WholeBodyCandidate(q, self.max_iterations)
        return WholeBodyCandidate(
            q, self.max_iterations, f"no convergence in {self.max_iterations} iterations"
        )


class PeerWholeBody(WholeBodySolver):
    """A method solving with a peer library's own tasks and constraints: each task and each of the
    problem's constraints (:meth:`WholeBody.constraints`) goes through the peer's ``forms``; what has
    none is listed in :meth:`unsupported`. ``priorities``: what the peer has instead of strict
    priority levels."""

    forms: ClassVar[PeerForms]
    priorities: ClassVar[str] = "weighted costs only"

    def items(self, problem: WholeBody, tasks: list[Task], placements: dict,
              polygon) -> list[tuple[str, object]]:
        """(what, item) of every task and constraint of ``problem``: the constraints first, then
        ``tasks`` (the problem's, or their copies) named as the problem names them."""
        constraints = problem.constraints(placements, polygon)
        return ([(constraint.name, constraint) for constraint in constraints]
                + [(f"task {name}", task) for name, task in zip(problem.task_names, tasks, strict=True)])

    def unsupported(self, problem: WholeBody) -> list[Unsupported]:
        """Strict priority levels, and every task and constraint the peer has no form for (decided by
        class and by the item's own settings, so any start configuration gives the same list)."""
        missing = []
        if len({task.priority for task in problem.tasks}) > 1:
            missing.append(Unsupported(self.name, "strict priority levels", self.priorities))
        q = self.robot.nominal
        try:
            polygon = problem.support_polygon(q)
        except DegenerateSupportPolygonError:
            polygon = None  # (no method solves on it: solve() refuses it)
        for what, item in self.items(problem, problem.tasks, problem.contact_placements(q), polygon):
            why = self.forms.refusal(item)
            if why is not None:
                missing.append(Unsupported(self.name, what, why))
        return missing

    def started_tasks(self, problem: WholeBody, q0: np.ndarray) -> tuple[list[Task], Kinematics]:
        """Copies of the problem's tasks started at q0, and the kinematics at q0 they started on."""
        tasks = problem.copied_tasks()
        kinematics = Kinematics(self.robot.model, q0)
        for task in tasks:
            task.start(kinematics)
        return tasks, kinematics

    def translate(self, items: list[tuple[str, object]], target) -> None:
        """Add every item the peer can express to ``target``, the peer's problem being built."""
        for _, item in items:
            if self.forms.refusal(item) is None:
                self.forms.build(item, target)


@dataclass
class SolveIKProblem:
    """What the forms of a peer solving as Pink's and mink's ``solve_ik(configuration, tasks, dt,
    damping, limits, constraints)`` add to: its ``tasks``, equality ``constraints`` (tasks whose
    every row is held), ``limits`` and ``damping``; with wbik's ``kinematics`` at the start and the
    step ``dt`` (s)."""

    kinematics: Kinematics
    dt: float
    damping: float
    tasks: list = field(default_factory=list)
    constraints: list = field(default_factory=list)
    limits: list = field(default_factory=list)


def stalled(velocity: np.ndarray, dt: float, peer: str) -> str:
    """Why to stop after a ``solve_ik`` step of ``velocity`` over ``dt`` that no longer moves the
    robot, or ""."""
    moved = float(np.max(np.abs(velocity))) * dt
    return f"stalled: {peer}'s steps no longer move the robot" if moved < 1e-12 else ""


def raise_damping(task: RegularizationTask, problem: SolveIKProblem) -> None:
    """A regularisation (w |dq|^2) as ``solve_ik``'s damping on every DOF: the larger of the two."""
    problem.damping = max(problem.damping, largest_weight(task, 0.0))


def lowest_priority(tasks: list[Task]) -> int:
    """The priority number of the lowest level of ``tasks`` (0 without tasks): where a regularisation
    goes. The step keeps each level's achieved rows for the levels below it, a regularisation's rows
    (J = I) included, so one above another level would leave that level no motion at all."""
    return max((task.priority for task in tasks), default=0)
