"""Hard constraints: typed rows for one QP step over dq (nv) from ``BoundConstraint.bounds``,
``EqualityConstraint.equality`` or ``InequalityConstraint.inequality``, a measure by FK for the shared
check, and words for their own rows (``labels``, ``row_text``, ``blocker_text``, ``advice``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection
from dataclasses import asdict, dataclass

import numpy as np
import pinocchio as pin

from wbik.qp.kinematics import Kinematics
from wbik.qp.rows import BoundRows, EqualityRows, InequalityRows, RowLabel, Rows, StackedRows

SLACK = 1e-9
"""How far (m or rad) a configuration may be past a constraint's edge and still satisfy it (rounding)."""


@dataclass(frozen=True)
class Measure:
    """How a configuration stands against a constraint: ``value`` of ``quantity``, ``holds``, ``failure``."""

    constraint: str
    quantity: str
    value: float
    unit: str
    holds: bool
    failure: str = ""


@dataclass(frozen=True)
class StartViolation:
    """A hard constraint q0 breaks, in words; ``clipped``: clipped before the first step, else repaired."""

    constraint: str
    kind: str
    subject: str
    side: str
    value: float
    bound: float
    unit: str
    text: str
    clipped: bool = False

    def as_dict(self) -> dict:
        return asdict(self)


class Describer:
    """Words for the rows of one source of rows (a constraint, the step box)."""

    name = "constraint"
    label_kind = "inequality"
    """A short word for what its rows are, kept in the labels' JSON."""
    groups_rows = False
    """True when the rows of one subject are one thing in words (a contact's six axes)."""

    def label(self, subject: str, side: str = "", value: float = math.nan, bound: float = math.nan,
              unit: str = "") -> RowLabel:
        return RowLabel(self.name, self.label_kind, subject, side, value, bound, unit, self)

    def row_text(self, label: RowLabel) -> str:
        """One row of a conflicting set."""
        return f"{label.constraint} {label.subject}{' ' + label.side if label.side else ''}"

    def group_text(self, labels: list[RowLabel]) -> str:
        """Rows of one subject named together (the first alone unless ``groups_rows``)."""
        return self.row_text(labels[0])

    def blocker_text(self, label: RowLabel) -> str:
        """An active row that holds the goals back."""
        return f"{label.constraint} ({label.subject}{', ' + label.side if label.side else ''})"

    def advice(self, label: RowLabel) -> str | None:
        """What to change when this row blocks the goals (None: nothing specific)."""
        return None

    def conflict_advice(self, labels: list[RowLabel]) -> str | None:
        """What to change when ``labels`` (this source's among them) conflict (None: the generic advice)."""
        return None


