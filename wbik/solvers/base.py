"""The one solver interface of every method: a method implements ``_solve(target, q0, deadline)`` (and,
taking whole-body problems, ``_solve_problem``); the base validates input, times the call, and the shared
check (:mod:`wbik.solvers.check`) decides ``success``."""

from __future__ import annotations

import hashlib
import math
import threading
import time
from collections.abc import Iterable, Sequence

import numpy as np
import pinocchio as pin

from wbik.errors import (
    InvalidBudgetError,
    InvalidConfigurationError,
    InvalidOptionError,
    InvalidSettingError,
    UnsupportedError,
)
from wbik.options import COUNT, SEED, TIMEOUT_S
from wbik.qp.constraint import Constraint
from wbik.qp.limits import JointAccelerationLimits, JointPositionLimits, JointVelocityLimits, LockedJoints
from wbik.qp.tasks import FrameTask, PositionTask, RegularizationTask
from wbik.robot import Chain, Robot
from wbik.solvers.batch_results import IKResults
from wbik.solvers.check import check_problem, evaluate
from wbik.solvers.result import Candidate, IKResult, Tolerances, checked_tolerances
from wbik.solvers.workers import solve_in_workers
from wbik.targets import Target, as_target
from wbik.wholebody.problem import StartedProblem, WholeBody

DEFAULT_TIMEOUT_S = 0.005  # s: TRAC-IK's benchmark protocol and MoveIt's KDL default
STEP_SHAPING = (JointVelocityLimits, JointAccelerationLimits)  # shape steps, not answers: chains drop them


class IterationBudget:
    """The one budget rule: a method whose loop is ours (an iteration cost set, s) runs ``max_iterations``,
    else the iterations costing about ``timeout_s`` or the default budget (docs/measurements.md)."""

    iteration_cost_s: float | None = None
    default_budget_s: float = DEFAULT_TIMEOUT_S
    problem_iteration_cost_s: float | None = None
    problem_budget_s: float = 0.1

    @classmethod
    def iterations_for(cls, timeout_s: float, problem: bool = False) -> int:
        """ceil(timeout / cost), at least 1: the iterations costing about ``timeout_s`` (ours only)."""
        cost = cls.problem_iteration_cost_s if problem else cls.iteration_cost_s
        if cost is None:
            raise UnsupportedError(f"method {cls.name!r} is budgeted by wall-clock time only")
        return max(1, math.ceil(TIMEOUT_S.checked(timeout_s, "timeout_s", "budget") / cost))

    @classmethod
    def budget_options(cls, timeout_s: float, options: dict,
                       problem: bool = False) -> tuple[float | None, dict]:
        """(timeout_s, options) for a budget of ``timeout_s``: ours as ``max_iterations``, others' as is."""
        cost = cls.problem_iteration_cost_s if problem else cls.iteration_cost_s
        if cost is None:
            return timeout_s, dict(options)
        if "max_iterations" in options:
            return None, dict(options)
        return None, {**options, "max_iterations": cls.iterations_for(timeout_s, problem)}

    def _iteration_budget(self, max_iterations: int | None, problem: bool = False) -> int:
        """``max_iterations`` checked, or the budget equivalent to ``timeout_s`` or the default budget."""
        if max_iterations is not None:
            return COUNT.checked(max_iterations, "max_iterations", type(self).__name__, InvalidBudgetError)
        default = self.problem_budget_s if problem else self.default_budget_s
        return self.iterations_for(self.timeout_s or default, problem)


