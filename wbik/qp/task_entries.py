"""Task entries: the mapping form of a QP task (a ``wholebody_ik`` phase, ``WholeBody.from_dict``).

``build_task(robot, q, entry)`` turns one entry into a :mod:`wbik.qp.tasks` task whose target is
resolved at the configuration q (world frame, m and rad)::

    {type: frame, frame: r_hand, target: [x, y, z], rpy: [r, p, y]}   # absolute pose
    {type: position, frame: r_hand, offset: [0.04, 0, 0]}              # start position + offset
    {type: orientation, frame: pelvis, keep: true, weight: 0.1, goal: false}
    {type: relative, frame: l_eef, reference: r_eef, offset: [0, 0.1, 0]}   # in the reference frame
    {type: com, over: r_sole, axes: xy}                                # above that frame's origin
    {type: posture, reference: nominal | start, joints: [...]}
    {type: regularization, weight: 1e-6}

A frame-like target (frame, position, orientation) is ``target`` (position; the rotation is ``rpy``
if given, else the start's), or the start placement with ``offset`` added to its position (world
axes) and ``rpy`` replacing its rotation; ``keep: true`` (or nothing) holds the start placement.
A relative target is the child's placement in the reference frame at q, or ``target`` [+ ``rpy``],
or that placement with ``offset`` added (reference axes). A CoM target is ``target``, or the
start CoM with ``over``'s origin as its x and y, or the start CoM plus ``offset``.

Options passed to the task: weight, goal, priority, tolerance, gain, name (and position_weight,
orientation_weight for ``frame``). An entry that cannot be built raises :class:`TaskEntryError`.
Scenario files are checked against their schema first (:mod:`wbik.scenarios.wholebody`), so
these errors are what a Python caller sees.

Every entry type is declared by a :class:`TaskEntry`: its ``type``, the task class, its own keys (by
kind, :data:`KEY_KINDS`; the task-file schema is made from them), the keys it requires and its builder.
A module declares its entry types in a ``TASK_ENTRIES`` tuple and is listed in
:data:`TASK_ENTRY_MODULES` (imported on first use, :class:`wbik.registry.DeclaredRegistry`); user code
adds one with :func:`register_task_entry`. The types above are declared here.
"""

from __future__ import annotations

from collections.abc import Callable
from collections.abc import Mapping
from dataclasses import dataclass
from dataclasses import field
from typing import Any

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidSettingError
from wbik.errors import UnknownFrameError
from wbik.qp.tasks import ComTask
from wbik.qp.tasks import FrameTask
from wbik.qp.tasks import OrientationTask
from wbik.qp.tasks import PositionTask
from wbik.qp.tasks import PostureTask
from wbik.qp.tasks import RegularizationTask
from wbik.qp.tasks import RelativeFrameTask
from wbik.qp.tasks import Task
from wbik.registry import DeclaredRegistry
from wbik.registry import RegistryError
from wbik.validation import finite_vector

__all__ = ["KEY_KINDS", "TASK_ENTRIES", "TASK_ENTRY_MODULES", "TASK_ENTRY_REGISTRY", "TASK_OPTIONS",
           "TaskEntry", "TaskEntryError", "build_task", "com_target", "entry_vector", "frame_target",
           "register_task_entry", "relative_target", "task_types"]

TASK_OPTIONS = ("weight", "goal", "priority", "tolerance", "gain", "name")
"""Keys every task type passes to its :class:`wbik.qp.tasks.Task` (unless its entry says otherwise)."""
REGULARIZATION_WEIGHT = 1e-6
"""Weight of a ``regularization`` entry that gives none (and of a wholebody_ik phase's)."""
KEY_KINDS = {
    "frame": "a frame name of the robot",
    "vector3": "3 numbers (m or rad)",
    "boolean": "true or false",
    "axes": "a non-empty subset of xyz, each once",
    "non_negative": "a number >= 0",
    "positive": "a number > 0",
    "length": "a number (m)",
    "joint_names": "a list of joint names",
}
"""The kinds of an entry's own keys, as :attr:`TaskEntry.keys` names them (a tuple of words instead:
one of those words). The task-file schema gives each kind its node (:mod:`wbik.scenarios.wholebody`)."""


class TaskEntryError(InvalidSettingError):
    """A task entry with an unknown type, a missing frame, or a target that is not 3 finite numbers."""


