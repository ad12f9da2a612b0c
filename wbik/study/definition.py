"""Study definitions: what to compare, on what, how many times.

A study file (YAML or TOML, in ``comparisons/``) names one or more *cases* (robot, chain, target
kind) and the *methods* to run on each, with the number of poses, the seed, the time budget and
the tolerances of the shared FK check. A single-case study may give ``robot``/``chain``/``target``
at the top level instead of a ``cases`` list. Example::

    name: panda_pose
    robot: panda            # a built-in robot or a URDF path
    chain: arm
    target: pose            # or position
    poses: 10000
    seed: 2017
    timeout_s: 0.005        # default budget of every method
    tolerances: {position: 1.0e-6, rotation: 1.0e-6}
    baseline: bounded_lm    # Mann-Whitney reference
    methods:
      - bounded_lm
      - {label: kdl_15s, method: kdl, timeout_s: 15, note: "a published run's timeout"}
      - {label: dls_per_pose, method: dls, per_pose: true}   # time of single calls
    reference:              # published figures to set beside ours (wbik.study.reference)
      name: paper
      source: "a paper's Table 2"
      figures: {kdl_15s: {percent_solved: 72.5, time_median_ms: 200}}

Every mistake raises :class:`StudyDefinitionError` naming the file, the field and what to write.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import tomllib
from dataclasses import asdict
from dataclasses import dataclass
from dataclasses import field
from dataclasses import replace
from pathlib import Path

import yaml

from wbik.data import data_dir
from wbik.data import study_path
from wbik.errors import WbikError
from wbik.errors import closest_name
from wbik.errors import did_you_mean
from wbik.study.metrics import ANGLE_AXES
from wbik.study.metrics import POSITION_AXES
from wbik.study.metrics import ROTATION_VECTOR_AXES
from wbik.study.metrics import STUDY_SEQUENCE
from wbik.study.metrics import TAIT_BRYAN_SEQUENCES
from wbik.study.metrics import AngleConvention
from wbik.study.reference import REFERENCE_METRICS
from wbik.study.reference import Reference

COMPARISONS_DIR = data_dir("comparisons")
"""The ``comparisons/`` folder (study files; final reports under ``reports/``): the repository's, or
the installed package's copy of its study files."""

DEFAULT_STUDY = COMPARISONS_DIR / "default.yaml"

DEFAULT_TARGET = "pose"
"""The kind of a case entry that names none (``target:``, or a key only one kind takes): the case
kinds are those of :mod:`wbik.study.case_kinds` (pose, position, wholebody, and any registered)."""
CASE_KEYS = {"name", "robot", "chain", "target", "robot_params", "poses", "reference", "base", "tip",
             "targets"}
"""The keys of a case entry every kind reads (a kind may take more: its ``entry_keys``). ``targets``
names a target set (:func:`_target_set_kind`), whose kind checks and completes its parameters."""
START_KINDS = ("nominal", "mid_range", "random")
REFERENCE_KEYS = {"name", "source", "angles", "figures", "significance", "significance_source", "notes"}
_LABEL = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")


class StudyDefinitionError(WbikError, ValueError):
    """A study file that cannot be run as written; the message names the field to fix."""


@dataclass(frozen=True)
class MethodSpec:
    """One column of the comparison: a registered method with its options under a label."""

    label: str
    method: str
    options: dict = field(default_factory=dict)
    timeout_s: float | None = None  # None: the study's default
    note: str = ""
    per_pose: bool = False  # True: one solve() per pose instead of a batched solve_many (time per call)


@dataclass(frozen=True)
class CaseSpec:
    """One robot chain and target kind the methods are compared on."""

    name: str
    robot: str
    chain: str | None = None
    target: str = DEFAULT_TARGET  # the case's kind (wbik.study.case_kinds)
    robot_params: dict = field(default_factory=dict)
    poses: int | None = None  # None: the study's
    reference: Reference | None = None  # published figures to compare with, and their angle names
    scenario: str | None = None  # target "wholebody": the case sampler (wbik.wholebody.cases)
    base: str | None = None  # a chain named by its base and tip frames (``chain`` is then its name)
    tip: str | None = None
    targets: dict | None = None  # a target set and its parameters (``targets:``; None: the kind's own)
    path: dict | None = None  # target "path": the path's shape and parameters (wbik.study.paths)
    success: dict | None = None  # target "protocol": the case's success rule (wbik.study.protocols)
    peers: list | None = None  # target "protocol": peers' published figures (report only, not fingerprinted)


