"""``solve_many(..., workers=N)`` splits a batch over forked processes: the answers are those of one process,
bit for bit and in order, for a method's own batched path (bounded_lm's vectorised rows, analytic's choice)
and for the per-target path; the first part is solved in the caller and the others in forked processes,
each with BLAS on its share of the cores; bad counts and bad starts are refused in the caller, before any
process is forked."""

from __future__ import annotations

import os

import numpy as np
import pytest
from threadpoolctl import threadpool_info

import wbik
from wbik.errors import InvalidConfigurationError, InvalidSettingError
from wbik.solvers import workers
from wbik.solvers.dls import DampedLeastSquares
from wbik.solvers.method import IKMethod
from wbik.solvers.method_registry import IK_METHOD_REGISTRY, register_method


def _same(first, second) -> None:
    assert len(first) == len(second)
    for a, b in zip(first, second, strict=True):
        assert (a.success, a.reason, a.iterations) == (b.success, b.reason, b.iterations)
        assert (a.q is None and b.q is None) or np.array_equal(a.q, b.q)


def _poses(chain, count: int, rng) -> list:
    return [chain.fk(q) for q in chain.random(rng, count)]


@pytest.mark.parametrize(("method", "robot", "chain"), [("bounded_lm", "ur5", "arm"),
                                                        ("analytic", "ur5", "arm")])
def test_the_parts_give_the_answers_of_one_process(method, robot, chain, rng):
    solver = wbik.solver(method, robot, chain=chain)
    targets = _poses(solver.chain, 30, rng)
    starts = solver.chain.random(rng, len(targets))  # one start per target: the rows must follow their part
    _same(solver.solve_many(targets, starts), solver.solve_many(targets, starts, workers=3))
    _same(solver.solve_many(targets), solver.solve_many(targets, workers=2))


def test_an_unreachable_target_in_a_part_is_unsolved_with_its_reason(rng):
    solver = wbik.solver("bounded_lm", "ur5", chain="arm", max_iterations=200)
    targets = _poses(solver.chain, 5, rng)
    far = targets[3].copy()
    far.translation = far.translation + np.array([3.0, 0.0, 0.0])
    targets[3] = far
    answers = solver.solve_many(targets, workers=2)
    assert [a.success for a in answers] == [True, True, True, False, True]
    assert answers[3].reason
    _same(answers, solver.solve_many(targets))


def test_the_parts_run_in_other_processes(rng):
    class WhereSolved(DampedLeastSquares):
        def _solve(self, target, q0, deadline):
            candidate = super()._solve(target, q0, deadline)
            candidate.extra["pid"] = os.getpid()
            candidate.extra["blas_threads"] = {pool["num_threads"] for pool in threadpool_info()
                                               if pool["user_api"] == "blas"}
            return candidate

    with IK_METHOD_REGISTRY.isolated():
        register_method(IKMethod("where_solved_test", WhereSolved, "test only: records the solving process"))
        solver = wbik.solver("where_solved_test", "ur5", chain="arm")
        answers = solver.solve_many(_poses(solver.chain, 6, rng), workers=2)
    processes = [a.extra["pid"] for a in answers]
    assert processes[:3] == [os.getpid()] * 3  # the first half here
    assert processes[3:] == [processes[3]] * 3 and processes[3] != os.getpid()  # the second in a fork
    share = max(1, workers.usable_cores() // 2)  # each part's BLAS on its share of the cores
    assert all(a.extra["blas_threads"] <= {share} for a in answers)
    pool = workers._POOLS[solver][0]
    assert workers._POOLS[solver][1] == 1 and list(pool._processes) == [processes[3]]  # one forked
    solver.solve_many(_poses(solver.chain, 4, rng), workers=2)
    assert workers._POOLS[solver][0] is pool  # kept for the solver's next batch


def test_a_changed_setting_reaches_every_part(rng):
    """The caller's part runs with the solver as it is; the forked parts see it as it was at the fork, so
    a change of a plain setting (here the tolerances) forks them again and every part solves with it."""
    class Tolerant(DampedLeastSquares):
        def _solve(self, target, q0, deadline):
            candidate = super()._solve(target, q0, deadline)
            candidate.extra["position_tolerance"] = self.tolerances.position
            return candidate

    with IK_METHOD_REGISTRY.isolated():
        register_method(IKMethod("tolerant_test", Tolerant, "test only: records its tolerance"))
        solver = wbik.solver("tolerant_test", "ur5", chain="arm")
        targets = _poses(solver.chain, 4, rng)
        solver.solve_many(targets, workers=2)
        first_pool = workers._POOLS[solver][0]
        solver.tolerances = wbik.Tolerances(position=2e-6, rotation=2e-6)
        answers = solver.solve_many(targets, workers=2)
    assert [a.extra["position_tolerance"] for a in answers] == [2e-6] * 4
    assert workers._POOLS[solver][0] is not first_pool


def test_answers_travel_as_columns_and_come_back_the_same():
    """Arrays of one shape and dtype are stacked, numbers gathered, equal names and empty mappings sent once,
    and anything else (arrays of several shapes, None among arrays) as a list; the rows rebuilt equal."""
    from wbik.solvers.result import IKResult

    def answer(q, method="m", extra=None):
        return IKResult(q, q is not None, "", 0.0, 0.0, np.zeros(3), np.zeros(3), 1e-6, 1, method,
                        extra or {})

    batches = {"rows": [answer(np.zeros(3)), answer(np.ones(3))],
               "list": [answer(np.zeros(3)), answer(np.ones(4))],
               "mixed": [answer(np.zeros(3)), answer(None)]}
    for expected, answers in batches.items():
        kind, columns = workers._columns(answers)
        assert kind is IKResult and columns["q"][0] == ("list" if expected == "mixed" else expected)
        assert columns["method"] == ("same", "m") and columns["extra"] == ("same", {})
        back = workers._rows(kind, columns)
        for a, b in zip(answers, back, strict=True):
            assert (a.q is None and b.q is None) or np.array_equal(a.q, b.q)
            assert (a.success, a.method, a.extra, a.time_s) == (b.success, b.method, b.extra, b.time_s)
        assert back[0].extra is not back[1].extra  # each answer its own mapping


@pytest.mark.parametrize("count", [0, -1, 1.5, True, "two"])
def test_a_bad_worker_count_is_refused(count):
    solver = wbik.solver("analytic", "ur5", chain="arm")
    with pytest.raises(InvalidSettingError, match="workers must be an integer >= 1"):
        solver.solve_many([solver.chain.fk(solver.chain.nominal)], workers=count)


def test_bad_starts_are_refused_before_any_process_is_forked(rng):
    solver = wbik.solver("analytic", "ur5", chain="arm")
    targets = _poses(solver.chain, 4, rng)
    with pytest.raises(InvalidConfigurationError, match="4 targets but 3 start configurations"):
        solver.solve_many(targets, solver.chain.random(rng, 3), workers=2)
    assert solver not in workers._POOLS
    assert solver.solve_many([], workers=2) == []
