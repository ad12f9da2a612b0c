"""Scenario kind ``ur5_riveting`` for ``wbik run tasks/ur5_riveting.yaml`` (see wbik.riveting.report).

The report (JSON with ``--output``) holds every planner's summary, Table 5 score and cycles;
``report_folder`` in the task file also writes report.json and report.md there.
"""

from __future__ import annotations

from wbik.errors import WbikError
from wbik.riveting.report import format_text, run_task, write_report
from wbik.scenarios import ScenarioError, register_runner


def run_riveting(spec: dict, on_progress=None) -> dict:
    try:
        report = run_task(spec, on_progress)
    except WbikError:
        raise
    except (ValueError, TypeError) as exc:
        raise ScenarioError(f"ur5_riveting: {exc}") from exc
    if spec.get("report_folder"):
        write_report(report, spec["report_folder"])
    return report


register_runner("ur5_riveting", run_riveting, format_text)