BUDGET_CURVE_MS = (0.2, 0.3, 0.5, 1.0, 2.0, 3.0, 5.0, 8.0, 12.0, 20.0)
"""The budgets (ms) of a study's success-versus-budget curves unless ``budget_curves.budgets_ms`` says."""
SUCCESS_DROP_CI = "ci"


@dataclass(frozen=True)
class BudgetCurveSpec:
    """``budget_curves:``: success against the budget, from the first ``poses`` targets of every case
    solved again at each budget of ``budgets_ms`` (:mod:`wbik.study.budget_curves`); 0 poses: none."""

    poses: int = 0
    budgets_ms: tuple[float, ...] = BUDGET_CURVE_MS


@dataclass(frozen=True)
class RegressionRule:
    """``regression:``: when ``wbik study --compare-to OLD`` calls a method worse than in OLD
    (:mod:`wbik.study.compare`). ``success_drop``: "ci" (the two runs' 95 % intervals of the share
    solved are disjoint, the new one below) or percentage points (new < old - points);
    ``time_rise``: a factor r >= 1 (the new median time's interval lies above r x the old one's),
    None: times are not gated."""

    success_drop: str | float = SUCCESS_DROP_CI
    time_rise: float | None = 1.2


@dataclass(frozen=True)
class Study:
    name: str
    cases: tuple[CaseSpec, ...]
    methods: tuple[MethodSpec, ...]
    poses: int = 1000
    seed: int = 0
    timeout_s: float = 0.005
    tolerances: dict = field(default_factory=lambda: {"position": 1e-6, "rotation": 1e-6})
    start: str = "nominal"
    baseline: str | None = None
    chunk_size: int = 100
    budget_curves: BudgetCurveSpec = field(default_factory=BudgetCurveSpec)
    regression: RegressionRule = field(default_factory=RegressionRule)
    description: str = ""
    notes: str = ""
    source: str = ""  # the file it came from (not part of the fingerprint)

    def poses_of(self, case: CaseSpec) -> int:
        return self.poses if case.poses is None else case.poses

    def timeout_of(self, method: MethodSpec) -> float:
        return self.timeout_s if method.timeout_s is None else method.timeout_s

    def method(self, label: str) -> MethodSpec:
        for spec in self.methods:
            if spec.label == label:
                return spec
        raise StudyDefinitionError(f"study {self.name!r} has no method labelled {label!r}; "
                                   f"labels: {', '.join(m.label for m in self.methods)}")

    def as_dict(self) -> dict:
        """Plain data (JSON-friendly), without ``source``."""
        data = asdict(self)
        data.pop("source")
        return data

    def fingerprint(self) -> str:
        """Hash of what every method's results depend on: cases, poses, seed, start, chunking,
        tolerances and the reference's angle columns (not the methods, descriptions, notes or the
        reference's figures). The angle columns enter as ``angle_names``, keyed by the study's own
        angles when the reference's sequence is the study's (the form of files written before the
        reference block, whose results folders therefore still resume)."""
        data = self.as_dict()
        for key in ("description", "notes", "methods", "baseline", "timeout_s"):
            data.pop(key)
        for key in ("budget_curves", "regression"):  # what is measured beside the rows, how runs compare
            data.pop(key)
        for spec, case in zip(self.cases, data["cases"], strict=True):
            case.pop("reference")
            case["angle_names"] = _fingerprint_angles(spec.reference.angles if spec.reference else None)
            if case.get("scenario") is None:  # chain cases: the same fingerprint as before whole-body cases
                case.pop("scenario", None)
            for key in ("base", "tip", "targets", "path", "success"):  # keys a case leaves out: the
                if case.get(key) is None:  # fingerprint of before them
                    case.pop(key, None)
            case.pop("peers", None)  # report text, as the reference
        return _digest(data)

    def method_fingerprint(self, method: MethodSpec) -> str:
        """Hash of what one method's results depend on: the study's fingerprint and the method's spec."""
        data = asdict(method)
        data.pop("note")
        data["timeout_s"] = self.timeout_of(method)
        return _digest({"study": self.fingerprint(), "method": data})

    def with_overrides(self, *, poses: int | None = None, methods: list[str] | None = None,
                       robot: str | None = None, chain: str | None = None,
                       chunk_size: int | None = None, seed: int | None = None,
                       name: str | None = None, budget_curve_poses: int | None = None) -> Study:
        """A copy with command-line overrides applied (and validated)."""
        study = self
        if methods:
            unknown = [m for m in methods if m not in {s.label for s in self.methods}]
            if unknown:
                raise StudyDefinitionError(
                    f"--methods names {unknown} which study {self.name!r} does not have; its labels: "
                    f"{', '.join(s.label for s in self.methods)}")
            study = replace(study, methods=tuple(s for s in self.methods if s.label in methods))
            if study.baseline not in methods:
                study = replace(study, baseline=study.methods[0].label)
        if robot is not None or chain is not None:
            if len(study.cases) != 1:
                raise StudyDefinitionError("--robot/--chain apply to single-case studies only")
            case = study.cases[0]
            new_robot = robot or case.robot
            case = replace(case, robot=new_robot, chain=chain if chain is not None else
                           (case.chain if robot is None else None),
                           name=_case_name(new_robot, chain if chain is not None else case.chain,
                                           case.target) if robot is not None else case.name,
                           robot_params={} if robot is not None else case.robot_params,
                           reference=None if robot is not None else case.reference)
            study = replace(study, cases=(case,))
            check_schema((), study.cases, "command line")
        if poses is not None:
            study = replace(study, poses=_positive_int(poses, "--poses", "command line"),
                            cases=tuple(replace(c, poses=None) for c in study.cases))
        if chunk_size is not None:
            study = replace(study, chunk_size=_positive_int(chunk_size, "--chunk-size", "command line"))
        if seed is not None:
            study = replace(study, seed=int(seed))
        if name is not None:
            study = replace(study, name=_label(name, "--name", "command line"))
        if budget_curve_poses is not None:
            if isinstance(budget_curve_poses, bool) or not isinstance(budget_curve_poses, int) \
                    or budget_curve_poses < 0:
                raise StudyDefinitionError(f"command line: --budget-curves must be a number of poses >= 0 "
                                           f"(0: none), got {budget_curve_poses!r}")
            study = replace(study, budget_curves=replace(study.budget_curves, poses=budget_curve_poses))
        return study