class Constraint(Describer):
    """Base class: derive from BoundConstraint, EqualityConstraint or InequalityConstraint."""

    quantity = ""
    """What :meth:`measure` reports ("" for a constraint that shapes steps only, e.g. velocity limits)."""
    _model: pin.Model | None = None

    def bind(self, model: pin.Model) -> None:
        """Make what depends on the model alone (``_bind``), once per model."""
        if self._model is not model:
            self._bind(model)
            self._model = model

    def _bind(self, model: pin.Model) -> None:
        """What ``bind`` makes (a problem calls it when it is made)."""

    def start(self, kinematics: Kinematics) -> None:
        """Bind to the model and the start configuration (called once per solve)."""
        self.bind(kinematics.model)

    def rows(self, kinematics: Kinematics, dt: float) -> Rows:
        """This constraint's rows at the kinematics' q (``dt``: the control period, for velocities)."""
        raise NotImplementedError(f"{type(self).__name__} must derive from BoundConstraint, "
                                  "EqualityConstraint or InequalityConstraint and implement its method")

    def compiled_rows(self, kinematics: Kinematics, rows: StackedRows) -> Callable[[], bool | None] | None:
        """A call that writes this constraint's rows at the kinematics' q (as ``rows(kinematics, dt)`` gives
        them, for any dt) straight into ``rows``, through compiled kernels, at every later step and start of
        the same problem; it returns False where it cannot (its count of rows changed, say: nothing is
        then taken from it, the step builds every row through ``rows`` and asks again). None (the default):
        no such call, every step builds the rows in Python."""
        return None

    def labels(self, kinematics: Kinematics, rows: Rows) -> list:
        """One RowLabel per row of ``rows`` (a bound constraint: a (lower, upper) pair per index)."""
        count = len(rows[1]) if not isinstance(rows, BoundRows) else 0
        return [self.label(f"row {index}") for index in range(count)]

    def stepped(self, dq: np.ndarray, dt: float) -> None:
        """The step dq (over dt) was taken: a constraint with a memory updates it."""

    def violation(self, kinematics: Kinematics) -> float:
        """How far the kinematics' q is beyond the constraint (m or rad, 0 inside); the IK loop's test."""
        return 0.0

    def measure(self, kinematics: Kinematics, tolerances) -> Measure | None:
        """The shared check's verdict on the kinematics' q (None: nothing to judge)."""
        return None

    def start_violations(self, kinematics: Kinematics, q0: np.ndarray) -> list[StartViolation]:
        """What the start q0 breaks (the kinematics stand at q0 clipped into the joint limits)."""
        if (violation := float(self.violation(kinematics))) <= SLACK:
            return []
        text = f"{self.name} violated by {violation:.3g}"
        return [self.start_violation(self.name, violation, 0.0, "m", text)]

    def start_violation(self, subject: str, value: float, bound: float, unit: str, text: str, side: str = "",
                        clipped: bool = False) -> StartViolation:
        return StartViolation(self.name, self.label_kind, subject, side, value, bound, unit, text, clipped)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class BoundConstraint(Constraint):
    """lower <= dq[index] <= upper."""

    label_kind = "bound"
    unit = ""

    def rows(self, kinematics: Kinematics, dt: float) -> BoundRows:
        return self.bounds(kinematics, dt)

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        raise NotImplementedError

    def labels(self, kinematics: Kinematics, rows: Rows) -> list[tuple[RowLabel, RowLabel]]:
        """(lower, upper) labels per bounded coordinate, named by the tangent coordinate."""
        names = tangent_names(kinematics.model)
        return [(self.label(names[v], "lower", value, low, self.unit),
                 self.label(names[v], "upper", value, high, self.unit))
                for v, value, low, high in zip(*self.label_values(kinematics, rows), strict=True)]

    def label_values(self, kinematics: Kinematics, rows: BoundRows) -> tuple[list, list, list, list]:
        """(tangent indices, measured values (NaN: none), lower bounds, upper bounds) of the labels."""
        indices = np.arange(kinematics.nv)[rows.index]
        lower, upper = (np.broadcast_to(np.asarray(v, dtype=float), indices.shape).tolist() for v in rows[1:])
        return indices.tolist(), [math.nan] * len(indices), lower, upper


class EqualityConstraint(Constraint):
    """A dq = b; the IK loop also projects its iterates onto these (Newton steps on e = 0)."""

    label_kind = "equality"

    def rows(self, kinematics: Kinematics, dt: float) -> EqualityRows:
        return self.equality(kinematics)

    def equality(self, kinematics: Kinematics) -> EqualityRows:
        raise NotImplementedError


class InequalityConstraint(Constraint):
    """G dq <= h."""

    def rows(self, kinematics: Kinematics, dt: float) -> InequalityRows:
        return self.inequality(kinematics)

    def inequality(self, kinematics: Kinematics) -> InequalityRows:
        raise NotImplementedError


class StepBox(Describer):
    """The trust region |dq_j| <= radius of a step: where no constraint bounds a coordinate tighter."""

    name = "step box"
    label_kind = "trust region"

    def row_text(self, label: RowLabel) -> str:
        return f"the step box on {label.subject} ({label.side}, |dq| <= {label.bound:.2g})"

    blocker_text = row_text


STEP_BOX = StepBox()


def tangent_names(model: pin.Model) -> list[str]:
    """A name per tangent coordinate: the joint's; "<joint> x" ... "rz" (free flyer) or "<joint>[i]"."""
    names = [""] * model.nv
    for joint_id in range(1, model.njoints):
        joint, name = model.joints[joint_id], model.names[joint_id]
        if joint.nv == 1:
            names[joint.idx_v] = name
        else:
            axes = ("x", "y", "z", "rx", "ry", "rz") if joint.nv == 6 else None
            for offset in range(joint.nv):
                names[joint.idx_v + offset] = f"{name} {axes[offset]}" if axes else f"{name}[{offset}]"
    return names


def bounded_joint_indices(model: pin.Model, unbounded: Collection[str] = ()) -> tuple[np.ndarray, np.ndarray]:
    """(q indices, v indices) of the 1-DOF joints with finite limits, but the ``unbounded`` ones."""
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit
    joints = [joint for joint_id, joint in enumerate(model.joints)
              if joint_id and joint.nq == 1 and joint.nv == 1 and model.names[joint_id] not in unbounded
              and np.isfinite(lower[joint.idx_q]) and np.isfinite(upper[joint.idx_q])
              and upper[joint.idx_q] - lower[joint.idx_q] < 1e10]
    return np.array([j.idx_q for j in joints], dtype=int), np.array([j.idx_v for j in joints], dtype=int)
