"""Wall-clock solves watched for CPU starvation, and the workers a method with threads of its own
is run with.

A method budgeted by a wall clock inside another library (KDL, TRAC-IK, PlaCo) answers differently
when the machine is busy. Such a solve is run while the process's CPU time is measured beside its
wall time; a solve that got less than ``STARVED_CPU_SHARE`` of the CPU it was meant to have is run
again, its answer discarded, with its wall budget stretched, up to ``MAX_RERUNS`` times.

The CPU a solve is meant to have is its wall time times the method's threads: TRAC-IK runs KDL's
NR_JL and an SQP in two threads of its own (:data:`METHOD_THREADS`), so a TRAC-IK solve of wall
time w is meant to have 2 w of CPU, one w per thread. The study runs such a method's tasks after
the others, with at most cores // threads workers (:func:`workers_for`): on 2 cores, one worker, so
TRAC-IK's two threads have a core each while nothing else of the study runs.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable

STARVED_CPU_SHARE = 0.8
"""A wall-clock solve that got less CPU time than this share of wall time x threads is run again."""
STARVED_MIN_WALL_S = 0.001
"""Solves shorter than this are not judged (a short preemption says little, and they ended early)."""
MAX_RERUNS = 3
MAX_STRETCH = 20.0
"""A re-run's wall budget is at most this many times the study's."""
METHOD_THREADS: dict[str, int] = {
    "trac_ik": 2,  # KDL NR_JL and an SQP (NLopt), concurrently, each until the wall budget
}
"""Threads a method's solve keeps busy, for methods that run more than the caller's one (a solver
class may say so itself with a ``threads`` attribute, which wins)."""


def method_threads(method: str, factory=None) -> int:
    """The threads a solve of ``method`` keeps busy: the solver class's ``threads`` attribute if it
    has one (``factory``), else :data:`METHOD_THREADS`, else 1."""
    declared = getattr(factory, "threads", None)
    if isinstance(declared, int) and declared >= 1:
        return declared
    return METHOD_THREADS.get(method, 1)


def threads_of(method: str) -> int:
    """The threads a solve of the registered chain method ``method`` keeps busy (1 for a name the
    chain methods' registry does not know, e.g. a whole-body method)."""
    from wbik.errors import WbikError
    from wbik.solvers.method_registry import method_factory
    try:
        factory = method_factory(method)
    except WbikError:
        factory = None
    return method_threads(method, factory)


def solver_threads(solver) -> int:
    """The threads a solve of the built ``solver`` keeps busy (:func:`method_threads`)."""
    return method_threads(getattr(solver, "name", ""), type(solver))


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the OS says, else the CPU count)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def workers_for(threads: int, jobs: int, cores: int | None = None) -> int:
    """The workers to run tasks of a method with ``threads`` threads when the study asks for
    ``jobs``: max(1, min(jobs, cores // threads)), so every thread of every worker has a core."""
    cores = usable_cores() if cores is None else cores
    return max(1, min(jobs, cores // max(1, threads)))


def starved(wall_s: float, cpu_s: float, threads: int = 1) -> bool:
    """Whether a solve of wall time ``wall_s`` that got ``cpu_s`` of process CPU time was starved:
    it ran at least STARVED_MIN_WALL_S and cpu < STARVED_CPU_SHARE x threads x wall."""
    return wall_s >= STARVED_MIN_WALL_S and cpu_s < STARVED_CPU_SHARE * threads * wall_s


def solve_watching_the_cpu(solver, target, q0, timeout_s: float, rebuild: Callable[[float], object]) -> tuple:
    """(answer, CPU seconds, re-runs) of a wall-clock solve whose budget is T = ``timeout_s``;
    ``rebuild(budget)`` makes the same solver with another wall budget.

    A solve is *starved* (:func:`starved`) when it ran for at least STARVED_MIN_WALL_S and the
    process got less than STARVED_CPU_SHARE of k x its wall time as CPU time, k the method's threads
    (:func:`solver_threads`; process CPU time counts TRAC-IK's own threads): the machine was busy.
    Its answer is then discarded, whatever it was, and the solve is run again with its wall budget
    stretched by k x wall / CPU (at most MAX_STRETCH x T), so that each thread gets about T of CPU,
    up to MAX_RERUNS times. Keeping only answers of solves that had the CPU keeps the success rate
    that of an idle machine: re-running only the failures would give a method with random restarts
    of its own (TRAC-IK) a second draw, and re-running them for the missing CPU alone would replay
    a seeded method's first restarts.
    """
    threads = solver_threads(solver)
    reruns, current = 0, solver
    while True:
        cpu_start = time.process_time()
        answer = current.solve(target, q0)
        cpu = time.process_time() - cpu_start
        wall = answer.time_s
        if not starved(wall, cpu, threads) or reruns >= MAX_RERUNS:
            return answer, cpu, reruns
        reruns += 1
        stretch = max(threads * wall / max(cpu, 1e-9), 1.0 / STARVED_CPU_SHARE)
        current = rebuild(timeout_s * min(MAX_STRETCH, stretch))