class Solver(IterationBudget):
    """Base class of every IK method of one robot; ``chain``: where chain targets are solved (default the
    robot's only chain). ``_solve`` stops at ``deadline`` (``time.perf_counter()``, ``math.inf``: none) with
    its best effort and a reason. State is per thread and restarts draw from the call's own stream
    (:meth:`_call_rng`): an answer depends on (seed, target, q0) only."""

    name = "base"
    supports_position_only = True
    supports_pose = True
    pose_only_because = ""  # a pose-only method's refusal ends with why (what it lacks, what to use)
    budgeted: bool = True  # False for closed forms: a fixed amount of work per call
    takes_problems: bool = False  # a method with its own whole-body formulation (``_solve_problem``)

    def __init__(self, robot: Robot, chain: str | None = None, *,
                 tolerances: Tolerances | None = None, timeout_s: float | None = None,
                 seed: int | None = 0):
        if not isinstance(robot, Robot):
            raise InvalidOptionError(f"robot must be a wbik.Robot, got {type(robot).__name__}",
                                     option="robot")
        self.robot = robot
        self._chain_name = chain
        self._chain = None if self.takes_problems and chain is None else robot.chain(chain)
        self.tolerances = checked_tolerances(tolerances)
        if timeout_s is None and self.iteration_cost_s is None and self.problem_iteration_cost_s is None:
            timeout_s = DEFAULT_TIMEOUT_S
        self.timeout_s = None if timeout_s is None else TIMEOUT_S.checked(timeout_s, "timeout_s", self.name)
        self.seed = None if SEED.checked(seed, "seed", self.name) is None else int(seed)
        self._local = threading.local()

    @property
    def chain(self) -> Chain:
        """The chain of chain targets (UnknownChainError when the robot has no default)."""
        if self._chain is None:
            self._chain = self.robot.chain(self._chain_name)
        return self._chain

    def __repr__(self) -> str:
        where = self.robot.name if self._chain is None else f"{self.robot.name}.{self._chain.name}"
        return f"{type(self).__name__}({where})"

    def _thread_state(self):
        """This thread's mutable working objects, built on first use."""
        state = getattr(self._local, "state", None)
        if state is None:
            state = self._local.state = self._new_thread_state()
        return state

    def _new_thread_state(self):
        return None

    def solve(self, target, q0: Sequence[float] | None = None) -> IKResult:
        """Solve a target (SE3, 4x4, 3-vector or Target) or a WholeBody from q0 (default: the nominal)."""
        if isinstance(target, WholeBody):
            return self.solve_problem(target, q0)
        target = as_target(target)
        if not (self.supports_pose if target.rotation is not None else self.supports_position_only):
            self._check_target_kind(target)  # raises the detailed UnsupportedError
        chain = self.chain
        q_start = chain.nominal.copy() if q0 is None else chain.check_q(q0)
        start = time.perf_counter()
        deadline = math.inf if self.timeout_s is None else start + self.timeout_s
        candidate = self._solve(target, q_start, deadline)
        elapsed = time.perf_counter() - start
        return evaluate(chain, target, candidate, self.tolerances, elapsed, self.name)

    def solve_problem(self, problem: WholeBody, q0=None) -> IKResult:
        """Solve a whole-body problem from q0 (default the robot's nominal); UnsupportedError if it cannot."""
        if not isinstance(problem, WholeBody):
            raise InvalidSettingError(f"solve_problem() takes a wbik.WholeBody, got "
                                      f"{type(problem).__name__}")
        if problem.robot is not self.robot and (problem.robot.name != self.robot.name
                                                or problem.robot.model.nq != self.robot.model.nq):
            raise InvalidSettingError(f"the problem is on {problem.robot.name!r}, this solver on "
                                      f"{self.robot.name!r}")
        q_start = problem.check_q(self.robot.nominal if q0 is None else q0)
        if not self.takes_problems:
            if why := self.cannot_express(problem, q_start):
                raise UnsupportedError(f"method {self.name!r} cannot solve this problem: {why}")
        started = problem.start(q_start)
        unsupported = self.unsupported(problem)
        start = time.perf_counter()
        deadline = math.inf if self.timeout_s is None else start + self.timeout_s
        candidate = self._solve_problem(started, deadline, getattr(self, "problem_max_iterations", 0))
        elapsed = time.perf_counter() - start
        return check_problem(started, candidate.q, self.tolerances, method=self.name, time_s=elapsed,
                             iterations=candidate.iterations, reason=candidate.reason,
                             unsupported=unsupported, extra=candidate.extra)

    def solve_many(self, targets: Iterable, q0s: np.ndarray | Sequence | None = None,
                   workers: int = 1) -> IKResults:
        """Solve a batch: an IKResult per target, in order, also as columns (:class:`IKResults`). The
        targets: any of ``solve``'s, or one array of them ((B, 4, 4) poses, (B, 3) positions); ``q0s``: one
        start for all, one per target, or None. ``workers`` > 1 splits the batch over that many forked
        processes (:mod:`wbik.solvers.workers`), with the same answers."""
        targets = targets if isinstance(targets, np.ndarray) and targets.ndim > 1 else list(targets)
        workers = min(COUNT.checked(workers, "workers", "solve_many"), max(len(targets), 1))
        if workers == 1:
            answers = self._solve_targets(targets, q0s)
        else:
            self._batch_starts(q0s, len(targets))  # a bad start raises here, not in a worker
            answers = solve_in_workers(self, targets, q0s, workers)
        return IKResults.of(answers, None if self._chain is None else self._chain.nq)

    def _solve_targets(self, targets: list, q0s) -> list[IKResult]:
        """The batch in this process: ``solve`` per target (a method with a batched path overrides it)."""
        starts = self._batch_starts(q0s, len(targets))
        return [self.solve(target, q0) for target, q0 in zip(targets, starts, strict=True)]

    def solve_all(self, target) -> list[IKResult]:
        """Every distinct solution (closed-form methods only)."""
        raise UnsupportedError(f"method {self.name!r} finds one solution; use 'analytic' for all branches")

    def unsupported(self, problem: WholeBody) -> list[str]:
        """What of ``problem`` this method cannot express (it solves the problem without it)."""
        if self.takes_problems:
            return []
        return [f"{c.name} (a chain method takes no step limits)" for c in problem.constraints
                if isinstance(c, STEP_SHAPING)]

    def cannot_express(self, problem: WholeBody, q0=None) -> str | None:
        """Why ``problem`` is outside what this method can solve, or None. A chain method takes one goal,
        a frame or position task on the chain's tip, under joint limits, the other joints at nominal."""
        if self.takes_problems:
            return None
        try:
            chain = self.chain
        except UnsupportedError as exc:
            return str(exc)
        goals = [task for task in problem.tasks if task.goal]
        task = goals[0] if len(goals) == 1 else None
        if task is None or type(task) not in (FrameTask, PositionTask) or task.frame != chain.tip_frame \
                or (isinstance(task, PositionTask) and len(task.rows) != 3):
            return (f"it solves one frame or position task on the tip {chain.tip_frame!r} of chain "
                    f"{chain.name!r}; use a whole-body method (qp, placo, pink, mink) for other problems")
        others = [c.name for c in problem.constraints
                  if not isinstance(c, (JointPositionLimits, LockedJoints, *STEP_SHAPING))]
        if others:
            return f"it cannot hold {', '.join(others)}; use a whole-body method (qp, placo, pink, mink)"
        q0 = self.robot.nominal if q0 is None else np.asarray(q0, dtype=float)
        outside = np.delete(q0 - self.robot.nominal, chain.q_index)
        if outside.size and not np.allclose(outside, 0.0, rtol=0.0, atol=1e-12):
            return (f"the joints outside chain {chain.name!r} must be at the robot's nominal values (the "
                    "chain's reduced model)")
        return None

    def _call_rng(self, target: Target, q0: np.ndarray) -> np.random.Generator:
        """The random stream of one call, seeded by (seed, target, q0); fresh entropy without ``seed``."""
        if self.seed is None:
            return np.random.default_rng()
        digest = hashlib.blake2b(target.position.tobytes(), digest_size=8)
        if target.rotation is not None:
            digest.update(target.rotation.tobytes())
        digest.update(np.ascontiguousarray(q0, dtype=float).tobytes())
        return np.random.default_rng([self.seed, int.from_bytes(digest.digest(), "little")])

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        """A whole-body method solves a chain target as the chain's problem (:meth:`chain_problem`)."""
        if not self.takes_problems:
            raise NotImplementedError
        chain = self.chain
        problem = self.chain_problem(target)
        candidate = self._solve_problem(problem.start(chain.full_configuration(chain.clip(q0))), deadline,
                                        self.max_iterations)
        if candidate.q is not None:
            candidate.q = candidate.q[chain.q_index]
        return candidate

    def chain_problem(self, target: Target, constraints: Sequence[Constraint] = (),
                      regularization: float = 0.0) -> WholeBody:
        """A chain target as a whole-body problem: a frame (or position) task on the tip, the chain's joint
        limits (none on continuous joints), every other joint locked, ``constraints``, a regularisation."""
        chain = self.chain
        world = chain.base_placement * target.se3()
        tip = (FrameTask(chain.tip_frame, world) if target.is_pose
               else PositionTask(chain.tip_frame, world.translation.copy()))
        tasks = [tip] + ([RegularizationTask(regularization)] if regularization else [])
        continuous = [n for n, wraps in zip(chain.joint_names, chain.continuous, strict=True) if wraps]
        model = self.robot.model
        others = [model.names[j] for j in range(1, model.njoints) if model.names[j] not in chain.joint_names
                  and model.joints[j].nv]
        locked = [LockedJoints(others)] if others else []
        return WholeBody(self.robot, tasks, limits="none",
                         constraints=[JointPositionLimits(unbounded=continuous), *locked, *constraints])

    def _solve_problem(self, started: StartedProblem, deadline: float, max_iterations: int) -> Candidate:
        """A whole-body problem: a chain method solves the chain target it stands for."""
        chain = self.chain
        task = next(task for task in started.tasks if task.goal)
        world = task.target if isinstance(task, FrameTask) else pin.SE3(np.eye(3), task.target)
        local = chain.base_placement.actInv(world)
        target = as_target(local if isinstance(task, FrameTask) else local.translation)
        candidate = self._solve(target, started.q0[chain.q_index], deadline)
        if candidate.q is not None:
            joints = np.asarray(candidate.q, dtype=float).reshape(-1)
            q = started.q0.copy()
            if joints.shape == chain.lower.shape and np.all(np.isfinite(joints)):
                q[chain.q_index] = chain.clip(joints)  # as the chain check clips and wraps them
            candidate.q = q if joints.shape == chain.lower.shape else None
        return candidate

    def check_target_kind(self, kind: str) -> None:
        """UnsupportedError, saying why, if this solver cannot take ``kind`` ("pose", "position") targets."""
        if kind == "pose" and not self.supports_pose:
            raise UnsupportedError(f"method {self.name!r} on {self.chain.name!r} takes position targets only")
        if kind == "position" and not self.supports_position_only:
            because = f": {self.pose_only_because}" if self.pose_only_because else ""
            raise UnsupportedError(
                f"method {self.name!r} on {self.chain.name!r} needs a full pose target{because}")

    def _check_target_kind(self, target: Target) -> None:
        self.check_target_kind("pose" if target.is_pose else "position")

    def _batch_starts(self, q0s, count: int) -> list[np.ndarray | None]:
        if q0s is None:
            return [None] * count
        array = np.asarray(q0s, dtype=float)
        if array.ndim == 1:
            return [self.chain.check_q(array)] * count
        if array.shape[0] != count:
            raise InvalidConfigurationError(f"{count} targets but {array.shape[0]} start configurations")
        return [self.chain.check_q(row) for row in array]
