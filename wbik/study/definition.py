"""Study files (YAML or TOML, docs/formats/study-files.md): their schema, read into a :class:`Study`; a
mistake raises a :class:`StudyDefinitionError` naming the file, the key's path and what to write."""

from __future__ import annotations

from dataclasses import fields, replace
from pathlib import Path

from wbik.data import data_dir, study_path
from wbik.errors import did_you_mean
from wbik.files import read_data_file
from wbik.geometry import TAIT_BRYAN_SEQUENCES
from wbik.options import Options
from wbik.schema import (
    Anything,
    Boolean,
    Context,
    Either,
    Errors,
    Key,
    ListOf,
    Map,
    Node,
    Number,
    SchemaBudgetError,
    SchemaValueError,
    Shorthand,
    Text,
    UnknownKeyError,
    dataclass_default,
    join,
    unknown_keys,
)
from wbik.study.metrics import ANGLE_AXES, POSITION_AXES, ROTATION_VECTOR_AXES, AngleConvention
from wbik.study.reference import REFERENCE_METRICS, Reference
from wbik.study.regression_rule import regression_rule, regression_schema
from wbik.study.spec import (
    BUDGET_CURVE_MS,
    BUDGET_CURVE_POSES,
    DEFAULT_TARGET,
    BudgetCurveSpec,
    CaseSpec,
    MethodSpec,
    Study,
    StudyDefinitionError,
)

COMPARISONS_DIR = data_dir("comparisons")
DEFAULT_STUDY = COMPARISONS_DIR / "default.yaml"

CASE_KEYS = {"name", "robot", "chain", "target", "robot_params", "poses", "reference", "base", "tip",
             "targets"}
"""The keys of a case entry every kind reads (a kind may take more; ``targets`` names a target set)."""
START_KINDS = ("nominal", "mid_range", "random")
SHAPE = "a study is a mapping of fields (name, robot, methods, ...)"


def with_overrides(study: Study, *, poses: int | None = None, methods: list[str] | None = None,
                   robot: str | None = None, chain: str | None = None,
                   chunk_size: int | None = None, seed: int | None = None,
                   name: str | None = None, budget_curve_poses: int | None = None,
                   figures: bool | None = None) -> Study:
    """A copy of ``study`` with command-line overrides applied (and validated)."""
    cli = Context("command line", STUDY_ERRORS)
    if methods:
        if unknown := [m for m in methods if m not in {s.label for s in study.methods}]:
            raise StudyDefinitionError(
                f"--methods names {unknown} which study {study.name!r} does not have; its labels: "
                f"{', '.join(s.label for s in study.methods)}")
        study = replace(study, methods=tuple(s for s in study.methods if s.label in methods))
        if study.baseline not in methods:
            study = replace(study, baseline=study.methods[0].label)
    if robot is not None or chain is not None:
        if len(study.cases) != 1:
            raise StudyDefinitionError("--robot/--chain apply to single-case studies only")
        case = study.cases[0]
        if robot is None:
            case = replace(case, chain=chain)
        else:
            case = replace(case, robot=robot or case.robot, chain=chain, robot_params={}, reference=None,
                           name=_case_name(robot or case.robot, case.chain if chain is None else chain,
                                           case.target))
        study = replace(study, cases=(case,))
        check_schema((), study.cases, "command line")
    if poses is not None:
        study = replace(study, poses=_count().check(poses, "--poses", cli),
                        cases=tuple(replace(c, poses=None) for c in study.cases))
    changes = {"chunk_size": None if chunk_size is None else _count().check(chunk_size, "--chunk-size", cli),
               "seed": None if seed is None else int(seed),
               "name": None if name is None else LABEL.check(name, "--name", cli),
               "figures": None if figures is None else bool(figures)}
    study = replace(study, **{key: value for key, value in changes.items() if value is not None})
    if budget_curve_poses is not None:
        poses_or_none = Number(integer=True, ge=0, what="a number of poses >= 0 (0: none)")
        study = replace(study, budget_curves=replace(study.budget_curves, poses=poses_or_none.check(
            budget_curve_poses, "--budget-curves", cli)))
    return study


def load_study(path: str | Path | None = None) -> Study:
    """Read and validate a study file (``.yaml``/``.yml`` or ``.toml``; a shipped study's name,
    :func:`wbik.data.study_path`); None: the default study."""
    path = DEFAULT_STUDY if path is None else study_path(path)
    available = sorted(p.name for p in COMPARISONS_DIR.glob("*.y*ml")) if COMPARISONS_DIR.is_dir() else []
    data = read_data_file(path, StudyDefinitionError, "study", SHAPE, f"; the studies shipped in "
                          f"{COMPARISONS_DIR}: {', '.join(available) or '(none)'}")
    return study_from_dict(data, source=str(path))


