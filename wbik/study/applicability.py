"""Which methods apply to a study case: typed checks made once per (case, method), before solving.

A method is *not applicable* to a case, with its own message, when

1. building it raises :class:`~wbik.errors.UnsupportedError` (the method does not apply to this
   robot or chain) or :class:`~wbik.errors.MissingDependencyError` (an optional library is not
   installed). A :class:`~wbik.qp.backends.BackendUnavailableError` is not that: a QP backend the
   study file names but that is not installed is a mistake in the file, and propagates;
2. a chain method refuses the case's target kind: its capability query
   ``solver.check_target_kind(kind)`` ("pose" or "position") raises UnsupportedError (every
   :class:`~wbik.solvers.base.Solver` has it; ``analytic`` also refuses a kind its robot declares no
   closed form of);
3. a whole-body method's query ``solver.cannot_express(problem, q0)`` on the case's first problem
   gives the reason it cannot take it (goal tasks it has no way to state); the text is the method's.

Nothing else means "not applicable": other errors while building propagate to the runner (a
:class:`~wbik.errors.WbikError` is a mistake in the study file, anything else a bug), and an error
while solving a pose is recorded in that pose's row by the chunk.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from wbik.errors import MissingDependencyError
from wbik.errors import UnsupportedError
from wbik.study.context import _robot
from wbik.study.context import make_solver

if TYPE_CHECKING:
    from wbik.study.runner import ChunkTask

REFUSALS = (UnsupportedError, MissingDependencyError)
"""The typed errors by which a method, while being built, says it does not apply."""


def not_applicable(task: ChunkTask) -> str | None:
    """Why the method of ``task`` does not apply to its case (None if it does); ``task`` holds the
    case's first pose. See the module docstring for the checks."""
    from wbik.qp.backends import BackendUnavailableError

    try:
        solver = _build(task)
    except BackendUnavailableError:
        raise
    except REFUSALS as exc:
        return str(exc)
    if task.scenario is not None:
        return _wholebody_refusal(task, solver)
    return _target_kind_refusal(task, solver)


def _build(task: ChunkTask):
    if task.scenario is None:
        return make_solver(task.robot, task.robot_params, task.chain, task.method, dict(task.options),
                           task.timeout_s, task.tolerances, task.seed, task.base, task.tip)
    import wbik
    from wbik.wholebody.methods import wholebody_solver

    return wholebody_solver(task.method, _robot(task.robot, task.robot_params),
                            tolerances=wbik.Tolerances(*task.tolerances), timeout_s=task.timeout_s,
                            seed=task.seed, **dict(task.options))


def _target_kind_refusal(task: ChunkTask, solver) -> str | None:
    """The solver's refusal of the case's target kind (see the module docstring, 2)."""
    try:
        solver.check_target_kind("position" if task.rotations is None else "pose")
    except UnsupportedError as exc:
        return str(exc)
    return None


def _wholebody_refusal(task: ChunkTask, solver) -> str | None:
    """The method's own reason it cannot express the case's first problem (module docstring, 3)."""
    from wbik.wholebody.cases import sample_case

    case = sample_case(task.scenario, task.scenario_seed, task.first_pose)
    return solver.cannot_express(case.problem, task.q0[0])
