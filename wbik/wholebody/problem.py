"""One whole-body problem: goal and soft tasks (:mod:`wbik.qp.tasks`) under hard constraints
(:mod:`wbik.qp.constraint`), what every method that solves whole bodies is given, and what the shared
check (:func:`wbik.solvers.check.check_problem`) judges an answer against.

The constraints are open: ``constraints=[...]`` takes any constraint object (a contact, the CoM in the
support polygon, joint, velocity and acceleration limits, minimum distances, collision avoidance, a
class of the user's); the keywords ``contacts``, ``support``, ``margin``, ``limits``, ``collisions`` and
``acceleration_limit`` are a short way of listing the common ones. A problem is a template: a solve
starts a copy of it at q0 (:meth:`WholeBody.start`), where its contacts are held.
"""

from __future__ import annotations

import copy
import math
import numbers
from collections.abc import Mapping
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError
from wbik.errors import InvalidSettingError
from wbik.errors import RobotDescriptionError
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.constraint import Constraint
from wbik.qp.contacts import Contact
from wbik.qp.contacts import HeldFrame
from wbik.qp.contacts import PointContact
from wbik.qp.distances import MinimumDistance
from wbik.qp.kinematics import Kinematics
from wbik.qp.limits import JointAccelerationLimits
from wbik.qp.limits import JointPositionLimits
from wbik.qp.limits import JointVelocityLimits
from wbik.qp.support_polygon import DegenerateSupportPolygonError
from wbik.qp.tasks import Task
from wbik.robot import Robot

LIMITS = ("position", "position+velocity", "none")