def study_from_dict(data, source: str = "study") -> Study:
    """Plain data (as read from a file) validated into a :class:`Study` (mistakes name ``source``)."""
    if not isinstance(data, dict):
        raise StudyValueError(f"{source}: {SHAPE}, got {type(data).__name__}")
    ctx = Context(source, STUDY_ERRORS)
    checked = study_schema().check(data, "", ctx)
    methods = [MethodSpec(label=item["label"], method=item["method"], options=dict(item["options"]),
                          timeout_s=item["timeout_s"], note=item["note"] or "")
               for item in checked["methods"]]
    cases = [CaseSpec(**{f.name: item[f.name] for f in fields(CaseSpec) if f.name in item})
             for item in checked["cases"]]
    check_schema(methods, cases, source)
    labels = [m.label for m in methods]
    baseline = checked.get("baseline") or labels[0]
    if baseline not in labels:
        ctx.fail("baseline", f"baseline {baseline!r} is not one of the method labels"
                             f"{did_you_mean(baseline, labels)}; known: {', '.join(labels)}")
    for index, case in enumerate(cases):
        for label in case.reference.labels if case.reference else ():
            if label not in labels:
                where = join(f"cases[{index}]" if "cases" in data else "", "reference")
                ctx.fail(where, f"case {case.name!r}: the reference figures name method {label!r}, which is "
                                f"not a method label of the study{did_you_mean(label, labels)}; known: "
                                f"{', '.join(labels)}")
    plain = ("name", "poses", "seed", "timeout_s", "tolerances", "start", "chunk_size", "figures")
    return Study(**{key: checked[key] for key in plain}, cases=tuple(cases), methods=tuple(methods),
                 baseline=baseline, budget_curves=_budget_curves(checked["budget_curves"]),
                 regression=regression_rule(checked["regression"]), description=checked["description"] or "",
                 notes=checked["notes"] or "", source=source)


class StudyValueError(StudyDefinitionError, SchemaValueError):
    """A value of a study file that its schema refuses (wrong type, outside its range, a missing key)."""


class UnknownStudyKeyError(StudyDefinitionError, UnknownKeyError):
    """A key of a study file that is not read there; ``path`` is where, ``known`` the keys allowed."""


class StudyBudgetError(StudyValueError, SchemaBudgetError):
    """A study's time budget (``timeout_s``) that is not a finite number > 0."""


STUDY_ERRORS = Errors(StudyValueError, UnknownStudyKeyError, StudyBudgetError)
LABEL = Text(pattern=r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$",
             what="a name of letters, digits, '_', '-' or '.' (it names files)")


def _count(what: str = "a positive integer", nullable: bool = False) -> Number:
    return Number(integer=True, gt=0, nullable=nullable, what=what)


def _real(what: str, **bounds) -> Number:
    """A number (a string holding one counts: YAML 1.1 reads 1e-6 as a string), as a float."""
    return Number(strings=True, as_float=True, what=what, **bounds)