def _fingerprint_angles(angles: AngleConvention | None) -> dict:
    if angles is None:
        return {}
    if angles.sequence == STUDY_SEQUENCE:
        return {angles.study_angle(axis): name for axis, name in angles.names}
    return {"sequence": angles.sequence, **dict(angles.names)}


def _digest(data) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]


# -- parsing -----------------------------------------------------------------------------------
def load_study(path: str | Path | None = None) -> Study:
    """Read and validate a study file (``.yaml``/``.yml`` or ``.toml``); None: the default study.

    A name of a shipped study (``default``, or ``comparisons/default.yaml``) that is no
    file where it is run from is the shipped file (see :func:`wbik.data.study_path`)."""
    path = DEFAULT_STUDY if path is None else study_path(path)
    if not path.is_file():
        available = sorted(p.name for p in COMPARISONS_DIR.glob("*.y*ml")) if COMPARISONS_DIR.is_dir() else []
        raise StudyDefinitionError(f"study file {str(path)!r} does not exist; the studies shipped in "
                                   f"{COMPARISONS_DIR}: {', '.join(available) or '(none)'}")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise StudyDefinitionError(f"{path}: not a text file (byte {exc.start} is not UTF-8); a study file "
                                   "is YAML or TOML text") from None
    try:
        if path.suffix.lower() == ".toml":
            data = tomllib.loads(text)
        else:
            data = yaml.safe_load(text)
    except (yaml.YAMLError, tomllib.TOMLDecodeError) as exc:
        raise StudyDefinitionError(f"{path}: not valid {path.suffix.lstrip('.').upper()}: {exc}") from exc
    return study_from_dict(data, source=str(path))


