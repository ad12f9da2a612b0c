"""Scenario files (YAML, JSON or TOML) run with ``wbik run FILE``, checked against their kind's schema."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import yaml

from wbik.errors import UnsupportedError
from wbik.files import atomic_write_text
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


def _read(path: Path):
    """The parsed content of a scenario file, or a ScenarioFileError saying what is wrong with it."""
    if path.is_dir():
        raise ScenarioFileError(f"scenario file {str(path)!r} is a directory; pass a YAML/JSON/TOML "
                                "scenario file, e.g. tasks/bioloid_balance.yaml")
    if not path.is_file():
        raise ScenarioFileError(f"scenario file {str(path)!r} does not exist")
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioFileError(f"{path}: not UTF-8 text (byte {exc.start}: {exc.reason}); a scenario is "
                                "a YAML/JSON/TOML text file") from None
    except OSError as exc:
        raise ScenarioFileError(f"cannot read scenario file {str(path)!r}: {exc.strerror}") from None
    if not text.strip():
        raise ScenarioFileError(f"{path}: the file is empty; a scenario is a mapping with a 'kind' "
                                f"(one of {', '.join(kind_names())})")
    suffix = path.suffix.lower()
    try:
        return {".json": json.loads, ".toml": tomllib.loads}.get(suffix, yaml.safe_load)(text)
    except Exception as exc:  # yaml, json and tomllib raise several types
        raise ScenarioFileError(f"{path}: not valid {suffix.lstrip('.').upper() or 'YAML'}: {exc}") from None


def load_scenario(path: str | Path) -> dict:
    """A scenario file's mapping (``name`` defaults to the file's stem), checked against its kind's schema."""
    path = Path(path)
    spec = _read(path)
    if spec is None:
        raise ScenarioFileError(f"{path}: the file is empty (only comments or null); a scenario is "
                                f"a mapping with a 'kind' (one of {', '.join(kind_names())})")
    from wbik.scenario_schema import validate  # (it imports this package's kinds)

    if isinstance(spec, dict):
        spec.setdefault("name", path.stem)
    validate(spec, str(path))  # (a ScenarioFileError for anything but a mapping)
    return spec


def run_scenario_report(scenario: str | Path | dict, output: str | Path | None = None,
                        source: str | None = None) -> ScenarioReport:
    """The :class:`ScenarioReport` of a scenario (file or dict); ``output``: the JSON report, each phase."""
    from wbik.scenario_schema import validate

    spec = scenario if isinstance(scenario, dict) else load_scenario(scenario)
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
