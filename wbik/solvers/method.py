"""An IK method as the registry holds it: its name, its factory and a one-line description."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from wbik.dependencies import OptionalDependency
from wbik.registry import RegistryError
from wbik.solvers.base import Solver

SolverFactory = Callable[..., Solver]  # a Solver subclass or any factory(robot, chain, **options)


@dataclass(frozen=True)
class IKMethod:
    """An IK method: ``name``, ``factory(robot, chain, **options)``, ``description``, the library it needs."""

    name: str
    factory: SolverFactory
    description: str = ""
    needs: OptionalDependency | None = None

    def missing(self) -> str | None:
        """Why the method cannot be built here (its optional library is not installed), or None."""
        if self.needs is None or self.needs.installed():
            return None
        return str(self.needs.error(f"method {self.name!r}"))

    def __post_init__(self) -> None:
        if not callable(self.factory):
            raise RegistryError(f"IK method {self.name!r}: the factory must be a Solver subclass or a "
                                f"callable, got {self.factory!r}")