def study_schema() -> Map:
    """The schema of a study file: its keys, methods and cases (or one case's keys at the top level)."""
    tolerances = dataclass_default(Study, "tolerances")
    keys = {
        "name": Key(LABEL, doc="the study's name (the output folder); default: the file's name"),
        "description": Key(Text(nullable=True), "", doc="text for the report"),
        "notes": Key(Text(nullable=True), "", doc="text for the report"),
        "cases": Key(ListOf(CaseEntry(), min_items=1, what="{robot, chain, target} mappings"),
                     doc="the cases (or one case's keys at the top level)"),
        "methods": Key(ListOf(method_schema(), min_items=1, what="method names or {label, method, options, "
                              "timeout_s, note} mappings, e.g. [analytic, dls, {label: kdl_15s, "
                              "method: kdl, timeout_s: 15}]"), required=True, doc="the methods compared"),
        "poses": Key(_count(), dataclass_default(Study, "poses"), doc="targets per case"),
        "seed": Key(Number(integer=True, ge=0, what="a non-negative integer"),
                    dataclass_default(Study, "seed"), doc="the targets, the starts and every seeded method"),
        "timeout_s": Key(_real("a positive number (s)", gt=0, budget=True),
                         dataclass_default(Study, "timeout_s"), doc="default budget per solve"),
        "tolerances": Key(Map({key: Key(_real(f"a positive number ({unit})", gt=0), tolerances[key])
                               for key, unit in (("position", "m"), ("rotation", "rad"))}, nullable=True,
                              what="a mapping {position: m, rotation: rad}"), tolerances,
                          doc="the shared FK check's tolerances"),
        "start": Key(Text(START_KINDS,
                          what=f"one of {', '.join(START_KINDS)} (the q0 given to every method)"),
                     dataclass_default(Study, "start"), doc="the start configuration of every solve"),
        "baseline": Key(Text(nullable=True),
                        doc="the method label the tests compare with; default: the first"),
        "chunk_size": Key(_count(), dataclass_default(Study, "chunk_size"), doc="targets per work unit"),
        "budget_curves": Key(Either(Boolean(nullable=True), budget_curves_schema(),
                                    what="true, false or {poses: 100, budgets_ms: [0.2, 1, 5, 20]}"), None,
                             doc="success versus budget"),
        "regression": Key(regression_schema(), {}, doc="the rule of wbik study --compare-to"),
        "figures": Key(Boolean(), True, doc="the report's figures (false: tables only, quicker)"),
        **{key: Key(Anything("one case's key (see a case)"), doc="a single-case study's case key")
           for key in sorted(_case_keys() - {"name", "poses"})},
    }
    return Map(keys, post=_across_keys)


def _across_keys(study: dict, path: str, ctx: Context) -> None:
    """The study's name (default: the file's), its cases (``cases:`` or the top level's), unique names."""
    if "name" not in study:
        study["name"] = LABEL.check(Path(ctx.source).stem, "name", ctx)
    case_keys = _case_keys()
    top_level = {key for key in case_keys - {"name", "poses"} if key in study}
    if "cases" in study:
        if top_level - {"reference"}:
            ctx.fail(path, "give either cases: [...] or robot/chain/target at the top level, not both "
                           f"(found {sorted(top_level - {'reference'})})")
        if "reference" in study:
            ctx.fail("reference", "reference: belongs inside each case of cases: (the figures and angle "
                                  "names are a case's)")
    else:
        if "robot" not in study and not (case_keys - CASE_KEYS) & set(study):
            ctx.fail(path, "say which robot to study (robot: NAME or a URDF path) or list cases:")
        study["cases"] = [CaseEntry().check({key: study.pop(key) for key in sorted(top_level)}, path, ctx)]
    names = [case["name"] for case in study["cases"]]
    if len(set(names)) != len(names):
        ctx.fail("cases", f"case names must be unique (give each a name:), got {names}")
    labels = [method["label"] for method in study["methods"]]
    if repeated := sorted({label for label in labels if labels.count(label) > 1}):
        ctx.fail("methods", f"method labels must be unique; repeated: {repeated} (give each variant its own "
                            "label:)")


def method_schema() -> Shorthand:
    """A method of ``methods:``: its name, or {method, label, options, timeout_s, note}."""

    def label_and_settings(item: dict, path: str, ctx: Context) -> None:
        if "label" not in item:
            item["label"] = LABEL.check(item["method"], join(path, "label"), ctx)
        for reserved in ("timeout_s", "tolerances", "seed"):
            if reserved in item["options"]:
                ctx.says(join(path, f"options.{reserved}"),
                         f"is set by the study; use {join(path, 'timeout_s')} or the study's tolerances/seed")

    keys = {"method": Key(MethodName(), required=True, doc="an IK method ('wbik methods')"),
            "label": Key(LABEL, doc="its name in the report; default: the method"),
            "options": Key(Map(values=Anything(), nullable=True, what="a mapping of keyword arguments"), {},
                           doc="keyword options of the method"),
            "timeout_s": Key(_real("a positive number (s)", gt=0, nullable=True, budget=True), None,
                             doc="its budget per solve; default: the study's"),
            "note": Key(Text(nullable=True), "", doc="text for the report's methods table")}
    return Shorthand(Map(keys, post=label_and_settings), "method",
                     what="a method name or a mapping {label, method, options, timeout_s, note}")


class MethodName(Text):
    """A method some case kind runs (``wbik methods``, whole-body methods too)."""

    what = "a method name ('wbik methods' lists them)"

    def __init__(self):
        super().__init__(_known_methods)

    def check(self, value, path, ctx):
        if not isinstance(value, str):
            self.wrong(value, path, ctx)
        if value not in (known := self.choices):
            ctx.fail(path, f"unknown method {value!r}{did_you_mean(value, known)}; known: {', '.join(known)}")
        return value


