"""Wall-clock solves watched for CPU starvation.

A method budgeted by a wall clock inside another library (KDL, TRAC-IK, PlaCo) answers differently
when the machine is busy. Such a solve is run while the process's CPU time is measured beside its
wall time; a solve that got less than ``STARVED_CPU_SHARE`` of its wall time as CPU is run again, its
answer discarded, with its wall budget stretched by wall/CPU, up to ``MAX_RERUNS`` times.
"""

from __future__ import annotations

import time
from collections.abc import Callable

STARVED_CPU_SHARE = 0.8
"""A wall-clock solve that got less CPU time than this share of its wall time is run again."""
STARVED_MIN_WALL_S = 0.001
"""Solves shorter than this are not judged (a short preemption says little, and they ended early)."""
MAX_RERUNS = 3
MAX_STRETCH = 20.0
"""A re-run's wall budget is at most this many times the study's."""


def solve_watching_the_cpu(solver, target, q0, timeout_s: float, rebuild: Callable[[float], object]) -> tuple:
    """(answer, CPU seconds, re-runs) of a wall-clock solve whose budget is T = ``timeout_s``;
    ``rebuild(budget)`` makes the same solver with another wall budget.

    A solve is *starved* when it ran for at least STARVED_MIN_WALL_S and the process got less than
    STARVED_CPU_SHARE of that wall time as CPU time (process CPU time: TRAC-IK's own threads count):
    the machine was busy. Its answer is then discarded, whatever it was, and the solve is run again
    with its wall budget stretched by the wall/CPU ratio just observed (at most MAX_STRETCH x T), so
    that it gets about T of CPU, up to MAX_RERUNS times. Keeping only answers of solves that had the
    CPU keeps the success rate that of an idle machine: re-running only the failures would give a
    method with random restarts of its own (TRAC-IK) a second draw, and re-running them for the
    missing CPU alone would replay a seeded method's first restarts.
    """
    reruns, current = 0, solver
    while True:
        cpu_start = time.process_time()
        answer = current.solve(target, q0)
        cpu = time.process_time() - cpu_start
        wall = answer.time_s
        starved = wall >= STARVED_MIN_WALL_S and cpu < STARVED_CPU_SHARE * wall
        if not starved or reruns >= MAX_RERUNS:
            return answer, cpu, reruns
        reruns += 1
        current = rebuild(timeout_s * min(MAX_STRETCH, max(wall / max(cpu, 1e-9), 1.0 / STARVED_CPU_SHARE)))
