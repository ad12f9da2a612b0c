"""The hard rows of one QP step, each with its label, for the diagnoses of a failed solve.

:func:`step_rows` rebuilds the step's stacked system as rows M dq <= u (or = u), as the backend saw them:
every finite bound its own row (+dq_j <= ub_j, -dq_j <= -lb_j) labelled by the constraint that set it (or
the step box), violated inequality rows relaxed to h -> max(h, 0) unless ``relax`` is False.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wbik.qp.backends import split_rows
from wbik.qp.constraint import STEP_BOX, tangent_names
from wbik.qp.rows import BoundRows, RowLabel

INFINITE = 1e29
"""A bound at or beyond this is no bound (the stack writes 1e30 for none)."""


@dataclass
class HardRows:
    """M dq <= u (``equality``: M dq = u), one label per row (m rows, nv columns)."""

    matrix: np.ndarray
    upper: np.ndarray
    equality: np.ndarray
    labels: list[RowLabel]

    def __len__(self) -> int:
        return len(self.labels)

    def subset(self, keep: np.ndarray) -> HardRows:
        """The rows of the boolean mask ``keep``."""
        return HardRows(self.matrix[keep], self.upper[keep], self.equality[keep],
                        [label for label, kept in zip(self.labels, keep.tolist(), strict=True) if kept])

    def split(self) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None, np.ndarray | None]:
        """(G, h, A, b) for a backend (None for an empty block)."""
        return split_rows(self.matrix, self.upper, self.equality)

    def as_inequalities(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(M', u', owner): each equality row as two inequality rows; ``owner``: each row's index here."""
        equality = np.flatnonzero(self.equality)
        matrix = np.vstack((self.matrix, -self.matrix[equality]))
        upper = np.concatenate((self.upper, -self.upper[equality]))
        return matrix, upper, np.concatenate((np.arange(len(self)), equality))


def group_key(label: RowLabel) -> tuple[str, str, str, str]:
    """Rows a diagnosis names together: a bound by coordinate and side, any other row by its subject."""
    side = label.side if label.side in ("lower", "upper") and not label.owner.groups_rows else ""
    return label.constraint, label.kind, label.subject, side


def step_rows(step, dt: float, radius: float, relax: bool = True) -> HardRows:
    """The labelled rows of a QPStep ``step`` at its q (see the module docstring); ``radius``: the box."""
    stack = step.build_constraints(dt, radius)
    kinematics, nv = step.kinematics, step.nv
    general: list[RowLabel] = []
    candidates: list[list[tuple[float, float, RowLabel, RowLabel]]] = [[] for _ in range(nv)]
    for constraint in step.constraints:
        rows = constraint.rows(kinematics, dt)
        labels = constraint.labels(kinematics, rows)
        if isinstance(rows, BoundRows):
            indices = np.arange(nv)[rows.index]
            lower, upper = (np.broadcast_to(np.asarray(value, dtype=float), indices.shape).tolist()
                            for value in rows[1:])
            for j, low, high, pair in zip(indices.tolist(), lower, upper, labels, strict=True):
                candidates[j].append((low, high, *pair))
        else:
            if len(labels) != (count := len(rows[1])):  # (labels that do not match the rows: generic ones)
                labels = [constraint.label(f"row {i}") for i in range(count)]
            general.extend(labels)
    names = tangent_names(kinematics.model)
    sides = (("lower", -1.0, stack.lower), ("upper", 1.0, stack.upper))
    bounds = [(j, side, sign, bound[j]) for j in range(nv) for side, sign, bound in sides
              if abs(bound[j]) < INFINITE]  # each finite bound a row: sign dq_j <= sign bound
    bound_matrix = np.zeros((len(bounds), nv))
    for row, (j, _, sign, _) in enumerate(bounds):
        bound_matrix[row, j] = sign
    uppers = [sign * value for _, _, sign, value in bounds]
    labels = [_bound_label(candidates[j], side, value, radius, names[j]) for j, side, _, value in bounds]
    equality = stack.sense[nv:] == 5
    upper = stack.upper[nv:].copy()
    if relax:
        upper[~equality] = np.maximum(upper[~equality], 0.0)
    return HardRows(np.vstack((bound_matrix, stack.matrix)), np.concatenate((uppers, upper)),
                    np.concatenate((np.zeros(len(uppers), dtype=bool), equality)), labels + general)


def _bound_label(candidates: list, side: str, value: float, radius: float, name: str) -> RowLabel:
    """The label of the constraint that set ``value`` (the closest candidate, else the step box)."""
    lower_side = side == "lower"
    best, best_gap = None, np.inf
    for low, high, low_label, high_label in candidates:
        bound, label = (low, low_label) if lower_side else (high, high_label)
        if (gap := abs(bound - value)) < best_gap:
            best, best_gap = label, gap
    if best is None or (best_gap > 1e-12 * (1.0 + abs(value)) and abs(abs(value) - radius) <= best_gap):
        return STEP_BOX.label(name, side, float("nan"), radius, "")
    return best
