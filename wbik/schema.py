"""The schema language of wbik's inputs (task and study files, task entries, whole-body problems, solver
options): ``node.check(value, path, ctx)`` returns the value with its defaults filled in, or raises the
source's error (:class:`Errors`, all :class:`~wbik.errors.InvalidSettingError`) in one message form,
starting with the source and the key's path (``cases[2].poses``):

- ``{path} must be {what the node takes}, got {value} ({type})`` (a "did you mean" for a word);
- ``{key path}: {path} has unknown field(s) [...] (did you mean ...?); allowed: ...``;
- ``{path}: {why}`` (:meth:`Context.fail`).
"""

from __future__ import annotations

import copy
import inspect
import math
import numbers
import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import MISSING, dataclass, field, fields

from wbik.errors import InvalidBudgetError, InvalidSettingError, WbikError, closest_name, did_you_mean


# -- errors -----------------------------------------------------------------------------------------
class SchemaError(InvalidSettingError):
    """A value its schema refuses; the message names the source and the key's path."""


class SchemaValueError(SchemaError):
    """A value of the wrong type, outside its range, or not one of the allowed words; or a missing key."""


class UnknownKeyError(SchemaError):
    """A key the mapping does not read; ``path`` is where, ``known`` the keys allowed there."""

    def __init__(self, message: str, path: str = "", known: list[str] | tuple[str, ...] = ()):
        self.path, self.known = path, sorted(known)
        super().__init__(message)


class SchemaBudgetError(SchemaValueError, InvalidBudgetError):
    """A time or iteration budget that is not a finite number > 0."""


@dataclass(frozen=True)
class Errors:
    """A source's error classes: wrong values and missing keys, unknown keys (made from (message, path,
    known keys)), budgets (:class:`Number` with ``budget=True``)."""

    value: type[WbikError] = SchemaValueError
    unknown: type[WbikError] = UnknownKeyError
    budget: type[WbikError] = SchemaBudgetError


@dataclass
class Context:
    """Where a check runs: the source (a file, a Python call: every message starts with it), its errors."""

    source: str
    errors: Errors = field(default_factory=Errors)

    def fail(self, path: str, message: str, error: type[WbikError] | None = None):
        """Refuse the value at ``path``: "{source}: {path}: {message}"."""
        raise (error or self.errors.value)(f"{self.source}: {f'{path}: ' if path else ''}{message}")

    @property
    def refusals(self) -> tuple[type[WbikError], ...]:
        """The errors a check here raises (:class:`Either` tries its next option after one)."""
        return (SchemaError, self.errors.value, self.errors.unknown, self.errors.budget)

    def must(self, path: str, expected: str, value, error: type[WbikError] | None = None, hint: str = ""):
        """Refuse the value at ``path``: "{source}: {path} must be {expected}, got {value} ({type})"."""
        self.says(path, f"must be {expected}, {got(value)}{hint}", error)

    def says(self, path: str, sentence: str, error: type[WbikError] | None = None):
        """Refuse the value at ``path`` with a sentence going on from it: "{source}: {path} {sentence}"."""
        raise (error or self.errors.value)(f"{self.source}: {path or 'the top level'} {sentence}")


def join(path: str, key) -> str:
    """``path`` and one more key: ``phases[0]`` + ``tasks`` is ``phases[0].tasks``."""
    return f"{path}.{key}" if path else str(key)


def short(value, limit: int = 60) -> str:
    """``repr(value)``, cut to ``limit`` characters."""
    try:
        text = repr(value)
    except Exception:  # noqa: BLE001 - a hostile __repr__ must not hide the real error
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[:limit - 3] + "..."


def got(value) -> str:
    """"got VALUE (TYPE)", the tail of a refusal."""
    return f"got {short(value)} ({type(value).__name__})"


def _is_number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _words(choices) -> str:
    """'a', 'b' or 'c'."""
    quoted = [repr(str(choice)) for choice in choices]
    return quoted[0] if len(quoted) == 1 else f"{', '.join(quoted[:-1])} or {quoted[-1]}"


