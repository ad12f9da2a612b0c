"""The whole-body solver interface and the generic methods: ``wholebody_solver(method,
robot).solve(problem, q0)`` (the registry is :mod:`wbik.wholebody.methods`).

Every method builds its own formulation of a :class:`~wbik.wholebody.problem.WholeBody`, lists in
``unsupported`` what it cannot express (it then solves the problem without it, and says so), and
its answer is judged by the one shared check, :func:`~wbik.wholebody.problem.check_wholebody`.

Methods:

Contacts on a point foot (``problem.point_contacts``) hold its position only, in every method.

- ``qp``: our task QP (:class:`wbik.qp.IKProblem`), contacts as equalities, the CoM in the shrunk
  support polygon as hard rows, limits as bounds (and acceleration limits, ``acceleration_limit``);
  ``backend=`` any installed qpsolvers backend. A result that fails the check carries a
  ``diagnosis`` (what blocks the goals, what conflicts with them, what to change: its summary ends
  the reason), made after the timed solve (``diagnose=False`` leaves it out).
- ``placo``: PlaCo's KinematicsSolver: its own frame / position / orientation / CoM / joints tasks
  (soft, with our weights), contacts as hard frame tasks (a point foot: a hard position task), its
  CoM polygon constraint with the
  polygon clockwise (PlaCo's convention) and configured hard (as benchmarks/qp.py does), joint
  limits; one ``solve(True)`` per iteration of our loop.
- ``pink``: pin-pink 4.4: FrameTask (also for position-only and orientation-only tasks, the other
  half at cost 0), ComTask, PostureTask, contacts as Pink equality constraints (a point foot: a
  3-row task of our own, :func:`pink_point_contact`), ConfigurationLimit
  (and VelocityLimit); Pink has no hard CoM-in-polygon constraint, so it solves without one:
  every pink result with a support polygon lists it in ``unsupported``.

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

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidOptionError
from wbik.errors import InvalidSettingError
from wbik.qp.kinematics import Kinematics
from wbik.qp.tasks import ComTask
from wbik.qp.tasks import FrameTask
from wbik.qp.tasks import OrientationTask
from wbik.qp.tasks import PositionTask
from wbik.qp.tasks import PostureTask
from wbik.qp.tasks import RegularizationTask
from wbik.qp.tasks import RelativeFrameTask
from wbik.qp.tasks import Task
from wbik.robot import Robot
from wbik.solvers.base import Candidate
from wbik.solvers.base import IterationBudget
from wbik.solvers.base import PerThreadState
from wbik.solvers.base import Tolerances
from wbik.solvers.base import checked_tolerances
from wbik.validation import check_budget
from wbik.validation import check_seed
from wbik.wholebody.methods import WholeBodyMethod
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


PEER_TASKS = (
    FrameTask,
    PositionTask,
    OrientationTask,
    RelativeFrameTask,
    ComTask,
    PostureTask,
    RegularizationTask,
)
"""The task types PlaCo's and Pink's translations build (others are listed in ``unsupported``)."""


def _peer_unsupported(problem: WholeBody, priorities: str) -> list[str]:
    """What PlaCo and Pink both cannot express: collisions, strict priority levels (``priorities``
    says what the peer has instead), acceleration limits."""
    missing = []
    if problem.collisions:
        missing.append("minimum distances between frames (collisions)")
    if problem.acceleration_limit is not None:
        missing.append("acceleration limits (solved with position and velocity limits only)")
    if len({task.priority for task in problem.tasks}) > 1:
        missing.append(f"strict priority levels ({priorities})")
    return missing


def lowest_priority(tasks: list[Task]) -> int:
    """The priority number of the lowest level of ``tasks`` (0 without tasks): where a regularisation
    goes. The step keeps each level's achieved rows for the levels below it, a regularisation's rows
    (J = I) included, so one above another level would leave that level no motion at all."""
    return max((task.priority for task in tasks), default=0)


# -- qp -------------------------------------------------------------------------------------------------
class QPWholeBody(WholeBodySolver):
    """Our task QP (wbik.qp.IKProblem) on the whole model."""

    name = "qp"
    iteration_cost_s = 800e-6  # DAQP step, projection, FK checks; a biped with nv 24: measured 0.8-1.5 ms
    default_budget_s = 0.08

    def __init__(
        self,
        robot,
        *,
        backend: str = "default",
        max_step: float = 0.2,
        lm_damping: float = 1e-3,
        regularization: float = 1e-6,
        diagnose: bool = True,
        **options,
    ):
        from wbik.qp import backends

        super().__init__(robot, **options)
        self.backend = backends.resolve(backend)
        self.max_step, self.lm_damping, self.regularization = (
            float(max_step),
            float(lm_damping),
            float(regularization),
        )
        self.diagnose = bool(diagnose)

    def solve(self, problem: WholeBody, q0=None) -> WholeBodyResult:
        """The shared check's result; one that fails it gets the QP's diagnosis (after the timing), and
        a start outside the limits is reported in ``diagnosis.start`` either way."""
        self._local.last = None
        result = super().solve(problem, q0)
        last = getattr(self._local, "last", None)
        if last is None:
            return result
        ik, solution = last
        self._local.last = None
        if not result.success and self.diagnose:
            diagnosis = ik.diagnose(solution)
            result.diagnosis = diagnosis
            text = diagnosis.summary()
            if text:
                result.reason = f"{result.reason}; {text}" if result.reason else text
        elif solution.start_violations:
            from wbik.qp.diagnosis import Diagnosis

            result.diagnosis = Diagnosis(start=list(solution.start_violations))
        return result

    def _solve(self, problem, q0, placements, polygon, deadline):
        from wbik.qp.constraints import CoMInSupportPolygon
        from wbik.qp.constraints import JointAccelerationLimits
        from wbik.qp.constraints import JointPositionLimits
        from wbik.qp.constraints import JointVelocityLimits
        from wbik.qp.constraints import MinimumDistance
        from wbik.qp.humanoid import contact_constraint
        from wbik.qp.problem import IKProblem

        model = self.robot.model
        tasks = problem.copied_tasks()
        tolerance = 0.5 * min(self.tolerances.position, self.tolerances.rotation)
        for task in tasks:
            if task.goal:
                task.tolerance = min(task.tolerance, tolerance)
        # on the lowest level: on a level above others, its kept rows sqrt(w) dq would pin the step for them
        tasks.append(RegularizationTask(self.regularization, priority=lowest_priority(tasks)))
        constraints = [contact_constraint(self.robot, frame, held) for frame, held in placements.items()]
        if polygon is not None:
            constraints.append(CoMInSupportPolygon(polygon, problem.margin))
        if problem.limits != "none":
            constraints.append(JointPositionLimits(model))
        if problem.limits == "position+velocity":
            constraints.append(JointVelocityLimits(model, model.velocityLimit * problem.step_dt))
        if problem.acceleration_limit is not None:  # (the IK's steps are periods of step_dt, solved at dt 1)
            constraints.append(JointAccelerationLimits(model, np.multiply(problem.acceleration_limit,
                                                                          problem.step_dt ** 2)))
        constraints += [MinimumDistance(c.frame_a, c.frame_b, c.distance) for c in problem.collisions]
        ik = IKProblem(
            model,
            tasks,
            constraints,
            backend=self.backend,
            max_step=self.max_step,
            lm_damping=self.lm_damping,
        )
        solution = ik.solve(
            q0, max_iterations=self.max_iterations, deadline=None if deadline == math.inf else deadline,
            diagnose=False,
        )
        self._local.last = (ik, solution)
        return WholeBodyCandidate(
            solution.q,
            solution.iterations,
            solution.reason,
            {"backend": self.backend, "converged": solution.converged},
        )


# -- placo ----------------------------------------------------------------------------------------------
def clockwise(polygon) -> list[np.ndarray]:
    """The polygon's vertices clockwise, as PlaCo's CoMPolygonConstraint wants them (wbik stores them
    counter-clockwise); the same rule as benchmarks/qp.py ``placo_polygon``."""
    vertices = [np.array(v, dtype=float) for v in polygon.vertices]
    x, y = np.array([v[0] for v in vertices]), np.array([v[1] for v in vertices])
    area = 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    return vertices[::-1] if area > 0 else vertices


def _weights(task: Task) -> tuple[float, float]:
    """(position weight, orientation weight) of a task, from its per-row weights."""
    weight = np.asarray(task.weight, dtype=float)
    if isinstance(task, FrameTask | RelativeFrameTask):
        return float(np.max(weight[:3])), float(np.max(weight[3:]))
    return _largest_weight(task, 1.0), 0.0


def _largest_weight(task: Task, default: float) -> float:
    """The largest of a task's per-row weights (``default`` for a task without rows)."""
    weight = np.asarray(task.weight, dtype=float)
    return float(np.max(weight)) if weight.size else default


