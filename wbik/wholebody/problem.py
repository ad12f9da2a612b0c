"""One whole-body problem description, one result type, one shared check by forward kinematics.

A :class:`WholeBody` is what every whole-body method is asked to solve: tasks (the types of
:mod:`wbik.qp.tasks`), contacts (frames that keep their pose; a point foot, a sole with a single
contact point, keeps its position only), the support polygon (soles whose contact points make it)
with a CoM margin, joint limits and optional minimum distances. Every method's
answer is judged by :func:`check_wholebody`, the same FK check for all, as
:func:`wbik.solvers.base.evaluate` judges chain answers:

- task errors: every *goal* task's error at q (the task's own e(q), evaluated on a fresh
  Pinocchio data by FK), split into position (m) and rotation (rad) parts;
- contact drift: the largest position (m) or rotation (rad) error of a contact frame against
  where it was held (its placement at q0, or the placement given); position only for a point foot;
- CoM margin: distance of the CoM's ground projection inside the support polygon built by FK at
  q from the support soles' contact points (m, negative outside); support that spans no area (two
  point feet, feet on one line) is degenerate: the margin is minus the distance to the segment or
  point it collapses to and the check fails (:mod:`wbik.qp.support_polygon`);
- limit excess: how far any bounded joint is beyond its limits (rad or m);
- collision clearance: min over the minimum-distance pairs of (distance - required) (m).

Success: every goal task within the tolerances, every contact within them, the CoM margin at
least ``margin`` (1e-9 slack), no joint beyond its limits (1e-9), every clearance >= -1e-9.
"""

from __future__ import annotations

import copy
import math
import numbers
from collections.abc import Mapping
from collections.abc import Sequence
from dataclasses import dataclass
from dataclasses import field
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError
from wbik.errors import InvalidSettingError
from wbik.files import json_plain
from wbik.geometry import rotation_angle
from wbik.qp.diagnosis import Diagnosis
from wbik.qp.humanoid import is_point_foot
from wbik.qp.kinematics import Kinematics
from wbik.qp.support_polygon import DegenerateSupport
from wbik.qp.tasks import Task
from wbik.robot import Robot
from wbik.solvers.base import Tolerances
from wbik.solvers.base import invalid_joints_reason

if TYPE_CHECKING:
    from wbik.qp.constraints import Constraint

LIMITS = ("position", "position+velocity", "none")
LIMIT_SLACK = 1e-9
"""A joint this far beyond its limit (rad or m) still counts as inside (rounding)."""
MARGIN_SLACK = 1e-9
"""The CoM margin may fall this far short of the required margin (m) and still pass."""


@dataclass(frozen=True)
class MinimumDistance:
    """Two frame origins kept at least ``distance`` apart (m): a collision pair in its simplest form."""

    frame_a: str
    frame_b: str
    distance: float