def unknown_keys(ctx: Context, path: str, given, known, error: type[WbikError] | None = None,
                 words: str = "field(s)", allowed: str = "allowed") -> None:
    """Refuse the keys of ``given`` that ``known`` lacks, each named with a "did you mean" guess."""
    known = sorted(map(str, known))
    unknown = sorted((key for key in given if key not in known), key=str)
    if not unknown:
        return
    guesses = [(key, guess) for key in unknown if (guess := closest_name(key, known)) is not None]
    hint = (f" (did you mean {guesses[0][1]!r}?)" if len(unknown) == 1 and guesses else " (did you mean "
            + ", ".join(f"{guess!r} for {key!r}" for key, guess in guesses) + "?)" if guesses else "")
    where = ", ".join(join(path, key) for key in unknown)
    raise (error or ctx.errors.unknown)(
        f"{ctx.source}: {where}: {f'{path} has ' if path else ''}unknown {words} {unknown}{hint}; {allowed}: "
        f"{', '.join(known) or '(none)'}", join(path, unknown[0]), known)


# -- nodes ------------------------------------------------------------------------------------------
NO_DEFAULT = object()  # a key's default when it has none: absent stays absent


class Node:
    """A value's rule: ``check(value, path, ctx)`` returns it (defaults filled in) or raises."""

    expected = "a value"

    def check(self, value, path: str, ctx: Context):
        return value

    def wrong(self, value, path: str, ctx: Context, error: type[WbikError] | None = None):
        ctx.must(path, self.expected, value, error)

    def checked(self, value, name: str, source: str, error: type[WbikError] | None = None):
        """``value``, the argument ``name`` of the Python call ``source``, checked (refused as ``error``)."""
        return self.check(value, name, Context(source, Errors(error, budget=error) if error else Errors()))

    def described(self, what: str) -> Node:
        """A copy that says ``what`` in its messages."""
        node = copy.copy(self)
        node.what = what
        return node


class Anything(Node):
    """Any value (the code that reads it checks it)."""

    def __init__(self, expected: str = "a value"):
        self.expected = expected


class Text(Node):
    """A string: one of ``choices`` (a tuple, or a function giving it), matching ``pattern``, not empty
    with ``non_empty``; ``what`` names it in messages (default: the choices, else the class's ``what``)."""

    what: str = "text"

    def __init__(self, choices: tuple | Callable[[], tuple] | None = None, nullable: bool = False,
                 what: str | None = None, pattern: str | None = None, non_empty: bool = False):
        self._choices = choices
        self.nullable, self.non_empty = nullable, non_empty
        self.pattern = re.compile(pattern) if pattern else None
        if what:
            self.what = what

    @property
    def choices(self) -> tuple | None:
        return self._choices() if callable(self._choices) else self._choices

    @property
    def expected(self) -> str:
        choices = self.choices
        text = vars(self).get("what") or (_words(choices) if choices else self.what)
        return text + (" or null" if self.nullable else "")

    def check(self, value, path, ctx):
        if value is None and self.nullable:
            return value
        if not isinstance(value, str) or (self.non_empty and not value.strip()) \
                or (self.pattern is not None and not self.pattern.match(value)):
            self.wrong(value, path, ctx)
        choices = self.choices
        if choices and value not in choices:
            ctx.must(path, self.expected, value, hint=did_you_mean(value, choices))
        return value


