"""Scenario kind ``ur5_riveting`` for ``wbik run tasks/ur5_riveting.yaml`` (see wbik.riveting.report).

The report (JSON with ``--output``) holds every planner's summary, Table 5 score and cycles;
``report_folder`` in the task file also writes report.json and report.md there. The task file's
keys, types and defaults are declared in :mod:`wbik.scenario_schema`; the runner gets the checked
spec (registered by name in :data:`wbik.scenarios.KINDS`).
"""

from __future__ import annotations

from wbik.errors import WbikError
from wbik.riveting.report import format_text, run_task, write_report
from wbik.scenarios import ScenarioError


def run_riveting(spec: dict, on_progress=None) -> dict:
    """Every planner of a checked spec (defaults filled in by wbik.scenario_schema)."""
    try:
        report = run_task(spec, on_progress)
    except WbikError:
        raise
    except (ValueError, TypeError) as exc:
        raise ScenarioError(f"ur5_riveting: {exc}") from exc
    if spec["report_folder"]:
        write_report(report, spec["report_folder"])
    return report


__all__ = ["format_text", "run_riveting"]
