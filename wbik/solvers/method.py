"""An IK method as the registry holds it: its name, its factory and a one-line description."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from wbik.registry import RegistryError
from wbik.solvers.base import Solver

SolverFactory = Callable[..., Solver]  # a Solver subclass or any factory(robot, chain, **options)


@dataclass(frozen=True)
class IKMethod:
    """An IK method: its ``name`` (``solver(name, ...)``, a study's ``method:``), its ``factory``
    (``factory(robot, chain, **options)``, usually a Solver subclass) and a one-line ``description``."""

    name: str
    factory: SolverFactory
    description: str = ""

    def __post_init__(self) -> None:
        if not callable(self.factory):
            raise RegistryError(f"IK method {self.name!r}: the factory must be a Solver subclass or a "
                                f"callable, got {self.factory!r}")
