"""Playing a scenario file (tasks/*.yaml) in the viewer: ``wbik view TASKFILE``.

Scenario files belong to ``wbik.scenarios`` (YAML with a ``kind``; ``run_scenario`` returns a
report). A report whose ``phases`` carry the configuration each phase reached (``q``, full) plays
as an animation: from the start configuration through every phase, ``PHASE_SECONDS`` each,
interpolated on the configuration manifold (``pinocchio.interpolate``, so a floating base turns
properly). The first frame a phase task moves is traced; the last phase's CoM and support polygon
are drawn when the robot has feet. A report with a ``trajectory`` (``times`` and full ``q`` rows)
plays as it is.
"""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np
import pinocchio as pin

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


def phase_keyframes(robot, start: np.ndarray, configurations: list[np.ndarray]
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and full configurations from ``start`` through each phase's configuration."""
    times, rows = [0.0], [start]
    previous = start
    for index, q in enumerate(configurations):
        for step in range(1, SAMPLES_PER_PHASE + 1):
            alpha = step / SAMPLES_PER_PHASE
            rows.append(pin.interpolate(robot.model, previous, q, alpha))
            times.append((index + alpha) * PHASE_SECONDS)
        previous = q
    return np.array(times), np.array(rows)


def scenario_viewer(path: str | Path, server: bool = False, style: str = "auto"):
    """A Viewer playing the scenario in ``path`` (with a meshcat server when ``server``)."""
    from wbik.viz.viewer import Viewer

    path = Path(path)
    if not path.is_file():
        raise RobotDescriptionError(f"scenario file {str(path)!r} does not exist")
    scenarios = load_scenario_module()
    spec = scenarios.load_scenario(path)
    report = scenarios.run_scenario(spec)
    robot_name = report.get("robot") or spec.get("robot")
    if not robot_name:
        raise UnsupportedError(f"the scenario in {path} names no robot, so there is nothing to show")
    viewer = Viewer(robot_name, server=server, style=style, title=f"wbik: {path.stem}")
    robot = viewer.robot
    trajectory = report.get("trajectory")
    if trajectory is not None:
        viewer.animate(trajectory["times"], trajectory["q"], trace_frame=moved_frame(spec))
        return viewer
    phases = [phase for phase in report.get("phases", []) if phase.get("q") is not None]
    if not phases:
        raise UnsupportedError(f"the {report.get('kind')!r} scenario in {path} produced no configurations "
                               "to play")
    start = robot.nominal.copy() if spec.get("start", "nominal") == "nominal" else np.asarray(
        spec["start"], dtype=float)
    times, rows = phase_keyframes(robot, start, [np.asarray(p["q"], dtype=float) for p in phases])
    viewer.animate(times, rows, trace_frame=moved_frame(spec), repetitions=1)
    last = phases[-1]
    if robot.info.get("sole_corners") and last.get("support"):
        viewer.show_com_and_polygon(rows[-1], feet=last["support"])
        viewer.show(rows[0])
    return viewer
