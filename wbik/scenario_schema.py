"""The schema language of scenario files (tasks/*.yaml): keys, types, ranges, defaults, and checking.

Each scenario kind declares its schema next to its runner (a :class:`Map` built by the kind's
``schema`` function, see :class:`wbik.scenarios.kinds.ScenarioKind`) from the nodes below.
``validate(spec, source)`` checks a scenario mapping against its kind's schema before anything
runs and returns a copy with the defaults filled in; every runner reads that copy (``spec["margin"]``,
never ``spec.get("margin", ...)``), so each default is written once: in the schema, or in the
function, dataclass or class the key feeds, which the schema reads (:func:`default_of`,
:func:`from_dataclass`).

One set of defaults for the keys several kinds share (the builders below give them):

- ``robot_params`` (:func:`common_keys`): ``{}``; every kind loads its robot with them, or refuses
  the key by name (ur5_riveting); for a robot loaded from a URDF path or ``example-robot-data:NAME``
  they are typed (:func:`urdf_robot_params`: floating_base, nominal, soles, chains, ...);
- ``soles`` (:func:`soles_key`): ``[]``; the feet (rectangles, contact points, point feet) of a robot
  loaded from a URDF path or example-robot-data, for the kinds that keep one balanced;
- ``backend`` (:func:`backend_key`): :data:`wbik.qp.backends.DEFAULT`, for every kind that solves
  a whole-body QP (and the riveting ``ours`` planner);
- ``margin`` (:func:`margin_key`): :data:`COM_MARGIN` = 0.005 m, the CoM margin of every kind that
  keeps a robot balanced;
- ``expect``: null (each kind's own default expectations; see its runner);
- ``start``: "nominal"; ``timing.law``: "quintic". ``timing.mode`` differs on purpose: "global"
  for motion kinds (:func:`wbik.motion.timing.time_scale`), "segment" for the Bioloid's servo
  timing, rest at every sample like the seed code (the Bioloid application's gait timing).

What is refused, always naming the file and the key's path (``phases[1].tasks[0].frame``):

- a key the kind does not read (:class:`UnknownScenarioKeyError`, with the known keys and a
  "did you mean" guess; inside ``expect`` blocks it is also an
  :class:`~wbik.expectations.ExpectationError`);
- a value of the wrong type or outside its range, or a word not among the allowed ones
  (:class:`ScenarioValueError`); budgets (``timeout_s``, ``max_iterations``, ``duration_s``) must
  be finite and > 0 (:class:`ScenarioBudgetError`, an :class:`~wbik.errors.InvalidBudgetError`);
- an unknown robot (:class:`~wbik.errors.UnknownRobotError` listing the robots), robot parameters
  the robot's builder does not take (:class:`~wbik.errors.InvalidOptionError`), an unknown IK
  method (:class:`~wbik.errors.UnknownMethodError`), a QP backend that is unknown
  (:class:`ScenarioValueError`) or not installed (:class:`~wbik.errors.MissingDependencyError`,
  checked with :func:`wbik.qp.backends.resolve`).
"""

from __future__ import annotations

import copy
import inspect
import math
import numbers
from collections.abc import Callable
from collections.abc import Mapping
from dataclasses import MISSING
from dataclasses import dataclass
from dataclasses import fields

from wbik.errors import InvalidBudgetError
from wbik.errors import InvalidOptionError
from wbik.errors import MissingDependencyError
from wbik.errors import UnknownMethodError
from wbik.errors import UnknownRobotError
from wbik.errors import WbikError
from wbik.errors import did_you_mean
from wbik.expectations import ExpectationError

__all__ = ["COM_MARGIN", "Key", "Map", "ScenarioBudgetError", "ScenarioError", "ScenarioFileError",
           "ScenarioValueError", "UnknownExpectationKeyError", "UnknownScenarioKeyError", "apply_soles",
           "backend_key", "common_keys", "default_of", "expect_block", "from_dataclass", "kind_schema",
           "margin_key", "soles_key", "urdf_robot_params", "validate"]