def _known_methods() -> tuple[str, ...]:
    from wbik.study.case_kinds import case_kinds

    return tuple(dict.fromkeys(name for kind in case_kinds().values() for name in kind.methods()))


def budget_curves_schema() -> Map:
    """``budget_curves:`` as a mapping {poses, budgets_ms}."""
    return Map({"poses": Key(Number(integer=True, ge=0, what="a number of poses >= 0 (0: no curves)"),
                             BUDGET_CURVE_POSES, doc="the first poses of every case solved again"),
                "budgets_ms": Key(ListOf(_real("a positive number (ms)", gt=0), min_items=1,
                                         what="budgets in ms"), list(BUDGET_CURVE_MS), doc="the budgets")},
               what="{poses: 100, budgets_ms: [0.2, 1, 5, 20]}")


def _budget_curves(raw) -> BudgetCurveSpec:
    """``budget_curves:`` checked: false or absent (none), true (BUDGET_CURVE_POSES poses) or a mapping."""
    if raw is None or raw is False:
        return BudgetCurveSpec()
    if raw is True:
        return BudgetCurveSpec(poses=BUDGET_CURVE_POSES)
    return BudgetCurveSpec(poses=raw["poses"], budgets_ms=tuple(sorted(set(raw["budgets_ms"]))))


def _common_case_keys() -> dict[str, Key]:
    """The keys every case entry takes (CASE_KEYS but ``targets``, a target set kind's)."""
    return {
        "name": Key(LABEL, doc="the case's name; default: robot_chain_target"),
        "robot": Key(Text(non_empty=True, what="a robot name or URDF path"),
                     doc="a built-in robot, example-robot-data:NAME or a URDF path"),
        "chain": Key(Text(nullable=True, what="a chain name"), doc="a chain of the robot, by name"),
        "target": Key(Text(what="a case kind"), doc="the case's kind; default: pose"),
        "robot_params": Key(Map(values=Anything(), nullable=True,
                                what="a mapping of the robot's parameters (e.g. {lengths: [3, 2, 2]})"), {},
                            doc="keyword parameters of the robot's builder"),
        "poses": Key(_count(nullable=True), doc="this case's number of targets; default: the study's"),
        "reference": Key(reference_schema(), doc="published figures to set beside ours"),
        **{key: Key(Text(non_empty=True, nullable=True, what="a frame name"),
                    doc="a chain named by its frames") for key in ("base", "tip")},
    }


def case_schema(kind) -> Map:
    """The schema of a case entry of ``kind``: every case's keys and the kind's own."""
    return Map({**_common_case_keys(), **kind.entry_schema()}, what="a mapping {robot, chain, target, ...}")


class CaseEntry(Node):
    """A case entry of ``cases:``, checked against the schema of its kind (:func:`_case_kind`)."""

    expected = "a mapping {robot, chain, target, ...}"

    def check(self, value, path, ctx):
        if not isinstance(value, dict):
            self.wrong(value, path, ctx)
        unknown_keys(ctx, path, value, _case_keys())
        kind = _case_kind(value, path, ctx)
        item = kind.entry(case_schema(kind).check(value, path, ctx), path, ctx)
        base, tip = item.get("base"), item.get("tip")
        if (base is None) != (tip is None):
            ctx.fail(path, "give both base: and tip: (the chain's frames), got only "
                           f"{'base' if tip is None else 'tip'}")
        robot = item.get("robot")
        if robot is None:
            ctx.says(join(path, "robot"),
                     "is required: a built-in robot, example-robot-data:NAME or a URDF path")
        chain = f"{base}_to_{tip}" if base is not None and item.get("chain") is None else item.get("chain")
        item["chain"], item["target"] = chain, kind.name
        if "name" not in item:
            item["name"] = LABEL.check(_case_name(robot, chain, kind.name), join(path, "name"), ctx)
        item["robot_params"] = dict(item.get("robot_params") or {})
        item["reference"] = _reference(item.get("reference"), kind, join(path, "reference"), ctx)
        return item


