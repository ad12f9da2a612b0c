"""The whole-body method registry: ``wholebody_solver(method, robot, **options)``.

A method is declared where its class lives, in that module's ``WHOLEBODY_METHODS`` tuple of
:class:`WholeBodyMethod` (name, :class:`~wbik.wholebody.solvers.WholeBodySolver` subclass, one-line
description); the modules holding methods are listed by name in :data:`METHOD_MODULES` (imported on
first use, see :class:`wbik.registry.DeclaredRegistry`: a module that fails to import, declares
none, or declares a name another declares too is an error naming it). User code adds a method with
:func:`register_wholebody_method`; :data:`WHOLEBODY_METHOD_REGISTRY` is the registry itself (a module
of methods: ``WHOLEBODY_METHOD_REGISTRY.register_module(name)``).

The methods' own optional libraries (PlaCo, Pink, mink and MuJoCo) are imported when a solver is
built, not when its module is, so listing a method costs no optional dependency.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from wbik.errors import UnknownMethodError
from wbik.registry import DeclaredRegistry
from wbik.registry import RegistryError
from wbik.registry import check_options
from wbik.registry import factory_options
from wbik.robot import Robot

if TYPE_CHECKING:
    from wbik.wholebody.solvers import WholeBodySolver

__all__ = ["METHOD_MODULES", "WHOLEBODY_METHOD_REGISTRY", "WholeBodyMethod", "register_wholebody_method",
           "wholebody_budget", "wholebody_methods", "wholebody_solver", "wholebody_solver_options"]

METHOD_MODULES: list[str] = [
    "wbik.wholebody.qp",
    "wbik.wholebody.placo",
    "wbik.wholebody.pink",
    "wbik.wholebody.mink",
]
"""The core's modules whose ``WHOLEBODY_METHODS`` are registered (a new module of methods: one line
here); applications add theirs through the entry-point group ``wbik.wholebody_methods``."""


@dataclass(frozen=True)
class WholeBodyMethod:
    """A whole-body method: its ``name`` (``wholebody_solver(name, ...)``, a study's ``method:``),
    its ``factory`` (a WholeBodySolver subclass: ``factory(robot, **options)``) and a one-line
    ``description``."""

    name: str
    factory: type[WholeBodySolver]
    description: str = ""

    def __post_init__(self) -> None:
        from wbik.wholebody.solvers import WholeBodySolver

        if not (isinstance(self.factory, type) and issubclass(self.factory, WholeBodySolver)):
            raise RegistryError(f"whole-body method {self.name!r}: the factory must be a WholeBodySolver "
                                f"subclass, got {self.factory!r}")


WHOLEBODY_METHOD_REGISTRY: DeclaredRegistry[WholeBodyMethod] = DeclaredRegistry(
    "whole-body method", "WHOLEBODY_METHODS", METHOD_MODULES, "wbik.wholebody.methods.METHOD_MODULES",
    WholeBodyMethod, unknown=UnknownMethodError, plugins="wbik.wholebody_methods",
)


def wholebody_methods() -> dict[str, str]:
    """Whole-body method names with a one-line description."""
    return WHOLEBODY_METHOD_REGISTRY.descriptions()


register_wholebody_method = WHOLEBODY_METHOD_REGISTRY.register
"""Add a method from user code (``replace`` one of the same name only when asked)."""


def _factory(method: str) -> type[WholeBodySolver]:
    return WHOLEBODY_METHOD_REGISTRY.get(method).factory


def wholebody_solver_options(method: str) -> set[str]:
    """Keyword options ``wholebody_solver(method, robot, **options)`` accepts."""
    return factory_options(_factory(method), leading=1) or set()  # robot


def wholebody_budget(method: str, timeout_s: float, options: dict) -> tuple[float | None, dict]:
    """(timeout_s, options) for a study budget of ``timeout_s`` s: every whole-body loop is ours, so
    the budget becomes ``max_iterations`` (unless given) and no wall clock."""
    if "max_iterations" in options:
        return None, dict(options)
    return None, {**options, "max_iterations": _factory(method).iterations_for(timeout_s)}


def wholebody_solver(method: str, robot: Robot | str, **options) -> WholeBodySolver:
    """Make a whole-body solver: ``wbik.wholebody_solver("qp", wbik.load(name), backend="daqp")``."""
    factory = _factory(method)
    check_options(f"whole-body method {method!r}", options, wholebody_solver_options(method))
    if isinstance(robot, str):
        from wbik.models import load

        robot = load(robot)
    return factory(robot, **options)
