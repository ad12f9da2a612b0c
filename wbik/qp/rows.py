"""Typed rows: what a hard constraint contributes to one QP step over the tangent displacement dq.

Three forms (the models are PlaCo's ``add_constraint`` and mink's ``Constraint(G, h)``):

- ``EqualityRows(A, b)``                A dq = b                (contacts)
- ``InequalityRows(G, h)``              G dq <= h               (CoM in the polygon, distances)
- ``BoundRows(index, lower, upper)``    lower <= dq[index] <= upper   (joint limits)

Each is an immutable named tuple (so ``G, h = constraint.inequality(k)`` still unpacks) that writes
itself into the stacked QP with ``add_to``: the step never asks a constraint what kind it is.
The arrays may be buffers a constraint reuses at its next configuration; ``add_to`` copies them.

A :class:`RowLabel` says what one row stands for (a joint's limit, a contact's axis, an edge of the
support polygon, a collision pair) and carries its ``owner``, the constraint that puts it in words
(:class:`wbik.qp.constraint.Describer`): the diagnoses of :mod:`wbik.qp.diagnosis` and
:mod:`wbik.qp.elastic` ask the owner, never the kind. Labels are made on failure only, never in a step.
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import field
from typing import TYPE_CHECKING
from typing import Any
from typing import NamedTuple

import numpy as np

if TYPE_CHECKING:
    from wbik.qp.backends import StackedConstraints


class EqualityRows(NamedTuple):
    """A dq = b (m x nv, m)."""

    A: np.ndarray
    b: np.ndarray

    def add_to(self, stack: StackedConstraints) -> None:
        stack.add(self.A, self.b, equality=True)


class InequalityRows(NamedTuple):
    """G dq <= h (m x nv, m)."""

    G: np.ndarray
    h: np.ndarray

    def add_to(self, stack: StackedConstraints) -> None:
        stack.add(self.G, self.h)


class BoundRows(NamedTuple):
    """lower <= dq[index] <= upper; ``index`` is an index array or a slice of the nv entries."""

    index: np.ndarray | slice
    lower: np.ndarray | float
    upper: np.ndarray | float

    def add_to(self, stack: StackedConstraints) -> None:
        stack.tighten(self.index, self.lower, self.upper)


Rows = EqualityRows | InequalityRows | BoundRows
"""What ``Constraint.rows`` returns."""

@dataclass(frozen=True)
class RowLabel:
    """What one row of a hard constraint stands for.

    ``constraint``: the constraint's name; ``kind``: its owner's word for its rows; ``subject``: the joint,
    the contact frame, the polygon edge ("left_sole_link[2]-right_sole_link[1]") or the pair;
    ``side``: "lower" / "upper" for a bound, the axis ("x", ..., "rz") of a contact row;
    ``value`` and ``bound``: the measured quantity and its limit at the configuration the row was made
    at (rad or m in ``unit``; NaN where they mean nothing), e.g. a joint's angle and its limit, the
    CoM's distance to the edge and the margin, a pair's distance and the safety distance; ``owner``:
    the constraint (or step box) that describes the row.
    """

    constraint: str
    kind: str
    subject: str
    side: str = ""
    value: float = float("nan")
    bound: float = float("nan")
    unit: str = ""
    owner: Any = field(default=None, compare=False, repr=False)

    def with_side(self, side: str) -> RowLabel:
        """The same label for one side of a bound (the other fields kept)."""
        return RowLabel(self.constraint, self.kind, self.subject, side, self.value, self.bound, self.unit,
                        self.owner)

    @property
    def text(self) -> str:
        """The row in words, as its owner says it."""
        return self.owner.row_text(self)


def as_index(indices: np.ndarray) -> np.ndarray | slice:
    """``indices`` as a slice when they are consecutive (a slice indexes a few times faster)."""
    indices = np.asarray(indices, dtype=int)
    if indices.size and np.array_equal(indices, np.arange(indices[0], indices[0] + indices.size)):
        return slice(int(indices[0]), int(indices[0]) + indices.size)
    return indices