Builder = Callable[[Any, np.ndarray, Mapping, dict], Task]
"""``build(robot, q, entry, options) -> Task``: ``options`` holds the entry's :attr:`TaskEntry.options`."""


@dataclass(frozen=True)
class TaskEntry:
    """One entry type: ``name`` (the entry's ``type``), the ``task`` class it builds, ``build(robot, q,
    entry, options)``, its own ``keys`` ({key: a kind of :data:`KEY_KINDS`, a tuple of allowed words,
    or a :mod:`wbik.scenario_schema` node}), the keys it ``requires``, the Task ``options`` it takes from
    the entry (default :data:`TASK_OPTIONS`) and a one-line ``description``."""

    name: str
    task: type[Task]
    build: Builder
    keys: Mapping[str, Any] = field(default_factory=dict)
    required: tuple[str, ...] = ()
    options: tuple[str, ...] = TASK_OPTIONS
    description: str = ""

    def __post_init__(self) -> None:
        if not (isinstance(self.task, type) and issubclass(self.task, Task)):
            raise RegistryError(f"task entry {self.name!r}: task must be a wbik.qp.tasks.Task subclass, "
                                f"got {self.task!r}")
        unknown = [key for key in (*self.required, *self.options) if key not in self.keys
                   and key not in TASK_OPTIONS]
        if unknown:
            raise RegistryError(f"task entry {self.name!r}: {unknown} are neither its keys nor task options")
        kinds = [kind for kind in self.keys.values() if isinstance(kind, str) and kind not in KEY_KINDS]
        if kinds:
            raise RegistryError(f"task entry {self.name!r}: unknown key kind(s) {kinds}; the kinds are "
                                f"{', '.join(KEY_KINDS)}")


# -- what builders share -----------------------------------------------------------------------------------
def entry_vector(value, size: int, what: str) -> np.ndarray:
    """``value`` as ``size`` finite numbers, else a TaskEntryError naming ``what``."""
    return finite_vector(value, size, what, TaskEntryError)


def _rotation(entry: Mapping) -> np.ndarray:
    return pin.rpy.rpyToMatrix(*entry_vector(entry["rpy"], 3, "rpy"))


def _placement(robot, q: np.ndarray, frame: str) -> pin.SE3:
    try:
        return robot.frame_placement(q, frame)
    except UnknownFrameError as exc:
        raise TaskEntryError(str(exc)) from exc


def frame_target(robot, q: np.ndarray, entry: Mapping, frame: str) -> pin.SE3:
    """World target of a frame-like entry (keep / offset / target [+ rpy]), see the module notes."""
    start = _placement(robot, q, frame)
    if "target" in entry:
        rotation = _rotation(entry) if "rpy" in entry else start.rotation
        return pin.SE3(rotation, entry_vector(entry["target"], 3, "target"))
    placement = start.copy()
    if "offset" in entry:
        placement.translation = start.translation + entry_vector(entry["offset"], 3, "offset")
    if "rpy" in entry:
        placement.rotation = _rotation(entry)
    return placement


def relative_target(robot, q: np.ndarray, entry: Mapping, frame: str, reference: str) -> pin.SE3:
    """``frame`` in ``reference`` axes: the placement at q, or target [+ rpy], or + offset."""
    relative = _placement(robot, q, reference).actInv(_placement(robot, q, frame))
    if "target" in entry:
        rotation = _rotation(entry) if "rpy" in entry else relative.rotation
        return pin.SE3(rotation, entry_vector(entry["target"], 3, "target"))
    if "offset" in entry:
        relative.translation = relative.translation + entry_vector(entry["offset"], 3, "offset")
    return relative


def com_target(robot, q: np.ndarray, entry: Mapping) -> np.ndarray:
    """A CoM entry's target: ``target``, or the start CoM under ``over``'s origin, or + ``offset``."""
    com = robot.center_of_mass(q)
    if "target" in entry:
        return entry_vector(entry["target"], 3, "com target")
    if "over" in entry:
        above = _placement(robot, q, entry["over"]).translation
        return np.array([above[0], above[1], com[2]])
    return com + entry_vector(entry.get("offset", [0, 0, 0]), 3, "offset")


# -- the core's entry types ----------------------------------------------------------------------------
def _frame(robot, q, entry, options) -> FrameTask:
    for key in ("position_weight", "orientation_weight"):
        if key in entry:
            options[key] = float(entry[key])
    return FrameTask(entry["frame"], frame_target(robot, q, entry, entry["frame"]), **options)


