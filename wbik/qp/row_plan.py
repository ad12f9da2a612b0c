"""The constraint rows of a QP step written by compiled calls alone: once a step has stacked every
constraint's rows in Python (``StackedConstraints.add``, ``tighten``), a :class:`RowPlan` asks each
constraint for a call that writes its rows straight into the same place of the stack
(``Constraint.compiled_rows``) and replays them at the next steps, with the step box opened and closed by one
kernel call each. The plan holds while the stack keeps its buffers; a constraint without such a call (one
defined outside wbik, say) leaves every row to Python.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from wbik.kernels.twins import chosen, compiled_twin
from wbik.qp.backends import StackedConstraints
from wbik.qp.constraint import Constraint
from wbik.qp.kinematics import Kinematics
from wbik.qp.rows import StackedRows

_STEP_BOX = compiled_twin("qp_rows", "step_box")
"""The compiled twin of StackedConstraints.clear's box and close_box (None where it is not built)."""


class RowPlan:
    """Compiled writers of every constraint's rows into ``stack``, at the rows a Python build put them."""

    def __init__(self, stack: StackedConstraints, writers: list[Callable[[], bool | None]], box):
        self.stack = stack
        self.writers = writers
        self._box = box
        self._matrix = stack._matrix  # (the buffers the writers' views belong to)
        self._lb, self._ub = stack._lb, stack._ub
        self._rows, self._adds = stack.rows, stack._adds

    @classmethod
    def compile(cls, stack: StackedConstraints, constraints: Sequence[Constraint], kinematics: Kinematics,
                spans: Sequence[tuple[int, int]]) -> RowPlan | None:
        """The plan of a stack just built from ``constraints``, each having added the general rows
        ``spans[i]`` (start, stop); None where a constraint (or the box) has no compiled call."""
        box = chosen(None, _STEP_BOX, "qp_rows")
        if box is None:
            return None
        n, writers = stack.n, []
        for constraint, (start, stop) in zip(constraints, spans, strict=True):
            rows = StackedRows(stack._matrix[start:stop], stack._upper[n + start:n + stop],
                               stack._lower[n + start:n + stop], stack._lb, stack._ub)
            if (writer := constraint.compiled_rows(kinematics, rows)) is None:
                return None
            writers.append(writer)
        return cls(stack, writers, box)

    def write(self, radius: float, toward_rest: bool) -> bool:
        """Every row at the kinematics' q, the box |dq_i| <= radius closed as ``StackedConstraints.close_box``
        does; False (the stack then to be built in Python) where the stack has new buffers or a writer
        could not write."""
        stack = self.stack
        if stack._matrix is not self._matrix:
            return False
        lb, ub, box = self._lb, self._ub, self._box
        box(lb, ub, radius, False, False)
        for writer in self.writers:
            if writer() is False:
                return False
        box(lb, ub, radius, True, toward_rest)
        stack.rows, stack._adds = self._rows, self._adds
        return True