# -- errors -----------------------------------------------------------------------------------------
class ScenarioError(WbikError, ValueError):
    """A scenario file that cannot be read or names something that does not exist."""


class ScenarioFileError(ScenarioError):
    """The file itself: missing, a directory, not UTF-8, empty, not YAML/JSON/TOML, not a mapping."""


class UnknownScenarioKeyError(ScenarioError):
    """A key the scenario's kind does not read; ``path`` is where, ``known`` the keys allowed there."""

    def __init__(self, message: str, path: str = "", known: list[str] | tuple[str, ...] = ()):
        self.path = path
        self.known = sorted(known)
        super().__init__(message)


class UnknownExpectationKeyError(UnknownScenarioKeyError, ExpectationError):
    """An unknown key inside an ``expect:`` block."""


class ScenarioValueError(ScenarioError):
    """A value of the wrong type, outside its range, or not one of the allowed words; or a missing key."""


class ScenarioBudgetError(ScenarioValueError, InvalidBudgetError):
    """A time or iteration budget that is not a finite number > 0."""


# -- nodes ------------------------------------------------------------------------------------------
NO_DEFAULT = object()


@dataclass
class Context:
    source: str

    def fail(self, path: str, message: str, error: type[WbikError] = ScenarioValueError):
        raise error(f"{self.source}: {path or 'the top level'}: {message}")


def _join(path: str, key) -> str:
    return f"{path}.{key}" if path else str(key)


