"""Typed rows of a hard constraint for one QP step over dq, each written into the stacked QP by ``add_to``
(a copy: a constraint may reuse its arrays); a :class:`RowLabel` names one row, for the diagnoses.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

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


class StackedRows(NamedTuple):
    """Where one constraint's rows stand in the stacked QP (views of its buffers): its general rows'
    ``matrix`` (k x nv), their ``upper`` and ``lower`` bounds (k), and the step's box ``lb``, ``ub`` (nv)."""

    matrix: np.ndarray
    upper: np.ndarray
    lower: np.ndarray
    lb: np.ndarray
    ub: np.ndarray


@dataclass(frozen=True)
class RowLabel:
    """What one row stands for: its ``constraint``'s name and ``kind``, its ``subject`` (a joint, contact,
    edge, pair), ``side`` (of a bound, a contact's axis), ``value`` and ``bound`` in ``unit`` (NaN: none),
    and ``owner``, the constraint (or step box) that puts the row in words."""

    constraint: str
    kind: str
    subject: str
    side: str = ""
    value: float = float("nan")
    bound: float = float("nan")
    unit: str = ""
    owner: Any = field(default=None, compare=False, repr=False)

    @property
    def text(self) -> str:
        """The row in words, as its owner says it."""
        return self.owner.row_text(self)

    def as_dict(self) -> dict:
        return {"constraint": self.constraint, "kind": self.kind, "subject": self.subject, "side": self.side,
                "value": self.value, "bound": self.bound, "unit": self.unit}


def as_index(indices: np.ndarray) -> np.ndarray | slice:
    """``indices`` as a slice when they are consecutive (a slice indexes a few times faster)."""
    indices = np.asarray(indices, dtype=int)
    if indices.size and np.array_equal(indices, np.arange(indices[0], indices[0] + indices.size)):
        return slice(int(indices[0]), int(indices[0]) + indices.size)
    return indices