def study_from_dict(data, source: str = "study") -> Study:
    """Validate plain data (as read from a file) into a :class:`Study`."""
    if not isinstance(data, dict):
        raise StudyDefinitionError(f"{source}: a study is a mapping of fields (name, robot, methods, ...), "
                                   f"got {type(data).__name__}")
    known = {"name", "description", "notes", "cases", "methods", "poses", "seed", "timeout_s", "tolerances",
             "start", "baseline", "chunk_size", "budget_curves", "regression", *_case_keys()}
    _no_unknown(data, known, source, "the study")
    name = _label(data.get("name", Path(source).stem), "name", source)
    poses = _positive_int(data.get("poses", 1000), "poses", source)
    seed = data.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise StudyDefinitionError(f"{source}: seed must be a non-negative integer, got {seed!r}")
    timeout_s = _positive_float(data.get("timeout_s", 0.005), "timeout_s", source)
    tolerances = data.get("tolerances", {}) or {}
    if not isinstance(tolerances, dict):
        raise StudyDefinitionError(f"{source}: tolerances must be a mapping {{position: m, rotation: rad}}")
    _no_unknown(tolerances, {"position", "rotation"}, source, "tolerances")
    tolerances = {key: _positive_float(tolerances.get(key, 1e-6), f"tolerances.{key}", source)
                  for key in ("position", "rotation")}
    start = data.get("start", "nominal")
    if start not in START_KINDS:
        raise StudyDefinitionError(f"{source}: start must be one of {', '.join(START_KINDS)} (the q0 given "
                                   f"to every method), got {start!r}")
    chunk_size = _positive_int(data.get("chunk_size", 100), "chunk_size", source)
    methods = _methods(data.get("methods"), source)
    cases = _cases(data, source)
    check_schema(methods, cases, source)
    baseline = data.get("baseline", methods[0].label)
    labels = [m.label for m in methods]
    _require_known(baseline, labels, f"{source}: baseline {baseline!r} is not one of the method labels")
    for case in cases:
        for label in case.reference.labels if case.reference else ():
            _require_known(label, labels, f"{source}: case {case.name!r}: the reference figures name method "
                                          f"{label!r}, which is not a method label of the study")
    return Study(name=name, cases=tuple(cases), methods=tuple(methods), poses=poses, seed=seed,
                 timeout_s=timeout_s, tolerances=tolerances, start=start, baseline=baseline,
                 chunk_size=chunk_size, budget_curves=_budget_curves(data.get("budget_curves"), source),
                 regression=_regression(data.get("regression"), source),
                 description=str(data.get("description", "") or ""),
                 notes=str(data.get("notes", "") or ""), source=source)


def _budget_curves(raw, source: str) -> BudgetCurveSpec:
    """``budget_curves:``: false/absent (none), true (100 poses), or {poses: n, budgets_ms: [...]}."""
    if raw is None or raw is False:
        return BudgetCurveSpec()
    if raw is True:
        return BudgetCurveSpec(poses=100)
    where = "budget_curves"
    raw = _mapping(raw, source, where, "is true, false or {poses: 100, budgets_ms: [0.2, 1, 5, 20]}")
    _no_unknown(raw, {"poses", "budgets_ms"}, source, where)
    poses = raw.get("poses", 100)
    if isinstance(poses, bool) or not isinstance(poses, int) or poses < 0:
        raise StudyDefinitionError(f"{source}: {where}.poses must be a number of poses >= 0 (0: no curves), "
                                   f"got {poses!r}")
    budgets = raw.get("budgets_ms", list(BUDGET_CURVE_MS))
    if not isinstance(budgets, list) or not budgets:
        raise StudyDefinitionError(f"{source}: {where}.budgets_ms must be a non-empty list of budgets in ms, "
                                   f"got {budgets!r}")
    budgets = sorted({_positive_float(value, f"{where}.budgets_ms", source) for value in budgets})
    return BudgetCurveSpec(poses=poses, budgets_ms=tuple(budgets))


def _regression(raw, source: str) -> RegressionRule:
    """``regression:``: {success_drop: ci or points >= 0, time_rise: factor >= 1, ci (1) or off}."""
    where = "regression"
    raw = _mapping(raw, source, where, "is {success_drop: ci, time_rise: 1.2}")
    _no_unknown(raw, {"success_drop", "time_rise"}, source, where)
    drop = raw.get("success_drop", SUCCESS_DROP_CI)
    if drop != SUCCESS_DROP_CI:
        drop = _yaml_number(drop)
        if isinstance(drop, bool) or not isinstance(drop, int | float) or not 0 <= drop <= 100:
            raise StudyDefinitionError(f"{source}: {where}.success_drop must be 'ci' (the 95 % intervals are "
                                       f"disjoint) or percentage points between 0 and 100, got {drop!r}")
        drop = float(drop)
    rise = raw.get("time_rise", 1.2)
    if rise in (None, False, "off"):
        rise = None
    elif rise == SUCCESS_DROP_CI:
        rise = 1.0
    else:
        rise = _yaml_number(rise)
        if isinstance(rise, bool) or not isinstance(rise, int | float) or not 1.0 <= rise < math.inf:
            raise StudyDefinitionError(f"{source}: {where}.time_rise must be a factor >= 1 (e.g. 1.2), 'ci' "
                                       f"(1) or off, got {rise!r}")
        rise = float(rise)
    return RegressionRule(success_drop=drop, time_rise=rise)


