"""What ``solve_many`` returns, :class:`IKResults`: a batch's answers as a sequence of
:class:`~wbik.solvers.result.IKResult` (one per target, in order) and as columns, one row per target.

A batched closed form checks its whole batch in a few array operations; its answers stay in those arrays
(:class:`SolvedRows`) and each ``IKResult`` is built the first time it is read, then kept. A batch of
thousands of poses thus costs one object, not thousands, until its answers are looked at one by one."""

from __future__ import annotations

import operator
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from wbik.solvers.result import IKResult


@dataclass(frozen=True)
class SolvedRows:
    """The answers of a batch's rows as columns, row ``i``: joints ``q[i]`` (inside the limits), errors
    ``position_xyz[i]`` (reached - target, m) and ``rotation_xyz[i]`` (log3(R*^T R), rad) with their norms,
    the solve time (s, the batch's time / its size) and the number of closed-form ``branches``."""

    q: np.ndarray
    position_norm: np.ndarray
    rotation_norm: np.ndarray
    position_xyz: np.ndarray
    rotation_xyz: np.ndarray
    time_s: np.ndarray
    branches: np.ndarray
    method: str

    def answer(self, index: int, success: bool = True, reason: str = "") -> IKResult:
        """Row ``index`` as an IKResult (one iteration, extra: its branches and that it was batched)."""
        return IKResult(self.q[index], success, reason, float(self.position_norm[index]),
                        float(self.rotation_norm[index]), self.position_xyz[index], self.rotation_xyz[index],
                        float(self.time_s[index]), 1, self.method,
                        {"branches": int(self.branches[index]), "batched": True})

    def taken(self, rows) -> SolvedRows:
        """The rows ``rows`` (a slice or an index array)."""
        return SolvedRows(self.q[rows], self.position_norm[rows], self.rotation_norm[rows],
                          self.position_xyz[rows], self.rotation_xyz[rows], self.time_s[rows],
                          self.branches[rows], self.method)

    @staticmethod
    def joined(parts: Sequence[SolvedRows]) -> SolvedRows:
        """The rows of ``parts`` (one method's) one after the other."""
        names = ("q", "position_norm", "rotation_norm", "position_xyz", "rotation_xyz", "time_s", "branches")
        return SolvedRows(*(np.concatenate([getattr(part, name) for part in parts]) for name in names),
                          parts[0].method)


class IKResults(Sequence[IKResult]):
    """The answers of a batch: ``results[i]`` is target ``i``'s :class:`IKResult`, and the columns
    :attr:`success`, :attr:`q`, :attr:`position_error`, :attr:`rotation_error` and :attr:`reasons` give
    one field of every answer at once (as arrays, NaN where an answer has no joints)."""

    __slots__ = ("_answers", "_rows", "_width")

    def __init__(self, answers: list[IKResult | None], rows: SolvedRows | None = None,
                 width: int | None = None):
        """``answers``: the built answers, None where row ``i`` of ``rows`` (a success) is the answer;
        ``width``: the joints of an answer (the :attr:`q` column's width when no answer has joints)."""
        if rows is None and any(answer is None for answer in answers):
            raise ValueError("IKResults: an answer left to be built needs the rows it is built from")
        self._answers, self._rows = answers, rows
        self._width = rows.q.shape[1] if rows is not None else width

    @classmethod
    def of(cls, answers: Sequence[IKResult], width: int | None = None) -> IKResults:
        """``answers`` (a list of IKResult, or IKResults returned as they are) as IKResults."""
        if isinstance(answers, IKResults):
            if answers._width is None:
                answers._width = width
            return answers
        return cls(list(answers), width=width)

    @classmethod
    def joined(cls, parts: Sequence[IKResults]) -> IKResults:
        """The answers of ``parts`` one after the other (rows kept as rows where every part has them)."""
        if len(parts) == 1:
            return parts[0]
        answers = [answer for part in parts for answer in part._answers]
        width = next((part._width for part in parts if part._width is not None), None)
        if all(part._rows is not None for part in parts) and len({part._rows.method for part in parts}) == 1:
            return cls(answers, SolvedRows.joined([part._rows for part in parts]))
        return cls([answer for part in parts for answer in part], width=width)

    def __len__(self) -> int:
        return len(self._answers)

    def __getitem__(self, index):
        if isinstance(index, slice):
            rows = None if self._rows is None else self._rows.taken(index)
            return IKResults(self._answers[index], rows, self._width)
        index = operator.index(index)
        answer = self._answers[index]
        if answer is None:
            answer = self._answers[index] = self._rows.answer(index)
        return answer

    def __iter__(self) -> Iterator[IKResult]:
        if self._rows is None:
            return iter(self._answers)
        return (self[index] for index in range(len(self._answers)))

    def __eq__(self, other) -> bool:
        if isinstance(other, IKResults | list | tuple):
            return len(self) == len(other) and all(a is b or a == b for a, b in zip(self, other, strict=True))
        return NotImplemented

    __hash__ = None  # mutable, like a list

    def __repr__(self) -> str:
        return f"IKResults({len(self)} answers, {int(self.success.sum())} solved)"

    def _built(self) -> list[tuple[int, IKResult]]:
        """(index, answer) of the answers already built."""
        return [(index, answer) for index, answer in enumerate(self._answers) if answer is not None]

    def _column(self, field: str, rows_column: np.ndarray | None) -> np.ndarray:
        """One number per answer: ``rows_column`` where the rows hold it, the built answers' ``field``."""
        values = np.full(len(self), np.nan) if rows_column is None else rows_column.astype(float)
        for index, answer in self._built():
            values[index] = getattr(answer, field)
        return values

    @property
    def success(self) -> np.ndarray:
        """Whether each answer passed the check, (B,) bool."""
        return np.array([answer is None or answer.success for answer in self._answers], dtype=bool)

    @property
    def position_error(self) -> np.ndarray:
        """Each answer's position error norm (m), (B,), NaN without joints."""
        return self._column("position_error", None if self._rows is None else self._rows.position_norm)

    @property
    def rotation_error(self) -> np.ndarray:
        """Each answer's rotation error angle (rad), (B,), NaN without joints."""
        return self._column("rotation_error", None if self._rows is None else self._rows.rotation_norm)

    @property
    def reasons(self) -> list[str]:
        """Each answer's reason ("" for a success)."""
        return ["" if answer is None else answer.reason for answer in self._answers]

    @property
    def q(self) -> np.ndarray:
        """Each answer's joints, (B, n), a row of NaN for an answer without joints."""
        width = self._width if self._width is not None else next(
            (len(answer.q) for answer in self._answers if answer is not None and answer.q is not None), 0)
        joints = np.full((len(self), width), np.nan) if self._rows is None else self._rows.q.astype(float)
        for index, answer in self._built():
            joints[index] = np.nan if answer.q is None else answer.q
        return joints
