"""The keyword options a factory takes (``wbik.solver``'s, a study or task file's methods'), as a schema
read from its signature (:func:`option_schema`): each option typed by its default, or for a None default
by its ``X | None`` annotation, untyped ones taking any value; ``timeout_s`` and ``seed`` typed by what
they are (:data:`TIMEOUT_S`, :data:`SEED`).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from functools import partial

from wbik.errors import InvalidOptionError
from wbik.schema import Anything, Boolean, Errors, Key, Map, Node, Number, Text, UnknownKeyError

TIMEOUT_S = Number(gt=0, unit="s", budget=True, as_float=True)
"""A time budget (s)."""
SEED = Number(integer=True, ge=0, nullable=True)
"""A random seed (None: unseeded)."""
COUNT = Number(integer=True, ge=1)
"""A count (threads, grid points, ...)."""
_NAMED = {"timeout_s": Number(gt=0, unit="s", budget=True, as_float=True, nullable=True), "seed": SEED,
          "tolerances": Anything("wbik.Tolerances(position=..., rotation=...)")}
_TYPED: dict[str, Callable[..., Node]] = {"bool": Boolean, "int": partial(Number, integer=True),
                                          "float": partial(Number, finite=False), "str": Text}


class UnknownOptionError(UnknownKeyError, InvalidOptionError):
    """An option the factory does not take: ``option`` (its path), ``accepted`` (the options it takes)."""

    def __init__(self, message: str, path: str = "", known: list[str] | tuple[str, ...] = ()):
        UnknownKeyError.__init__(self, message, path, known)
        self.option, self.accepted = path, self.known


OPTION_ERRORS = Errors(unknown=UnknownOptionError)
"""A Python call's option errors: InvalidOptionError (unknown), InvalidSettingError (bad value)."""


class Options(Map):
    """The options of ``owner`` (``"method 'dls'"``): ``keys``, and any other with ``any_other``."""

    words = "option(s)"

    def __init__(self, keys: dict[str, Key], any_other: bool = False, owner: str = "the factory",
                 unknown_error: type[UnknownKeyError] | None = None):
        super().__init__(keys, Anything() if any_other else None, unknown_error=unknown_error,
                         what=f"a mapping of the options of {owner}")
        self.owner, self.allowed = owner, f"{owner} takes"

    @property
    def accepted(self) -> set[str] | None:
        """The option names (None: any)."""
        return None if self.values is not None else set(self.keys)


def option_schema(factory: Callable, leading: int, skip: tuple[str, ...] = (), owner: str = "the factory",
                  unknown_error: type[UnknownKeyError] | None = None) -> Options:
    """The keyword options of ``factory(*leading arguments, **options)`` less ``skip``: for a class, those
    of each ``__init__`` along its hierarchy as far as ``**options`` are handed on; ``owner`` names the
    factory in messages."""
    functions = [factory] if not isinstance(factory, type) else [
        vars(klass)["__init__"] for klass in factory.__mro__[:-1] if "__init__" in vars(klass)]
    found: dict[str, inspect.Parameter] = {}
    any_other = True
    for function in functions:
        parameters = list(inspect.signature(function).parameters.values())
        for parameter in parameters[leading + isinstance(factory, type):]:  # self too
            if parameter.kind in (parameter.POSITIONAL_OR_KEYWORD, parameter.KEYWORD_ONLY):
                found.setdefault(parameter.name, parameter)
        any_other = any(parameter.kind is parameter.VAR_KEYWORD for parameter in parameters)
        if not any_other:
            break
    return Options({name: Key(_NAMED.get(name) or _node(parameter)) for name, parameter in found.items()
                    if name not in skip}, any_other, owner, unknown_error)


def _node(parameter: inspect.Parameter) -> Node:
    """An option's node from its default (or, for a None default, its annotation)."""
    default = parameter.default
    kind = type(default).__name__ if type(default) in (bool, int, float, str) else None
    if default is None and isinstance(parameter.annotation, str):
        words = {part.strip() for part in parameter.annotation.split("|")} - {"None"}
        kind = next(iter(words)) if len(words) == 1 else None
    return _TYPED[kind](nullable=default is None) if kind in _TYPED else Anything()