def _axes(task: Task) -> str:
    """The axes a position or CoM task holds, as PlaCo's masks name them ("xz", ...)."""
    return "".join("xyz"[i] for i in task.rows)


class PlacoWholeBody(WholeBodySolver):
    """PlaCo's KinematicsSolver with its own tasks, hard contacts and hard clockwise CoM polygon."""

    name = "placo"
    iteration_cost_s = 300e-6  # solve(True), read-back, convergence FK; the same biped: measured 0.25-0.3 ms
    default_budget_s = 0.08

    def __init__(self, robot, *, regularization: float = 1e-6, **options):
        from wbik.solvers.placo import import_placo

        super().__init__(robot, **options)
        self.placo = import_placo()
        self.regularization = float(regularization)
        self._thread_state()  # this thread's PlaCo robot now (errors show here, its cost is not a solve's)

    def unsupported(self, problem):
        missing = _peer_unsupported(problem, "PlaCo: hard or soft only; all tasks soft")
        for task in problem.tasks:
            if not isinstance(task, PEER_TASKS):
                missing.append(f"task {task.name} ({type(task).__name__})")
        return missing

    def _new_thread_state(self):
        """This thread's PlaCo robot (loading the URDF costs milliseconds; a solver is built per call)."""
        from wbik.solvers.placo import placo_robot

        return placo_robot(self.robot)

    def _solve(self, problem, q0, placements, polygon, deadline):
        from wbik.solvers.placo import placo_configuration
        from wbik.solvers.placo import set_placo_configuration

        robot, placo = self.robot, self.placo
        wrapper = self._thread_state()
        set_placo_configuration(robot, wrapper, q0)
        solver = placo.KinematicsSolver(wrapper)
        if not robot.has_floating_base:
            solver.mask_fbase(True)
        if problem.limits != "none":
            solver.enable_joint_limits(True)
        if problem.limits == "position+velocity":
            solver.dt = problem.step_dt
            solver.enable_velocity_limits(True)
        for index, (frame, placement) in enumerate(placements.items()):
            if frame in problem.point_contacts:  # a point foot: its position only
                task = solver.add_position_task(frame, placement.translation.copy())
                task.configure(f"contact_{index}", "hard", 1.0)
            else:
                task = solver.add_frame_task(frame, placement.homogeneous)
                task.configure(f"contact_{index}", "hard", 1.0, 1.0)
        tasks = problem.copied_tasks()
        kinematics = Kinematics(robot.model, q0)
        for index, task in enumerate(tasks):
            task.start(kinematics)
            self._add_task(solver, wrapper, task, index, q0)
        if polygon is not None:
            constraint = solver.add_com_polygon_constraint(clockwise(polygon), problem.margin)
            constraint.configure("com_polygon", "hard", 1.0)
        solver.add_regularization_task(self.regularization)

        def step(q: np.ndarray) -> tuple[np.ndarray, str]:
            try:
                solver.solve(True)
            except RuntimeError as exc:
                return q, f"PlaCo's QP failed: {exc}"
            wrapper.update_kinematics()
            previous, q = q, placo_configuration(robot, wrapper)
            if float(np.max(np.abs(pin.difference(robot.model, previous, q)))) < 1e-12:
                return q, "stalled: PlaCo's steps no longer move the robot"
            return q, ""

        return self._peer_loop(step, q0.copy(), deadline, problem, kinematics, tasks, placements, polygon)

    def _add_task(self, solver, wrapper, task: Task, index: int, q0: np.ndarray) -> None:
        label = f"task_{index}"
        position_weight, orientation_weight = _weights(task)
        if isinstance(task, FrameTask | RelativeFrameTask):
            if isinstance(task, FrameTask):
                placo_task = solver.add_frame_task(task.frame, task.target.homogeneous)
            else:
                placo_task = solver.add_relative_frame_task(
                    task.reference_frame, task.frame, task.target.homogeneous
                )
            placo_task.configure(label, "soft", position_weight, orientation_weight)
        elif isinstance(task, PositionTask):
            placo_task = solver.add_position_task(task.frame, self._full_position(task, q0))
            placo_task.mask.set_axises(_axes(task))
            placo_task.configure(label, "soft", position_weight)
        elif isinstance(task, OrientationTask):
            placo_task = solver.add_orientation_task(task.frame, task.target)
            placo_task.configure(label, "soft", position_weight)
        elif isinstance(task, ComTask):
            target = task.target.copy()
            placo_task = solver.add_com_task(target)
            placo_task.mask.set_axises(_axes(task))
            placo_task.configure(label, "soft", position_weight)
        elif isinstance(task, PostureTask):
            model = self.robot.model
            names = task.joint_names or [
                model.names[j] for j in range(1, model.njoints) if model.joints[j].nq == 1
            ]
            joints = {
                name: float(task.reference[model.joints[model.getJointId(name)].idx_q]) for name in names
            }
            placo_task = solver.add_joints_task()
            placo_task.set_joints(joints)
            placo_task.configure(label, "soft", _largest_weight(task, 1e-3))
        elif isinstance(task, RegularizationTask):
            solver.add_regularization_task(_largest_weight(task, 1e-6))

    def _full_position(self, task: PositionTask, q0: np.ndarray) -> np.ndarray:
        target = self.robot.frame_placement(q0, task.frame).translation.copy()
        target[task.rows] = task.target[task.rows]
        return target


