"""The schemas of scenario files (tasks/*.yaml): the keys their kinds share, and the check of a file.

Each scenario kind declares its schema next to its runner (a :class:`Map` built by the kind's
``schema`` function, see :class:`wbik.scenarios.kinds.ScenarioKind`) from the nodes of
:mod:`wbik.schema` (the schema language of wbik's files, importable from here too) and the builders
below.
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

from collections.abc import Mapping

from wbik.errors import InvalidOptionError
from wbik.errors import did_you_mean
from wbik.scenarios.kinds import KIND_REGISTRY
from wbik.scenarios.kinds import ScenarioBudgetError
from wbik.scenarios.kinds import ScenarioError
from wbik.scenarios.kinds import ScenarioFileError
from wbik.scenarios.kinds import ScenarioValueError
from wbik.scenarios.kinds import UnknownExpectationKeyError
from wbik.scenarios.kinds import UnknownScenarioKeyError
from wbik.scenarios.kinds import kind_names
from wbik.schema import NO_DEFAULT
from wbik.schema import Anything
from wbik.schema import Axes
from wbik.schema import Backend
from wbik.schema import Boolean
from wbik.schema import Context
from wbik.schema import Either
from wbik.schema import Errors
from wbik.schema import Key
from wbik.schema import ListOf
from wbik.schema import Map
from wbik.schema import Method
from wbik.schema import Node
from wbik.schema import Number
from wbik.schema import Refused
from wbik.schema import Robot
from wbik.schema import Text
from wbik.schema import Variants
from wbik.schema import Vector
from wbik.schema import default_of
from wbik.schema import from_dataclass
from wbik.schema import got as _got
from wbik.schema import join as _join
from wbik.schema import short as _short

__all__ = ["COM_MARGIN", "FRAME", "FRAMES", "NON_NEGATIVE", "NO_DEFAULT", "POSITIVE", "SCENARIO_ERRORS",
           "START", "VECTOR3", "Anything", "Axes", "Backend", "Boolean", "Context", "Either", "Key",
           "ListOf", "Map", "Method", "Node", "Number", "Refused", "Robot", "ScenarioBudgetError",
           "ScenarioError", "ScenarioFileError", "ScenarioValueError", "Text",
           "UnknownExpectationKeyError", "UnknownScenarioKeyError", "Variants", "Vector", "apply_soles",
           "backend_key", "check_robot_params", "common_keys", "default_of", "expect_block",
           "from_dataclass", "kind_schema", "margin_key", "soles_key", "time_laws", "timing_modes",
           "urdf_robot_params", "validate"]

SCENARIO_ERRORS = Errors(ScenarioValueError, UnknownScenarioKeyError, ScenarioBudgetError)
"""The errors a task file's check raises."""


# -- building blocks the kinds' schemas share --------------------------------------------------------
COM_MARGIN = 0.005
"""m, the default CoM margin inside the support polygon of every kind that keeps a robot balanced."""

POSITIVE = Number(gt=0)
NON_NEGATIVE = Number(ge=0)
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


# -- checking a scenario ---------------------------------------------------------------------------
def validate(spec, source: str = "scenario") -> dict:
    """``spec`` checked against its kind's schema: a new dict with every default filled in.

    ``source`` (the file) starts every error message. See the module docstring for what is refused;
    the kind is looked up in :mod:`wbik.scenarios.kinds` (which imports the kinds' modules).
    """
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
    return KIND_REGISTRY.get(kind).schema_map.check(spec, "", Context(source, SCENARIO_ERRORS))