class WholeBody:
    """A whole-body IK problem on one robot (see the module docstring).

    ``contacts``: frame names (held at their pose at q0) or {frame: SE3} (held there); a point foot
    (a sole with a single contact point, :func:`wbik.qp.humanoid.is_point_foot`) is held in position
    only, listed in ``point_contacts``. ``support``: soles whose contact points (``robot.soles``) make
    the support polygon;
    default the contacts that are soles; ``[]`` for none. ``limits``: "position",
    "position+velocity" (each IK step also bounded by v_max * ``step_dt``) or "none".
    ``acceleration_limit``: rad/s^2 (one value for every joint, or nv values), each IK step being a
    period of ``step_dt``: the joint velocity dq / step_dt changes by at most a_max * step_dt from one
    kept step to the next, and each joint stays slow enough to stop before its limits
    (:class:`wbik.qp.constraints.JointAccelerationLimits`); None (default) for none.
    ``collisions``: minimum distances, as :class:`MinimumDistance` or (frame_a, frame_b, m).
    """

    def __init__(
        self,
        robot: Robot,
        tasks: Sequence[Task] = (),
        contacts=(),
        support: Sequence[str] | None = None,
        margin: float = 0.005,
        limits: str = "position+velocity",
        collisions=None,
        *,
        step_dt: float = 1.0,
        acceleration_limit=None,
        name: str = "",
    ):
        if not isinstance(robot, Robot):
            raise InvalidSettingError(f"WholeBody needs a wbik.Robot, got {type(robot).__name__}")
        self.robot = robot
        self.name = str(name)
        self.tasks = list(tasks)
        for task in self.tasks:
            if not isinstance(task, Task):
                raise InvalidSettingError(
                    f"tasks must be wbik.qp.tasks types (FrameTask, ComTask, ...), got {task!r}"
                )
        if not any(task.goal for task in self.tasks):
            raise InvalidSettingError(
                "a whole-body problem needs at least one goal task (posture and regularisation are not goals)"
            )
        if isinstance(contacts, str):
            contacts = [contacts]
        if isinstance(contacts, Mapping):
            self.contacts = {
                str(frame): (None if placement is None else pin.SE3(placement))
                for frame, placement in contacts.items()
            }
        else:
            self.contacts = {str(frame): None for frame in contacts}
        self.point_contacts = frozenset(frame for frame in self.contacts if is_point_foot(robot, frame))
        corners = robot.soles
        if support is None:
            support = [frame for frame in self.contacts if frame in corners]
        if isinstance(support, str):
            support = [support]
        self.support = [str(frame) for frame in support]
        for frame in [*self.contacts, *self.support]:
            robot.frame_id(frame)  # UnknownFrameError names the frames
        missing = [frame for frame in self.support if frame not in corners]
        if missing:
            from wbik.errors import RobotDescriptionError

            raise RobotDescriptionError(
                f"support frames {missing} have no sole contact points on {robot.name!r} "
                f"(robot.soles lists {sorted(corners)})"
            )
        if (
            isinstance(margin, bool)
            or not isinstance(margin, numbers.Real)
            or not math.isfinite(margin)
            or margin < 0
        ):
            raise InvalidSettingError(f"margin must be a finite number >= 0 (m), got {margin!r}")
        self.margin = float(margin)
        if limits not in LIMITS:
            raise InvalidSettingError(f"limits must be one of {', '.join(LIMITS)}, got {limits!r}")
        self.limits = limits
        if isinstance(step_dt, bool) or not isinstance(step_dt, numbers.Real) or not step_dt > 0:
            raise InvalidSettingError(f"step_dt must be a positive number (s), got {step_dt!r}")
        self.step_dt = float(step_dt)
        self.acceleration_limit = self._acceleration(robot, acceleration_limit)
        self.collisions = [self._distance(item) for item in (collisions or ())]
        for item in self.collisions:
            robot.frame_id(item.frame_a)
            robot.frame_id(item.frame_b)
        names = [task.name for task in self.tasks]
        self.task_names = [
            name if names.count(name) == 1 else f"{name}#{index}" for index, name in enumerate(names)
        ]

    @staticmethod
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
        raise InvalidSettingError(f"acceleration_limit must be one number > 0 or {nv} numbers >= 0 "
                                  f"(rad/s^2), got {value!r}")

    @staticmethod
    def _distance(item) -> MinimumDistance:
        if isinstance(item, MinimumDistance):
            return item
        if isinstance(item, Mapping):
            frames = item.get("frames", ())
            item = (*frames, item.get("distance"))
        try:
            frame_a, frame_b, distance = item
            return MinimumDistance(str(frame_a), str(frame_b), float(distance))
        except (TypeError, ValueError):
            raise InvalidSettingError(
                f"a collision entry is (frame_a, frame_b, distance m) or "
                f"{{frames: [a, b], distance: m}}, got {item!r}"
            ) from None

    def __repr__(self) -> str:
        return (
            f"WholeBody({self.robot.name}, {len(self.tasks)} tasks, contacts={list(self.contacts)}, "
            f"support={self.support}, margin={self.margin:g})"
        )

    @property
    def goal_tasks(self) -> list[tuple[str, Task]]:
        return [(name, task) for name, task in zip(self.task_names, self.tasks, strict=True) if task.goal]

    # -- from a task-file entry ------------------------------------------------------------------
    @classmethod
    def from_dict(cls, robot: Robot, data: Mapping, q: np.ndarray | None = None) -> WholeBody:
        """A problem from a task-file mapping, targets resolved at q (default: the robot's nominal).

        Keys: ``tasks`` (entries as in a ``wholebody_ik`` phase: type frame | position | orientation |
        relative | com | posture | regularization or a type registered in :mod:`wbik.qp.task_entries`,
        with target / keep / offset / over), ``contacts``,
        ``support``, ``margin``, ``limits``, ``collisions`` ([{frames: [a, b], distance: m}]),
        ``step_dt``, ``acceleration_limit``, ``name``.
        """
        from wbik.qp.task_entries import build_task

        if not isinstance(data, Mapping):
            raise InvalidSettingError(
                f"a whole-body problem is a mapping (tasks, contacts, ...), got {data!r}"
            )
        known = {"tasks", "contacts", "support", "margin", "limits", "collisions", "name", "step_dt",
                 "acceleration_limit"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InvalidSettingError(
                f"unknown key(s) {unknown} in a whole-body problem; allowed: {', '.join(sorted(known))}"
            )
        q = robot.nominal.copy() if q is None else np.asarray(q, dtype=float)
        entries = data.get("tasks") or []
        if not isinstance(entries, list):
            raise InvalidSettingError("tasks must be a list of task entries ({type: frame, frame: ..., ...})")
        tasks = [build_task(robot, q, entry) for entry in entries]
        return cls(
            robot,
            tasks,
            contacts=list(data.get("contacts") or []),
            support=data.get("support"),
            margin=data.get("margin", 0.005),
            limits=data.get("limits", "position+velocity"),
            collisions=data.get("collisions"),
            step_dt=data.get("step_dt", 1.0),
            acceleration_limit=data.get("acceleration_limit"),
            name=str(data.get("name", "") or ""),
        )

    # -- resolved at a start configuration -------------------------------------------------------
    def contact_placements(self, q0: np.ndarray) -> dict[str, pin.SE3]:
        """Where each contact is held: its given placement, else its placement at q0."""
        return {
            frame: (placement.copy() if placement is not None else self.robot.frame_placement(q0, frame))
            for frame, placement in self.contacts.items()
        }

    def support_polygon(self, q: np.ndarray):
        """The support polygon of the support soles at q (None without support); a support that spans
        no area raises DegenerateSupportPolygonError naming the soles (no hard CoM constraint on it)."""
        if not self.support:
            return None
        from wbik.qp.support_polygon import feet_support_polygon

        return feet_support_polygon(
            Kinematics(self.robot.model, q), self.robot.soles, self.support
        )

    def support_region(self, kinematics: Kinematics):
        """The support polygon at the kinematics' q, or the DegenerateSupport its points collapse to
        (for the check, which reports instead of raising); None without support."""
        if not self.support:
            return None
        from wbik.qp.support_polygon import feet_support_region

        return feet_support_region(kinematics, self.robot.soles, self.support)

    def contact_error(self, kinematics: Kinematics, frame: str, held: pin.SE3) -> tuple[float, float]:
        """(position error m, rotation error rad) of contact ``frame`` at the kinematics' q against
        ``held``; the rotation error of a point foot is 0 (its rotation is free)."""
        reached = kinematics.placement(kinematics.frame_id(frame))
        position = float(np.linalg.norm(reached.translation - held.translation))
        if frame in self.point_contacts:
            return position, 0.0
        return position, rotation_angle(reached.rotation, held.rotation)

    def check_q(self, q, what: str = "q0") -> np.ndarray:
        array = np.asarray(q, dtype=float).reshape(-1) if q is not None else None
        if array is None or array.shape != (self.robot.model.nq,) or not np.all(np.isfinite(array)):
            raise InvalidConfigurationError(
                f"{what} must be {self.robot.model.nq} finite values for {self.robot.name!r}, got {q!r}"
            )
        return array.copy()

    def copied_tasks(self) -> list[Task]:
        """Fresh copies of the tasks (a task keeps buffers and frame ids: one copy per solve)."""
        return [copy.deepcopy(task) for task in self.tasks]

    def constraints(self, placements: Mapping[str, pin.SE3], polygon=None) -> list[Constraint]:
        """The problem's hard constraints as :mod:`wbik.qp.constraints` (what ``qp`` solves with, and
        what the peers express in their own terms): each contact held at ``placements`` (a point
        foot: its position), the CoM in ``polygon`` (the support polygon, None for none) shrunk by
        the margin, the limits (velocity: v_max ``step_dt`` per IK step), the acceleration limits
        (an IK step is a period of ``step_dt``, solved at dt 1) and the minimum distances."""
        from wbik.qp.constraints import CoMInSupportPolygon
        from wbik.qp.constraints import JointAccelerationLimits
        from wbik.qp.constraints import JointPositionLimits
        from wbik.qp.constraints import JointVelocityLimits
        from wbik.qp.constraints import MinimumDistance as DistanceConstraint
        from wbik.qp.humanoid import contact_constraint

        model = self.robot.model
        constraints: list[Constraint] = [contact_constraint(self.robot, frame, held)
                                         for frame, held in placements.items()]
        if polygon is not None:
            constraints.append(CoMInSupportPolygon(polygon, self.margin))
        if self.limits != "none":
            constraints.append(JointPositionLimits(model))
        if self.limits == "position+velocity":
            constraints.append(JointVelocityLimits(model, model.velocityLimit * self.step_dt))
        if self.acceleration_limit is not None:
            constraints.append(JointAccelerationLimits(model, np.multiply(self.acceleration_limit,
                                                                          self.step_dt ** 2)))
        constraints += [DistanceConstraint(c.frame_a, c.frame_b, c.distance) for c in self.collisions]
        return constraints


@dataclass
class WholeBodyResult:
    """The answer of every whole-body method, judged by :func:`check_wholebody`.

    ``task_errors``: goal task name -> max(position error m, rotation error rad) at q;
    ``contact_drift``: the largest contact error (m or rad), 0 without contacts; ``com_margin``: m
    inside the support polygon (NaN without support); ``limit_excess``: rad or m beyond the limits;
    ``collision_clearance``: min (distance - required) m (NaN without pairs); ``unsupported``:
    what the method could not express (it solved the problem without it); ``diagnosis``: why a
    method that explains itself (``qp``) did not succeed - the constraints active at the answer, the
    tasks in conflict with the goals, an infeasible step's conflicting rows, a start outside the
    limits (:class:`wbik.qp.diagnosis.Diagnosis`; its summary ends ``reason``) - or None.
    """

    q: np.ndarray | None
    success: bool
    reason: str
    task_errors: dict[str, float]
    contact_drift: float
    com_margin: float
    limit_excess: float
    time_s: float
    iterations: int
    method: str = ""
    unsupported: list[str] = field(default_factory=list)
    collision_clearance: float = math.nan
    task_position_errors: dict[str, float] = field(default_factory=dict)
    task_rotation_errors: dict[str, float] = field(default_factory=dict)
    extra: dict = field(default_factory=dict)
    diagnosis: Diagnosis | None = None

    @property
    def task_error(self) -> float:
        """The largest goal task error (m or rad), NaN without joints."""
        return max(self.task_errors.values(), default=0.0) if self.q is not None else math.nan

    @property
    def complete(self) -> bool:
        """True when the method expressed the whole problem (nothing in ``unsupported``)."""
        return not self.unsupported

    JSON_FIELDS = ("method", "success", "reason", "q", "task_errors", "contact_drift", "com_margin",
                   "limit_excess", "collision_clearance", "time_s", "iterations", "unsupported", "diagnosis")
    """The fields :meth:`as_dict` gives."""

    def as_dict(self) -> dict:
        """JSON-friendly dictionary of the ``JSON_FIELDS`` (the diagnosis as its ``as_dict``)."""
        values = {name: getattr(self, name) for name in self.JSON_FIELDS}
        if self.diagnosis is not None:
            values["diagnosis"] = self.diagnosis.as_dict()
        return json_plain(values)


def task_error_parts(task: Task, kinematics: Kinematics) -> tuple[float | None, float | None]:
    """(position error m or None, rotation error rad or None) of one task at the kinematics' q, as
    the task splits its error (:meth:`wbik.qp.tasks.Task.error_parts`)."""
    return task.error_parts(np.asarray(task.error(kinematics), dtype=float))


def _limit_excess(robot: Robot, q: np.ndarray) -> float:
    from wbik.qp.constraints import bounded_joint_indices

    index, _ = bounded_joint_indices(robot.model)
    if index.size == 0:
        return 0.0
    joints = q[index]
    lower, upper = robot.model.lowerPositionLimit[index], robot.model.upperPositionLimit[index]
    return float(max(np.max(lower - joints), np.max(joints - upper), 0.0))


def _without_joints(
    problem: WholeBody,
    reason: str,
    time_s: float,
    iterations: int,
    method: str,
    unsupported: list[str],
    extra: dict,
) -> WholeBodyResult:
    """The failed result of an answer without usable joints: every error and margin NaN."""
    return WholeBodyResult(
        q=None,
        success=False,
        reason=reason,
        task_errors={name: math.nan for name, _ in problem.goal_tasks},
        contact_drift=math.nan,
        com_margin=math.nan,
        limit_excess=math.nan,
        time_s=time_s,
        iterations=iterations,
        method=method,
        unsupported=unsupported,
        extra=extra,
    )


def check_wholebody(
    problem: WholeBody,
    q,
    tolerances: Tolerances | None = None,
    *,
    q0: np.ndarray | None = None,
    contact_placements: Mapping[str, pin.SE3] | None = None,
    method: str = "",
    time_s: float = math.nan,
    iterations: int = 0,
    reason: str = "",
    unsupported: Sequence[str] = (),
    extra: dict | None = None,
) -> WholeBodyResult:
    """The shared whole-body check of configuration q (see the module docstring).

    Contacts are measured against ``contact_placements``, else the problem's given placements, else
    their placements at ``q0`` (one of these is needed when the problem has contacts).
    """
    tolerances = tolerances or Tolerances()
    unsupported = list(unsupported)
    extra = dict(extra or {})
    if q is None:
        return _without_joints(
            problem, reason or "no configuration", time_s, iterations, method, unsupported, extra
        )
    q = np.asarray(q, dtype=float).reshape(-1)
    if q.shape != (problem.robot.model.nq,) or not np.all(np.isfinite(q)):
        return _without_joints(
            problem, invalid_joints_reason(q), time_s, iterations, method, unsupported, extra
        )
    if problem.robot.has_floating_base:  # a unit quaternion, whatever the method returned
        q = q.copy()
        q[3:7] /= np.linalg.norm(q[3:7])
    robot = problem.robot
    kinematics = Kinematics(robot.model, q)
    failures: list[str] = []
    task_errors, position_errors, rotation_errors = {}, {}, {}
    for name, task in zip(problem.task_names, problem.copied_tasks(), strict=True):
        if not task.goal:
            continue
        task.start(kinematics)
        position, rotation = task_error_parts(task, kinematics)
        parts = [value for value in (position, rotation) if value is not None]
        task_errors[name] = max(parts)
        for part, error, errors, tolerance, unit in (
            ("position", position, position_errors, tolerances.position, "m"),
            ("rotation", rotation, rotation_errors, tolerances.rotation, "rad"),
        ):
            if error is not None:
                errors[name] = error
                if error > tolerance:
                    failures.append(f"task {name} {part} error {error:.3g} {unit}")
    if contact_placements is None and problem.contacts:
        if all(p is not None for p in problem.contacts.values()):
            contact_placements = problem.contact_placements(q)  # every placement is given
        elif q0 is None:
            raise InvalidSettingError(
                "check_wholebody needs q0 (or contact_placements) to know where the contacts are held"
            )
        else:
            contact_placements = problem.contact_placements(problem.check_q(q0))
    drift = 0.0
    for frame, held in (contact_placements or {}).items():
        position, rotation = problem.contact_error(kinematics, frame, held)
        drift = max(drift, position, rotation)
        if position > tolerances.position or rotation > tolerances.rotation:
            failures.append(f"contact {frame} drifted {position:.3g} m, {rotation:.3g} rad")
    com_margin = math.nan
    region = problem.support_region(kinematics)
    if region is not None:
        com_margin = region.margin_of(kinematics.com()[:2])
        if isinstance(region, DegenerateSupport):
            shape = "a segment" if len(region.vertices) == 2 else "a point"
            failures.append(f"support polygon is degenerate (the support spans no area: {shape}), CoM "
                            f"{-com_margin * 1e3:.3g} mm from it")
        elif com_margin < problem.margin - MARGIN_SLACK:
            failures.append(f"CoM margin {com_margin * 1e3:.3g} mm < {problem.margin * 1e3:g} mm")
    limit_excess = _limit_excess(robot, q) if problem.limits != "none" else 0.0
    if limit_excess > LIMIT_SLACK:
        failures.append(f"a joint {limit_excess:.3g} beyond its limits")
    clearance = math.nan
    for pair in problem.collisions:
        a = kinematics.placement(kinematics.frame_id(pair.frame_a)).translation
        b = kinematics.placement(kinematics.frame_id(pair.frame_b)).translation
        value = float(np.linalg.norm(a - b)) - pair.distance
        clearance = value if math.isnan(clearance) else min(clearance, value)
    if not math.isnan(clearance) and clearance < -LIMIT_SLACK:
        failures.append(f"a minimum distance broken by {-clearance:.3g} m")
    success = not failures
    if success:
        reason = ""
    else:
        check = "check failed: " + "; ".join(failures[:3]) + ("; ..." if len(failures) > 3 else "")
        reason = f"{reason} ({check})" if reason else check
    return WholeBodyResult(
        q,
        success,
        reason,
        task_errors,
        drift,
        com_margin,
        limit_excess,
        time_s,
        iterations,
        method,
        unsupported,
        clearance,
        position_errors,
        rotation_errors,
        extra,
    )
