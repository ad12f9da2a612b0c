"""Scenario kind ``ur5_riveting`` for ``wbik run tasks/ur5_riveting.yaml`` (see wbik.riveting.report).

The report (JSON with ``--output``) holds every planner's summary, Table 5 score and cycles;
``report_folder`` in the task file also writes report.json and report.md there. The task file's
keys, types and defaults are declared in :mod:`wbik.scenario_schema`; the runner gets the checked
spec (registered by name in :data:`wbik.scenarios.KINDS`).

Besides the report the runner returns a light :class:`wbik.viz.animation.Animation` (what
``wbik view`` plays; the three 300 s runs at this rate would add some 9,000 samples, ~12 MB): the
first planner's first ``ANIMATION_SECONDS`` (going home and the first cycle, which takes 33 s with
the thesis timing) sampled every ``ANIMATION_SAMPLE_S``, the tool tip traced.
"""

from __future__ import annotations

import numpy as np

from wbik.errors import WbikError
from wbik.riveting.report import format_text, run_task, write_report
from wbik.scenarios import ScenarioError

ANIMATION_SECONDS = 40.0
"""s of the first planner's run that the animation shows."""
ANIMATION_SAMPLE_S = 0.1
"""s between two samples of the animation."""


def run_riveting(spec: dict, on_progress=None) -> tuple[dict, object]:
    """Every planner of a checked spec (defaults filled in by wbik.scenario_schema); the report and
    the animation of the first planner's first cycle."""
    kept = {}
    try:
        report = run_task(spec, on_progress, keep=kept)
    except WbikError:
        raise
    except (ValueError, TypeError) as exc:
        raise ScenarioError(f"ur5_riveting: {exc}") from exc
    if spec["report_folder"]:
        write_report(report, spec["report_folder"])
    if not kept:
        return report, None
    from wbik.models import load

    robot = load(spec["robot"])  # the robot of wbik.riveting.report.Cell, arm chain "arm"
    return report, riveting_animation(robot.chain("arm"), next(iter(kept.values())))


def riveting_animation(chain, result, seconds: float = ANIMATION_SECONDS,
                       sample_s: float = ANIMATION_SAMPLE_S):
    """The first ``seconds`` of a planner's run (a wbik.riveting.cycle.RunResult, whose timeline holds
    the moves with their start times) every ``sample_s``, the chain's tip traced."""
    from wbik.viz.animation import Animation

    timeline = result.timeline
    end = min(seconds, timeline[-1][0] + timeline[-1][1].duration)
    times = np.append(np.arange(0.0, end, sample_s), end)
    times = times[np.r_[True, np.diff(times) > 1e-9]]
    rows, index = [], 0
    for t in times:
        while index + 1 < len(timeline) and timeline[index + 1][0] <= t:
            index += 1
        start, move = timeline[index]
        rows.append(move.evaluate(min(t - start, move.duration))[0])
    return Animation.from_chain(chain.robot, chain, times, np.array(rows), name=f"riveting, {result.planner}")


__all__ = ["format_text", "run_riveting"]
