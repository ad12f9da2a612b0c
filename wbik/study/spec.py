"""What a study is, as data: its cases, methods, budgets and settings (:class:`Study`); the study file's
reading and checking are :mod:`wbik.study.definition`."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field

from wbik.errors import WbikError
from wbik.study.metrics import STUDY_SEQUENCE, AngleConvention
from wbik.study.reference import Reference
from wbik.study.regression_rule import RegressionRule

DEFAULT_TARGET = "pose"
"""The kind of a case entry that names none (``target:``, or a key only one kind takes)."""


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
BUDGET_CURVE_POSES = 100
"""The poses of ``budget_curves: true`` and of a ``budget_curves`` mapping that names none."""


@dataclass(frozen=True)
class BudgetCurveSpec:
    """``budget_curves:``: the first ``poses`` targets of every case solved again at each budget of
    ``budgets_ms`` (:mod:`wbik.study.budget_curves`); 0 poses: none."""

    poses: int = 0
    budgets_ms: tuple[float, ...] = BUDGET_CURVE_MS


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
    figures: bool = True  # the report's PNG figures (a CI gate may leave them out: the rows are the same)
    description: str = ""
    notes: str = ""
    source: str = ""  # the file it came from (not part of the fingerprint)

    def poses_of(self, case: CaseSpec) -> int:
        return self.poses if case.poses is None else case.poses

    def timeout_of(self, method: MethodSpec) -> float:
        return self.timeout_s if method.timeout_s is None else method.timeout_s

    def method(self, label: str) -> MethodSpec:
        if (spec := next((m for m in self.methods if m.label == label), None)) is not None:
            return spec
        raise StudyDefinitionError(f"study {self.name!r} has no method labelled {label!r}; "
                                   f"labels: {', '.join(m.label for m in self.methods)}")

    def as_dict(self) -> dict:
        """Plain data (JSON-friendly), without ``source``."""
        data = asdict(self)
        data.pop("source")
        return data

    def fingerprint(self) -> str:
        """Hash of :meth:`row_settings`."""
        return _digest(self.row_settings())

    def row_settings(self) -> dict:
        """What every method's results depend on: cases (unset keys left out, the reference's angle columns
        as ``angle_names``), poses, seed, start, chunking and tolerances."""
        data = self.as_dict()
        for key in ("description", "notes", "methods", "baseline", "timeout_s", "budget_curves",
                    "regression", "figures"):
            data.pop(key)
        for spec, case in zip(self.cases, data["cases"], strict=True):
            case.pop("reference")
            case.pop("peers", None)
            case["angle_names"] = _fingerprint_angles(spec.reference.angles if spec.reference else None)
            for key in ("scenario", "base", "tip", "targets", "path", "success"):
                if case.get(key) is None:
                    case.pop(key, None)
        return data

    def method_fingerprint(self, method: MethodSpec) -> str:
        """Hash of what one method's results depend on: the study's fingerprint and the method's spec."""
        data = asdict(method)
        data.pop("note")
        data["timeout_s"] = self.timeout_of(method)
        return _digest({"study": self.fingerprint(), "method": data})


def _fingerprint_angles(angles: AngleConvention | None) -> dict:
    """The reference's angle columns, keyed by the study's own angles when its sequence is the study's."""
    if angles is None:
        return {}
    if angles.sequence == STUDY_SEQUENCE:
        return {angles.study_angle(axis): name for axis, name in angles.names}
    return {"sequence": angles.sequence, **dict(angles.names)}


def _digest(data) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]
