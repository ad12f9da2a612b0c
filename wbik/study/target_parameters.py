"""The parameters of a study's target sets and paths, with defaults, checked as schema nodes."""

from __future__ import annotations

import math
from dataclasses import dataclass

from wbik.schema import Context, Interval, Key, Map, Node, Number, Shorthand, Text


@dataclass(frozen=True)
class Parameter:
    """A target set's or a path's parameter: ``default``, ``what`` it must be (messages), ``check``."""

    default: object
    what: str
    check: Node
    description: str = ""

    @property
    def node(self) -> Node:
        """The check, saying ``what`` in its messages."""
        return self.check.described(self.what)

    @property
    def key(self) -> Key:
        """The parameter as a schema key, with its default."""
        return Key(self.node, self.default, doc=self.description)


def number(low: float, high: float, *, low_open: bool = False, high_open: bool = False) -> Number:
    """A number in [low, high] (ends open where asked), as a float; a string holding one counts."""
    bounds = {("gt" if low_open else "ge"): low if math.isfinite(low) else None,
              ("lt" if high_open else "le"): high if math.isfinite(high) else None}
    return Number(**bounds, strings=True, as_float=True)


def integer(low: int, high: int | None = None) -> Number:
    """An integer in [low, high] (no upper end for None)."""
    return Number(ge=low, le=high, integer=True)


def interval(low: float, high: float) -> Interval:
    """A pair [a, b] with low <= a <= b <= high (a tuple of floats)."""
    return Interval(low, high, strings=True)


def parameters_map(name: str, parameters: dict[str, Parameter]) -> Shorthand:
    """A case's ``targets:``, the set's name or a mapping ``{set: name, key: value}``, defaults filled in."""
    keys = {"set": Key(Text((name,)), name, doc="the target set"),
            **{key: parameter.key for key, parameter in parameters.items()}}
    return Shorthand(Map(keys, what=f"a mapping {{set: {name}, ...its parameters}}"), "set",
                     what="a target set's name or a mapping {set: NAME, ...its parameters}")


def defaults(name: str, parameters: dict[str, Parameter]) -> dict:
    """The set's parameters at their defaults: ``{"set": name, key: default}``."""
    return parameters_map(name, parameters).check(name, "targets", Context("defaults"))