def _methods(raw, source: str) -> list[MethodSpec]:
    if not isinstance(raw, list) or not raw:
        raise StudyDefinitionError(f"{source}: methods must be a non-empty list, e.g. [analytic, dls, "
                                   "{label: kdl_15s, method: kdl, timeout_s: 15}]")
    from wbik.study.case_kinds import case_kinds

    known_methods = {name: description for kind in case_kinds().values()  # every kind's methods
                     for name, description in kind.methods().items()}
    specs: list[MethodSpec] = []
    for index, item in enumerate(raw):
        where = f"methods[{index}]"
        if isinstance(item, str):
            item = {"method": item}
        if not isinstance(item, dict):
            raise StudyDefinitionError(f"{source}: {where} must be a method name or a mapping, got {item!r}")
        _no_unknown(item, {"label", "method", "options", "timeout_s", "note", "per_pose"}, source, where)
        method = item.get("method")
        _require_known(method, known_methods, f"{source}: {where}: unknown method {method!r}")
        options = item.get("options", {}) or {}
        if not isinstance(options, dict):
            raise StudyDefinitionError(f"{source}: {where}.options must be a mapping of keyword arguments")
        for reserved in ("timeout_s", "tolerances", "seed"):
            if reserved in options:
                raise StudyDefinitionError(f"{source}: {where}.options.{reserved} is set by the study; "
                                           f"use {where}.timeout_s or the study's tolerances/seed")
        timeout = item.get("timeout_s")
        per_pose = item.get("per_pose", False)
        if not isinstance(per_pose, bool):
            raise StudyDefinitionError(f"{source}: {where}.per_pose must be true or false")
        specs.append(MethodSpec(
            label=_label(item.get("label", method), f"{where}.label", source), method=method,
            options=dict(options),
            timeout_s=None if timeout is None else _positive_float(timeout, f"{where}.timeout_s", source),
            note=str(item.get("note", "") or ""), per_pose=per_pose))
    labels = [s.label for s in specs]
    duplicates = sorted({label for label in labels if labels.count(label) > 1})
    if duplicates:
        raise StudyDefinitionError(f"{source}: method labels must be unique; repeated: {duplicates} "
                                   "(give each variant its own label:)")
    return specs


def _case_name(robot: str, chain: str | None, target: str) -> str:
    from wbik.models.erd import example_robot_name

    robot = example_robot_name(robot) or Path(robot).stem
    return "_".join(part for part in (robot, chain, target) if part)


def _case_keys() -> set[str]:
    """The keys a case entry may hold: CASE_KEYS and every case kind's own."""
    from wbik.study.case_kinds import case_kinds

    return CASE_KEYS | {key for kind in case_kinds().values() for key in kind.entry_keys}


def _case_kind(item: dict, source: str, where: str):
    """The kind of a case entry: its ``target:``, else the kind whose own key it holds, else
    DEFAULT_TARGET; a key of another kind than the target's is an error."""
    from wbik.study.case_kinds import case_kinds

    kinds = case_kinds()
    if "targets" in item:
        return _target_set_kind(item, kinds, source, where)
    owners = {key: kind for kind in kinds.values() for key in kind.entry_keys if key in item}
    target = item.get("target", next(iter(owners.values())).name if owners else DEFAULT_TARGET)
    for key, owner in owners.items():
        if owner.name != target:
            raise StudyDefinitionError(f"{source}: {where}: {key}: is for target: {owner.name} cases, got "
                                       f"target {target!r}")
    if not isinstance(target, str) or target not in kinds:
        names = [repr(name) for name, kind in kinds.items() if not getattr(kind, "target_set", None)]
        sets = [name for name, kind in kinds.items() if getattr(kind, "target_set", None)]
        choices = f"{', '.join(names[:-1])} or {names[-1]}" if len(names) > 1 else names[0]
        also = f" (or a target set: {', '.join(sets)}; see targets:)" if sets else ""
        raise StudyDefinitionError(f"{source}: {where}.target must be {choices}{also}, got {target!r}")
    return kinds[target]


def _target_set_kind(item: dict, kinds: dict, source: str, where: str):
    """The kind of a case entry naming a target set, ``targets: NAME`` or ``targets: {set: NAME, ...}``:
    the registered kind whose ``target_set`` is NAME and whose target is the entry's ``target`` (pose
    by default, or the kind's own name)."""
    raw = item["targets"]
    if isinstance(raw, dict):
        name, key = raw.get("set"), f"{where}.targets.set"
    else:
        name, key = raw, f"{where}.targets"
    sets: dict[str, list] = {}
    for kind in kinds.values():
        if getattr(kind, "target_set", None):
            sets.setdefault(kind.target_set, []).append(kind)
    if not isinstance(name, str) or name not in sets:
        known = ", ".join(sets) or "none is registered"
        raise StudyDefinitionError(f"{source}: {key} must name a target set ({known}), got "
                                   f"{name!r}{did_you_mean(name, sets)}")
    target = item.get("target", DEFAULT_TARGET)
    for kind in sets[name]:
        if target in (kind.target, kind.name):
            return kind
    raise StudyDefinitionError(f"{source}: {where}.target: the target set {name!r} draws "
                               f"{' or '.join(kind.target for kind in sets[name])} targets, got {target!r}")


