"""Seeded whole-body cases for the whole-body study (``target: wholebody``, ``scenario: <sampler>``): case
``index`` of a :class:`CaseSampler` depends only on (sampler name, seed, index) (:func:`case_rng`). Samplers
are declared in a module's ``WHOLEBODY_CASES`` (:data:`CASE_MODULES`) or by :func:`register_sampler`."""

from __future__ import annotations

import zlib
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from wbik.models import load
from wbik.registry import DeclaredRegistry
from wbik.robot import Robot
from wbik.wholebody.problem import WholeBody

__all__ = ["CASE_MODULES", "CASE_REGISTRY", "CaseSampler", "WholeBodyCase", "cached_robot", "case_rng",
           "register_sampler", "sample_case"]

CASE_MODULES: list = []
"""The modules that declare samplers (also the entry-point group ``wbik.case_samplers``)."""


@dataclass
class WholeBodyCase:
    """One seeded case: ``problem`` from ``q0``, ``anchor`` (3,), its main target point, and ``q_true``."""

    problem: WholeBody
    q0: np.ndarray
    anchor: np.ndarray
    q_true: np.ndarray | None = None


@dataclass(frozen=True)
class CaseSampler:
    """A family of seeded cases: ``name`` (``scenario:``), ``robot``, ``sample(rng, index)``, description."""

    name: str
    robot: str
    sample: Callable[[np.random.Generator, int], WholeBodyCase]
    description: str = ""


CASE_REGISTRY: DeclaredRegistry[CaseSampler] = DeclaredRegistry(
    "whole-body case sampler", "WHOLEBODY_CASES", CASE_MODULES, "wbik.wholebody.cases.CASE_MODULES",
    CaseSampler, plugins="wbik.case_samplers",
)


def case_rng(name: str, seed: int, index: int) -> np.random.Generator:
    """The random stream of case ``index`` of sampler ``name`` for ``seed``."""
    return np.random.default_rng([int(seed), zlib.crc32(name.encode()), int(index)])


@lru_cache(maxsize=8)
def cached_robot(name: str) -> Robot:
    """The built-in robot ``name``, loaded once per process (samplers build many cases on it)."""
    return load(name)


register_sampler = CASE_REGISTRY.register
"""Add a sampler from user code (``replace`` one of the same name only when asked)."""


def sample_case(name: str, seed: int, index: int) -> WholeBodyCase:
    """Case ``index`` of sampler ``name`` for ``seed`` (see the module docstring)."""
    return CASE_REGISTRY.get(name).sample(case_rng(name, seed, index), int(index))
