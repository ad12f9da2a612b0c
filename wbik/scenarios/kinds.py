"""Scenario kinds (:class:`ScenarioKind`, declared in a module's ``SCENARIO_KINDS``), what a runner
``run(checked spec, on_progress)`` returns (:class:`ScenarioReport`), their registry and the errors."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property, reduce
from typing import TYPE_CHECKING

import numpy as np

from wbik.errors import InvalidBudgetError, MissingDependencyError, WbikError, did_you_mean
from wbik.expectations import ExpectationError, format_checks, verdict
from wbik.files import json_plain
from wbik.models import load
from wbik.registry import DeclaredRegistry, RegistryError, RegistryImportError
from wbik.schema import Refused, SchemaBudgetError, SchemaValueError, UnknownKeyError
from wbik.validation import finite_vector

if TYPE_CHECKING:
    from wbik.robot import Robot
    from wbik.schema import Map
    from wbik.viz.animation import Animation

KIND_MODULES: list = []  # the registry's sources besides wbik.catalog and entry points
VERDICTS = ("PASSED", "FAILED", "informational")


class ScenarioError(WbikError, ValueError):
    """A scenario file that cannot be read or names something that does not exist."""


class ScenarioFileError(ScenarioError):
    """The file itself: missing, a directory, not UTF-8, empty, not YAML/JSON/TOML, not a mapping."""


class UnknownScenarioKeyError(ScenarioError, UnknownKeyError):
    """A key the scenario's kind does not read; ``path`` is where, ``known`` the keys allowed there."""


class UnknownExpectationKeyError(UnknownScenarioKeyError, ExpectationError):
    """An unknown key inside an ``expect:`` block."""


class ScenarioValueError(ScenarioError, SchemaValueError):
    """A value of the wrong type, outside its range, or not one of the allowed words; or a missing key."""


class ScenarioBudgetError(ScenarioValueError, SchemaBudgetError, InvalidBudgetError):
    """A time or iteration budget that is not a finite number > 0."""


class ScenarioKindError(RegistryError):
    """A kind registered twice, or a module of kinds that declares none."""


class ScenarioKindImportError(ScenarioKindError, RegistryImportError, MissingDependencyError):
    """A module of scenario kinds that cannot be imported."""


@dataclass
class ScenarioReport:
    """A runner's ``figures`` (JSON-friendly, judged entries with their ``expectations``), the ``verdict``
    over them (PASSED, FAILED or informational) and the ``animation`` ``wbik view`` plays (or None)."""

    name: str
    kind: str
    robot: str
    figures: dict = field(default_factory=dict)
    verdict: str = "informational"
    animation: Animation | None = None

    def __post_init__(self) -> None:
        if self.verdict not in VERDICTS:
            raise ValueError(f"a scenario verdict is one of {VERDICTS}, got {self.verdict!r}")

    @property
    def passed(self) -> bool:
        """The scenario did not fail (PASSED or informational)."""
        return self.verdict != "FAILED"

    def add_entry(self, key: str, entry: dict) -> dict:
        """Append a judged entry to ``figures[key]``; the verdict is then the one over that list."""
        entries = self.figures.setdefault(key, [])
        entries.append(entry)
        self.verdict = verdict(check for item in entries for check in item["expectations"])
        return entry

    def as_dict(self) -> dict:
        """The JSON report: name, kind, robot, the figures, passed, verdict (and ``animation_frames``)."""
        report = {"name": self.name, "kind": self.kind, "robot": self.robot, **self.figures,
                  "passed": self.passed, "verdict": self.verdict}
        if self.animation is not None:
            report["animation_frames"] = self.animation.frames
        return report

    @classmethod
    def from_dict(cls, report: dict, animation: Animation | None = None) -> ScenarioReport:
        """From a JSON report (for runners that build the dict); ``passed`` false is FAILED."""
        figures = {k: v for k, v in report.items()
                   if k not in ("name", "kind", "robot", "passed", "verdict", "animation_frames")}
        outcome = "FAILED" if not report.get("passed", True) else report.get("verdict", "informational")
        return cls(str(report.get("name", "")), str(report.get("kind", "")), str(report.get("robot", "")),
                   figures, outcome, animation)


def report_verdict(report: dict | ScenarioReport) -> str:
    """PASSED / FAILED / informational of a report (a JSON report's ``passed`` false is FAILED)."""
    if isinstance(report, ScenarioReport):
        return report.verdict
    return report.get("verdict", "PASSED") if report.get("passed") else "FAILED"