def _cases(data: dict, source: str) -> list[CaseSpec]:
    case_keys = _case_keys()
    top_level = {key for key in case_keys - {"name", "poses", "reference"} if key in data}
    if "cases" in data:
        if top_level:
            raise StudyDefinitionError(f"{source}: give either cases: [...] or robot/chain/target at the "
                                       f"top level, not both (found {sorted(top_level)})")
        raw = data["cases"]
        if not isinstance(raw, list) or not raw:
            raise StudyDefinitionError(f"{source}: cases must be a non-empty list of "
                                       "{robot, chain, target} mappings")
        if "reference" in data:
            raise StudyDefinitionError(f"{source}: reference: belongs inside each case of cases: (the "
                                       "figures and angle names are a case's)")
    else:
        if "robot" not in data and not (case_keys - CASE_KEYS) & set(data):
            raise StudyDefinitionError(f"{source}: say which robot to study (robot: NAME or a URDF path) "
                                       "or list cases:")
        raw = [{key: value for key, value in data.items() if key in case_keys - {"name", "poses"}}]
    cases: list[CaseSpec] = []
    for index, item in enumerate(raw):
        where = f"cases[{index}]" if "cases" in data else "the study"
        if not isinstance(item, dict):
            raise StudyDefinitionError(f"{source}: {where} must be a mapping, got {item!r}")
        _no_unknown(item, case_keys, source, where)
        kind = _case_kind(item, source, where)
        item = kind.entry(item, source, where)
        robot = item.get("robot")
        if not isinstance(robot, str) or not robot:
            raise StudyDefinitionError(f"{source}: {where}.robot must be a robot name or URDF path")
        chain = item.get("chain")
        if chain is not None and not isinstance(chain, str):
            raise StudyDefinitionError(f"{source}: {where}.chain must be a chain name")
        base, tip = _chain_frames(item, source, where)
        if base is not None and chain is None:
            chain = f"{base}_to_{tip}"
        target = kind.name
        params = item.get("robot_params", {}) or {}
        if not isinstance(params, dict):
            raise StudyDefinitionError(f"{source}: {where}.robot_params must be a mapping of the robot's "
                                       f"parameters (e.g. {{lengths: [3, 2, 2]}}), got {params!r}")
        poses = item.get("poses")
        case = CaseSpec(
            name=_label(item.get("name", _case_name(robot, chain, target)), f"{where}.name", source),
            robot=robot, chain=chain, target=target, robot_params=dict(params),
            poses=None if poses is None else _positive_int(poses, f"{where}.poses", source),
            reference=_reference(item.get("reference"), kind, source, f"{where}.reference"),
            scenario=item.get("scenario"), base=base, tip=tip, targets=item.get("targets"),
            path=item.get("path"), success=item.get("success"), peers=item.get("peers"))
        cases.append(case)
    names = [c.name for c in cases]
    if len(set(names)) != len(names):
        raise StudyDefinitionError(f"{source}: case names must be unique (give each a name:), got {names}")
    return cases


def _chain_frames(item: dict, source: str, where: str) -> tuple[str | None, str | None]:
    """A case's ``base``/``tip`` (a chain named by its frames, as KDL and TRAC-IK take it): both or
    neither, frame names."""
    base, tip = item.get("base"), item.get("tip")
    if base is None and tip is None:
        return None, None
    if base is None or tip is None:
        raise StudyDefinitionError(f"{source}: {where}: give both base: and tip: (the chain's frames), got "
                                   f"only {'base' if tip is None else 'tip'}")
    for key, value in (("base", base), ("tip", tip)):
        if not isinstance(value, str) or not value:
            raise StudyDefinitionError(f"{source}: {where}.{key} must be a frame name, got {value!r}")
    return base, tip


