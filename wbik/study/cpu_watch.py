"""Wall-clock solves (KDL, TRAC-IK, PlaCo) watched for CPU starvation: a solve given less CPU than
``STARVED_CPU_SHARE`` x threads x wall is run again with a stretched budget, up to ``MAX_RERUNS`` times."""

from __future__ import annotations

import time
from collections.abc import Callable

from wbik.solvers.workers import usable_cores

STARVED_CPU_SHARE = 0.8
"""A wall-clock solve that got less CPU time than this share of wall time x threads is run again."""
STARVED_MIN_WALL_S = 0.001
"""Solves shorter than this are not judged (a short preemption says little, and they ended early)."""
MAX_RERUNS = 3
MAX_STRETCH = 20.0
"""A re-run's wall budget is at most this many times the study's."""
METHOD_THREADS: dict[str, int] = {"trac_ik": 2}  # KDL NR_JL and an SQP (NLopt), side by side
"""Threads a method's solve keeps busy beyond one (a solver class's ``threads`` attribute wins)."""


def method_threads(method: str, factory=None) -> int:
    """The threads a solve of ``method`` keeps busy: ``factory.threads``, else METHOD_THREADS, else 1."""
    declared = getattr(factory, "threads", None)
    return declared if isinstance(declared, int) and declared >= 1 else METHOD_THREADS.get(method, 1)


def threads_of(method: str) -> int:
    """The threads a solve of the registered method ``method`` keeps busy (1 for an unknown name)."""
    from wbik.errors import WbikError
    from wbik.solvers.method_registry import method_factory
    try:
        factory = method_factory(method)
    except WbikError:
        factory = None
    return method_threads(method, factory)


def workers_for(threads: int, jobs: int, cores: int | None = None) -> int:
    """The workers for a method of ``threads`` threads: max(1, min(jobs, cores // threads))."""
    return max(1, min(jobs, (usable_cores() if cores is None else cores) // max(1, threads)))


def starved(wall_s: float, cpu_s: float, threads: int = 1) -> bool:
    """Whether a solve was starved: wall >= STARVED_MIN_WALL_S, cpu < STARVED_CPU_SHARE x threads x wall."""
    return wall_s >= STARVED_MIN_WALL_S and cpu_s < STARVED_CPU_SHARE * threads * wall_s


def solve_watching_the_cpu(solver, target, q0, timeout_s: float, rebuild: Callable[[float], object]) -> tuple:
    """(answer, CPU seconds, re-runs) of a wall-clock solve of budget T: a starved solve's answer, whatever
    it was, is discarded and the solve run again by ``rebuild(budget)`` with the budget stretched by
    threads x wall / CPU (at most MAX_STRETCH x T), up to MAX_RERUNS times."""
    threads = method_threads(getattr(solver, "name", ""), type(solver))
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