class Number(Node):
    """A finite real number (an int with ``integer``), optionally bounded (``gt``/``lt`` strict);
    ``strings``: a string holding one counts (PyYAML reads ``1e-6`` as a string); ``as_float``: returned
    as a float; ``finite=False``: infinities count; ``budget``: refused as a budget error."""

    def __init__(self, ge: float | None = None, gt: float | None = None, le: float | None = None,
                 lt: float | None = None, integer: bool = False, nullable: bool = False, unit: str = "",
                 budget: bool = False, strings: bool = False, as_float: bool = False, what: str = "",
                 finite: bool = True):
        self.ge, self.gt, self.le, self.lt, self.finite = ge, gt, le, lt, finite
        self.integer, self.nullable, self.unit, self.budget = integer, nullable, unit, budget
        self.strings, self.as_float, self.what = strings, as_float, what

    @property
    def expected(self) -> str:
        if self.what:
            return self.what + (" or null" if self.nullable else "")
        bounds = [(op, bound) for op, bound in ((">", self.gt), (">=", self.ge), ("<", self.lt),
                                                ("<=", self.le)) if bound is not None]
        text = "an integer" if self.integer else "a finite number" if self.finite else "a number"
        text += (" " + " and ".join(f"{op} {bound:g}" for op, bound in bounds)) if bounds else ""
        text += f" ({self.unit})" if self.unit else ""
        return text + (" or null" if self.nullable else "")

    def check(self, value, path, ctx):
        if value is None and self.nullable:
            return value
        error = ctx.errors.budget if self.budget else ctx.errors.value
        number = value
        if self.strings and isinstance(value, str) and not self.integer:
            try:
                number = float(value)
            except ValueError:
                pass
        if not _is_number(number) or (self.integer and not isinstance(number, numbers.Integral)):
            self.wrong(value, path, ctx, error)
        outside = ((self.gt is not None and not number > self.gt)
                   or (self.ge is not None and not number >= self.ge)
                   or (self.lt is not None and not number < self.lt)
                   or (self.le is not None and not number <= self.le))
        if (self.finite and not math.isfinite(number)) or math.isnan(number) or outside:
            self.wrong(value, path, ctx, error)
        return float(number) if self.as_float else number


class Vector(Node):
    """A list of ``size`` (any number when None) finite numbers."""

    def __init__(self, size: int | None = None, positive: bool = False, unit: str = ""):
        self.size, self.positive, self.unit = size, positive, unit

    @property
    def expected(self) -> str:
        return (f"a list of {f'{self.size} ' if self.size else ''}{'positive ' if self.positive else ''}"
                f"finite numbers{f' ({self.unit})' if self.unit else ''}")

    def check(self, value, path, ctx):
        if not isinstance(value, list | tuple) or not value or (self.size and len(value) != self.size):
            self.wrong(value, path, ctx)
        for index, item in enumerate(value):
            if not _is_number(item) or not math.isfinite(item) or (self.positive and not item > 0):
                ctx.must(f"{path}[{index}]", f"a {'positive ' if self.positive else ''}finite number "
                                             f"({path} is {self.expected})", item)
        return value


class Interval(Node):
    """A pair ``[a, b]`` with ``low <= a <= b <= high`` (``strings`` as for :class:`Number`), as floats."""

    def __init__(self, low: float, high: float, strings: bool = False, what: str = ""):
        self.low, self.high, self.strings, self.what = low, high, strings, what

    @property
    def expected(self) -> str:
        return self.what or f"a pair [a, b] with {self.low:g} <= a <= b <= {self.high:g}"

    def check(self, value, path, ctx):
        if not isinstance(value, list | tuple) or len(value) != 2:
            self.wrong(value, path, ctx)
        ends = Number(strings=self.strings, as_float=True)
        try:
            a, b = (ends.check(item, path, ctx) for item in value)
        except ctx.refusals:
            self.wrong(value, path, ctx)
        if not self.low <= a <= b <= self.high:
            self.wrong(value, path, ctx)
        return (a, b)


class ListOf(Node):
    def __init__(self, item: Node, min_items: int = 0, what: str = ""):
        self.item, self.min_items, self.what = item, min_items, what

    @property
    def expected(self) -> str:
        least = f" of at least {self.min_items}" if self.min_items > 1 else (
            " (not empty)" if self.min_items == 1 else "")
        return f"a list{least} of {self.what or self.item.expected}"

    def check(self, value, path, ctx):
        if not isinstance(value, list | tuple) or len(value) < self.min_items:
            self.wrong(value, path, ctx)
        return [self.item.check(item, f"{path}[{index}]", ctx) for index, item in enumerate(value)]


