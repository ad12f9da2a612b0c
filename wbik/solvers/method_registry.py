"""The IK method registry: ``solver(method, robot, chain, **options)``.

A module declares its methods in an ``IK_METHODS`` tuple of :class:`IKMethod`; the modules are listed in
:data:`METHOD_MODULES` and imported on first use (:class:`wbik.registry.DeclaredRegistry`). User code adds
a method with :func:`register` (``wbik.register(name, MySolver)``) or a module of methods with
``IK_METHOD_REGISTRY.register_module(name)``. A method's optional library is imported when a solver is
built, so listing methods needs none.
"""

from __future__ import annotations

import importlib
import inspect

from wbik.errors import InvalidOptionError, UnknownMethodError
from wbik.options import OPTION_ERRORS, option_schema
from wbik.registry import DeclaredRegistry, RegistryError
from wbik.robot import Robot
from wbik.schema import Context, got
from wbik.solvers.base import Solver
from wbik.solvers.method import IKMethod, SolverFactory

__all__ = ["IKMethod", "IK_METHOD_REGISTRY", "METHOD_MODULES", "budget_options", "method_factory", "methods",
           "register", "register_method", "solver", "solver_options"]

METHOD_MODULES: list = []
"""The registry's modules: wbik's own (:mod:`wbik.catalog`), user code's (``register_module``), installed
packages' (entry-point group ``wbik.ik_methods``)."""

IK_METHOD_REGISTRY: DeclaredRegistry[IKMethod] = DeclaredRegistry(
    "IK method", "IK_METHODS", METHOD_MODULES, "wbik.solvers.method_registry.METHOD_MODULES", IKMethod,
    unknown=UnknownMethodError, plugins="wbik.ik_methods",
)

register_method = IK_METHOD_REGISTRY.register
"""Add an :class:`IKMethod` from user code (``replace`` one of the same name only when asked)."""


def register(name: str, factory: SolverFactory | str, description: str = "") -> None:
    """Add a method from user code: ``factory`` is a Solver subclass, a callable
    ``factory(robot, chain, **options)`` or a "package.module:Class" path (imported now). A name user code
    registered is replaced, a declared one only by ``register_method(IKMethod(...), replace=True)``."""
    if isinstance(factory, str):
        module_name, _, attribute = factory.partition(":")
        try:
            factory = getattr(importlib.import_module(module_name), attribute)
        except (ImportError, AttributeError, ValueError) as exc:
            raise RegistryError(f"IK method {name!r}: cannot import {factory!r} "
                                f"(expected 'package.module:Class'): {exc}") from exc
    IK_METHOD_REGISTRY.register(IKMethod(name, factory, description),
                      replace=IK_METHOD_REGISTRY.added_at_run_time(name) is not None)


def methods(installed: bool = False) -> dict[str, str]:
    """Registered method names with a one-line description; ``installed``: only those usable here."""
    found = IK_METHOD_REGISTRY.descriptions()
    if not installed:
        return found
    return {name: text for name, text in found.items() if IK_METHOD_REGISTRY.get(name).missing() is None}


def budget_options(method: str, timeout_s: float, options: dict,
                   problem: bool = False) -> tuple[float | None, dict]:
    """(timeout_s, options) of ``method`` for a budget of ``timeout_s``: :meth:`Solver.budget_options`."""
    factory = method_factory(method)
    rule = getattr(factory, "budget_options", None)
    return (timeout_s, dict(options)) if rule is None else rule(timeout_s, options, problem)


def method_factory(method: str) -> SolverFactory:
    """The factory of ``method``; UnknownMethodError listing the known methods."""
    return IK_METHOD_REGISTRY.get(method).factory


def solver_options(method: str) -> set[str] | None:
    """Keyword options ``solver(method, ...)`` accepts (None: any keyword)."""
    return option_schema(method_factory(method), leading=2).accepted  # robot, chain


def solver(method: str, robot: Robot | str, chain: str | None = None, *, base: str | None = None,
           tip: str | None = None, **options) -> Solver:
    """Make a solver: ``wbik.solver("dls", wbik.load("ur5"), chain="arm", timeout_s=0.01)``; a chain by
    name, or by its ``base`` and ``tip`` frames. Options are checked against the method's option schema
    first: an unknown one is an InvalidOptionError listing the method's options, a value of the wrong type
    an InvalidSettingError."""
    entry = IK_METHOD_REGISTRY.get(method)
    if entry.missing():
        raise entry.needs.error(f"method {method!r}")
    factory = entry.factory
    source = f"wbik.solver({method!r})"
    schema = option_schema(factory, leading=2, owner=f"method {method!r}")  # robot, chain
    options = schema.check(options, "", Context(source, OPTION_ERRORS))
    if not isinstance(factory, type):
        try:  # a plain callable: its own signature decides the rest (required options, **kwargs)
            inspect.signature(factory).bind(robot, chain, **options)
        except TypeError as exc:
            raise InvalidOptionError(f"{source}: method {method!r} cannot take these options: {exc}",
                                     option=f"({exc})", accepted=sorted(schema.accepted or ())) from exc
    if isinstance(robot, str):
        from wbik.models import load

        robot = load(robot)
    elif not isinstance(robot, Robot):
        raise InvalidOptionError(f"{source}: robot must be a wbik.Robot or a robot name, {got(robot)}",
                                 option="robot")
    if base is not None or tip is not None:
        if base is None or tip is None:
            raise InvalidOptionError("a chain by its frames needs both base= and tip=", option="base/tip")
        chain = robot.chain_between(base, tip, name=chain).name
    return factory(robot, chain, **options)
