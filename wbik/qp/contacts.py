"""Contacts: a frame held where it is (a flat foot: its pose; a point foot: its position)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from wbik.qp.constraint import EqualityConstraint, Measure, StepBox
from wbik.qp.kinematics import Kinematics
from wbik.qp.rows import EqualityRows, RowLabel, StackedRows
from wbik.qp.tasks import FrameTask, PositionTask


class HeldFrame(EqualityConstraint):
    """What the two contacts share: a task on ``frame`` held at its target, its rows J dq = -e."""

    label_kind = "contact"
    quantity = "contact drift"
    groups_rows = True
    axes = ("x", "y", "z", "rx", "ry", "rz")
    _task: FrameTask | PositionTask

    def error(self, kinematics: Kinematics) -> np.ndarray:
        return self._task.error(kinematics)

    def drift(self, kinematics: Kinematics) -> tuple[float, float]:
        """(position error m, rotation error rad; 0 for a point contact) at the kinematics' q."""
        error = self.error(kinematics)
        return float(np.linalg.norm(error[:3])), float(np.linalg.norm(error[3:])) if error.size > 3 else 0.0

    def labels(self, kinematics: Kinematics, rows) -> list[RowLabel]:
        error = self.error(kinematics).tolist()
        return [self.label(self.frame, axis, float(value), 0.0, "m" if index < 3 else "rad")
                for index, (axis, value) in enumerate(zip(self.axes[:len(error)], error, strict=True))]

    def violation(self, kinematics: Kinematics) -> float:
        return max(self.drift(kinematics))

    def measure(self, kinematics: Kinematics, tolerances) -> Measure:
        position, rotation = self.drift(kinematics)
        return Measure(self.name, self.quantity, max(position, rotation), "m, rad",
                       position <= tolerances.position and rotation <= tolerances.rotation,
                       f"contact {self.frame} drifted {position:.3g} m, {rotation:.3g} rad")

    def row_text(self, label: RowLabel) -> str:
        drift = f", drift {abs(label.value) * 1e3:.3g} m{label.unit}" if math.isfinite(label.value) else ""
        return f"contact {label.subject} ({label.side}{drift})"

    def group_text(self, labels: list[RowLabel]) -> str:
        if len(labels) == 1:
            return self.row_text(labels[0])
        drifts = [abs(label.value) for label in labels if math.isfinite(label.value)]
        drift = f"; drift up to {max(drifts) * 1e3:.3g} m{labels[0].unit}" if drifts else ""
        return f"contact {labels[0].subject} ({', '.join(label.side for label in labels)}{drift})"

    def blocker_text(self, label: RowLabel) -> str:
        return f"contact {label.subject}"

    def advice(self, label: RowLabel) -> str:
        return f"the contact {label.subject} holds the body: the goal needs it to move (release it or step)"

    def conflict_advice(self, labels: list[RowLabel]) -> str | None:
        if any(isinstance(label.owner, StepBox) for label in labels):
            return ("the contacts drift more than one step may repair: project onto them first "
                    "(IKProblem.project) or allow a larger step (max_step)")
        return None


class Contact(HeldFrame):
    """A frame held at a world ``placement`` (default: at the start), a flat foot: J dq = -e, 6 rows."""

    def __init__(self, frame: str, placement: pin.SE3 | None = None):
        self.frame = frame
        self.name = f"contact[{frame}]"
        self.fixed_placement = placement
        self._task = FrameTask(frame, placement if placement is not None else pin.SE3.Identity())

    @property
    def placement(self) -> pin.SE3:
        return self._task.target

    def start(self, kinematics: Kinematics) -> None:
        self._task.start(kinematics)
        if self.fixed_placement is None:
            self._task.target = kinematics.placement(self._task.frame_id).copy()
        if getattr(self, "_jacobian", np.zeros((0, 0))).shape != (6, kinematics.nv):
            self._jacobian, self._rhs = np.zeros((6, kinematics.nv)), np.zeros(6)
        self._version = -1

    def _rows(self, kinematics: Kinematics) -> None:
        """J and -e, once per configuration."""
        if self._version != kinematics.version:
            self._task.fill(kinematics, self._jacobian, self._rhs)
            np.negative(self._rhs, out=self._rhs)
            self._version = kinematics.version

    def equality(self, kinematics: Kinematics) -> EqualityRows:
        """J dq = -e (buffers reused at the next configuration: copy them to keep them)."""
        self._rows(kinematics)
        return EqualityRows(self._jacobian, self._rhs)

    def compiled_rows(self, kinematics: Kinematics, rows: StackedRows) -> Callable[[], bool] | None:
        """``equality``'s J and b = -e written by the frame task's kernel (False near a half turn)."""
        task = self._task
        frame_rows = task._compiled_rows if task._compiled_for is kinematics else None
        if frame_rows is None or rows.matrix.shape[0] != 6:
            return None
        J, upper, lower = rows.matrix, rows.upper, rows.lower
        return lambda: frame_rows(task._target_translation, task._target_rotation, J, upper, lower)

    def violation(self, kinematics: Kinematics) -> float:
        self._rows(kinematics)
        x, y, z, rx, ry, rz = self._rhs.tolist()  # Python floats: cheaper than six small-array calls
        return math.sqrt(max(x * x + y * y + z * z, rx * rx + ry * ry + rz * rz))


class PointContact(HeldFrame):
    """A frame's origin held at ``position`` (m; default: at the start), a point foot: J_v dq = -(p - p*)."""

    def __init__(self, frame: str, position: np.ndarray | None = None):
        self.frame = frame
        self.name = f"point contact[{frame}]"
        self.fixed_position = None if position is None else np.array(position, dtype=float).reshape(3)
        self._task = PositionTask(frame, np.zeros(3) if position is None else self.fixed_position)

    @property
    def position(self) -> np.ndarray:
        return self._task.target

    def start(self, kinematics: Kinematics) -> None:
        self._task.start(kinematics)
        if self.fixed_position is None:
            self._task.target = kinematics.placement(self._task.frame_id).translation.copy()

    def equality(self, kinematics: Kinematics) -> EqualityRows:
        return EqualityRows(self._task.jacobian(kinematics), -self._task.error(kinematics))
