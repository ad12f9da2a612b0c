"""One whole-body problem, tasks (:mod:`wbik.qp.tasks`) under hard constraints (:mod:`wbik.qp.constraint`),
as every whole-body method gets it and the shared check judges it; a solve starts a copy at q0."""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError, InvalidSettingError, RobotDescriptionError
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.constraint import Constraint
from wbik.qp.contacts import Contact, HeldFrame, PointContact
from wbik.qp.distances import MinimumDistance
from wbik.qp.humanoid import contact_constraint
from wbik.qp.kinematics import Kinematics
from wbik.qp.limits import JointAccelerationLimits, JointPositionLimits, JointVelocityLimits
from wbik.qp.support_polygon import DegenerateSupportPolygonError
from wbik.qp.task_entries import FRAME, TASK_ENTRY, build_task
from wbik.qp.tasks import Task
from wbik.robot import Robot
from wbik.schema import Context, Either, Instance, Key, ListOf, Map, Number, Text, Vector
from wbik.validation import finite_vector

LIMITS = ("position", "position+velocity", "none")
FRAMES = ListOf(FRAME, what="frame names")
COLLISION = Map({"frames": Key(ListOf(FRAME, min_items=2, what="2 frame names"), required=True),
                 "distance": Key(Number(ge=0, unit="m"), required=True)}, what="{frames: [a, b], distance}")
KEYS = {"margin": Key(Number(ge=0, unit="m", as_float=True)), "limits": Key(Text(LIMITS)),
        "step_dt": Key(Number(gt=0, unit="s", as_float=True)), "name": Key(Text())}
"""The settings :class:`WholeBody` and :meth:`WholeBody.from_dict` share."""
ARGUMENTS = Map({"robot": Key(Instance(Robot, "a wbik.Robot")), **KEYS,
                 "tasks": Key(ListOf(Instance(Task, "a wbik.qp.tasks task (FrameTask, ComTask, ...)"))),
                 "constraints": Key(ListOf(Instance(Constraint, "a wbik.qp constraint (Contact, ...)")))})
"""The arguments of :class:`WholeBody` a node checks."""
ACCELERATION = Either(Number(gt=0), Vector(), what="one number > 0 or a list of numbers >= 0 (rad/s^2)")
PROBLEM = Map({"tasks": Key(ListOf(TASK_ENTRY, what="task entries"), []), "contacts": Key(FRAMES),
               "support": Key(FRAMES), "collisions": Key(ListOf(COLLISION)), **KEYS,
               "acceleration_limit": Key(ACCELERATION)}, what="a mapping (tasks, contacts, ...)")
"""The keys of :meth:`WholeBody.from_dict` (null: the default)."""


