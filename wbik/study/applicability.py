"""Which methods apply to a study case: typed checks made once per (case, method), before solving.

A method is *not applicable*, with its own message, when building it (the kind's
:meth:`~wbik.study.case_kinds.CaseKind.build`) raises :class:`~wbik.errors.UnsupportedError` or
:class:`~wbik.errors.MissingDependencyError`, or when the built solver refuses the case's first pose (the
kind's :meth:`~wbik.study.case_kinds.CaseKind.refusal`: a chain method its target kind, a whole-body method
a goal task it cannot state). A QP backend the file names but that is not installed is a mistake in the
file and propagates, as does any other error while building; an error while solving is recorded in its row.
"""

from __future__ import annotations

from wbik.errors import MissingDependencyError
from wbik.errors import UnsupportedError
from wbik.study.case_kinds import ChunkTask


def not_applicable(task: ChunkTask) -> str | None:
    """Why the method of ``task`` (holding the case's first pose) does not apply to it; None if it does."""
    from wbik.qp.backends import BackendUnavailableError

    try:
        solver = task.kind.build(task)
    except BackendUnavailableError:
        raise
    except (UnsupportedError, MissingDependencyError) as exc:
        return str(exc)
    return task.kind.refusal(task, solver)
