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
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidSettingError
from wbik.errors import UnknownFrameError
from wbik.validation import finite_vector

__all__ = ["TASK_OPTIONS", "TASK_TYPES", "TaskEntryError", "build_task"]

TASK_TYPES = ("frame", "position", "orientation", "relative", "com", "posture", "regularization")
TASK_OPTIONS = ("weight", "goal", "priority", "tolerance", "gain", "name")
"""Keys every task type passes to its :class:`wbik.qp.tasks.Task`."""
REGULARIZATION_WEIGHT = 1e-6
"""Weight of a ``regularization`` entry that gives none (and of a wholebody_ik phase's)."""


class TaskEntryError(InvalidSettingError):
    """A task entry with an unknown type, a missing frame, or a target that is not 3 finite numbers."""


def _vector(value, size: int, what: str) -> np.ndarray:
    return finite_vector(value, size, what, TaskEntryError)


def _rotation(entry: Mapping) -> np.ndarray:
    return pin.rpy.rpyToMatrix(*_vector(entry["rpy"], 3, "rpy"))


def _placement(robot, q: np.ndarray, frame: str) -> pin.SE3:
    try:
        return robot.frame_placement(q, frame)
    except UnknownFrameError as exc:
        raise TaskEntryError(str(exc)) from exc


def _target_placement(robot, q: np.ndarray, entry: Mapping, frame: str) -> pin.SE3:
    """World target of a frame-like entry (keep / offset / target [+ rpy]), see the module notes."""
    start = _placement(robot, q, frame)
    if "target" in entry:
        rotation = _rotation(entry) if "rpy" in entry else start.rotation
        return pin.SE3(rotation, _vector(entry["target"], 3, "target"))
    placement = start.copy()
    if "offset" in entry:
        placement.translation = start.translation + _vector(entry["offset"], 3, "offset")
    if "rpy" in entry:
        placement.rotation = _rotation(entry)
    return placement


def _relative_target(robot, q: np.ndarray, entry: Mapping, frame: str, reference: str) -> pin.SE3:
    """``frame`` in ``reference`` axes: the placement at q, or target [+ rpy], or + offset."""
    relative = _placement(robot, q, reference).actInv(_placement(robot, q, frame))
    if "target" in entry:
        rotation = _rotation(entry) if "rpy" in entry else relative.rotation
        return pin.SE3(rotation, _vector(entry["target"], 3, "target"))
    if "offset" in entry:
        relative.translation = relative.translation + _vector(entry["offset"], 3, "offset")
    return relative


def _com_target(robot, q: np.ndarray, entry: Mapping) -> np.ndarray:
    com = robot.center_of_mass(q)
    if "target" in entry:
        return _vector(entry["target"], 3, "com target")
    if "over" in entry:
        above = _placement(robot, q, entry["over"]).translation
        return np.array([above[0], above[1], com[2]])
    return com + _vector(entry.get("offset", [0, 0, 0]), 3, "offset")


def build_task(robot, q: np.ndarray, entry: Mapping):
    """The :mod:`wbik.qp.tasks` task of one entry, its target resolved at configuration q."""
    from wbik.qp import tasks as T

    if not isinstance(entry, Mapping) or "type" not in entry:
        raise TaskEntryError(f"a task entry needs a 'type' (one of {', '.join(TASK_TYPES)}), got {entry!r}")
    kind = entry["type"]
    options = {key: entry[key] for key in TASK_OPTIONS if key in entry}
    frame = entry.get("frame")
    if kind in ("frame", "position", "orientation", "relative") and not frame:
        raise TaskEntryError(f"task type {kind!r} needs a 'frame'")
    if kind == "frame":
        for key in ("position_weight", "orientation_weight"):
            if key in entry:
                options[key] = float(entry[key])
        return T.FrameTask(frame, _target_placement(robot, q, entry, frame), **options)
    if kind == "position":
        return T.PositionTask(frame, _target_placement(robot, q, entry, frame).translation,
                              axes=entry.get("axes", "xyz"), **options)
    if kind == "orientation":
        return T.OrientationTask(frame, _target_placement(robot, q, entry, frame).rotation, **options)
    if kind == "relative":
        reference = entry.get("reference")
        if not reference:
            raise TaskEntryError("task type 'relative' needs a 'reference' frame")
        return T.RelativeFrameTask(frame, reference, _relative_target(robot, q, entry, frame, reference),
                                   **options)
    if kind == "com":
        return T.ComTask(_com_target(robot, q, entry), axes=entry.get("axes", "xyz"), **options)
    if kind == "posture":
        reference = robot.nominal if entry.get("reference", "nominal") == "nominal" else q
        return T.PostureTask(reference, joints=entry.get("joints"), **options)
    if kind == "regularization":
        return T.RegularizationTask(float(entry.get("weight", REGULARIZATION_WEIGHT)))
    raise TaskEntryError(f"unknown task type {kind!r}; use {', '.join(TASK_TYPES)}")
