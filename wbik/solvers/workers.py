"""A batch split over processes: ``solve_many(targets, q0s, workers=N)`` solves N contiguous parts of the
batch at once, the first in this process and the others in N - 1 processes forked from it, each running the
method's own batched path on its part, and joins the answers in order. The solver is inherited by the
fork, never pickled; SE3 targets travel as one array of 4 x 4 matrices and the answers as columns (a
field's arrays stacked, its numbers in one array), a few microseconds an answer, so a part pays where a
pose costs more than that. Every part's BLAS runs on its share of the cores (in the caller, for the
length of the call: other threads' BLAS too). The processes are forked on a solver's first such call and
kept for its later calls until it is garbage collected; a change of the solver's plain settings (numbers,
strings, tolerances) forks them again, so that every part solves with the settings of the call."""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import multiprocessing
import os
import threading
import weakref
from concurrent.futures import ProcessPoolExecutor
from operator import attrgetter

import numpy as np
import pinocchio as pin
from threadpoolctl import ThreadpoolController, threadpool_limits

from wbik.solvers.batch_results import IKResults
from wbik.solvers.result import Tolerances

LOGGER = logging.getLogger("wbik.workers")

_INHERITED: dict[int, object] = {}  # the solver whose pool is being forked, read by the children
_POOLS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # solver -> (executor, its processes)


def fork_available() -> bool:
    """Whether this platform forks processes (Linux does; Windows does not)."""
    return "fork" in multiprocessing.get_all_start_methods()


def solve_in_workers(solver, targets, q0s, workers: int) -> IKResults:
    """``solver._solve_targets`` over ``workers`` contiguous parts of ``targets`` (with their rows of a 2-D
    ``q0s``, else ``q0s`` for every part), in forked processes; in this process where none can fork."""
    if not fork_available():
        LOGGER.warning("this platform cannot fork worker processes: solve_many runs in one process")
        return IKResults.of(solver._solve_targets(targets, q0s))
    per_row = q0s is not None and np.ndim(q0s) == 2
    own, *others = [part for part in np.array_split(np.arange(len(targets)), workers) if len(part)]
    futures = []
    if others:
        executor = _pool(solver, len(others))
        rest = targets[len(own):]
        array = isinstance(rest, np.ndarray)
        se3 = not array and all(type(target) is pin.SE3 for target in rest)
        matrices = rest if array else np.array([target.homogeneous for target in rest]) if se3 else None
        futures = [executor.submit(_solve_part, id(solver), matrices[part - len(own)], array,
                                   np.asarray(q0s)[part] if per_row else q0s) if array or se3 else
                   executor.submit(_solve_part, id(solver), [targets[i] for i in part], False,
                                   np.asarray(q0s)[part] if per_row else q0s) for part in others]
    with _caller_share(workers):
        answers = IKResults.of(solver._solve_targets(targets[:len(own)],
                                                     np.asarray(q0s)[own] if per_row else q0s))
    return IKResults.joined([answers, *(_answers(*future.result()) for future in futures)])


_SHARING = threading.Lock()
_SHARED: dict[str, object] = {"calls": 0, "limits": None, "controller": None}


@contextlib.contextmanager
def _caller_share(workers: int):
    """BLAS on the caller's share of the cores while its part runs: set by the first of concurrent calls,
    restored by the last (threadpoolctl restores what it found, so nested limits would not unwind)."""
    with _SHARING:
        if not _SHARED["calls"]:
            if _SHARED["controller"] is None:
                _SHARED["controller"] = ThreadpoolController()
            _SHARED["limits"] = _SHARED["controller"].limit(limits=_share(workers), user_api="blas")
        _SHARED["calls"] += 1
    try:
        yield
    finally:
        with _SHARING:
            _SHARED["calls"] -= 1
            if not _SHARED["calls"]:
                _SHARED["limits"].restore_original_limits()


def _settings(solver) -> tuple:
    """The solver's plain settings (numbers, strings, tolerances), which its forked processes must share."""
    return tuple(sorted((name, value) for name, value in vars(solver).items()
                        if value is None or type(value) in (bool, int, float, str, Tolerances)))


