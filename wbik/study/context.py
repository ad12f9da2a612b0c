"""What the study's runner, applicability check, case kinds and report share: the robot a task runs
on, the solver of a method, a method's solver budget, a chunk's seed, how many chunks a case has, and
the plain-data form of a mapping.

This module sits below :mod:`wbik.study.runner`, :mod:`wbik.study.applicability`,
:mod:`wbik.study.report` and the case kinds (:mod:`wbik.study.case_kinds`): they import it, it
imports none of them, so nothing here depends on the runner. The runner re-exports these names.
"""

from __future__ import annotations

import threading
import zlib
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from wbik.study.spec import CaseSpec
    from wbik.study.spec import Study

_LOCAL = threading.local()


def _frozen(mapping: dict) -> tuple:
    """A mapping as a sorted tuple of items (hashable, cheap to pickle, the same in every process)."""
    return tuple(sorted(mapping.items()))


def _robot(name: str, params: tuple):
    """The robot, loaded once per worker thread (a Robot's Pinocchio data is not thread-safe, and
    a Dask worker may run several tasks in threads of one process)."""
    cache = getattr(_LOCAL, "robots", None)
    if cache is None:
        cache = _LOCAL.robots = {}
    key = (name, params)
    if key not in cache:
        from wbik.models import load

        cache[key] = load(name, **dict(params))
    return cache[key]


def case_chain(robot_name: str, robot_params: tuple, chain: str | None, base: str | None = None,
               tip: str | None = None):
    """The chain of a case on the (per-thread cached) robot: by name, or between ``base`` and ``tip``
    (registered under ``chain``)."""
    robot = _robot(robot_name, robot_params)
    return robot.chain_between(base, tip, name=chain) if base is not None else robot.chain(chain)


def chain_of(case: CaseSpec):
    """The chain of a study case on the (per-thread cached) robot: :func:`case_chain` of its robot, robot
    parameters, chain name, base and tip."""
    return case_chain(case.robot, _frozen(case.robot_params), case.chain, case.base, case.tip)


def make_solver(robot_name: str, robot_params: tuple, chain: str | None, method: str, options: dict,
                timeout_s: float | None, tolerances: tuple, seed: int, base: str | None = None,
                tip: str | None = None):
    """The chain solver ``method`` on the (per-thread cached) robot, built as the study builds it."""
    from wbik.solvers.method_registry import solver
    from wbik.solvers.result import Tolerances

    robot = _robot(robot_name, robot_params)
    if base is not None:
        chain = case_chain(robot_name, robot_params, chain, base, tip).name
    return solver(method, robot, chain=chain, timeout_s=timeout_s,
                       tolerances=Tolerances(*tolerances), seed=seed, **options)


def solver_budget(method: str, timeout_s: float, options: dict) -> tuple[float | None, dict]:
    """(timeout_s, options) to build ``method`` with for a study budget of ``timeout_s`` seconds.

    Ours: no wall clock and ``max_iterations`` = the iterations that cost ``timeout_s`` on the
    reference machine (unless the study gives max_iterations itself). Others: the wall clock.
    """
    from wbik.solvers.method_registry import method_factory
    factory = method_factory(method)
    if getattr(factory, "iteration_cost_s", None) is None:
        return timeout_s, options
    if "max_iterations" in options:
        return None, options
    return None, {**options, "max_iterations": factory.iterations_for(timeout_s)}


def chunk_seed(seed: int, case: str, label: str, chunk: int) -> int:
    """A solver seed that depends only on the study seed and the task's identity."""
    sequence = np.random.SeedSequence([seed, zlib.crc32(case.encode()), zlib.crc32(label.encode()), chunk])
    return int(sequence.generate_state(1)[0])


def chunk_count(study: Study, case: CaseSpec) -> int:
    """How many chunks of ``study.chunk_size`` poses the case is cut into."""
    return -(-study.poses_of(case) // study.chunk_size)