class Either(Node):
    """The first option that accepts the value; else the refusal of the one mapping option sharing its
    keys, of the one word option for a string (its "did you mean"), or one listing every option."""

    def __init__(self, *options: Node, what: str = ""):
        self.options, self.what = options, what

    @property
    def expected(self) -> str:
        return self.what or " or ".join(option.expected for option in self.options)

    def check(self, value, path, ctx):
        refusals = []
        for option in self.options:
            try:
                return option.check(value, path, ctx)
            except ctx.refusals as exc:
                refusals.append((option, exc))
        if isinstance(value, Mapping):
            maps = [(option, exc) for option, exc in refusals if isinstance(option, Map)]
            sharing = [exc for option, exc in maps if set(option.keys) & set(value)]
            if len(sharing) == 1 or len(maps) == 1:
                raise (sharing or [maps[0][1]])[0]
        if isinstance(value, str):
            words = [exc for option, exc in refusals if isinstance(option, Text) and option.choices]
            if len(words) == 1 and not self.what:
                raise words[0]
        self.wrong(value, path, ctx)


class Constant(Node):
    """One of a few exact values (``off``, ``false``, null, ...)."""

    def __init__(self, *values, what: str = ""):
        self.values, self.what = values, what

    @property
    def expected(self) -> str:
        return self.what or " or ".join("null" if value is None else repr(value) for value in self.values)

    def check(self, value, path, ctx):
        if not any(value is option or (type(value) is type(option) and value == option)
                   for option in self.values):
            self.wrong(value, path, ctx)
        return value


class Instance(Node):
    """A Python object of class ``kind`` (an argument of a Python call); ``nullable``: or None."""

    def __init__(self, kind: type | tuple[type, ...], expected: str, nullable: bool = False):
        self.kind, self.expected, self.nullable = kind, expected, nullable

    def check(self, value, path, ctx):
        if not isinstance(value, self.kind) and not (value is None and self.nullable):
            self.wrong(value, path, ctx)
        return value


class Boolean(Instance):
    def __init__(self, nullable: bool = False):
        super().__init__(bool, "true, false or null" if nullable else "true or false", nullable)


class Refused(Node):
    """A key that cannot be used here, refused by name with the reason."""

    def __init__(self, why: str):
        self.why = why

    def check(self, value, path, ctx):
        ctx.fail(path, self.why)


@dataclass
class Key:
    """A mapping's key: its rule, its default (filled in when absent), required or not, a ``doc`` line."""

    node: Node
    default: object = NO_DEFAULT
    required: bool = False
    doc: str = ""


class Map(Node):
    """A mapping with known ``keys`` and/or free keys whose values follow ``values``; ``post(result, path,
    ctx)`` runs after the keys (cross-key checks and defaults); ``nullable``: null is an empty mapping."""

    words, allowed = "field(s)", "allowed"

    def __init__(self, keys: dict[str, Key] | None = None, values: Node | None = None,
                 post: Callable | None = None, nullable: bool = False,
                 unknown_error: type[UnknownKeyError] | None = None, what: str = ""):
        self.keys = keys or {}
        self.values, self.post, self.nullable = values, post, nullable
        self.unknown_error, self.what = unknown_error, what

    @property
    def expected(self) -> str:
        return self.what or (f"a mapping with keys {', '.join(self.keys)}" if self.keys else "a mapping")

    def check(self, value, path, ctx):
        if value is None and self.nullable:
            value = {}
        if not isinstance(value, Mapping):
            self.wrong(value, path, ctx)
        for key in value:
            if not isinstance(key, str):
                ctx.fail(join(path, key), f"keys must be strings, {got(key)}")
        if self.values is None:
            unknown_keys(ctx, path, value, self.keys, self.unknown_error, self.words, self.allowed)
        nodes = {key: self.keys[key].node if key in self.keys else self.values for key in value}
        result = {key: nodes[key].check(item, join(path, key), ctx) for key, item in value.items()}
        for key, rule in self.keys.items():
            if key in result:
                continue
            if rule.required:
                ctx.fail(path, f"missing the required key {key!r} ({rule.node.expected})")
            if rule.default is None:
                result[key] = None
            elif rule.default is not NO_DEFAULT:
                result[key] = rule.node.check(copy.deepcopy(rule.default), join(path, key), ctx)
        if self.post is not None:
            self.post(result, path, ctx)
        return result