def json_default(value):
    """``json.dumps(..., default=json_default)``: NumPy arrays and scalars as plain values."""
    if isinstance(value, np.ndarray | np.generic):
        return json_plain(value)
    raise TypeError(f"not JSON serialisable: {type(value)}")


Progress = Callable[[ScenarioReport], None] | None
Runner = Callable[[dict, Progress], ScenarioReport]


def robot_of(spec: dict) -> Robot:
    """The robot a checked spec names, built with its ``robot_params``."""
    return load(spec["robot"], **spec["robot_params"])


def start_of(spec: dict, owner) -> np.ndarray:
    """A checked spec's ``start``: "nominal" (of ``owner``, a robot or a chain) or as many numbers."""
    start, nominal = spec["start"], owner.nominal
    if start == "nominal":
        return nominal.copy()
    return finite_vector(start, nominal.size, "start", ScenarioError)


class KindRun:
    """A runner's work in progress: the spec's robot, the report whose ``figures[key]`` it fills and the
    entries' animations, played ``pause`` s apart."""

    def __init__(self, spec: dict, key: str, on_progress: Progress = None, pause: float = 0.5,
                 figures: dict | None = None):
        self.spec, self.key, self.on_progress, self.pause = spec, key, on_progress, pause
        self.robot = robot_of(spec)
        self.report = ScenarioReport(spec["name"], spec["kind"], self.robot.name,
                                     {**(figures or {}), key: []})
        self.animations: list[Animation] = []

    def add(self, entry: dict, animation: Animation | None = None) -> dict:
        """Append a judged entry (and its animation), then report progress; the entry."""
        self.report.add_entry(self.key, entry)
        if animation is not None:
            self.animations.append(animation)
        if self.on_progress is not None:
            self.on_progress(self.report)
        return entry

    def finished(self) -> ScenarioReport:
        """The report, with the entries' animations one after the other (None without any)."""
        self.report.animation = reduce(lambda first, then: first.then(then, pause=self.pause),
                                       self.animations) if self.animations else None
        return self.report


def report_header(report: dict) -> str:
    """The first line of a printed report: ``name (kind, robot): VERDICT``."""
    return (f"{report.get('name', '')} ({report.get('kind')}, {report.get('robot', '')}): "
            f"{report_verdict(report)}")


def format_entries(report: dict, key: str, describe: Callable[[dict], str]) -> str:
    """The header, then per entry of ``report[key]``: ``[ok|FAIL|info] NAME: describe(entry)``, its checks."""
    lines = [report_header(report)]
    for entry in report.get(key, []):
        status = "info" if entry.get("verdict") == "informational" else ("ok" if entry["passed"] else "FAIL")
        lines.append(f"  [{status}] {entry['name']}: {describe(entry)}")
        lines.extend(format_checks(entry.get("expectations", [])))
    return "\n".join(lines)


@dataclass(frozen=True)
class ScenarioKind:
    """A scenario kind: ``name`` (the files' ``kind:``), its runner, ``schema()`` building its Map (once),
    ``format(JSON report) -> str`` for ``wbik run`` (default: the header line) and a one-line ``summary``."""

    name: str
    run: Runner
    schema: Callable[[], Map]
    format: Callable[[dict], str] | None = None
    summary: str = ""

    @cached_property
    def schema_map(self) -> Map:
        return self.schema()

    def takes(self, key: str) -> bool:
        """Whether the kind's files take the top-level ``key``."""
        rule = self.schema_map.keys.get(key)
        return rule is not None and not isinstance(rule.node, Refused)

    def format_report(self, report: dict) -> str:
        return self.format(report) if self.format is not None else report_header(report)


def _unknown_kind(name: str, known: list[str]) -> WbikError:
    return ScenarioValueError(f"unknown scenario kind {name!r}{did_you_mean(name, known)}; known kinds: "
                              f"{', '.join(known)}")


KIND_REGISTRY: DeclaredRegistry[ScenarioKind] = DeclaredRegistry(
    "scenario kind", "SCENARIO_KINDS", KIND_MODULES, "wbik.scenarios.kinds.KIND_MODULES", ScenarioKind,
    unknown=_unknown_kind, error=ScenarioKindError, import_error=ScenarioKindImportError,
    plugins="wbik.scenario_kinds",
)


register_kind = KIND_REGISTRY.register  # a kind from user code (``replace=True`` to replace one)


def kind_names() -> list[str]:
    return sorted(KIND_REGISTRY.entries())
