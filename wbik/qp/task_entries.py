"""Task entries: the mapping form of a QP task (a ``wholebody_ik`` phase, ``WholeBody.from_dict``).

``build_task(robot, q, entry)`` makes the task, its target resolved at q (world frame, m and rad)::

    {type: frame, frame: r_hand, target: [x, y, z], rpy: [r, p, y]}   # absolute pose
    {type: position, frame: r_hand, offset: [0.04, 0, 0]}              # start position + offset
    {type: orientation, frame: pelvis, keep: true, weight: 0.1, goal: false}
    {type: relative, frame: l_eef, reference: r_eef, offset: [0, 0.1, 0]}   # in the reference frame
    {type: com, over: r_sole, axes: xy}                                # above that frame's origin
    {type: posture, reference: nominal | start, joints: [...]}
    {type: regularization, weight: 1e-6}

A frame-like target is ``target`` (the rotation ``rpy`` if given, else the start's), or the start
placement with ``offset`` added to its position (world axes) and ``rpy`` replacing its rotation (``keep``
or nothing: the start placement); a relative one the same in the reference frame's axes, ``rpy`` only with
``target``. A CoM target is ``target``, or the start CoM under ``over``'s origin, or plus ``offset``.

A :class:`TaskEntry` declares an entry type: in a module's ``TASK_ENTRIES`` (:data:`TASK_ENTRY_MODULES`)
or by :func:`register_task_entry`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from wbik.errors import UnknownFrameError
from wbik.qp.tasks import (
    ComTask,
    FrameTask,
    OrientationTask,
    PositionTask,
    PostureTask,
    RegularizationTask,
    RelativeFrameTask,
    Task,
)
from wbik.registry import DeclaredRegistry, RegistryError
from wbik.schema import (
    Boolean,
    Context,
    Either,
    Errors,
    Key,
    ListOf,
    Map,
    Node,
    Number,
    SchemaValueError,
    Text,
    UnknownKeyError,
    Variants,
    Vector,
)

__all__ = ["AXES", "FRAME", "NON_NEGATIVE", "POSITIVE", "TASK_ENTRIES", "TASK_ENTRY", "TASK_ENTRY_MODULES",
           "TASK_ENTRY_REGISTRY", "TASK_OPTIONS", "VECTOR3", "TaskEntry", "TaskEntryError", "build_task",
           "com_target", "frame_target", "register_task_entry"]

TASK_OPTIONS = ("weight", "goal", "priority", "tolerance", "gain", "name")
"""Keys every task type passes to its :class:`wbik.qp.tasks.Task` (unless its entry says otherwise)."""
REGULARIZATION_WEIGHT = 1e-6
"""Weight of a ``regularization`` entry that gives none (and of a wholebody_ik phase's)."""
FRAME = Text(what="a frame name")
VECTOR3 = Vector(3)
POSITIVE, NON_NEGATIVE = Number(gt=0), Number(ge=0)
AXES = Text(pattern=r"(?!.*(.).*\1)[xyz]+\Z", what="a subset of 'xyz', each axis once (e.g. xy)")
TASK_OPTION_KEYS = {"type": Key(Text()), "name": Key(Text()), "weight": Key(Either(NON_NEGATIVE, Vector())),
                    "goal": Key(Boolean()), "priority": Key(Number(integer=True)),
                    "tolerance": Key(POSITIVE), "gain": Key(POSITIVE)}
"""The keys of the Task options (:data:`TASK_OPTIONS`)."""


class TaskEntryError(SchemaValueError):
    """A task entry with an unknown type, a missing key, a wrong value or an unknown frame."""


class UnknownTaskKeyError(TaskEntryError, UnknownKeyError):
    """A key a task entry's type does not read."""


TASK_ENTRY_ERRORS = Errors(TaskEntryError, UnknownTaskKeyError, TaskEntryError)
Builder = Callable[[Any, np.ndarray, Mapping, dict], Task]
"""``build(robot, q, entry, options) -> Task``: ``options`` holds the entry's :attr:`TaskEntry.options`."""


@dataclass(frozen=True)
class TaskEntry:
    """One entry type: ``name`` (the entry's ``type``), the ``task`` class, ``build(robot, q, entry,
    options)``, its own ``keys`` ({key: a :mod:`wbik.schema` node}), those it ``requires``, the Task
    ``options`` it takes (default :data:`TASK_OPTIONS`) and a one-line ``description``."""

    name: str
    task: type[Task]
    build: Builder
    keys: Mapping[str, Node] = field(default_factory=dict)
    required: tuple[str, ...] = ()
    options: tuple[str, ...] = TASK_OPTIONS
    description: str = ""

    def __post_init__(self) -> None:
        if not (isinstance(self.task, type) and issubclass(self.task, Task)):
            raise RegistryError(f"task entry {self.name!r}: task must be a wbik.qp.tasks.Task subclass, "
                                f"got {self.task!r}")
        if unknown := [key for key in (*self.required, *self.options) if key not in self.keys
                       and key not in TASK_OPTIONS]:
            raise RegistryError(f"task entry {self.name!r}: {unknown} are neither its keys nor task options")
        if loose := {key: node for key, node in self.keys.items() if not isinstance(node, Node)}:
            raise RegistryError(f"task entry {self.name!r}: each key is a wbik.schema node (FRAME, VECTOR3, "
                                f"Number(...), ...), got {loose}")

    def schema(self) -> Map:
        """The entry's node: ``type``, the task options it takes and its own keys."""
        keys = {key: rule for key, rule in TASK_OPTION_KEYS.items() if key == "type" or key in self.options}
        return Map(keys | {key: Key(node, required=key in self.required) for key, node in self.keys.items()})


# -- what builders share -----------------------------------------------------------------------------------
def _placement(robot, q: np.ndarray, frame: str) -> pin.SE3:
    try:
        return robot.frame_placement(q, frame)
    except UnknownFrameError as exc:
        raise TaskEntryError(str(exc)) from exc


def frame_target(robot, q: np.ndarray, entry: Mapping, frame: str, reference: str | None = None) -> pin.SE3:
    """Target of a frame-like entry in the world, or in ``reference``'s axes (see the module notes)."""
    start = _placement(robot, q, frame)
    if reference is not None:
        start = _placement(robot, q, reference).actInv(start)
    if "target" in entry:
        rotation = pin.rpy.rpyToMatrix(*entry["rpy"]) if "rpy" in entry else start.rotation
        return pin.SE3(rotation, np.array(entry["target"], dtype=float))
    placement = start.copy()
    if "offset" in entry:
        placement.translation = start.translation + np.array(entry["offset"], dtype=float)
    if "rpy" in entry and reference is None:
        placement.rotation = pin.rpy.rpyToMatrix(*entry["rpy"])
    return placement


def com_target(robot, q: np.ndarray, entry: Mapping) -> np.ndarray:
    """A CoM entry's target: ``target``, or the start CoM under ``over``'s origin, or + ``offset``."""
    com = robot.center_of_mass(q)
    if "target" in entry:
        return np.array(entry["target"], dtype=float)
    if "over" in entry:
        above = _placement(robot, q, entry["over"]).translation
        return np.array([above[0], above[1], com[2]])
    return com + np.array(entry.get("offset", [0, 0, 0]), dtype=float)


# -- the core's entry types ----------------------------------------------------------------------------
def _frame(robot, q, entry, options) -> FrameTask:
    options |= {key: float(entry[key]) for key in ("position_weight", "orientation_weight") if key in entry}
    return FrameTask(entry["frame"], frame_target(robot, q, entry, entry["frame"]), **options)


def _position(robot, q, entry, options) -> PositionTask:
    target = frame_target(robot, q, entry, entry["frame"]).translation
    return PositionTask(entry["frame"], target, axes=entry.get("axes", "xyz"), **options)


def _orientation(robot, q, entry, options) -> OrientationTask:
    return OrientationTask(entry["frame"], frame_target(robot, q, entry, entry["frame"]).rotation, **options)


def _relative(robot, q, entry, options) -> RelativeFrameTask:
    frame, reference = entry["frame"], entry["reference"]
    return RelativeFrameTask(frame, reference, frame_target(robot, q, entry, frame, reference), **options)


def _com(robot, q, entry, options) -> ComTask:
    return ComTask(com_target(robot, q, entry), axes=entry.get("axes", "xyz"), **options)


def _posture(robot, q, entry, options) -> PostureTask:
    reference = robot.nominal if entry.get("reference", "nominal") == "nominal" else q
    return PostureTask(reference, joints=entry.get("joints"), **options)


def _regularization(robot, q, entry, options) -> RegularizationTask:
    return RegularizationTask(float(entry.get("weight", REGULARIZATION_WEIGHT)))


_V, _KEEP = VECTOR3, Boolean()
TASK_ENTRIES = (
    TaskEntry("frame", FrameTask, _frame,
              {"frame": FRAME, "target": _V, "rpy": _V, "offset": _V, "keep": _KEEP,
               "position_weight": NON_NEGATIVE, "orientation_weight": NON_NEGATIVE},
              required=("frame",), description="a frame's pose in the world"),
    TaskEntry("position", PositionTask, _position,
              {"frame": FRAME, "target": _V, "offset": _V, "keep": _KEEP, "axes": AXES},
              required=("frame",), description="a frame's origin in the world, on some axes"),
    TaskEntry("orientation", OrientationTask, _orientation, {"frame": FRAME, "rpy": _V, "keep": _KEEP},
              required=("frame",), description="a frame's orientation in the world"),
    TaskEntry("relative", RelativeFrameTask, _relative,
              {"frame": FRAME, "reference": FRAME, "target": _V, "rpy": _V, "offset": _V, "keep": _KEEP},
              required=("frame", "reference"), description="a frame's pose in another frame"),
    TaskEntry("com", ComTask, _com, {"target": _V, "over": FRAME, "offset": _V, "keep": _KEEP, "axes": AXES},
              description="the centre of mass in the world, on some axes"),
    TaskEntry("posture", PostureTask, _posture,
              {"reference": Text(("nominal", "start")),
               "joints": ListOf(Text(what="a joint name"), what="joint names")},
              description="joints toward the nominal or the start configuration"),
    TaskEntry("regularization", RegularizationTask, _regularization, {"weight": POSITIVE}, options=(),
              description="small steps (weight |dq|^2)"),
)
"""The core's entry types (see the module docstring)."""

TASK_ENTRY_MODULES: list = []
"""The registry's sources: :mod:`wbik.catalog` adds this module, user code a module by name."""

TASK_ENTRY_REGISTRY: DeclaredRegistry[TaskEntry] = DeclaredRegistry(
    "task entry type", "TASK_ENTRIES", TASK_ENTRY_MODULES, "wbik.qp.task_entries.TASK_ENTRY_MODULES",
    TaskEntry)

register_task_entry = TASK_ENTRY_REGISTRY.register
"""Add an entry type from user code (``replace`` one of the same name only when asked)."""


TASK_ENTRY = Variants(lambda entry: entry.get("type"),
                      lambda: {name: entry.schema() for name, entry in TASK_ENTRY_REGISTRY.entries().items()},
                      "a task mapping with a 'type'", "type")
"""The node of a task entry: one variant per entry type registered when it is checked."""


def build_task(robot, q: np.ndarray, entry: Mapping, source: str = "task entry") -> Task:
    """The task of one entry (checked, ``source`` naming it), its target resolved at configuration q."""
    entry = TASK_ENTRY.check(entry, "", Context(source, TASK_ENTRY_ERRORS))
    declared = TASK_ENTRY_REGISTRY.get(entry["type"])
    return declared.build(robot, q, entry, {key: entry[key] for key in declared.options if key in entry})
