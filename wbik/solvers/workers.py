"""A batch split over worker processes: ``solve_many(targets, q0s, workers=N)`` solves N contiguous parts
of the batch at once in processes forked from this one, each running the method's own batched path on its
part, and joins the answers in order. The solver is inherited by the fork, never pickled; targets and
answers travel by pickle (about 30 us an answer), so a part pays only where a pose costs more than that.
The processes are forked on a solver's first such call and kept for its later calls until it is garbage
collected (they see the solver as it was then)."""

from __future__ import annotations

import logging
import multiprocessing
import weakref
from concurrent.futures import ProcessPoolExecutor

import numpy as np

LOGGER = logging.getLogger("wbik.workers")

_INHERITED: dict[int, object] = {}  # the solver whose pool is being forked, read by the children
_POOLS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # solver -> (executor, its processes)


def fork_available() -> bool:
    """Whether this platform forks processes (Linux does; Windows does not)."""
    return "fork" in multiprocessing.get_all_start_methods()


def solve_in_workers(solver, targets: list, q0s, workers: int) -> list:
    """``solver._solve_targets`` over ``workers`` contiguous parts of ``targets`` (with their rows of a 2-D
    ``q0s``, else ``q0s`` for every part), in forked processes; in this process where none can fork."""
    if not fork_available():
        LOGGER.warning("this platform cannot fork worker processes: solve_many runs in one process")
        return solver._solve_targets(targets, q0s)
    per_row = q0s is not None and np.ndim(q0s) == 2
    executor = _pool(solver, workers)
    parts = [part for part in np.array_split(np.arange(len(targets)), workers) if len(part)]
    futures = [executor.submit(_solve_part, id(solver), [targets[i] for i in part],
                               np.asarray(q0s)[part] if per_row else q0s) for part in parts]
    return [answer for future in futures for answer in future.result()]


def _pool(solver, workers: int) -> ProcessPoolExecutor:
    """The solver's pool of ``workers`` forked processes (a new one where the count changed)."""
    kept = _POOLS.get(solver)
    if kept is not None and kept[1] == workers:
        return kept[0]
    if kept is not None:
        kept[0].shutdown(wait=False, cancel_futures=True)
    executor = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"))
    _INHERITED[id(solver)] = solver
    try:  # a fork-context pool forks all its processes at the first submit
        executor.submit(int).result()
    finally:
        del _INHERITED[id(solver)]
    _POOLS[solver] = (executor, workers)
    weakref.finalize(solver, executor.shutdown, wait=False, cancel_futures=True)
    return executor


def _solve_part(key: int, targets: list, q0s) -> list:
    """In a worker: the inherited solver's batched path on its part."""
    return _INHERITED[key]._solve_targets(targets, q0s)
