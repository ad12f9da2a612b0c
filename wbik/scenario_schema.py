"""The schema of scenario files (tasks/*.yaml): every kind's keys, their types, ranges and defaults.

``validate(spec, source)`` checks a scenario mapping against its kind's schema before anything
runs and returns a copy with the defaults filled in; every runner reads that copy (``spec["margin"]``,
never ``spec.get("margin", ...)``), so each default is written once, here (or, for the riveting
cell's dataclasses, scene and planners, in the class the key feeds, which the schema reads).

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

Kinds and their keys are in ``KIND_SCHEMAS`` (built on first use, since some read constants of the
runner modules); ``register_schema`` adds one for a plugged-in kind.
"""

from __future__ import annotations

import copy
import difflib
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import MISSING, dataclass, fields

from wbik.errors import (
    InvalidBudgetError,
    InvalidOptionError,
    MissingDependencyError,
    UnknownMethodError,
    UnknownRobotError,
    WbikError,
)
from wbik.expectations import ExpectationError

__all__ = ["ScenarioBudgetError", "ScenarioError", "ScenarioFileError", "ScenarioValueError",
           "UnknownExpectationKeyError", "UnknownScenarioKeyError", "accepts", "kind_names",
           "register_schema", "schema_of", "validate"]


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


def _guess(word, choices) -> str:
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


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
    def __init__(self, choices: tuple | Callable[[], tuple] | None = None, nullable: bool = False,
                 what: str = "a string"):
        self._choices = choices
        self.nullable = nullable
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
            ctx.fail(path, f"{value!r} is not allowed{_guess(value, choices)}; allowed: "
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
    """The first option that accepts the value; else an error listing every option."""

    def __init__(self, *options: Node):
        self.options = options

    @property
    def expected(self) -> str:
        return " or ".join(option.expected for option in self.options)

    def check(self, value, path, ctx):
        for option in self.options:
            try:
                return option.check(value, path, ctx)
            except ScenarioValueError:
                continue
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
                    f"{ctx.source}: unknown key {where!r}{_guess(key, known)}; known keys "
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
        if name not in self.variants:
            choices = ", ".join(sorted(self.variants))
            if name is None:
                ctx.fail(path, f"must be {self.what}; it needs a {self.tag} (one of {choices}), "
                               f"got keys {sorted(map(str, value))}")
            where = _join(path, self.tag) if self.tag in value else path
            ctx.fail(where, f"{self.tag} {_short(name)} is not allowed{_guess(name, self.variants)}; "
                            f"allowed: {choices}")
        return self.variants[name].check(value, path, ctx)


# -- names checked against what exists --------------------------------------------------------------
class Robot(Text):
    """A built-in robot name or a .urdf path; ``only`` restricts a kind to some robots."""

    def __init__(self, only: tuple[str, ...] | None = None):
        super().__init__(what="a built-in robot name or the path of a .urdf file")
        self.only = only

    def check(self, value, path, ctx):
        from pathlib import Path

        from wbik.models import BUILTIN

        if not isinstance(value, str):
            raise UnknownRobotError(_short(value), list(BUILTIN), hint=f"{ctx.source}: {path} must be a "
                                    "robot name (a string) or the path of a .urdf file")
        if self.only and value not in self.only:
            ctx.fail(path, f"robot {value!r} cannot run this kind; it runs on {', '.join(self.only)}")
        if value not in BUILTIN and Path(value).suffix.lower() not in (".urdf", ".xml") \
                and not Path(value).expanduser().exists():
            raise UnknownRobotError(value, list(BUILTIN),
                                    hint=f"{ctx.source}: {path}{_guess(value, BUILTIN)}. Pass a built-in "
                                         "name ('wbik robots' lists them) or a .urdf path")
        return value


class Backend(Text):
    """A QP backend name: a known one ('fastest', 'default' or BACKEND_OPTIONS) that is installed."""

    def __init__(self):
        super().__init__(what="a QP backend name")

    def check(self, value, path, ctx):
        from wbik.qp.backends import BACKEND_OPTIONS, available, resolve

        super().check(value, path, ctx)
        known = ["fastest", "default", *sorted(BACKEND_OPTIONS)]
        if value not in known:
            ctx.fail(path, f"unknown QP backend {value!r}{_guess(value, known)}; known: {', '.join(known)} "
                           f"(installed here: {', '.join(available())})")
        try:
            resolve(value)
        except MissingDependencyError as exc:
            raise MissingDependencyError(f"{ctx.source}: {path}: {exc}") from None
        return value


class Method(Text):
    """A registered IK method (``wbik methods``)."""

    def __init__(self):
        super().__init__(what="an IK method name ('wbik methods' lists them)")

    def check(self, value, path, ctx):
        from wbik.solvers.base import methods

        if not isinstance(value, str) or value not in methods():
            raise UnknownMethodError(value if isinstance(value, str) else _short(value), list(methods()),
                                     hint=f"{ctx.source}: {path}{_guess(value, methods())}")
        return value


def _check_robot_params(spec: dict, path: str, ctx: Context) -> None:
    """The robot's builder must take every key of ``robot_params`` (wbik.models.check_parameters)."""
    from wbik.models import check_parameters

    params = spec.get("robot_params") or {}
    if params and spec.get("robot") is not None:
        try:
            check_parameters(spec["robot"], params)
        except InvalidOptionError as exc:
            raise InvalidOptionError(f"{ctx.source}: robot_params: {exc}", option=exc.option,
                                     accepted=exc.accepted) from None


def _time_laws() -> tuple[str, ...]:
    from wbik.motion.profiles import ALIASES, LAWS

    return (*LAWS, *ALIASES)


def _timing_modes() -> tuple[str, ...]:
    from wbik.motion.timing import MODES

    return MODES


def _expect(rules: Mapping, nullable: bool = True, **more: Key) -> Map:
    """An ``expect`` block: the rules' keys (values judged by wbik.expectations) and ``more``."""
    value = Anything("a threshold or {threshold, expected_to_fail, why}")
    return Map({**{key: Key(value) for key in rules}, **more}, nullable=nullable,
               unknown_error=UnknownExpectationKeyError)


def _from_dataclass(cls, nodes: dict[str, Node] | None = None) -> Map:
    """A mapping of a dataclass's fields, each with the dataclass's own default (one set of defaults)."""
    nodes = nodes or {}
    keys = {}
    for item in fields(cls):
        default = item.default if item.default is not MISSING else NO_DEFAULT
        integer = isinstance(default, int) and not isinstance(default, bool)
        keys[item.name] = Key(nodes.get(item.name, Number(integer=integer)), default)
    return Map(keys)


# -- the kinds --------------------------------------------------------------------------------------
POSITIVE = Number(gt=0)
NON_NEGATIVE = Number(ge=0)
VECTOR3 = Vector(3)
START = Either(Text(("nominal",)), Vector())
FRAME = Text(what="a frame name")
FRAMES = ListOf(FRAME, what="frame names")

TASK_OPTIONS = {"type": Key(Text()), "name": Key(Text()), "weight": Key(Either(NON_NEGATIVE, Vector())),
                "goal": Key(Boolean()), "priority": Key(Number(integer=True)),
                "tolerance": Key(POSITIVE), "gain": Key(POSITIVE)}
"""Keys every wholebody_ik task type takes (the options of wbik.qp.tasks.Task)."""


def _task(*names: str, required: tuple[str, ...] = (), **nodes: Node) -> Map:
    common = {"frame": FRAME, "target": VECTOR3, "rpy": VECTOR3, "offset": VECTOR3, "keep": Boolean(),
              "axes": Text(what="a subset of 'xyz' (e.g. xy)"), "reference": FRAME,
              "position_weight": NON_NEGATIVE, "orientation_weight": NON_NEGATIVE, "over": FRAME}
    keys = {name: Key(nodes.get(name, common.get(name)), required=name in required) for name in names}
    return Map({**TASK_OPTIONS, **keys})


def _wholebody_schema() -> Map:
    from wbik.qp.backends import DEFAULT
    from wbik.scenarios import PHASE_RULES

    tasks = {
        "frame": _task("frame", "target", "rpy", "offset", "keep", "position_weight", "orientation_weight",
                       required=("frame",)),
        "position": _task("frame", "target", "offset", "keep", "axes", required=("frame",)),
        "orientation": _task("frame", "rpy", "keep", required=("frame",)),
        "relative": _task("frame", "reference", "target", "rpy", "offset", "keep",
                          required=("frame", "reference")),
        "com": _task("target", "over", "offset", "keep", "axes"),
        "posture": _task("reference", "joints", reference=Text(("nominal", "start")),
                         joints=ListOf(Text(what="a joint name"), what="joint names")),
        "regularization": Map({"type": Key(Text()), "weight": Key(POSITIVE)}),
    }
    task = Variants(lambda entry: entry.get("type"), tasks, "a task mapping with a 'type'", "type")
    phase = Map({
        "name": Key(Text()),
        "contacts": Key(FRAMES, []),
        "support": Key(FRAMES),                      # default: the contacts
        "margin": Key(Number(unit="m")),             # default: the scenario's margin
        "lock": Key(ListOf(Text(what="a joint name"), what="joint names"), []),
        "tasks": Key(ListOf(task, min_items=1, what="task mappings"), required=True),
        "regularization": Key(POSITIVE, 1e-6),
        "min_distance": Key(ListOf(Map({"frames": Key(ListOf(FRAME, min_items=2), required=True),
                                        "distance": Key(NON_NEGATIVE, required=True)})), []),
        "max_step": Key(POSITIVE, 0.2),
        "max_iterations": Key(Number(gt=0, integer=True, budget=True), 300),
        "expect": Key(_expect(PHASE_RULES), None),
        "continue_from": Key(Text(("result", "start")), "result"),
    })

    collisions = Map({  # wbik.scenarios.collision_setup; absent: no collision constraint
        "self_collision": Key(Boolean(), True),
        "robot_obstacles": Key(Boolean(), True),
        "boxes": Key(ListOf(Map({"name": Key(Text(), required=True),
                                 "size": Key(Vector(3, positive=True, unit="m"), required=True),
                                 "xyz": Key(VECTOR3, [0.0, 0.0, 0.0]),
                                 "rpy": Key(VECTOR3, [0.0, 0.0, 0.0])}), what="box mappings"), []),
        "safety_distance": Key(Number(ge=0, unit="m"), 0.01),
        "influence_distance": Key(Number(gt=0, unit="m"), 0.1),
    })

    def post(spec: dict, path: str, ctx: Context) -> None:
        _check_robot_params(spec, path, ctx)
        block = spec["collisions"]
        if block is not None and not block["influence_distance"] > block["safety_distance"]:
            ctx.fail("collisions.influence_distance", f"must exceed safety_distance "
                                                      f"({block['safety_distance']:g} m)")
        for index, entry in enumerate(spec["phases"]):
            if block is None and "collision_distance_min_m" in (entry["expect"] or {}):
                ctx.fail(f"phases[{index}].expect.collision_distance_min_m",
                         "needs a top-level 'collisions' block (the pairs whose distance it judges)")
            entry.setdefault("name", f"phase {index + 1}")
            entry.setdefault("support", list(entry["contacts"]))
            if entry.get("margin") is None:
                entry["margin"] = spec["margin"]
            for item_index, item in enumerate(entry["min_distance"]):
                if len(item["frames"]) != 2:
                    ctx.fail(f"phases[{index}].min_distance[{item_index}].frames",
                             "must name exactly 2 frames")

    return Map({**_common(robot=Key(Robot(), required=True)),
                "backend": Key(Backend(), DEFAULT),
                "start": Key(START, "nominal"),
                "margin": Key(Number(unit="m"), 0.005),
                "collisions": Key(collisions, None),
                "phases": Key(ListOf(phase, min_items=1, what="phase mappings"), required=True)}, post=post)


def _common(**more: Key) -> dict[str, Key]:
    return {"kind": Key(Text(), required=True), "name": Key(Text(), ""),
            "robot_params": Key(Map(values=Anything()), {}), **more}


def _bioloid_schema(kind: str) -> Map:
    from wbik.bioloid.gait import GaitParameters
    from wbik.bioloid.scenarios import (
        FAITHFUL_RULES,
        KEYFRAME_RULES,
        PLACO_WALK_RULES,
        STAIR_RULES,
        WHOLEBODY_RULES,
    )
    from wbik.qp.backends import DEFAULT

    common = _common(robot=Key(Robot(only=("bioloid",)), "bioloid"))
    margin = {"margin": Key(Number(unit="m"), 0.005)}
    gait = {"gait": Key(Map(_from_dataclass(GaitParameters).keys, nullable=True), {})}
    timed = {"timing": Key(Map({"speed_rpm": Key(Number(gt=0, nullable=True, unit="rpm"), 40.0),
                                "law": Key(Text(_time_laws), "quintic"),
                                "mode": Key(Text(_timing_modes), "segment")}, nullable=True), {}),
             "export": Key(Map({"servo_csv": Key(Text(what="a file path", nullable=True)),
                                "dt": Key(Number(gt=0, unit="s"), 0.02)}, nullable=True), {}),
             "backend": Key(Backend(), DEFAULT)}
    walking = {"first": Key(Text(("left", "right")), "left"), "rear_lift": Key(Number(ge=0, unit="m"), 0.0)}
    generators = ("faithful", "wholebody")
    if kind == "bioloid_step":
        keys = {**margin, **gait, **timed, **walking,
                "generators": Key(ListOf(Text(generators), min_items=1), list(generators)),
                "round_degrees": Key(Boolean(), False),
                "expect": Key(_expect({}, faithful=Key(_expect(FAITHFUL_RULES)),
                                      wholebody=Key(_expect(WHOLEBODY_RULES))), None)}
    elif kind == "bioloid_walk":
        keys = {**margin, **gait, **timed, **walking, "steps": Key(Number(ge=1, integer=True), 4),
                "turn_deg": Key(Number(unit="deg"), 0.0), "expect": Key(_expect(WHOLEBODY_RULES), None)}
    elif kind == "bioloid_turn":
        keys = {**margin, **gait, **timed, "turn_deg": Key(Number(unit="deg"), 20.0),
                "expect": Key(_expect(WHOLEBODY_RULES), None)}
    elif kind == "bioloid_keyframes":
        keys = {"behaviours": Key(ListOf(Text(what="a behaviour name"), min_items=1),
                                  ["up_stair", "down_stair", "right_turn_medium", "left_turn_medium"]),
                "keyframes": Key(Text(what="a keyframe file path", nullable=True), None),
                "expect": Key(_expect(KEYFRAME_RULES, behaviours=Key(Map(values=_expect(KEYFRAME_RULES),
                                                                         nullable=True))), None)}
    elif kind == "bioloid_half_steps":
        from wbik.bioloid.scenarios import half_step_schema_sources

        HALF_STEPS, HALF_STEP_LIFT = half_step_schema_sources()
        keys = {**margin, **gait, **timed,
                "sequence": Key(ListOf(Text(tuple(HALF_STEPS)), min_items=1),
                                ["WalkSR1", "WalkSR2", "WalkSL1", "WalkSL2", "WalkSR1", "BackSR", "WalkSL1",
                                 "BackSL"]),
                "length": Key(Number(gt=0, nullable=True, unit="m"), None),
                "lift": Key(Number(ge=0, unit="m"), HALF_STEP_LIFT),
                "expect": Key(_expect(WHOLEBODY_RULES), None)}
    elif kind == "bioloid_stairs":
        from wbik.bioloid.scenarios import stair_schema_sources

        Staircase = stair_schema_sources()
        keys = {**margin, **gait, **timed,
                "stairs": Key(Map(_from_dataclass(Staircase).keys, nullable=True), {}),
                "climbs": Key(Number(ge=1, integer=True, nullable=True), None),
                "expect": Key(_expect(STAIR_RULES), None)}
    else:  # bioloid_placo_walk
        keys = {**margin, "steps": Key(Number(ge=1, integer=True), 4),
                "step_length": Key(Number(gt=0, unit="m"), 0.03),
                "expect": Key(_expect(PLACO_WALK_RULES), None)}
    return Map({**common, **keys}, post=_check_robot_params)


def _motion_schema(kind: str) -> Map:
    from wbik.motion.cartesian import DEFAULT_JUMP_THRESHOLD
    from wbik.motion.scenarios import MOVE_RULES

    limit = Either(Number(gt=0, nullable=True), Vector(positive=True))
    timing = Map({"law": Key(Text(_time_laws), "quintic"), "mode": Key(Text(_timing_modes), "global"),
                  "velocity_limit": Key(limit, None), "acceleration_limit": Key(limit, None),
                  "dt": Key(Number(gt=0, nullable=True, unit="s"), None)}, nullable=True)
    common = {**_common(robot=Key(Robot(), required=True)),
              "timing": Key(timing, {}),
              "export": Key(Map({"csv": Key(Text(what="a file path")), "json": Key(Text(what="a file path"))},
                                nullable=True), {}),
              "tolerance": Key(Number(gt=0, unit="m / rad"), 1e-6),
              "expect": Key(_expect(MOVE_RULES), None)}
    solving = {"method": Key(Method(), "dls"), "timeout_s": Key(Number(gt=0, unit="s", budget=True), 0.05),
               "start": Key(START, "nominal")}
    samples = {"samples": Key(Number(ge=1, integer=True), 10)}
    if kind == "motion_joint":
        keys = {**samples, "chain": Key(Text(what="a chain name", nullable=True), None),
                "configurations": Key(ListOf(Vector(), min_items=2, what="joint vectors"), required=True)}
    elif kind == "motion_cartesian":
        waypoint = Either(VECTOR3, Map({"position": Key(VECTOR3, required=True), "rpy": Key(VECTOR3)}))
        keys = {**solving, **samples, "chain": Key(Text(what="a chain name", nullable=True), None),
                "waypoints": Key(ListOf(waypoint, min_items=1, what="[x, y, z] or {position, rpy}"),
                                 required=True),
                "jump_threshold": Key(Number(gt=0, unit="rad"), DEFAULT_JUMP_THRESHOLD)}
    elif kind == "pincher_motion":
        # a move's own timing / tolerance / expect override the scenario's (no defaults here)
        own = {"timing": Key(timing), "tolerance": Key(common["tolerance"].node),
               "expect": Key(_expect(MOVE_RULES))}
        moves = {
            "jog": Map({"jog": Key(Either(Text(what="a joint name"), Number(integer=True))),
                        "delta_deg": Key(Number(unit="deg"), 0.0), **samples, **own}),
            "plane_line": Map({"plane_line": Key(Map({"start_xy_mm": Key(Vector(2), required=True),
                                                      "goal_xy_mm": Key(Vector(2), required=True),
                                                      "samples": Key(Number(ge=1, integer=True), 20)}),
                                                 required=True), **own}),
            "automatic": Map({"automatic": Key(Map({"samples": Key(Number(ge=1, integer=True), 10)},
                                                   nullable=True), required=True), **own}),
        }

        def move_kind(move: Mapping) -> str | None:
            found = [name for name in moves if name in move]
            return found[0] if len(found) == 1 else (None if not found else "+".join(found))

        move = Variants(move_kind, moves, "a move: {jog: JOINT, delta_deg: D}, {plane_line: {...}} or "
                                          "{automatic: {}}", "move")
        keys = {**solving, "moves": Key(ListOf(move, min_items=1, what="moves"), required=True)}
    elif kind == "golem3_approach":
        grasp = Either(Map({"from_joints": Key(Vector(), required=True)}),
                       Map({"position": Key(VECTOR3, required=True), "rpy": Key(VECTOR3)}))
        keys = {**solving, "samples": Key(Number(ge=1, integer=True), 20), "grasp": Key(grasp, required=True)}
    else:  # bioloid_stance_sensors
        keys = {"start": Key(START, "nominal"), "tolerance": Key(Number(gt=0, unit="m"), 1e-9),
                "expect": Key(_expect(MOVE_RULES), None)}
        common = {key: common[key] for key in ("kind", "name", "robot", "robot_params")}
    return Map({**common, **keys}, post=_check_robot_params)


def _riveting_schema() -> Map:
    from wbik.riveting.cycle import NoiseModel, RunConfig
    from wbik.riveting.plan import Insertion
    from wbik.riveting.report import RIVETING_RULES

    run = {item.name: item.default for item in fields(RunConfig)}
    position = Map({"position": Key(VECTOR3), "rpy": Key(VECTOR3)})
    rows = ListOf(Map({"x": Key(Vector(), required=True), "y": Key(Number(unit="m")),
                       "z": Key(Number(unit="m"))}), min_items=1)
    face = Map({"rows": Key(rows, required=True)})
    scene = Map({  # missing keys take wbik.riveting.scene.DEFAULT_SCENE
        "table": Key(Map({"top_z": Key(Number(unit="m")), "center": Key(Vector(2)),
                          "size": Key(Vector(3, positive=True))})),
        "workpiece": Key(Map({"center": Key(Vector(2)), "size": Key(Vector(3, positive=True))})),
        "hole_diameter": Key(Number(gt=0, unit="m")), "hole_depth": Key(Number(gt=0, unit="m")),
        "faces": Key(Map({"top": Key(face), "right": Key(face), "left": Key(face)})),
        "rivet_home": Key(position)}, nullable=True)
    named = {"name": Key(Text())}
    noise = {"position_sigma": NON_NEGATIVE, "position_max": POSITIVE, "angle_sigma_deg": NON_NEGATIVE}
    planners = {  # options and their defaults are the planner classes' (wbik.riveting.thesis / .ours)
        "thesis": Map({**named, "planner": Key(Text()), "timing": Key(Text(("thesis", "optimal"))),
                       "intermediate_distance": Key(Number(gt=0, unit="m")),
                       "intermediate_time": Key(Number(gt=0, unit="s")), "sleep": Key(Number(ge=0, unit="s")),
                       "move_time": Key(Number(gt=0, unit="s")),
                       "return_via": Key(Text(("direct", "intermediate")))}),
        "ours": Map({**named, "planner": Key(Text()), "minimum_clearance": Key(Number(ge=0, unit="m")),
                     "line_clearance": Key(Number(ge=0, unit="m")),
                     "knot_spacing": Key(Number(gt=0, unit="m")),
                     "max_step": Key(Number(gt=0, unit="rad")), "backend": Key(Backend())}),
    }
    planner = Variants(lambda entry: entry.get("planner", "ours"), planners,
                       "a planner mapping {name, planner: thesis | ours, options...}", "planner")

    def post(spec: dict, path: str, ctx: Context) -> None:
        names = [entry.get("name", entry.get("planner", "ours")) for entry in spec["planners"]]
        for name in spec.get("expect") or {}:
            if name not in names:
                raise UnknownExpectationKeyError(
                    f"{ctx.source}: unknown key 'expect.{name}'{_guess(name, names)}: expect names the "
                    f"planners of 'planners', which are {', '.join(names)}", f"expect.{name}", names)

    return Map({
        **_common(robot=Key(Robot(only=("ur5",)), "ur5")),
        "robot_params": Key(Refused("ur5_riveting does not take robot_params: its cell is built for the "
                                    "built-in UR5 with the rivet tool; remove the key")),
        "duration_s": Key(Number(gt=0, unit="s", budget=True), run["duration"]),
        "seed": Key(Number(ge=0, integer=True), run["seed"]),
        "max_cycles": Key(Number(ge=1, integer=True, nullable=True), run["max_cycles"]),
        "report_folder": Key(Text(what="a folder path", nullable=True), None),
        "limits": Key(Map({"velocity": Key(Either(POSITIVE, Vector(6, positive=True))),
                           "acceleration": Key(Number(gt=0, unit="rad/s^2"), 5.0),
                           "law": Key(Text(_time_laws), "quintic")}, nullable=True), {}),
        "insertion": Key(Map(_from_dataclass(Insertion, {"depth": POSITIVE}).keys, nullable=True), {}),
        "noise": Key(Map(_from_dataclass(NoiseModel, noise).keys, nullable=True), {}),
        "scene": Key(scene),
        "planners": Key(ListOf(planner, min_items=1, what="planner mappings"),
                        [{"name": "thesis", "planner": "thesis"}, {"name": "ours"}]),
        "expect": Key(Map(values=_expect(RIVETING_RULES), nullable=True), {}),
    }, post=post)


KIND_SCHEMAS: dict[str, Callable[[], Map]] = {
    "wholebody_ik": _wholebody_schema,
    **{kind: (lambda kind=kind: _bioloid_schema(kind)) for kind in
       ("bioloid_step", "bioloid_walk", "bioloid_turn", "bioloid_keyframes", "bioloid_placo_walk",
        "bioloid_half_steps", "bioloid_stairs")},
    **{kind: (lambda kind=kind: _motion_schema(kind)) for kind in
       ("motion_joint", "motion_cartesian", "pincher_motion", "golem3_approach", "bioloid_stance_sensors")},
    "ur5_riveting": _riveting_schema,
}
"""Kind name -> a function building its schema (called once, on first use)."""

_BUILT: dict[str, Map] = {}


def register_schema(kind: str, build: Callable[[], Map]) -> None:
    """The schema of a plugged-in kind (see wbik.scenarios.register_runner)."""
    KIND_SCHEMAS[kind] = build
    _BUILT.pop(kind, None)


def kind_names() -> list[str]:
    return sorted(KIND_SCHEMAS)


def schema_of(kind: str) -> Map:
    if kind not in _BUILT:
        _BUILT[kind] = KIND_SCHEMAS[kind]()
    return _BUILT[kind]


def accepts(kind: str, key: str) -> bool:
    """Whether a scenario of ``kind`` takes the top-level ``key``."""
    return kind in KIND_SCHEMAS and key in schema_of(kind).keys \
        and not isinstance(schema_of(kind).keys[key].node, Refused)


def validate(spec, source: str = "scenario") -> dict:
    """``spec`` checked against its kind's schema: a new dict with every default filled in.

    ``source`` (the file) starts every error message. See the module docstring for what is refused.
    """
    ctx = Context(source)
    if not isinstance(spec, Mapping):
        raise ScenarioFileError(f"{source}: a scenario is a mapping with a 'kind' (one of "
                                f"{', '.join(kind_names())}), {_got(spec)}")
    if "kind" not in spec:
        raise ScenarioValueError(f"{source}: the top level needs a 'kind', one of {', '.join(kind_names())}")
    kind = spec["kind"]
    if not isinstance(kind, str) or kind not in KIND_SCHEMAS:
        raise ScenarioValueError(f"{source}: kind: unknown scenario kind {_short(kind)}"
                                 f"{_guess(kind, KIND_SCHEMAS)}; known kinds: {', '.join(kind_names())}")
    return schema_of(kind).check(spec, "", ctx)
