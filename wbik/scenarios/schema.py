"""Scenario file schemas: robot, method and QP backend nodes, the keys kinds share, and :func:`validate`."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from wbik.errors import MissingDependencyError, UnknownMethodError, UnknownRobotError, did_you_mean
from wbik.models import URDF_PARAMS, builder_parameters, robot_entries
from wbik.models.erd import example_robot_name, example_robot_names
from wbik.motion.profiles import ALIASES, LAWS
from wbik.motion.timing import MODES
from wbik.options import UnknownOptionError, option_schema
from wbik.qp.backends import BACKEND_OPTIONS, DEFAULT, available, resolve
from wbik.qp.support_polygon import sole_rectangle
from wbik.qp.task_entries import FRAME, VECTOR3
from wbik.robot import ChainSpec
from wbik.scenarios.kinds import (
    KIND_REGISTRY,
    ScenarioBudgetError,
    ScenarioFileError,
    ScenarioValueError,
    UnknownExpectationKeyError,
    UnknownScenarioKeyError,
    kind_names,
)
from wbik.schema import (
    Anything,
    Boolean,
    Context,
    Either,
    Errors,
    Key,
    ListOf,
    Map,
    Number,
    Refused,
    Text,
    Vector,
    got,
    join,
    short,
)
from wbik.solvers.method_registry import methods

SCENARIO_ERRORS = Errors(ScenarioValueError, UnknownScenarioKeyError, ScenarioBudgetError)


class Robot(Text):
    """A built-in robot name, ``example-robot-data:NAME`` or a .urdf path (one of ``only`` if given)."""

    what = "a built-in robot name, example-robot-data:NAME or the path of a .urdf file"

    def __init__(self, only: tuple[str, ...] | None = None):
        super().__init__()
        self.only = only

    def check(self, value, path, ctx):
        known = list(robot_entries())
        if not isinstance(value, str):
            raise UnknownRobotError(short(value), known, hint=f"{ctx.source}: {path} must be {self.what}")
        if self.only and value not in self.only:
            ctx.fail(path, f"robot {value!r} cannot run this kind; it runs on {', '.join(self.only)}")
        example = example_robot_name(value)
        if example is not None and example not in (names := example_robot_names()):
            raise UnknownRobotError(value, [f"example-robot-data:{name}" for name in names],
                                    hint=f"{ctx.source}: {path}{did_you_mean(example, names)}")
        if example is None and value not in known and Path(value).suffix.lower() not in (".urdf", ".xml") \
                and not Path(value).expanduser().exists():
            raise UnknownRobotError(value, known, hint=f"{ctx.source}: {path}{did_you_mean(value, known)}; "
                                    f"it must be {self.what} ('wbik robots' lists the names)")
        return value


class Backend(Text):
    """A QP backend name: a known one ('fastest', 'default' or BACKEND_OPTIONS) that is installed."""

    what = "a QP backend name"

    def check(self, value, path, ctx):
        known = ["fastest", "default", *sorted(BACKEND_OPTIONS)]
        if super().check(value, path, ctx) not in known:
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
        if not isinstance(value, str) or value not in methods():
            raise UnknownMethodError(value if isinstance(value, str) else short(value), list(methods()),
                                     hint=f"{ctx.source}: {path}{did_you_mean(value, methods())}")
        return value


COM_MARGIN = 0.005  # m, the default CoM margin inside the support polygon

START = Either(Text(("nominal",)), Vector())


def urdf_robot_params() -> Map:
    """The ``robot_params`` of a robot loaded from a URDF path or example-robot-data."""
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
        if "chains" in params:
            params["chains"] = [ChainSpec(item["name"], item["base"], item["tip"], tuple(item["joints"]),
                                          item["description"]) for item in params["chains"]]

    return Map({name: Key(nodes.get(name, python_only)) for name in URDF_PARAMS}, post=post)


def check_robot_params(spec: dict, path: str, ctx: Context) -> None:
    """``robot_params`` checked as the options of the robot's builder (or :func:`urdf_robot_params`)."""
    params, robot = spec.get("robot_params") or {}, spec.get("robot")
    if params and robot is not None:
        entry = robot_entries().get(robot)
        schema = urdf_robot_params() if entry is None else option_schema(
            entry.module().build, 0, owner=f"robot {robot!r}", unknown_error=UnknownOptionError)
        spec["robot_params"] = schema.check(params, join(path, "robot_params"), ctx)