# -- pink -----------------------------------------------------------------------------------------------
class PinkWholeBody(WholeBodySolver):
    """pin-pink's differential IK, iterated by our loop (dt = 1 per step)."""

    name = "pink"
    iteration_cost_s = 500e-6  # solve_ik, integration, convergence FK; the same biped: measured 0.35-0.66 ms
    default_budget_s = 0.12

    def __init__(self, robot, *, qp_solver: str = "daqp", damping: float = 1e-6, **options):
        super().__init__(robot, **options)
        try:
            import pink  # noqa: F401
        except ImportError as exc:
            from wbik.errors import MissingDependencyError

            raise MissingDependencyError(
                "Pink is not installed: 'pip install pin-pink==4.4.0' (the dev extra)"
            ) from exc
        self.qp_solver = str(qp_solver)
        self.damping = float(damping)

    def unsupported(self, problem):
        missing = []
        if problem.support:
            missing.append(
                f"{NO_POLYGON} (Pink 4.4 has none; solved without it, the CoM margin is only checked)"
            )
        missing += _peer_unsupported(problem, "Pink: weighted costs only")
        for task in problem.tasks:
            if isinstance(task, PostureTask) and task.joint_names is not None:
                missing.append(f"task {task.name}: posture on some joints only (Pink's is on all joints)")
            elif not isinstance(task, PEER_TASKS):
                missing.append(f"task {task.name} ({type(task).__name__})")
        return missing

    def _pink_tasks(self, problem, tasks, kinematics):
        from pink import tasks as P

        built = []
        damping = self.damping
        for task in tasks:
            position_weight, orientation_weight = _weights(task)
            if isinstance(task, FrameTask | RelativeFrameTask):
                costs = {"position_cost": math.sqrt(position_weight),
                         "orientation_cost": math.sqrt(orientation_weight)}
                if isinstance(task, FrameTask):
                    pink_task = P.FrameTask(task.frame, **costs)
                else:
                    pink_task = P.RelativeFrameTask(task.frame, task.reference_frame, **costs)
                pink_task.set_target(task.target)
            elif isinstance(task, PositionTask):
                cost = np.zeros(3)
                cost[task.rows] = math.sqrt(position_weight)
                start = kinematics.placement(kinematics.frame_id(task.frame))
                translation = start.translation.copy()
                translation[task.rows] = task.target[task.rows]
                pink_task = P.FrameTask(task.frame, position_cost=cost, orientation_cost=0.0)
                pink_task.set_target(pin.SE3(start.rotation.copy(), translation))
            elif isinstance(task, OrientationTask):
                start = kinematics.placement(kinematics.frame_id(task.frame))
                pink_task = P.FrameTask(
                    task.frame, position_cost=0.0, orientation_cost=math.sqrt(position_weight)
                )
                pink_task.set_target(pin.SE3(task.target, start.translation.copy()))
            elif isinstance(task, ComTask):
                cost = np.zeros(3)
                cost[task.rows] = math.sqrt(position_weight)
                pink_task = P.ComTask(cost=cost)
                target = kinematics.com().copy()
                target[task.rows] = task.target[task.rows]
                pink_task.set_target(target)
            elif isinstance(task, PostureTask):
                pink_task = P.PostureTask(cost=math.sqrt(_largest_weight(task, 1e-3)))
                pink_task.set_target(task.reference)
            elif isinstance(task, RegularizationTask):
                damping = max(damping, _largest_weight(task, 0.0))
                continue
            else:
                continue
            built.append(pink_task)
        return built, damping

    def _solve(self, problem, q0, placements, polygon, deadline):
        import pink
        from pink import tasks as P
        from pink.limits import ConfigurationLimit
        from pink.limits import VelocityLimit

        model = self.robot.model
        data = model.createData()
        tasks = problem.copied_tasks()
        kinematics = Kinematics(model, q0)
        for task in tasks:
            task.start(kinematics)
        pink_tasks, damping = self._pink_tasks(problem, tasks, kinematics)
        constraints = []
        for frame, placement in placements.items():
            if frame in problem.point_contacts:  # a point foot: its position only (3 equality rows)
                constraints.append(pink_point_contact(frame, placement.translation))
                continue
            contact = P.FrameTask(frame, position_cost=1.0, orientation_cost=1.0)
            contact.set_target(placement)
            constraints.append(contact)
        limits = []
        if problem.limits != "none":
            limits.append(ConfigurationLimit(model))
        if problem.limits == "position+velocity":
            limits.append(VelocityLimit(model))
        configuration = pink.Configuration(model, data, q0.copy())

        def step(q: np.ndarray) -> tuple[np.ndarray, str]:
            try:
                velocity = pink.solve_ik(
                    configuration,
                    pink_tasks,
                    problem.step_dt,
                    solver=self.qp_solver,
                    damping=damping,
                    limits=limits,
                    constraints=constraints or None,
                    safety_break=False,
                )
            except Exception as exc:  # noqa: BLE001 - Pink raises its own NoSolutionFound and others
                return q, f"Pink found no step: {type(exc).__name__}: {exc}"
            q = configuration.integrate(velocity, problem.step_dt)
            configuration.update(q)
            if float(np.max(np.abs(velocity))) * problem.step_dt < 1e-12:
                return q, "stalled: Pink's steps no longer move the robot"
            return q, ""

        # no hard polygon in Pink: the loop stops on goals and contacts only, the check judges the CoM
        return self._peer_loop(step, q0.copy(), deadline, problem, kinematics, tasks, placements, None)