def _short(value, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _got(value) -> str:
    return f"got {_short(value)} ({type(value).__name__})"


def _is_number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


class Node:
    """A value's rule: ``check(value, path, ctx)`` returns it (defaults filled) or raises."""

    expected = "a value"

    def check(self, value, path: str, ctx: Context):
        return value

    def wrong(self, value, path: str, ctx: Context):
        ctx.fail(path, f"must be {self.expected}, {_got(value)}")


class Anything(Node):
    def __init__(self, expected: str = "a value"):
        self.expected = expected


class Boolean(Node):
    expected = "true or false"

    def check(self, value, path, ctx):
        if not isinstance(value, bool):
            self.wrong(value, path, ctx)
        return value


class Text(Node):
    """A string, one of ``choices`` when given (a tuple, or a function giving it); ``what`` says what
    it is in messages (a subclass's class attribute, unless given)."""

    what: str = "a string"

    def __init__(self, choices: tuple | Callable[[], tuple] | None = None, nullable: bool = False,
                 what: str | None = None):
        self._choices = choices
        self.nullable = nullable
        if what is not None:
            self.what = what

    @property
    def choices(self) -> tuple | None:
        return self._choices() if callable(self._choices) else self._choices

    @property
    def expected(self) -> str:
        choices = self.choices
        text = f"one of {', '.join(map(str, choices))}" if choices else self.what
        return text + (" or null" if self.nullable else "")

    def check(self, value, path, ctx):
        if value is None and self.nullable:
            return value
        if not isinstance(value, str):
            self.wrong(value, path, ctx)
        choices = self.choices
        if choices and value not in choices:
            ctx.fail(path, f"{value!r} is not allowed{did_you_mean(value, choices)}; allowed: "
                           f"{', '.join(map(str, choices))}")
        return value


class Number(Node):
    """A finite real number (an int with ``integer``), optionally bounded; ``gt`` is a strict bound."""

    def __init__(self, ge: float | None = None, gt: float | None = None, le: float | None = None,
                 integer: bool = False, nullable: bool = False, unit: str = "", budget: bool = False):
        self.ge, self.gt, self.le = ge, gt, le
        self.integer, self.nullable, self.unit, self.budget = integer, nullable, unit, budget

    @property
    def expected(self) -> str:
        text = "an integer" if self.integer else "a finite number"
        bounds = [f"{op} {bound:g}" for op, bound in ((">", self.gt), (">=", self.ge), ("<=", self.le))
                  if bound is not None]
        text += (" " + " and ".join(bounds)) if bounds else ""
        text += f" ({self.unit})" if self.unit else ""
        return text + (" or null" if self.nullable else "")

    def check(self, value, path, ctx):
        if value is None and self.nullable:
            return value
        error = ScenarioBudgetError if self.budget else ScenarioValueError
        if not _is_number(value) or (self.integer and not isinstance(value, numbers.Integral)):
            ctx.fail(path, f"must be {self.expected}, {_got(value)}", error)
        outside = ((self.gt is not None and not value > self.gt)
                   or (self.ge is not None and not value >= self.ge)
                   or (self.le is not None and not value <= self.le))
        if not math.isfinite(value) or outside:
            ctx.fail(path, f"must be {self.expected}, got {value!r}", error)
        return value


class Vector(Node):
    """A list of ``size`` (any number when None) finite numbers."""

    def __init__(self, size: int | None = None, positive: bool = False, unit: str = ""):
        self.size, self.positive, self.unit = size, positive, unit

    @property
    def expected(self) -> str:
        count = f"{self.size} " if self.size else ""
        sign = "positive " if self.positive else ""
        unit = f" ({self.unit})" if self.unit else ""
        return f"a list of {count}{sign}finite numbers{unit}"

    def check(self, value, path, ctx):
        if not isinstance(value, list | tuple) or not value or (self.size and len(value) != self.size):
            self.wrong(value, path, ctx)
        for index, item in enumerate(value):
            if not _is_number(item) or not math.isfinite(item) or (self.positive and not item > 0):
                ctx.fail(f"{path}[{index}]", f"must be a {'positive ' if self.positive else ''}finite "
                                             f"number ({path} is {self.expected}), {_got(item)}")
        return value


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
    """The first option that accepts the value; else the refusal of the one mapping option the value
    shares keys with (it names the key), for a string the refusal of the one word option (its "did
    you mean"), or an error listing every option."""

    def __init__(self, *options: Node):
        self.options = options

    @property
    def expected(self) -> str:
        return " or ".join(option.expected for option in self.options)

    def check(self, value, path, ctx):
        refusals = []
        for option in self.options:
            try:
                return option.check(value, path, ctx)
            except (ScenarioValueError, UnknownScenarioKeyError) as exc:
                refusals.append((option, exc))
        if isinstance(value, Mapping):
            maps = [(option, exc) for option, exc in refusals if isinstance(option, Map)]
            sharing = [exc for option, exc in maps if set(option.keys) & set(value)]
            if len(sharing) == 1 or len(maps) == 1:
                raise (sharing or [maps[0][1]])[0]
        if isinstance(value, str):
            words = [exc for option, exc in refusals if isinstance(option, Text) and option.choices]
            if len(words) == 1:
                raise words[0]
        self.wrong(value, path, ctx)


class Refused(Node):
    """A key a kind cannot use, refused by name with the reason."""

    def __init__(self, why: str):
        self.why = why

    def check(self, value, path, ctx):
        ctx.fail(path, self.why)


@dataclass
class Key:
    """A key of a mapping: its rule, its default (filled in when absent) and whether it is required."""

    node: Node
    default: object = NO_DEFAULT
    required: bool = False


class Map(Node):
    """A mapping with known keys (``keys``) and/or free keys whose values follow ``values``.

    ``post(result, path, ctx)`` runs after the keys: cross-key checks and defaults that depend on
    other keys. ``nullable``: null stands for an empty mapping.
    """

    def __init__(self, keys: dict[str, Key] | None = None, values: Node | None = None,
                 post: Callable | None = None, nullable: bool = False,
                 unknown_error: type[UnknownScenarioKeyError] = UnknownScenarioKeyError, what: str = ""):
        self.keys = keys or {}
        self.values, self.post, self.nullable = values, post, nullable
        self.unknown_error, self.what = unknown_error, what

    @property
    def expected(self) -> str:
        if self.what:
            return self.what
        return f"a mapping with keys {', '.join(self.keys)}" if self.keys else "a mapping"

    def check(self, value, path, ctx):
        if value is None and self.nullable:
            value = {}
        if not isinstance(value, Mapping):
            self.wrong(value, path, ctx)
        result = {}
        for key, item in value.items():
            where = _join(path, key)
            if not isinstance(key, str):
                ctx.fail(where, f"keys must be strings, got {_short(key)} ({type(key).__name__})")
            if key in self.keys:
                result[key] = self.keys[key].node.check(item, where, ctx)
            elif self.values is not None:
                result[key] = self.values.check(item, where, ctx)
            else:
                known = sorted(self.keys)
                raise self.unknown_error(
                    f"{ctx.source}: unknown key {where!r}{did_you_mean(key, known)}; known keys "
                    f"{'at ' + repr(path) if path else 'at the top level'}: {', '.join(known) or '(none)'}",
                    where, known)
        for key, rule in self.keys.items():
            if key in result:
                continue
            if rule.required:
                ctx.fail(path, f"missing the required key {key!r} ({rule.node.expected})")
            if rule.default is None:
                result[key] = None
            elif rule.default is not NO_DEFAULT:
                result[key] = rule.node.check(copy.deepcopy(rule.default), _join(path, key), ctx)
        if self.post is not None:
            self.post(result, path, ctx)
        return result


class Variants(Node):
    """A mapping whose allowed keys depend on one of its values (``select`` names the variant)."""

    def __init__(self, select: Callable[[Mapping], str | None], variants: dict[str, Node], what: str,
                 tag: str):
        self.select, self.variants, self.what, self.tag = select, variants, what, tag

    @property
    def expected(self) -> str:
        return self.what

    def check(self, value, path, ctx):
        if not isinstance(value, Mapping):
            self.wrong(value, path, ctx)
        name = self.select(value)
        if not isinstance(name, str) or name not in self.variants:  # a list or a mapping is no tag either
            choices = ", ".join(sorted(self.variants))
            if name is None:
                ctx.fail(path, f"must be {self.what}; it needs a {self.tag} (one of {choices}), "
                               f"got keys {sorted(map(str, value))}")
            where = _join(path, self.tag) if self.tag in value else path
            ctx.fail(where, f"{self.tag} {_short(name)} is not allowed{did_you_mean(name, self.variants)}; "
                            f"allowed: {choices}")
        return self.variants[name].check(value, path, ctx)


# -- names checked against what exists --------------------------------------------------------------
class Robot(Text):
    """A built-in robot name, ``example-robot-data:NAME`` or a .urdf path; ``only`` restricts a kind to
    some robots."""

    what = "a built-in robot name, example-robot-data:NAME or the path of a .urdf file"

    def __init__(self, only: tuple[str, ...] | None = None):
        super().__init__()
        self.only = only

    def check(self, value, path, ctx):
        from pathlib import Path

        from wbik.models import robot_entries
        from wbik.models.erd import example_robot_name
        from wbik.models.erd import example_robot_names

        known = list(robot_entries())
        if not isinstance(value, str):
            raise UnknownRobotError(_short(value), known, hint=f"{ctx.source}: {path} must be a "
                                    "robot name (a string) or the path of a .urdf file")
        if self.only and value not in self.only:
            ctx.fail(path, f"robot {value!r} cannot run this kind; it runs on {', '.join(self.only)}")
        example = example_robot_name(value)
        if example is not None:
            names = example_robot_names()
            if example not in names:
                raise UnknownRobotError(value, [f"example-robot-data:{name}" for name in names],
                                        hint=f"{ctx.source}: {path}{did_you_mean(example, names)}")
            return value
        if value not in known and Path(value).suffix.lower() not in (".urdf", ".xml") \
                and not Path(value).expanduser().exists():
            raise UnknownRobotError(value, known,
                                    hint=f"{ctx.source}: {path}{did_you_mean(value, known)}. Pass a built-in "
                                         "name ('wbik robots' lists them), example-robot-data:NAME or a "
                                         ".urdf path")
        return value


class Backend(Text):
    """A QP backend name: a known one ('fastest', 'default' or BACKEND_OPTIONS) that is installed."""

    what = "a QP backend name"

    def check(self, value, path, ctx):
        from wbik.qp.backends import BACKEND_OPTIONS
        from wbik.qp.backends import available
        from wbik.qp.backends import resolve

        super().check(value, path, ctx)
        known = ["fastest", "default", *sorted(BACKEND_OPTIONS)]
        if value not in known:
            ctx.fail(path, f"unknown QP backend {value!r}{did_you_mean(value, known)}; known: "
                           f"{', '.join(known)} (installed here: {', '.join(available())})")
        try:
            resolve(value)
        except MissingDependencyError as exc:
            raise MissingDependencyError(f"{ctx.source}: {path}: {exc}") from None
        return value


class Method(Text):
    """A registered IK method (``wbik methods``)."""

    what = "an IK method name ('wbik methods' lists them)"

    def check(self, value, path, ctx):
        from wbik.solvers.method_registry import methods

        if not isinstance(value, str) or value not in methods():
            raise UnknownMethodError(value if isinstance(value, str) else _short(value), list(methods()),
                                     hint=f"{ctx.source}: {path}{did_you_mean(value, methods())}")
        return value



# -- building blocks the kinds' schemas share --------------------------------------------------------
COM_MARGIN = 0.005
"""m, the default CoM margin inside the support polygon of every kind that keeps a robot balanced."""

POSITIVE = Number(gt=0)
NON_NEGATIVE = Number(ge=0)
class Axes(Text):
    """A non-empty subset of "xyz", each axis once (a task's ``axes``: "xy", "z", ...)."""

    what = "a subset of 'xyz' (e.g. xy)"

    def check(self, value, path, ctx):
        value = super().check(value, path, ctx)
        if not value or any(axis not in "xyz" for axis in value) or len(set(value)) != len(value):
            ctx.fail(path, f"must be {self.what}: each of x, y, z at most once, got {value!r}")
        return value


VECTOR3 = Vector(3)
START = Either(Text(("nominal",)), Vector())
FRAME = Text(what="a frame name")
FRAMES = ListOf(FRAME, what="frame names")


def urdf_robot_params() -> Map:
    """The ``robot_params`` of a robot loaded from a URDF path or example-robot-data (the keyword
    parameters of :func:`wbik.models.load`, ``URDF_PARAMS``), typed; ``chains`` entries become
    :class:`wbik.robot.ChainSpec` (without ``joints``: every joint between base and tip)."""
    from wbik.models import URDF_PARAMS

    chain = Map({"name": Key(Text(), required=True), "base": Key(FRAME, required=True),
                 "tip": Key(FRAME, required=True), "joints": Key(ListOf(Text(what="a joint name")), []),
                 "description": Key(Text(), "")})
    python_only = Refused("is a Python object: pass it to wbik.load(...) from Python")
    nodes = {"floating_base": Boolean(), "name": Text(), "nominal": Vector(unit="m, rad"),
             "package_dirs": ListOf(Text(what="a folder")),
             "soles": Map(values=Either(VECTOR3, ListOf(VECTOR3, min_items=1)),
                          what="a mapping {sole frame: its contact points [[x, y, z], ...] (m)}"),
             "chains": ListOf(chain, what="chain mappings {name, base, tip, joints}")}

    def post(params: dict, path: str, ctx: Context) -> None:
        from wbik.robot import ChainSpec

        if "chains" in params:
            params["chains"] = [ChainSpec(item["name"], item["base"], item["tip"], tuple(item["joints"]),
                                          item["description"]) for item in params["chains"]]

    return Map({name: Key(nodes.get(name, python_only)) for name in URDF_PARAMS}, post=post)


def check_robot_params(spec: dict, path: str, ctx: Context) -> None:
    """The robot's builder must take every key of ``robot_params`` (wbik.models.check_parameters); a
    robot loaded from a URDF path or example-robot-data has its parameters typed
    (:func:`urdf_robot_params`: an unknown key gets a "did you mean", a bad value names its path)."""
    from wbik.models import check_parameters
    from wbik.models import robot_entries

    params = spec.get("robot_params") or {}
    if params and spec.get("robot") is not None:
        if spec["robot"] not in robot_entries():
            spec["robot_params"] = urdf_robot_params().check(params, _join(path, "robot_params"), ctx)
            return
        try:
            check_parameters(spec["robot"], params)
        except InvalidOptionError as exc:
            raise InvalidOptionError(f"{ctx.source}: robot_params: {exc}", option=exc.option,
                                     accepted=exc.accepted) from None


def common_keys(robot: Key, **more: Key) -> dict[str, Key]:
    """The keys of every kind: ``kind``, ``name`` (default ''), ``robot`` and ``robot_params``
    (default {}: the parameters of the robot's builder; :func:`kind_schema` checks them, or pair the
    Map with ``post=check_robot_params``), and ``more``."""
    return {"kind": Key(Text(), required=True), "name": Key(Text(), ""), "robot": robot,
            "robot_params": Key(Map(values=Anything()), {}), **more}


def kind_schema(common: dict[str, Key], keys: dict[str, Key]) -> Map:
    """A kind's schema: the ``common`` keys (:func:`common_keys`, with those its family shares) and
    the kind's own ``keys``; ``robot_params`` checked against the robot's builder
    (:func:`check_robot_params`)."""
    return Map({**common, **keys}, post=check_robot_params)


def backend_key() -> Key:
    """``backend``: an installed QP backend, default :data:`wbik.qp.backends.DEFAULT`."""
    from wbik.qp.backends import DEFAULT

    return Key(Backend(), DEFAULT)


def margin_key() -> Key:
    """``margin``: the CoM margin (m), default :data:`COM_MARGIN`."""
    return Key(Number(unit="m"), COM_MARGIN)


def soles_key() -> Key:
    """``soles``: the feet of a robot loaded from a URDF path or example-robot-data, each
    ``{frame, size: [length, width], centre: [x, y, z]}`` (a flat sole: a rectangle in the sole frame,
    centred on ``centre``, default the frame's origin), ``{frame, corners: [[x, y, z], ...]}`` (any
    contact points: a polygon, an edge) or ``{frame, point: [x, y, z]}`` (a point foot), in m; default
    none (the robot's own soles). :func:`apply_soles` turns them into ``robot_params.soles``."""

    def one_shape(entry: dict, path: str, ctx: Context) -> None:
        shapes = [key for key in SOLE_SHAPES if key in entry]
        if len(shapes) != 1:
            ctx.fail(path, f"a sole takes exactly one of {', '.join(SOLE_SHAPES)}, got "
                           f"{', '.join(shapes) or 'none'} (size: a rectangle, corners: contact points, "
                           "point: a point foot)")
        if "centre" in entry and shapes != ["size"]:
            ctx.fail(_join(path, "centre"), "is the centre of a size rectangle; with corners or point, "
                                            "give the points themselves")

    sole = Map({"frame": Key(FRAME, required=True), "size": Key(Vector(2, positive=True, unit="m")),
                "centre": Key(VECTOR3), "corners": Key(ListOf(VECTOR3, min_items=1, what="[x, y, z] points")),
                "point": Key(VECTOR3)}, post=one_shape)
    return Key(ListOf(sole, what="sole mappings {frame, size | corners | point}"), [])


SOLE_SHAPES = ("size", "corners", "point")
"""The keys of a ``soles`` entry that give its shape (exactly one per sole)."""


def apply_soles(spec: dict, path: str, ctx: Context) -> None:
    """Checked ``soles`` entries (:func:`soles_key`) into ``robot_params.soles`` ({frame: (k, 3) contact
    points}), for a robot whose loader takes soles; a frame given twice, or soles given both ways, is
    refused by path."""
    from wbik.models import builder_parameters
    from wbik.qp.support_polygon import sole_rectangle

    entries = spec.get("soles") or []
    if not entries:
        return
    if "soles" not in builder_parameters(spec["robot"]):
        ctx.fail(_join(path, "soles"), f"robot {spec['robot']!r} declares its own soles (robot.soles); "
                                       "soles: is for a robot loaded from a URDF path or example-robot-data")
    points: dict[str, list] = {}
    for index, entry in enumerate(entries):
        frame = entry["frame"]
        if frame in points:
            ctx.fail(f"{_join(path, 'soles')}[{index}].frame", f"sole {frame!r} is given twice")
        if "size" in entry:
            points[frame] = sole_rectangle(*entry["size"], entry.get("centre", (0.0, 0.0, 0.0))).tolist()
        elif "point" in entry:
            points[frame] = [list(entry["point"])]
        else:
            points[frame] = [list(point) for point in entry["corners"]]
    given = (spec.get("robot_params") or {}).get("soles")
    if given is not None and given != points:  # (equal: a spec this function already filled)
        ctx.fail(_join(path, "soles"), "give the soles either here or in robot_params.soles, not both")
    spec["robot_params"] = {**(spec.get("robot_params") or {}), "soles": points}


def time_laws() -> tuple[str, ...]:
    """The time-law names a ``timing.law`` takes (wbik.motion.profiles)."""
    from wbik.motion.profiles import ALIASES
    from wbik.motion.profiles import LAWS

    return (*LAWS, *ALIASES)


def timing_modes() -> tuple[str, ...]:
    """The ``timing.mode`` words (wbik.motion.timing.MODES)."""
    from wbik.motion.timing import MODES

    return MODES


def expect_block(rules: Mapping, nullable: bool = True, **more: Key) -> Map:
    """An ``expect`` block: the rules' keys (values judged by wbik.expectations) and ``more``."""
    value = Anything("a threshold or {threshold, expected_to_fail, why}")
    return Map({**{key: Key(value) for key in rules}, **more}, nullable=nullable,
               unknown_error=UnknownExpectationKeyError)


def from_dataclass(cls, nodes: dict[str, Node] | None = None) -> Map:
    """A mapping of a dataclass's fields, each with the dataclass's own default (one set of defaults)."""
    nodes = nodes or {}
    keys = {}
    for item in fields(cls):
        default = item.default if item.default is not MISSING else NO_DEFAULT
        integer = isinstance(default, int) and not isinstance(default, bool)
        keys[item.name] = Key(nodes.get(item.name, Number(integer=integer)), default)
    return Map(keys)


def default_of(function: Callable, parameter: str):
    """The default value of ``function``'s ``parameter``: a schema key whose value is passed there
    takes the function's own default instead of a second copy of it."""
    default = inspect.signature(function).parameters[parameter].default
    if default is inspect.Parameter.empty:
        raise TypeError(f"{function.__qualname__}({parameter}) has no default")
    return default


# -- checking a scenario ---------------------------------------------------------------------------
def validate(spec, source: str = "scenario") -> dict:
    """``spec`` checked against its kind's schema: a new dict with every default filled in.

    ``source`` (the file) starts every error message. See the module docstring for what is refused;
    the kind is looked up in :mod:`wbik.scenarios.kinds` (which imports the kinds' modules).
    """
    from wbik.scenarios.kinds import KIND_REGISTRY
    from wbik.scenarios.kinds import kind_names

    if not isinstance(spec, Mapping):
        raise ScenarioFileError(f"{source}: a scenario is a mapping with a 'kind' (one of "
                                f"{', '.join(kind_names())}), {_got(spec)}")
    if "kind" not in spec:
        raise ScenarioValueError(f"{source}: the top level needs a 'kind', one of {', '.join(kind_names())}")
    kind = spec["kind"]
    if not isinstance(kind, str) or kind not in kind_names():
        known = kind_names()
        raise ScenarioValueError(f"{source}: kind: unknown scenario kind {_short(kind)}"
                                 f"{did_you_mean(kind, known)}; known kinds: {', '.join(known)}")
    return KIND_REGISTRY.get(kind).schema_map.check(spec, "", Context(source))