def _reference(raw: dict | None, kind, path: str, ctx: Context) -> Reference | None:
    """A case's checked ``reference:`` as a :class:`Reference` (None when absent or empty)."""
    if not raw or not any(value not in (None, {}, "") for value in raw.values()):
        return None
    angles = _angles(raw.get("angles"), kind.target, join(path, "angles"), ctx)
    axes = [*kind.axes(angles), "time"]
    for label, row in raw["significance"].items():
        unknown_keys(ctx, join(path, f"significance.{label}"), row, axes)
    texts = {key: raw.get(key) or "" for key in ("name", "source", "significance_source", "notes")}
    texts["name"] = texts["name"].strip() or dataclass_default(Reference, "name")
    return Reference(**texts, angles=angles, figures=raw["figures"], significance=raw["significance"])


ANGLES_EXAMPLE = "e.g. {sequence: zyx, names: {x: yaw, y: pitch, z: roll}} for R = Rz(roll) Ry(pitch) Rx(yaw)"


def reference_schema() -> Map:
    """A case's ``reference:`` block (see :mod:`wbik.study.reference`)."""

    def some_angle(angles: dict, path: str, ctx: Context) -> None:
        if not angles["names"]:
            ctx.says(join(path, "names"), f"must name at least one angle, {ANGLES_EXAMPLE}")

    sequence = Text(TAIT_BRYAN_SEQUENCES, what=f"one of {', '.join(TAIT_BRYAN_SEQUENCES)} (R = R_i R_j R_k "
                                               f"for 'ijk'), {ANGLES_EXAMPLE}")
    angles = Map({"sequence": Key(sequence, required=True),
                  "names": Key(Map({axis: Key(LABEL) for axis in POSITION_AXES}, nullable=True,
                                   what=f"a mapping of axes (x, y, z) to column names, {ANGLES_EXAMPLE}"), {},
                               doc="the column name of each angle")},
                 post=some_angle, nullable=True, what=f"a mapping {{sequence, names}}, {ANGLES_EXAMPLE}")
    metrics = Map({metric: Key(_real("a number")) for metric in REFERENCE_METRICS},
                  what=f"a mapping of metrics ({', '.join(REFERENCE_METRICS)}) to numbers")
    p_values = Map(values=_real("a number between 0 and 1 (a p-value)", ge=0, le=1),
                   what="a mapping of error axes to p-values")
    text = Text(nullable=True)
    return Map({"name": Key(text, doc="the report's name of the figures"),
                "source": Key(text, doc="where the figures come from"),
                "angles": Key(angles, doc="Euler angles whose errors get columns (pose targets only)"),
                "figures": Key(Map(values=metrics, nullable=True,
                                   what="a mapping of method labels to {metric: value}, e.g. "
                                        "{kdl: {percent_solved: 72.5}}"), {}, doc="{label: {metric: value}}"),
                "significance": Key(Map(values=p_values, nullable=True,
                                        what="a mapping of method labels to {axis: p-value}, e.g. "
                                             "{kdl: {x: 0, time: 1.0e-3}}"), {},
                                    doc="{label: {axis: p-value}}"),
                "significance_source": Key(text, doc="where the p-values come from"),
                "notes": Key(text, doc="text for the report")},
               nullable=True, what="a mapping {name, source, angles, figures, significance, "
                                   "significance_source, notes}")


def _angles(raw: dict | None, target: str, path: str, ctx: Context) -> AngleConvention | None:
    """``reference.angles`` as an :class:`AngleConvention`: pose targets only, new column names only."""
    if raw is None or raw == {}:
        return None
    if target != "pose":
        ctx.fail(path, f"Euler angles apply to pose targets only, this case's target is {target!r} (leave "
                       "angles: out)")
    taken = {*POSITION_AXES, *ROTATION_VECTOR_AXES, *ANGLE_AXES}
    names = raw["names"]
    columns = tuple((axis, names[axis]) for axis in POSITION_AXES if names.get(axis) is not None)
    for axis, column in columns:
        if column in taken:
            ctx.fail(f"{path}.names.{axis}", f"{column!r} is already an error column "
                                            f"({', '.join(sorted(taken))}); choose another name")
        taken.add(column)
    return AngleConvention(sequence=raw["sequence"], names=columns)


def _case_name(robot: str, chain: str | None, target: str) -> str:
    from wbik.models.erd import example_robot_name

    robot = example_robot_name(robot) or Path(robot).stem
    return "_".join(part for part in (robot, chain, target) if part)


def _case_keys() -> set[str]:
    """The keys a case entry may hold: CASE_KEYS and every case kind's own."""
    from wbik.study.case_kinds import case_kinds

    return CASE_KEYS | {key for kind in case_kinds().values() for key in kind.entry_keys}