class Variants(Node):
    """A mapping whose keys depend on the variant ``select`` names; ``variants``: {name: node} or a getter."""

    def __init__(self, select: Callable[[Mapping], str | None],
                 variants: dict[str, Node] | Callable[[], dict[str, Node]], what: str, tag: str):
        self.select, self._variants, self.what, self.tag = select, variants, what, tag

    @property
    def variants(self) -> dict[str, Node]:
        return self._variants() if callable(self._variants) else self._variants

    @property
    def expected(self) -> str:
        return self.what

    def check(self, value, path, ctx):
        if not isinstance(value, Mapping):
            self.wrong(value, path, ctx)
        name, variants = self.select(value), self.variants
        if not isinstance(name, str) or name not in variants:  # a list or a mapping is no tag either
            choices = ", ".join(sorted(variants))
            if name is None:
                ctx.fail(path, f"must be {self.what}; it needs a {self.tag!r} (one of {choices}), "
                               f"got keys {sorted(map(str, value))}")
            where = join(path, self.tag) if self.tag in value else path
            ctx.fail(where, f"{self.tag} {short(name)} is not allowed{did_you_mean(name, variants)}; "
                            f"allowed: {choices}")
        return variants[name].check(value, path, ctx)


class Shorthand(Node):
    """A mapping a single word may stand for: ``s`` is ``{key: s}`` (``methods: [dls]``)."""

    def __init__(self, node: Map, key: str, what: str = ""):
        self.node, self.key, self.what = node, key, what

    @property
    def expected(self) -> str:
        return self.what or f"a {self.key} name or {self.node.expected}"

    def check(self, value, path, ctx):
        if isinstance(value, str):
            value = {self.key: value}
        elif not isinstance(value, Mapping):
            self.wrong(value, path, ctx)
        return self.node.check(value, path, ctx)


# -- schemas read from code ---------------------------------------------------------------------------
def from_dataclass(cls, nodes: dict[str, Node] | None = None) -> Map:
    """A mapping of a dataclass's fields, each with the dataclass's own default (one set of defaults)."""
    keys = {}
    for item in fields(cls):
        default = item.default if item.default is not MISSING else NO_DEFAULT
        integer = isinstance(default, int) and not isinstance(default, bool)
        keys[item.name] = Key((nodes or {}).get(item.name, Number(integer=integer)), default)
    return Map(keys)


def dataclass_default(cls, name: str):
    """The default of the dataclass ``cls``'s field ``name`` (its default factory called)."""
    item = {item.name: item for item in fields(cls)}[name]
    if item.default_factory is not MISSING:
        return item.default_factory()
    if item.default is MISSING:
        raise TypeError(f"{cls.__qualname__}.{name} has no default")
    return item.default


def default_of(function: Callable, parameter: str):
    """The default value of ``function``'s ``parameter`` (a key's default, written once)."""
    default = inspect.signature(function).parameters[parameter].default
    if default is inspect.Parameter.empty:
        raise TypeError(f"{function.__qualname__}({parameter}) has no default")
    return default


# -- reading a schema ---------------------------------------------------------------------------------
def key_rows(node: Node, path: str = "", depth: int = 0,
             nesting: int = 6) -> Iterator[tuple[str, str, str, str]]:
    """(key path, what it must be, default, doc) of a schema's keys, nested ones expanded: docs tables."""
    if isinstance(node, Shorthand):
        node = node.node
    if isinstance(node, Map):
        for key, rule in node.keys.items():
            where = join(path, key)
            if isinstance(rule.node, Refused):
                yield where, f"refused: {rule.node.why}", "", rule.doc
                continue
            default = ("required" if rule.required else "" if rule.default is NO_DEFAULT
                       else _doc_value(rule.default))
            yield where, rule.node.expected, default, rule.doc
            if depth < nesting:
                yield from key_rows(rule.node, where, depth + 1, nesting)
    elif isinstance(node, ListOf) and depth < nesting:
        yield from key_rows(node.item, f"{path}[]", depth + 1, nesting)
    elif isinstance(node, Variants) and depth < nesting:
        for name, variant in node.variants.items():
            for where, what, default, doc in key_rows(variant, path, depth + 1, nesting):
                yield f"{where} ({node.tag}: {name})", what, default, doc


def _doc_value(value) -> str:
    text = repr(value) if not isinstance(value, str) else f'"{value}"'
    return text if len(text) <= 40 else text[:37] + "..."