class WholeBody:
    """A whole-body IK problem on one robot (see the module docstring).

    ``contacts``: frame names (held at their pose at q0) or {frame: SE3} (held there); a point foot (a sole
    with one contact point) is held in position only. ``support``: soles whose contact points
    (``robot.soles``) make the support polygon, the CoM kept ``margin`` (m) inside it; default the
    contacts that are soles, ``[]`` for none. ``limits``: "position", "position+velocity" (each IK step
    also bounded by v_max ``step_dt``) or "none". ``acceleration_limit``: rad/s^2 (one value or nv), each
    IK step a period of ``step_dt`` (:class:`wbik.qp.limits.JointAccelerationLimits`). ``collisions``:
    minimum distances between frame origins, (frame_a, frame_b, m) or {frames: [a, b], distance: m}.
    ``constraints``: any further constraint objects.
    """

    def __init__(self, robot: Robot, tasks: Sequence[Task] = (), contacts=(),
                 support: Sequence[str] | None = None, margin: float = 0.005,
                 limits: str = "position+velocity", collisions=None, *,
                 constraints: Sequence[Constraint] = (), step_dt: float = 1.0, acceleration_limit=None,
                 name: str = ""):
        if not isinstance(robot, Robot):
            raise InvalidSettingError(f"WholeBody needs a wbik.Robot, got {type(robot).__name__}")
        self.robot, self.name, self.tasks = robot, str(name), list(tasks)
        for task in self.tasks:
            if not isinstance(task, Task):
                raise InvalidSettingError(
                    f"tasks must be wbik.qp.tasks types (FrameTask, ComTask, ...), got {task!r}")
        if not any(task.goal for task in self.tasks):
            raise InvalidSettingError(
                "a whole-body problem needs at least one goal task (posture and regularisation are not "
                "goals)")
        if isinstance(margin, bool) or not isinstance(margin, numbers.Real) or not math.isfinite(margin) \
                or margin < 0:
            raise InvalidSettingError(f"margin must be a finite number >= 0 (m), got {margin!r}")
        if limits not in LIMITS:
            raise InvalidSettingError(f"limits must be one of {', '.join(LIMITS)}, got {limits!r}")
        if isinstance(step_dt, bool) or not isinstance(step_dt, numbers.Real) or not step_dt > 0:
            raise InvalidSettingError(f"step_dt must be a positive number (s), got {step_dt!r}")
        self.step_dt = float(step_dt)
        self.acceleration_limit = _acceleration(robot, acceleration_limit)
        made = self._contacts(contacts)
        made += self._support(support, [c.frame for c in made], float(margin))
        if limits != "none":
            made.append(JointPositionLimits())
        if limits == "position+velocity":
            made.append(JointVelocityLimits(period=self.step_dt))
        if self.acceleration_limit is not None:
            made.append(JointAccelerationLimits(self.acceleration_limit, period=self.step_dt))
        made += [_distance(item) for item in (collisions or ())]
        for constraint in constraints:
            if not isinstance(constraint, Constraint):
                raise InvalidSettingError(f"constraints must be wbik.qp constraint objects (Contact, "
                                          f"JointPositionLimits, ...), got {constraint!r}")
        self.constraints: list[Constraint] = made + list(constraints)
        for frame in [*self.contacts, *self.support, *(f for c in self.collisions for f in c.frames)]:
            robot.frame_id(frame)  # UnknownFrameError names the frames
        names = [task.name for task in self.tasks]
        self.task_names = [name if names.count(name) == 1 else f"{name}#{i}" for i, name in enumerate(names)]

    def _contacts(self, contacts) -> list[HeldFrame]:
        if isinstance(contacts, str):
            contacts = [contacts]
        held = dict(contacts) if isinstance(contacts, Mapping) else dict.fromkeys(contacts)
        made: list[HeldFrame] = []
        for frame, placement in held.items():
            placement = None if placement is None else pin.SE3(placement)
            sole = self.robot.soles.get(str(frame))
            if sole is not None and len(sole) == 1:  # a point foot: its position only
                made.append(PointContact(str(frame), None if placement is None else placement.translation))
            else:
                made.append(Contact(str(frame), placement))
        return made

    def _support(self, support, contacts: list[str], margin: float) -> list[Constraint]:
        soles = self.robot.soles
        support = [f for f in contacts if f in soles] if support is None else support
        support = [str(frame) for frame in ([support] if isinstance(support, str) else support)]
        missing = [frame for frame in support if frame not in soles]
        if missing:
            raise RobotDescriptionError(f"support frames {missing} have no sole contact points on "
                                        f"{self.robot.name!r} (robot.soles lists {sorted(soles)})")
        return [CoMInSupportPolygon(margin=margin, soles={f: soles[f] for f in support})] if support else []

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
    def point_contacts(self) -> frozenset[str]:
        return frozenset(c.frame for c in self._of(PointContact))

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
        array = np.asarray(q, dtype=float).reshape(-1) if q is not None else None
        if array is None or array.shape != (self.robot.model.nq,) or not np.all(np.isfinite(array)):
            raise InvalidConfigurationError(
                f"{what} must be {self.robot.model.nq} finite values for {self.robot.name!r}, got {q!r}")
        return array.copy()

    def copied_tasks(self) -> list[Task]:
        """Fresh copies of the tasks (a task keeps buffers and frame ids: one copy per solve)."""
        return [copy.deepcopy(task) for task in self.tasks]

    def start(self, q0, need_q0: bool = False, strict: bool = True) -> StartedProblem:
        """A copy of the problem started at q0: tasks and constraints resolved there (contacts held where
        they are, the support polygon of the soles there; a support spanning no area raises
        DegenerateSupportPolygonError, unless not ``strict``: the check measures such a support).
        ``need_q0``: refuse when a contact would be held at a start the caller did not give."""
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
        """A problem from a task-file mapping, targets resolved at q (default: the robot's nominal).

        Keys: ``tasks`` (entries as in a ``wholebody_ik`` phase, :mod:`wbik.qp.task_entries`),
        ``contacts``, ``support``, ``margin``, ``limits``, ``collisions`` ([{frames: [a, b], distance: m}]),
        ``step_dt``, ``acceleration_limit``, ``name``."""
        from wbik.qp.task_entries import build_task

        if not isinstance(data, Mapping):
            raise InvalidSettingError(
                f"a whole-body problem is a mapping (tasks, contacts, ...), got {data!r}")
        known = {"tasks", "contacts", "support", "margin", "limits", "collisions", "name", "step_dt",
                 "acceleration_limit"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InvalidSettingError(
                f"unknown key(s) {unknown} in a whole-body problem; allowed: {', '.join(sorted(known))}")
        q = robot.nominal.copy() if q is None else np.asarray(q, dtype=float)
        entries = data.get("tasks") or []
        if not isinstance(entries, list):
            raise InvalidSettingError("tasks must be a list of task entries ({type: frame, frame: ..., ...})")
        return cls(robot, [build_task(robot, q, entry) for entry in entries],
                   contacts=list(data.get("contacts") or []), support=data.get("support"),
                   margin=data.get("margin", 0.005), limits=data.get("limits", "position+velocity"),
                   collisions=data.get("collisions"), step_dt=data.get("step_dt", 1.0),
                   acceleration_limit=data.get("acceleration_limit"), name=str(data.get("name", "") or ""))


@dataclass
class StartedProblem:
    """A problem as one solve started it at ``q0``: its tasks and constraints (copies) resolved there,
    the ``kinematics`` at q0."""

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
        """(what, item) of every constraint and task, the constraints first, named as the problem names
        them (what a peer translates, what a refusal names)."""
        return ([(c.name, c) for c in self.constraints]
                + [(f"task {name}", task)
                   for name, task in zip(self.problem.task_names, self.tasks, strict=True)])


def _acceleration(robot: Robot, value) -> float | np.ndarray | None:
    """``acceleration_limit`` checked: None, one number > 0 or nv numbers >= 0 (rad/s^2)."""
    if value is None:
        return None
    array = np.asarray(value, dtype=float) if not isinstance(value, bool) else np.array(np.nan)
    nv = robot.model.nv
    if array.ndim == 0 and math.isfinite(float(array)) and float(array) > 0:
        return float(array)
    if array.shape == (nv,) and not np.any(np.isnan(array)) and np.all(array >= 0):
        return array.copy()
    raise InvalidSettingError(f"acceleration_limit must be one number > 0 or {nv} numbers >= 0 (rad/s^2), "
                              f"got {value!r}")


def _distance(item) -> MinimumDistance:
    if isinstance(item, MinimumDistance):
        return item
    if isinstance(item, Mapping):
        item = (*item.get("frames", ()), item.get("distance"))
    try:
        frame_a, frame_b, distance = item
        return MinimumDistance(str(frame_a), str(frame_b), float(distance))
    except (TypeError, ValueError):
        raise InvalidSettingError(f"a collision entry is (frame_a, frame_b, distance m) or "
                                  f"{{frames: [a, b], distance: m}}, got {item!r}") from None