def _case_kind(item: dict, path: str, ctx: Context):
    """A case entry's kind: its ``target:`` (or ``targets:``), else the owner of a key, else the default."""
    from wbik.study.case_kinds import case_kinds

    kinds = case_kinds()
    if "targets" in item:
        return _target_set_kind(item, kinds, path, ctx)
    owners = {key: kind for kind in kinds.values() for key in kind.entry_keys if key in item}
    target = item.get("target", next(iter(owners.values())).name if owners else DEFAULT_TARGET)
    if not isinstance(target, str) or target not in kinds:
        names = [repr(name) for name, kind in kinds.items() if not getattr(kind, "target_set", None)]
        sets = [name for name, kind in kinds.items() if getattr(kind, "target_set", None)]
        choices = f"{', '.join(names[:-1])} or {names[-1]}" if len(names) > 1 else names[0]
        also = f" (or a target set: {', '.join(sets)}; see targets:)" if sets else ""
        ctx.says(join(path, "target"), f"must be {choices}{also}, got {target!r}"
                                       f"{did_you_mean(target, kinds) if isinstance(target, str) else ''}")
    for key, owner in owners.items():
        if owner.name != target:
            ctx.fail(join(path, key), f"is for target: {owner.name} cases, got target {target!r}")
    return kinds[target]


def _target_set_kind(item: dict, kinds: dict, path: str, ctx: Context):
    """The kind of an entry naming a target set (``targets: NAME`` or ``{set: NAME, ...}``)."""
    raw = item["targets"]
    name, key = ((raw.get("set"), join(path, "targets.set")) if isinstance(raw, dict)
                 else (raw, join(path, "targets")))
    sets: dict[str, list] = {}
    for kind in kinds.values():
        if getattr(kind, "target_set", None):
            sets.setdefault(kind.target_set, []).append(kind)
    if not isinstance(name, str) or name not in sets:
        known = ", ".join(sets) or "none is registered"
        ctx.says(key, f"must name a target set ({known}), got {name!r}"
                      f"{did_you_mean(name, sets) if isinstance(name, str) else ''}")
    target = item.get("target", DEFAULT_TARGET)
    for kind in sets[name]:
        if target in (kind.target, kind.name):
            return kind
    draws = " or ".join(kind.target for kind in sets[name])
    ctx.fail(join(path, "target"), f"the target set {name!r} draws {draws} targets, got {target!r}")


def check_schema(methods, cases, source: str) -> None:
    """Every method's ``options`` against its constructor, every case's robot and ``robot_params``."""
    from wbik.models import builder_parameters, robot_entries
    from wbik.models.erd import example_robot_name, example_robot_names
    from wbik.study.case_kinds import case_kinds, kinds_of

    study_settings = {"timeout_s", "tolerances", "seed"}  # every method takes these from the study
    kinds = kinds_of(cases) or list(case_kinds().values())
    for index, spec in enumerate(methods):
        kind = next((kind for kind in kinds if spec.method in kind.methods()), kinds[0])
        try:
            schema = kind.method_option_schema(spec.method)
        except ImportError:  # an optional dependency is missing: the runner reports it per method
            continue
        if schema is None:  # a kind that takes any options
            continue
        options = Options({name: key for name, key in schema.keys.items() if name not in study_settings},
                          schema.values is not None, f"method {spec.method!r} ({spec.label})")
        options.check({key: value for key, value in spec.options.items() if key not in study_settings},
                      f"methods[{index}].options", Context(source, STUDY_ERRORS))
    for case in cases:
        path = Path(case.robot).expanduser()
        example = example_robot_name(case.robot)
        if example is not None and example not in example_robot_names():
            raise StudyDefinitionError(
                f"{source}: case {case.name!r}: example-robot-data has no robot {example!r}"
                f"{did_you_mean(example, example_robot_names())}")
        if example is None and case.robot not in robot_entries() and not path.is_file():
            raise StudyDefinitionError(
                f"{source}: case {case.name!r}: robot {case.robot!r} is neither a built-in robot "
                f"({', '.join(robot_entries())}), example-robot-data:NAME nor an existing URDF file")
        if unknown := sorted(set(case.robot_params) - (accepted := builder_parameters(case.robot))):
            raise StudyValueError(f"{source}: case {case.name!r}: robot_params has unknown key(s) {unknown} "
                                  f"for robot {case.robot!r}; its parameters: "
                                  f"{', '.join(sorted(accepted)) or '(none)'}")
