"""What the study's runner, applicability check, case kinds and report share (and import from here, never
from each other): a task's robot, a chunk's seed and count."""

from __future__ import annotations

import threading
import zlib

import numpy as np

from wbik.study.spec import CaseSpec, Study

_LOCAL = threading.local()


def _frozen(mapping: dict) -> tuple:
    """A mapping as a sorted tuple of items (hashable, the same in every process)."""
    return tuple(sorted(mapping.items()))


def _robot(name: str, params: tuple):
    """The robot, loaded once per worker thread (a Robot's Pinocchio data is not thread-safe)."""
    cache = _LOCAL.__dict__.setdefault("robots", {})
    if (key := (name, params)) not in cache:
        from wbik.models import load

        cache[key] = load(name, **dict(params))
    return cache[key]


def case_chain(robot_name: str, robot_params: tuple, chain: str | None, base: str | None = None,
               tip: str | None = None):
    """A case's chain on the per-thread robot: by name, or between ``base`` and ``tip`` (named ``chain``)."""
    robot = _robot(robot_name, robot_params)
    return robot.chain_between(base, tip, name=chain) if base is not None else robot.chain(chain)


def chain_of(case: CaseSpec):
    """The chain of a study case (:func:`case_chain`)."""
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


def chunk_seed(seed: int, case: str, label: str, chunk: int) -> int:
    """A solver seed that depends only on the study seed and the task's identity."""
    sequence = np.random.SeedSequence([seed, zlib.crc32(case.encode()), zlib.crc32(label.encode()), chunk])
    return int(sequence.generate_state(1)[0])


def chunk_count(study: Study, case: CaseSpec) -> int:
    """How many chunks of ``study.chunk_size`` poses the case is cut into."""
    return -(-study.poses_of(case) // study.chunk_size)
