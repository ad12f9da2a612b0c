"""The parameters of a study's target sets: what a case's ``targets:`` mapping may hold, with defaults,
and their checks (a :class:`~wbik.study.definition.StudyDefinitionError` naming the key path, e.g.
``cases[2].targets.fraction``)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from wbik.errors import closest_name
from wbik.study.definition import StudyDefinitionError


@dataclass(frozen=True)
class Parameter:
    """One parameter of a target set: its ``default``, ``what`` it must be (for messages) and its
    ``check`` (the value normalised, or None when it is not one)."""

    default: object
    what: str
    check: Callable[[object], object | None]
    description: str = ""


def _float(value) -> float | None:
    """A finite float from a number or a string holding one (YAML reads 1e-3 as a string), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            return None
    if not isinstance(value, int | float) or not math.isfinite(value):
        return None
    return float(value)


def number(low: float, high: float, *, low_open: bool = False, high_open: bool = False) -> Callable:
    """A check of a number in [low, high] (ends open where asked)."""
    def check(value):
        number_ = _float(value)
        if number_ is None or number_ < low or number_ > high:
            return None
        if (low_open and number_ == low) or (high_open and number_ == high):
            return None
        return number_
    return check


def integer(low: int, high: int | None = None) -> Callable:
    """A check of an integer in [low, high] (no upper end for None)."""
    def check(value):
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            return None
        if high is not None and value > high:
            return None
        return int(value)
    return check


def interval(low: float, high: float) -> Callable:
    """A check of a pair [a, b] with low <= a <= b <= high (a tuple of floats)."""
    def check(value):
        if not isinstance(value, list | tuple) or len(value) != 2:
            return None
        a, b = _float(value[0]), _float(value[1])
        if a is None or b is None or not low <= a <= b <= high:
            return None
        return (a, b)
    return check


def choice(*names: str) -> Callable:
    """A check of one of ``names``."""
    return lambda value: value if isinstance(value, str) and value in names else None


def checked_parameters(name: str, parameters: dict[str, Parameter], raw, source: str, where: str) -> dict:
    """A case's ``targets:`` (the set's name, or a mapping with ``set:`` and parameters) checked against
    the set ``name``'s ``parameters`` and completed with their defaults: ``{"set": name, key: value}``."""
    given = {} if raw is None or isinstance(raw, str) else raw
    if not isinstance(given, dict):
        raise StudyDefinitionError(f"{source}: {where}.targets must be a target set's name or a mapping "
                                   f"{{set: NAME, ...its parameters}}, got {raw!r}")
    known = {"set", *parameters}
    unknown = sorted(set(given) - known, key=str)
    if unknown:
        guess = closest_name(unknown[0], known)
        hint = f" (did you mean {guess!r}?)" if guess else ""
        raise StudyDefinitionError(f"{source}: {where}.targets has unknown field(s) {unknown}{hint}; the "
                                   f"target set {name!r} takes: {', '.join(sorted(known))}")
    checked: dict = {"set": name}
    for key, parameter in parameters.items():
        value = given.get(key, parameter.default)
        normalised = parameter.check(value)
        if normalised is None:
            raise StudyDefinitionError(f"{source}: {where}.targets.{key} must be {parameter.what}, "
                                       f"got {value!r}")
        checked[key] = normalised
    return checked


def defaults(name: str, parameters: dict[str, Parameter]) -> dict:
    """The set's parameters at their defaults: ``{"set": name, key: default}``."""
    return checked_parameters(name, parameters, None, "defaults", "defaults")