class WholeBody:
    """A whole-body IK problem on one robot: ``constraints`` takes any constraint objects, the keywords list
    the common ones. ``contacts``: frame names (held where they are at q0) or {frame: SE3} (a point foot: its
    position); ``support``: soles holding the CoM ``margin`` (m) inside their polygon (default: the contacts
    that are soles); ``limits``: "position", "position+velocity" (IK steps of ``step_dt``, s) or "none";
    ``acceleration_limit``: rad/s^2 (one or nv); ``collisions``: (frame_a, frame_b, m) minimum distances."""

    def __init__(self, robot: Robot, tasks: Sequence[Task] = (), contacts=(),
                 support: Sequence[str] | None = None, margin: float = 0.005,
                 limits: str = "position+velocity", collisions=None, *,
                 constraints: Sequence[Constraint] = (), step_dt: float = 1.0, acceleration_limit=None,
                 name: str = ""):
        ctx = Context("WholeBody")
        checked = ARGUMENTS.check({"robot": robot, "tasks": list(tasks), "margin": margin, "limits": limits,
                                   "step_dt": step_dt, "constraints": list(constraints)}, "", ctx)
        self.robot, self.name, self.tasks = robot, str(name), checked["tasks"]
        self.step_dt = checked["step_dt"]
        if not any(task.goal for task in self.tasks):
            ctx.fail("tasks", "need at least one goal task (posture and regularisation are not goals)")
        self.acceleration_limit = _acceleration(robot, acceleration_limit, ctx)
        if isinstance(contacts, str):
            contacts = [contacts]
        held = dict(contacts) if isinstance(contacts, Mapping) else dict.fromkeys(contacts)
        made: list[Constraint] = [contact_constraint(robot, str(frame), None if at is None else pin.SE3(at))
                                  for frame, at in held.items()]
        soles = robot.soles
        support = [c.frame for c in made if c.frame in soles] if support is None else support
        support = [str(frame) for frame in ([support] if isinstance(support, str) else support)]
        if missing := [frame for frame in support if frame not in soles]:
            raise RobotDescriptionError(f"support frames {missing} have no sole contact points on "
                                        f"{robot.name!r} (robot.soles lists {sorted(soles)})")
        if support:
            made.append(CoMInSupportPolygon(margin=checked["margin"], soles={f: soles[f] for f in support}))
        if limits != "none":
            made.append(JointPositionLimits())
        if limits == "position+velocity":
            made.append(JointVelocityLimits(period=self.step_dt))
        if self.acceleration_limit is not None:
            made.append(JointAccelerationLimits(self.acceleration_limit, period=self.step_dt))
        made += [_distance(item, f"collisions[{index}]", ctx) for index, item in enumerate(collisions or ())]
        self.constraints: list[Constraint] = made + checked["constraints"]
        for frame in [*self.contacts, *self.support, *(f for c in self.collisions for f in c.frames)]:
            robot.frame_id(frame)  # UnknownFrameError names the frames
        names = [task.name for task in self.tasks]
        self.task_names = [name if names.count(name) == 1 else f"{name}#{i}" for i, name in enumerate(names)]

    def __repr__(self) -> str:
        return (f"WholeBody({self.robot.name}, {len(self.tasks)} tasks, contacts={list(self.contacts)}, "
                f"support={self.support}, margin={self.margin:g})")

    # -- what the constraints hold -------------------------------------------------------------------
    def _of(self, kind: type) -> list:
        return [c for c in self.constraints if isinstance(c, kind)]

    @property
    def contacts(self) -> dict[str, pin.SE3 | None]:
        """Held frames: their given placement, or None (held where they are at the start)."""
        return {c.frame: (c.fixed_placement if isinstance(c, Contact) else
                          None if c.fixed_position is None else pin.SE3(np.eye(3), c.fixed_position))
                for c in self._of(HeldFrame)}

    @property
    def support(self) -> list[str]:
        return [frame for c in self._of(CoMInSupportPolygon) for frame in (c.soles or ())]

    @property
    def margin(self) -> float:
        return max((c.margin for c in self._of(CoMInSupportPolygon)), default=0.0)

    @property
    def collisions(self) -> list[MinimumDistance]:
        return self._of(MinimumDistance)

    @property
    def goal_tasks(self) -> list[tuple[str, Task]]:
        return [(name, task) for name, task in zip(self.task_names, self.tasks, strict=True) if task.goal]

    def check_q(self, q, what: str = "q0") -> np.ndarray:
        """A copy of ``q`` as the robot's nq finite numbers, else InvalidConfigurationError."""
        nq, name = self.robot.model.nq, f"{what} of {self.robot.name!r}"
        return finite_vector(q, nq, name, InvalidConfigurationError).copy()

    def copied_tasks(self) -> list[Task]:
        """Fresh copies of the tasks (a task keeps buffers and frame ids: one copy per solve)."""
        return [copy.deepcopy(task) for task in self.tasks]

    def start(self, q0, need_q0: bool = False, strict: bool = True) -> StartedProblem:
        """A copy started at q0 (``strict``: a degenerate polygon raises; ``need_q0``: no contact open)."""
        if need_q0 and any(placement is None for placement in self.contacts.values()):
            raise InvalidSettingError("checking this problem needs q0 to know where its contacts are held")
        q0 = self.check_q(q0)
        kinematics = Kinematics(self.robot.model, q0)
        tasks, constraints = self.copied_tasks(), [copy.deepcopy(c) for c in self.constraints]
        for item in (*tasks, *constraints):
            try:
                item.start(kinematics)
            except DegenerateSupportPolygonError:
                if strict:
                    raise
        return StartedProblem(self, q0, kinematics, tasks, constraints)

    # -- from a task-file entry ---------------------------------------------------------------------
    @classmethod
    def from_dict(cls, robot: Robot, data: Mapping, q: np.ndarray | None = None) -> WholeBody:
        """A problem from a task-file mapping (:data:`PROBLEM`), targets resolved at q (default: nominal)."""
        source = "WholeBody.from_dict"
        if isinstance(data, Mapping):
            data = {key: value for key, value in data.items() if value is not None}
        data = PROBLEM.check(data, "", Context(source))
        q = robot.nominal.copy() if q is None else np.asarray(q, dtype=float)
        tasks = [build_task(robot, q, entry, source) for entry in data.pop("tasks")]
        return cls(robot, tasks, **data)


@dataclass
class StartedProblem:
    """A problem as one solve started it at ``q0``: copies of its tasks and constraints, its kinematics."""

    problem: WholeBody
    q0: np.ndarray
    kinematics: Kinematics
    tasks: list[Task]
    constraints: list[Constraint]

    @property
    def placements(self) -> dict[str, pin.SE3]:
        """Where each contact is held (a point foot: its position, the start's rotation)."""
        held = {}
        for c in self.constraints:
            if isinstance(c, Contact):
                held[c.frame] = c.placement.copy()
            elif isinstance(c, PointContact):
                rotation = self.kinematics.placement(self.kinematics.frame_id(c.frame)).rotation
                held[c.frame] = pin.SE3(rotation.copy(), c.position.copy())
        return held

    @property
    def polygon(self):
        """The support polygon (None without support)."""
        return next((c.polygon for c in self.constraints if isinstance(c, CoMInSupportPolygon)), None)

    def items(self) -> list[tuple[str, object]]:
        """(name, item) of every constraint, then every task, as the problem names them."""
        tasks = zip(self.problem.task_names, self.tasks, strict=True)
        return [(c.name, c) for c in self.constraints] + [(f"task {name}", task) for name, task in tasks]


def _acceleration(robot: Robot, value, ctx: Context) -> float | np.ndarray | None:
    """``acceleration_limit`` checked: None, one number > 0 or nv numbers >= 0 (rad/s^2)."""
    if value is None:
        return None
    try:
        array = np.array(np.nan) if isinstance(value, bool | str) else np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        array = np.array(np.nan)
    nv = robot.model.nv
    if array.ndim == 0 and math.isfinite(float(array)) and float(array) > 0:
        return float(array)
    if array.shape == (nv,) and not np.any(np.isnan(array)) and np.all(array >= 0):
        return array.copy()
    ctx.must("acceleration_limit", f"one number > 0 or {nv} numbers >= 0 (rad/s^2)", value)


def _distance(item, path: str, ctx: Context) -> MinimumDistance:
    if isinstance(item, MinimumDistance):
        return item
    if isinstance(item, Mapping):
        item = COLLISION.check(item, path, ctx)
        item = (*item["frames"], item["distance"])
    try:
        frame_a, frame_b, distance = item
        return MinimumDistance(str(frame_a), str(frame_b), float(distance))
    except (TypeError, ValueError):
        ctx.must(path, f"(frame_a, frame_b, distance m), {COLLISION.expected} or a MinimumDistance", item)
