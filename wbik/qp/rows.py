"""Typed rows: what a hard constraint contributes to one QP step over the tangent displacement dq.

Three forms (the models are PlaCo's ``add_constraint`` and mink's ``Constraint(G, h)``):

- ``EqualityRows(A, b)``                A dq = b                (contacts)
- ``InequalityRows(G, h)``              G dq <= h               (CoM in the polygon, distances)
- ``BoundRows(index, lower, upper)``    lower <= dq[index] <= upper   (joint limits)

Each is an immutable named tuple (so ``G, h = constraint.inequality(k)`` still unpacks) that writes
itself into the stacked QP with ``add_to``: the step never asks a constraint what kind it is.
The arrays may be buffers a constraint reuses at its next configuration; ``add_to`` copies them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
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


def as_index(indices: np.ndarray) -> np.ndarray | slice:
    """``indices`` as a slice when they are consecutive (a slice indexes a few times faster)."""
    indices = np.asarray(indices, dtype=int)
    if indices.size and np.array_equal(indices, np.arange(indices[0], indices[0] + indices.size)):
        return slice(int(indices[0]), int(indices[0]) + indices.size)
    return indices
