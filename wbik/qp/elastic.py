"""Why a step has no solution: a small set of its hard rows that conflict, by an elastic re-solve.

Every row M dq <= u (an equality as two) gets a slack s >= 0 in the LP  min sum_i s_i  s.t.  M dq - s <= u
(HiGHS), 0 exactly when the rows are compatible; otherwise its dual is a Farkas certificate, shrunk by a
deletion filter to an irreducible infeasible subsystem. A row's ``violation``: its slack (m or rad).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from wbik.qp.hard_rows import HardRows, group_key
from wbik.qp.rows import RowLabel

CONFLICT_TOLERANCE = 1e-9
"""Total violation (m or rad of one step) above which rows conflict."""


@dataclass(frozen=True)
class ConflictRow:
    """One row of the conflicting set: its label and its slack in the elastic optimum."""

    label: RowLabel
    violation: float

    @property
    def text(self) -> str:
        return self.label.text

    def as_dict(self) -> dict:
        return {**self.label.as_dict(), "violation": self.violation, "text": self.text}


def describe_rows(rows: Sequence[ConflictRow]) -> str:
    """The rows in words, as their constraints say them (a contact's axes in one phrase)."""
    groups: dict[tuple, list[RowLabel]] = {}
    for row in rows:
        groups.setdefault(group_key(row.label), []).append(row.label)
    return "; ".join(labels[0].owner.group_text(labels) for labels in groups.values())


def _elastic(matrix: np.ndarray, upper: np.ndarray) -> tuple[float, np.ndarray, np.ndarray] | None:
    """(optimum, slacks s, duals y >= 0) of the elastic LP over M dq <= u, or None if HiGHS fails."""
    count, nv = matrix.shape
    if count == 0:
        return 0.0, np.zeros(0), np.zeros(0)
    scale = max(1.0, float(np.abs(matrix).max()))
    cost = np.concatenate((np.zeros(nv), np.ones(count)))
    constraints = np.hstack((matrix / scale, -np.eye(count) / scale))
    bounds = [(None, None)] * nv + [(0.0, None)] * count
    from scipy.optimize import linprog  # on a failed step only: kept out of import wbik

    result = linprog(cost, A_ub=constraints, b_ub=upper / scale, bounds=bounds, method="highs")
    if result.status != 0:
        return None
    return float(result.fun), result.x[nv:], -np.asarray(result.ineqlin.marginals, dtype=float) / scale


def conflict(rows: HardRows, tolerance: float = CONFLICT_TOLERANCE,
             max_rows: int = 60) -> list[ConflictRow]:
    """An irreducible set of ``rows`` that conflict (empty: none; unshrunk above ``max_rows``)."""
    matrix, upper, owner = rows.as_inequalities()
    if (found := _elastic(matrix, upper)) is None or found[0] <= tolerance:
        return []
    _, slacks, duals = found
    support = np.flatnonzero(duals > 1e-9)
    if support.size == 0:
        support = np.flatnonzero(slacks > tolerance)
    order = support[np.argsort(-duals[support])]
    if order.size <= max_rows:
        kept = list(order)
        for candidate in list(order):
            trial = [row for row in kept if row != candidate]
            if (without := _elastic(matrix[trial], upper[trial])) is not None and without[0] > tolerance:
                kept = trial
        order = np.array(kept, dtype=int)
    return [ConflictRow(rows.labels[owner[index]], float(slacks[index]))
            for index in sorted(order.tolist(), key=lambda i: owner[i])]