def _reference(raw, kind, source: str, where: str) -> Reference | None:
    """A case's ``reference:`` block checked (see wbik.study.reference), None when absent; ``kind``
    the case's kind (:class:`wbik.study.case_kinds.CaseKind`: its target and error axes)."""
    if raw is None or raw == {}:
        return None
    if not isinstance(raw, dict):
        raise StudyDefinitionError(f"{source}: {where} must be a mapping {{name, source, angles, figures, "
                                   f"significance, significance_source, notes}}, got {raw!r}")
    _no_unknown(raw, REFERENCE_KEYS, source, where)
    texts = {key: raw.get(key, "") if raw.get(key) is not None else "" for key in
             ("name", "source", "significance_source", "notes")}
    for key, value in texts.items():
        if not isinstance(value, str):
            raise StudyDefinitionError(f"{source}: {where}.{key} must be text, got {value!r}")
    name = texts["name"].strip() or "reference"
    angles = _angles(raw.get("angles"), kind.target, source, f"{where}.angles")
    figures = _table(raw.get("figures"), source, f"{where}.figures",
                     "maps method labels to {metric: value}, e.g. {kdl: {percent_solved: 72.5}}",
                     "metrics", REFERENCE_METRICS, "numbers", _number)
    axes = [*kind.axes(angles), "time"]
    significance = _table(raw.get("significance"), source, f"{where}.significance",
                          "maps method labels to {axis: p-value}, e.g. {kdl: {x: 0, time: 1.0e-3}}",
                          "error axes", axes, "p-values", _p_value)
    return Reference(name=name, source=texts["source"], angles=angles, figures=figures,
                     significance=significance, significance_source=texts["significance_source"],
                     notes=texts["notes"])


def _table(raw, source: str, where: str, what: str, row_keys_are: str, row_keys, values_are: str,
           value) -> dict[str, dict[str, float]]:
    """A ``{label: {key: number}}`` block checked: ``what`` says what it maps; each row maps keys
    among ``row_keys`` (``row_keys_are``, e.g. "metrics") to ``values_are``, each one checked by
    ``value(item, field_name, source)``."""
    checked = {}
    for label, row in _mapping(raw, source, where, what).items():
        row_where = f"{where}.{label}"
        row = _mapping(row, source, row_where, f"maps {row_keys_are} ({', '.join(row_keys)}) to {values_are}")
        _no_unknown(row, set(row_keys), source, row_where)
        checked[str(label)] = {key: value(item, f"{row_where}.{key}", source) for key, item in row.items()}
    return checked


def _p_value(value, field_name: str, source: str) -> float:
    """A number between 0 and 1, else a StudyDefinitionError."""
    p_value = _number(value, field_name, source)
    if not 0.0 <= p_value <= 1.0:
        raise StudyDefinitionError(f"{source}: {field_name} is a p-value, between 0 and 1; got {value!r}")
    return p_value


def _angles(raw, target: str, source: str, where: str) -> AngleConvention | None:
    """``reference.angles``: {sequence: one of TAIT_BRYAN_SEQUENCES, names: {axis: column name}}."""
    if raw is None:
        return None
    example = "e.g. {sequence: zyx, names: {x: yaw, y: pitch, z: roll}} for R = Rz(roll) Ry(pitch) Rx(yaw)"
    if not isinstance(raw, dict):
        raise StudyDefinitionError(f"{source}: {where} must be a mapping {{sequence, names}}, {example}")
    _no_unknown(raw, {"sequence", "names"}, source, where)
    if target != "pose":
        raise StudyDefinitionError(f"{source}: {where}: Euler angles apply to pose targets only, this case's "
                                   f"target is {target!r} (leave angles: out)")
    sequence = raw.get("sequence")
    if sequence not in TAIT_BRYAN_SEQUENCES:
        raise StudyDefinitionError(
            f"{source}: {where}.sequence must be one of {', '.join(TAIT_BRYAN_SEQUENCES)} (R = R_i R_j R_k "
            f"for 'ijk'), got {sequence!r}{did_you_mean(sequence, TAIT_BRYAN_SEQUENCES)}; {example}")
    names = _mapping(raw.get("names"), source, f"{where}.names",
                     f"maps axes (x, y, z) to column names, {example}")
    if not names:
        raise StudyDefinitionError(f"{source}: {where}.names must name at least one angle, {example}")
    _no_unknown(names, set(POSITION_AXES), source, f"{where}.names")
    taken = {*POSITION_AXES, *ROTATION_VECTOR_AXES, *ANGLE_AXES}
    columns: list[tuple[str, str]] = []
    for axis in POSITION_AXES:
        if axis not in names:
            continue
        column = _label(names[axis], f"{where}.names.{axis}", source)
        if column in taken:
            raise StudyDefinitionError(f"{source}: {where}.names.{axis}: {column!r} is already an error "
                                       f"column ({', '.join(sorted(taken))}); choose another name")
        taken.add(column)
        columns.append((axis, column))
    return AngleConvention(sequence=sequence, names=tuple(columns))