def pink_point_contact(frame: str, position: np.ndarray):
    """A Pink task holding ``frame``'s origin at ``position`` (world, m), for Pink's equality
    constraints (which take a task's every row, whatever its cost): e = p - p*, J = the frame's
    world-aligned linear Jacobian (3 rows)."""
    from pink.tasks import Task as PinkTask

    class PointContactTask(PinkTask):
        def __init__(self):
            super().__init__(cost=1.0)
            self.frame, self.position = frame, np.array(position, dtype=float)

        def compute_error(self, configuration) -> np.ndarray:
            return configuration.get_transform_frame_to_world(self.frame).translation - self.position

        def compute_jacobian(self, configuration) -> np.ndarray:
            model, data = configuration.model, configuration.data
            return pin.getFrameJacobian(model, data, model.getFrameId(self.frame),
                                        pin.LOCAL_WORLD_ALIGNED)[:3]

        def __repr__(self) -> str:
            return f"PointContactTask({self.frame!r})"

    return PointContactTask()


WHOLEBODY_METHODS = (
    WholeBodyMethod(
        "qp", QPWholeBody,
        "our task QP (wbik.qp.IKProblem): hard contacts, hard CoM polygon, limits; backend= any installed",
    ),
    WholeBodyMethod(
        "placo", PlacoWholeBody,
        "PlaCo 0.10 KinematicsSolver: its tasks, hard contacts, hard clockwise CoM polygon, limits",
    ),
    WholeBodyMethod(
        "pink", PinkWholeBody,
        "pin-pink 4.4: frame / CoM / posture tasks, contacts as constraints; no hard CoM polygon",
    ),
)
"""The generic whole-body methods (registered through wbik.wholebody.methods.METHOD_MODULES)."""
