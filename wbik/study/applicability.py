"""Which methods apply to a study case: typed checks made once per (case, method), before solving.

A method is *not applicable* to a case, with its own message, when

1. building it (the case kind's :meth:`~wbik.study.case_kinds.CaseKind.build`) raises
   :class:`~wbik.errors.UnsupportedError` (the method does not apply to this robot or chain) or
   :class:`~wbik.errors.MissingDependencyError` (an optional library is not installed). A
   :class:`~wbik.qp.backends.BackendUnavailableError` is not that: a QP backend the study file names
   but that is not installed is a mistake in the file, and propagates;
2. the built solver refuses the case, by the case kind's
   :meth:`~wbik.study.case_kinds.CaseKind.refusal` on the case's first pose: a chain method its
   target kind (its capability query ``solver.check_target_kind(kind)``, "pose" or "position",
   raises UnsupportedError; ``analytic`` also refuses a kind its robot declares no closed form of),
   a whole-body method the case's first problem (its query ``solver.cannot_express(problem, q0)``
   gives the reason: goal tasks it has no way to state); the text is the method's.

Nothing else means "not applicable": other errors while building propagate to the runner (a
:class:`~wbik.errors.WbikError` is a mistake in the study file, anything else a bug), and an error
while solving a pose is recorded in that pose's row by the chunk.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from wbik.errors import MissingDependencyError
from wbik.errors import UnsupportedError

if TYPE_CHECKING:
    from wbik.study.case_kinds import ChunkTask

REFUSALS = (UnsupportedError, MissingDependencyError)
"""The typed errors by which a method, while being built, says it does not apply."""


def not_applicable(task: ChunkTask) -> str | None:
    """Why the method of ``task`` does not apply to its case (None if it does); ``task`` holds the
    case's first pose. See the module docstring for the checks."""
    from wbik.qp.backends import BackendUnavailableError

    try:
        solver = task.kind.build(task)
    except BackendUnavailableError:
        raise
    except REFUSALS as exc:
        return str(exc)
    return task.kind.refusal(task, solver)