def _mapping(value, source: str, where: str, what: str) -> dict:
    """``value`` if a mapping ({} for None), else a StudyDefinitionError saying what it maps."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise StudyDefinitionError(f"{source}: {where} {what}; got {value!r}")
    return value


def _number(value, field_name: str, source: str) -> float:
    """A finite number (PyYAML's string '1e-3' included), else a StudyDefinitionError."""
    value = _yaml_number(value)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise StudyDefinitionError(f"{source}: {field_name} must be a number, got {value!r}")
    return float(value)


def check_schema(methods, cases, source: str) -> None:
    """Check what the file names against the code, before any solving: every method's ``options``
    against its constructor, as the first of the cases' kinds that runs the method reads it
    (:meth:`wbik.study.case_kinds.CaseKind.method_options`), every case's robot (a built-in name or an
    existing URDF file) and its ``robot_params`` against the robot's builder."""
    from wbik.models import builder_parameters
    from wbik.models import robot_entries
    from wbik.models.erd import example_robot_name
    from wbik.models.erd import example_robot_names
    from wbik.study.case_kinds import case_kinds
    from wbik.study.case_kinds import kinds_of

    study_settings = {"timeout_s", "tolerances", "seed"}  # every method takes these from the study
    kinds = kinds_of(cases) or list(case_kinds().values())
    for index, spec in enumerate(methods):
        kind = next((kind for kind in kinds if spec.method in kind.methods()), kinds[0])
        try:
            accepted = kind.method_options(spec.method)
        except ImportError:  # an optional dependency is missing: the runner reports it per method
            continue
        if accepted is not None:
            accepted = accepted | study_settings
            _no_unknown_keys(spec.options, accepted, accepted - study_settings,
                             f"{source}: methods[{index}] ({spec.label}).options has unknown option(s)",
                             f"method {spec.method!r}; its options")
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
        accepted = builder_parameters(case.robot)
        _no_unknown_keys(case.robot_params, accepted, accepted,
                         f"{source}: case {case.name!r}: robot_params has unknown key(s)",
                         f"robot {case.robot!r}; its parameters")


def _no_unknown_keys(given, accepted: set[str], listed: set[str], what: str, whose: str) -> None:
    """A StudyDefinitionError when ``given`` has keys ``accepted`` lacks: "{what} [the keys] for
    {whose}: [``listed``, sorted]"."""
    unknown = sorted(set(given) - accepted)
    if unknown:
        raise StudyDefinitionError(f"{what} {unknown} for {whose}: {', '.join(sorted(listed)) or '(none)'}")


def _no_unknown(mapping: dict, known: set[str], source: str, where: str) -> None:
    unknown = sorted(set(mapping) - known, key=str)
    if unknown:
        guesses = [(key, closest_name(key, known)) for key in unknown]
        guesses = [(key, guess) for key, guess in guesses if guess is not None]
        if len(unknown) == 1 and guesses:
            hint = f" (did you mean {guesses[0][1]!r}?)"
        elif guesses:
            hint = " (did you mean " + ", ".join(f"{guess!r} for {key!r}" for key, guess in guesses) + "?)"
        else:
            hint = ""
        raise StudyDefinitionError(f"{source}: {where} has unknown field(s) {unknown}{hint}; allowed: "
                                   f"{', '.join(sorted(known))}")


def _require_known(name, known, message: str) -> None:
    """A StudyDefinitionError ``message`` + did-you-mean + the known names when ``name`` is not one."""
    if not isinstance(name, str) or name not in known:
        raise StudyDefinitionError(f"{message}{did_you_mean(name, known)}; known: {', '.join(known)}")


def _label(value, field_name: str, source: str) -> str:
    if not isinstance(value, str) or not _LABEL.match(value):
        raise StudyDefinitionError(f"{source}: {field_name} must be a name of letters, digits, '_', '-' or "
                                   f"'.' (it names files), got {value!r}")
    return value


def _positive_int(value, field_name: str, source: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise StudyDefinitionError(f"{source}: {field_name} must be a positive integer, got {value!r}")
    return value


def _yaml_number(value):
    """``value`` as a float when it is a string holding one (PyYAML reads 1e-6, no dot, as a string)."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            pass
    return value


def _positive_float(value, field_name: str, source: str) -> float:
    value = _yaml_number(value)
    if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
        raise StudyDefinitionError(f"{source}: {field_name} must be a positive number, got {value!r}")
    return float(value)
