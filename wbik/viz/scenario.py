"""Playing a scenario file (tasks/*.yaml) in the viewer: ``wbik view TASKFILE``.

Scenario files belong to ``wbik.scenarios`` (YAML with a ``kind``). Every runner returns, besides
its report, a :class:`wbik.viz.animation.Animation` (the robot, sample times, full configurations,
overlays); ``run_scenario_animated`` hands both over and the viewer plays the animation, one path
for every kind: its traced frame, the CoM and the support polygon of the soles on the ground at
each sample, the contact frames.

``wholebody_ik`` runs play from the start configuration through every phase, ``PHASE_SECONDS``
each, interpolated on the configuration manifold (``pinocchio.interpolate``, so a floating base
turns properly); the first frame a phase task moves is traced. The other kinds give their own
samples and times (see each runner).
"""

from __future__ import annotations

import importlib
from pathlib import Path

from wbik.errors import RobotDescriptionError, UnsupportedError

PHASE_SECONDS = 1.0
SAMPLES_PER_PHASE = 30


def load_scenario_module():
    """``wbik.scenarios``, or UnsupportedError saying what to do while it does not exist."""
    try:
        return importlib.import_module("wbik.scenarios")
    except ModuleNotFoundError as exc:
        if exc.name != "wbik.scenarios":
            raise
        raise UnsupportedError(
            "this wbik has no scenario support (wbik/scenarios.py is missing), so task files cannot be "
            "played; view a robot instead, e.g. 'wbik view bioloid --com'") from None


def moved_frame(spec: dict) -> str | None:
    """The first frame a phase task moves (frame/position tasks that do not keep their pose)."""
    for phase in spec.get("phases", []):
        contacts = set(phase.get("contacts", []))
        for task in phase.get("tasks", []):
            frame = task.get("frame")
            if task.get("type") in ("frame", "position") and frame and frame not in contacts \
                    and not task.get("keep"):
                return frame
    return None


def scenario_animation(path: str | Path, spec: dict | None = None):
    """Run the scenario in ``path`` (or the already loaded ``spec``); (report, Animation)."""
    path = Path(path)
    scenarios = load_scenario_module()
    if spec is None:
        if not path.is_file():
            raise RobotDescriptionError(f"scenario file {str(path)!r} does not exist")
        spec = scenarios.load_scenario(path)
    report, animation = scenarios.run_scenario_animated(spec, source=str(path))
    if animation is None:
        raise UnsupportedError(f"the {report.get('kind')!r} scenario in {path} produced no configurations "
                               "to play (its runner returns a report only)")
    return report, animation


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
