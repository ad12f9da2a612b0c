"""Which methods apply to a study case, decided once per (case, method) before solving: building the
method raises :class:`~wbik.errors.UnsupportedError` or :class:`~wbik.errors.MissingDependencyError`, or
the built solver refuses the case's first pose; any other error propagates."""

from __future__ import annotations

from wbik.errors import MissingDependencyError, UnsupportedError
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