def _pool(solver, processes: int) -> ProcessPoolExecutor:
    """The solver's pool of ``processes`` forked processes (a new one where the count or the solver's
    settings changed)."""
    kept, settings = _POOLS.get(solver), _settings(solver)
    if kept is not None and kept[1:] == (processes, settings):
        return kept[0]
    if kept is not None:
        kept[0].shutdown(wait=False, cancel_futures=True)
    executor = ProcessPoolExecutor(processes, mp_context=multiprocessing.get_context("fork"),
                                   initializer=_share_cores, initargs=(processes + 1,))
    _INHERITED[id(solver)] = solver
    try:  # a fork-context pool forks all its processes at the first submit
        executor.submit(int).result()
    finally:
        del _INHERITED[id(solver)]
    _POOLS[solver] = (executor, processes, settings)
    weakref.finalize(solver, executor.shutdown, wait=False, cancel_futures=True)
    return executor


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the OS says, else the CPU count)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def _share(workers: int) -> int:
    """One part's share of the cores: BLAS and LAPACK threads that do not spin on the cores the other
    parts compute on (one of two parts on 2 cores: one thread)."""
    return max(1, usable_cores() // workers)


def _share_cores(workers: int) -> None:
    """In a forked process: BLAS and LAPACK on its share of the cores, for good."""
    threadpool_limits(_share(workers), user_api="blas")


def _solve_part(key: int, targets, as_array: bool, q0s) -> tuple:
    """In a worker: the inherited solver's batched path on its part (4 x 4 matrices: SE3 targets unless
    ``as_array``, the user's own array), the answers as they are where kept as rows, else as
    :func:`_columns`."""
    if isinstance(targets, np.ndarray) and not as_array:
        targets = [pin.SE3(matrix) for matrix in targets]
    answers = _INHERITED[key]._solve_targets(targets, q0s)
    return ("answers", answers) if isinstance(answers, IKResults) else _columns(answers)


def _columns(answers: list) -> tuple:
    """(the answers' dataclass, {field: (how, values)}): arrays of one shape and dtype stacked ("rows"),
    numbers of one type in one array ("numbers"), anything else as the list; or (None, answers). The
    tests run as maps over the column (C loops: a few milliseconds for thousands of answers)."""
    if not answers or len(set(map(type, answers))) != 1:
        return None, answers
    columns = {}
    for name in (item.name for item in dataclasses.fields(answers[0])):
        values = list(map(attrgetter(name), answers))
        first, types = values[0], set(map(type, values))
        if types == {np.ndarray} and len(set(map(_SHAPE, values))) == 1 \
                and len(set(map(_DTYPE, values))) == 1:
            columns[name] = ("rows", np.stack(values))
        elif len(types) == 1 and type(first) in (bool, int, float):
            columns[name] = ("numbers", np.array(values))
        elif len(types) == 1 and (first is None or type(first) is str or type(first) in (dict, list)
                                  and not first) and values.count(first) == len(values):
            columns[name] = ("same", first)  # a method's name, None, an empty mapping or list
        else:
            columns[name] = ("list", values)
    return type(answers[0]), columns


_SHAPE, _DTYPE = attrgetter("shape"), attrgetter("dtype")


def _answers(kind, columns) -> IKResults:
    """The answers of :func:`_solve_part` back as IKResults."""
    return columns if kind == "answers" else IKResults.of(_rows(kind, columns))


def _rows(kind, columns) -> list:
    """The answers of :func:`_columns` back as objects (a stacked array's rows, Python numbers)."""
    if kind is None:
        return columns
    count = next(len(data) for how, data in columns.values() if how != "same")
    fields = [list(data) if how == "rows" else data.tolist() if how == "numbers" else
              [type(data)() for _ in range(count)] if how == "same" and data in ({}, []) else
              [data] * count if how == "same" else data for how, data in columns.values()]
    return [kind(*row) for row in zip(*fields, strict=True)]  # the fields in their declared order
