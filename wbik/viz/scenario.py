"""Playing a scenario file in the viewer (``wbik view TASKFILE``): its report carries the animation."""

from __future__ import annotations

from pathlib import Path

from wbik.errors import UnsupportedError

PHASE_SECONDS = 1.0  # s of playback per wholebody_ik phase
SAMPLES_PER_PHASE = 30


def scenario_animation(path: str | Path, spec: dict | None = None):
    """(report, animation) of the scenario in ``path`` (or of the loaded ``spec`` ``path`` names)."""
    from wbik.scenarios import run_scenario_report

    report = run_scenario_report(Path(path) if spec is None else spec, source=str(path))
    if report.animation is None:
        raise UnsupportedError(f"the {report.kind!r} scenario in {path} produced no configurations to play "
                               f"(verdict {report.verdict})")
    return report, report.animation


def animation_viewer(animation, server: bool = False, style: str = "auto", title: str | None = None):
    """A Viewer playing ``animation`` (with a meshcat server when ``server``)."""
    from wbik.viz.viewer import Viewer

    viewer = Viewer(animation.robot, server=server, style=style,
                    title=title or f"wbik: {animation.name or animation.robot.name}")
    viewer.play_animation(animation)
    return viewer


def scenario_viewer(path: str | Path, server: bool = False, style: str = "auto"):
    """A Viewer playing the scenario in ``path`` (with a meshcat server when ``server``)."""
    _, animation = scenario_animation(path)
    return animation_viewer(animation, server=server, style=style, title=f"wbik: {Path(path).stem}")
