"""Scenario files (YAML, JSON or TOML) run with ``wbik run FILE``, checked against their kind's schema."""

from __future__ import annotations

import json
from pathlib import Path

from wbik.errors import UnsupportedError
from wbik.files import atomic_write_text, read_data_file
from wbik.scenarios.kinds import (
    KIND_REGISTRY,
    ScenarioError,
    ScenarioFileError,
    ScenarioKind,
    ScenarioReport,
    json_default,
    kind_names,
    register_kind,
    report_verdict,
)

__all__ = ["KIND_REGISTRY", "ScenarioError", "ScenarioKind", "ScenarioReport", "format_report",
           "load_scenario", "register_kind", "report_verdict", "run_scenario", "run_scenario_report",
           "scenario_animation"]


def _spec(path: Path):
    """A scenario file's content (``name`` defaults to the file's stem), not yet checked."""
    spec = read_data_file(path, ScenarioFileError, "scenario",
                          f"a scenario is a mapping with a 'kind' (one of {', '.join(kind_names())})")
    if isinstance(spec, dict):
        spec.setdefault("name", path.stem)
    return spec


def load_scenario(path: str | Path) -> dict:
    """A scenario file's mapping (``name`` defaults to the file's stem), checked against its kind's schema."""
    from wbik.scenarios.schema import validate  # (it imports this package's kinds)

    spec = _spec(Path(path))
    validate(spec, str(path))  # (a ScenarioFileError for anything but a mapping)
    return spec


def run_scenario_report(scenario: str | Path | dict, output: str | Path | None = None,
                        source: str | None = None) -> ScenarioReport:
    """The :class:`ScenarioReport` of a scenario (file or dict); ``output``: the JSON report, each phase."""
    from wbik.scenarios.schema import validate

    spec = scenario if isinstance(scenario, dict) else _spec(Path(scenario))
    named = str(scenario) if spec is not scenario else f"scenario {spec.get('name') or spec.get('kind')!r}"
    checked = validate(spec, source or named)
    kind = KIND_REGISTRY.get(checked["kind"])

    def write(report: ScenarioReport) -> None:
        if output is not None:
            atomic_write_text(Path(output), json.dumps(report.as_dict(), indent=2, default=json_default))

    report = kind.run(checked, write)
    if not isinstance(report, ScenarioReport):
        raise TypeError(f"the runner of scenario kind {kind.name!r} returned a {type(report).__name__}, "
                        "not a ScenarioReport")
    write(report)
    return report


def run_scenario(scenario: str | Path | dict, output: str | Path | None = None,
                 source: str | None = None) -> dict:
    """:func:`run_scenario_report`'s JSON report."""
    return run_scenario_report(scenario, output, source).as_dict()


def scenario_animation(path: str | Path, spec: dict | None = None):
    """(report, animation) of the scenario in ``path`` (or of the loaded ``spec`` ``path`` names)."""
    report = run_scenario_report(Path(path) if spec is None else spec, source=str(path))
    if report.animation is None:
        raise UnsupportedError(f"the {report.kind!r} scenario in {path} produced no configurations to play "
                               f"(verdict {report.verdict})")
    return report, report.animation


def format_report(report: ScenarioReport | dict) -> str:
    """The report as ``wbik run`` prints it (its kind's formatter; a dict is a JSON report)."""
    data = report.as_dict() if isinstance(report, ScenarioReport) else report
    return KIND_REGISTRY.get(data["kind"]).format_report(data)