def _position(robot, q, entry, options) -> PositionTask:
    frame = entry["frame"]
    target = frame_target(robot, q, entry, frame).translation
    return PositionTask(frame, target, axes=entry.get("axes", "xyz"), **options)


def _orientation(robot, q, entry, options) -> OrientationTask:
    return OrientationTask(entry["frame"], frame_target(robot, q, entry, entry["frame"]).rotation, **options)


def _relative(robot, q, entry, options) -> RelativeFrameTask:
    frame, reference = entry["frame"], entry["reference"]
    return RelativeFrameTask(frame, reference, relative_target(robot, q, entry, frame, reference), **options)


def _com(robot, q, entry, options) -> ComTask:
    return ComTask(com_target(robot, q, entry), axes=entry.get("axes", "xyz"), **options)


def _posture(robot, q, entry, options) -> PostureTask:
    reference = robot.nominal if entry.get("reference", "nominal") == "nominal" else q
    return PostureTask(reference, joints=entry.get("joints"), **options)


def _regularization(robot, q, entry, options) -> RegularizationTask:
    return RegularizationTask(float(entry.get("weight", REGULARIZATION_WEIGHT)))


_V, _FRAME = "vector3", "frame"
TASK_ENTRIES = (
    TaskEntry("frame", FrameTask, _frame,
              {"frame": _FRAME, "target": _V, "rpy": _V, "offset": _V, "keep": "boolean",
               "position_weight": "non_negative", "orientation_weight": "non_negative"},
              required=("frame",), description="a frame's pose in the world"),
    TaskEntry("position", PositionTask, _position,
              {"frame": _FRAME, "target": _V, "offset": _V, "keep": "boolean", "axes": "axes"},
              required=("frame",), description="a frame's origin in the world, on some axes"),
    TaskEntry("orientation", OrientationTask, _orientation, {"frame": _FRAME, "rpy": _V, "keep": "boolean"},
              required=("frame",), description="a frame's orientation in the world"),
    TaskEntry("relative", RelativeFrameTask, _relative,
              {"frame": _FRAME, "reference": _FRAME, "target": _V, "rpy": _V, "offset": _V,
               "keep": "boolean"},
              required=("frame", "reference"), description="a frame's pose in another frame"),
    TaskEntry("com", ComTask, _com,
              {"target": _V, "over": _FRAME, "offset": _V, "keep": "boolean", "axes": "axes"},
              description="the centre of mass in the world, on some axes"),
    TaskEntry("posture", PostureTask, _posture, {"reference": ("nominal", "start"), "joints": "joint_names"},
              description="joints toward the nominal or the start configuration"),
    TaskEntry("regularization", RegularizationTask, _regularization, {"weight": "positive"}, options=(),
              description="small steps (weight |dq|^2)"),
)
"""The core's entry types (see the module docstring)."""

TASK_ENTRY_MODULES: list = []
"""The sources of the registry's modules: :mod:`wbik.catalog` adds this one (the core's entries), user code
a module by name or an entry (:func:`register_task_entry`)."""

TASK_ENTRY_REGISTRY: DeclaredRegistry[TaskEntry] = DeclaredRegistry(
    "task entry type", "TASK_ENTRIES", TASK_ENTRY_MODULES, "wbik.qp.task_entries.TASK_ENTRY_MODULES",
    TaskEntry)

register_task_entry = TASK_ENTRY_REGISTRY.register
"""Add an entry type from user code (``replace`` one of the same name only when asked)."""


def task_types() -> list[str]:
    """The entry types, in the order they were declared."""
    return list(TASK_ENTRY_REGISTRY.entries())


def build_task(robot, q: np.ndarray, entry: Mapping) -> Task:
    """The :mod:`wbik.qp.tasks` task of one entry, its target resolved at configuration q."""
    if not isinstance(entry, Mapping) or "type" not in entry:
        raise TaskEntryError(f"a task entry needs a 'type' (one of {', '.join(task_types())}), got {entry!r}")
    kind = entry["type"]
    declared = TASK_ENTRY_REGISTRY.entries().get(kind) if isinstance(kind, str) else None
    if declared is None:
        raise TaskEntryError(f"unknown task type {kind!r}; use {', '.join(task_types())}")
    for key in declared.required:
        if not entry.get(key):
            raise TaskEntryError(f"task type {kind!r} needs a {key!r}")
    options = {key: entry[key] for key in declared.options if key in entry}
    return declared.build(robot, q, entry, options)