def common_keys(robot: Key, **more: Key) -> dict[str, Key]:
    """The keys of every kind (``kind``, ``name``, ``robot``, ``robot_params``) and ``more``."""
    return {"kind": Key(Text(), required=True), "name": Key(Text(), ""), "robot": robot,
            "robot_params": Key(Map(values=Anything()), {}), **more}


def kind_schema(common: dict[str, Key], keys: dict[str, Key]) -> Map:
    """A kind's schema: the ``common`` keys and its own, ``robot_params`` checked against the robot."""
    return Map({**common, **keys}, post=check_robot_params)


def backend_key() -> Key:
    """``backend``: an installed QP backend, default :data:`wbik.qp.backends.DEFAULT`."""
    return Key(Backend(), DEFAULT)


def margin_key() -> Key:
    """``margin``: the CoM margin (m), default :data:`COM_MARGIN`."""
    return Key(Number(unit="m"), COM_MARGIN)


def soles_key() -> Key:
    """``soles`` of a URDF robot (m, sole frame): ``{frame, size: [l, w], centre}``, corners or point."""

    def one_shape(entry: dict, path: str, ctx: Context) -> None:
        shapes = [key for key in SOLE_SHAPES if key in entry]
        if len(shapes) != 1:
            ctx.fail(path, f"a sole takes exactly one of {', '.join(SOLE_SHAPES)}, got "
                           f"{', '.join(shapes) or 'none'} (size: a rectangle, corners: contact points, "
                           "point: a point foot)")
        if "centre" in entry and shapes != ["size"]:
            ctx.fail(join(path, "centre"), "is the centre of a size rectangle; with corners or point, "
                                            "give the points themselves")

    sole = Map({"frame": Key(FRAME, required=True), "size": Key(Vector(2, positive=True, unit="m")),
                "centre": Key(VECTOR3), "corners": Key(ListOf(VECTOR3, min_items=1, what="[x, y, z] points")),
                "point": Key(VECTOR3)}, post=one_shape)
    return Key(ListOf(sole, what="sole mappings {frame, size | corners | point}"), [])


SOLE_SHAPES = ("size", "corners", "point")  # the keys of a ``soles`` entry that give its shape


def apply_soles(spec: dict, path: str, ctx: Context) -> None:
    """Checked ``soles`` entries into ``robot_params.soles`` ({frame: (k, 3) contact points})."""
    if not (entries := spec.get("soles")):
        return
    if "soles" not in builder_parameters(spec["robot"]):
        ctx.fail(join(path, "soles"), f"robot {spec['robot']!r} declares its own soles (robot.soles); "
                                       "soles: is for a robot loaded from a URDF path or example-robot-data")
    points: dict[str, list] = {}
    for index, entry in enumerate(entries):
        frame = entry["frame"]
        if frame in points:
            ctx.fail(f"{join(path, 'soles')}[{index}].frame", f"sole {frame!r} is given twice")
        corners = entry.get("corners", [entry.get("point")])
        points[frame] = (sole_rectangle(*entry["size"], entry.get("centre", (0.0, 0.0, 0.0))).tolist()
                         if "size" in entry else [list(point) for point in corners])
    given = (spec.get("robot_params") or {}).get("soles")
    if given is not None and given != points:  # (equal: a spec this function already filled)
        ctx.fail(join(path, "soles"), "give the soles either here or in robot_params.soles, not both")
    spec["robot_params"] = {**(spec.get("robot_params") or {}), "soles": points}


time_laws = (*LAWS, *ALIASES)  # the time-law names a ``timing.law`` takes
timing_modes = MODES  # the ``timing.mode`` words


def expect_block(rules: Mapping, nullable: bool = True, **more: Key) -> Map:
    """An ``expect`` block: the rules' keys (values judged by wbik.expectations) and ``more``."""
    value = Anything("a threshold or {threshold, expected_to_fail, why}")
    return Map({**{key: Key(value) for key in rules}, **more}, nullable=nullable,
               unknown_error=UnknownExpectationKeyError)


def validate(spec, source: str = "scenario") -> dict:
    """``spec`` checked against its kind's schema (messages start with ``source``), defaults filled in."""
    if not isinstance(spec, Mapping):
        raise ScenarioFileError(f"{source}: a scenario is a mapping with a 'kind' (one of "
                                f"{', '.join(kind_names())}), {got(spec)}")
    ctx = Context(source, SCENARIO_ERRORS)
    kind = Map({"kind": Key(Text(kind_names), required=True)}, Anything()).check(spec, "", ctx)["kind"]
    return KIND_REGISTRY.get(kind).schema_map.check(spec, "", ctx)
