"""Every scenario file in tasks/ can be watched: its runner's report carries an animation, and the exported
HTML page holds the robot's meshes and one animation key per sample for every robot geometry.

Outputs the runners would write (servo tables, trajectories, riveting reports) are sent to tmp_path.
The riveting file runs its three planners for 300 s of simulated time each (~2 minutes): it is
``heavy``; the default run plays its documented shorter variant (``max_cycles: 1``, the first
planner only, no expectations: the animation shows the first planner's first cycle either way).
"""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import umsgpack

from wbik.scenarios import load_scenario
from wbik.viz.scenario import animation_viewer
from wbik.viz.scenario import scenario_animation

TASKS = Path(__file__).resolve().parents[1] / "tasks"
TASK_FILES = sorted(TASKS.glob("*.yaml"))
RIVETING = TASKS / "ur5_riveting.yaml"
MAX_HTML_BYTES = 20e6
ROBOT_PREFIX = "/meshcat/wbik/robot/"


def page_commands(html: str) -> list[dict]:
    """The meshcat commands the exported page replays (base64 msgpack, see wbik.viz.scene)."""
    encoded = re.search(r"var commands = (\[.*?\]);", html, re.S).group(1)
    return [umsgpack.unpackb(base64.b64decode(item)) for item in json.loads(encoded)]


def quiet_spec(path: Path, tmp_path: Path) -> dict:
    """The task file's spec with every output it would write redirected into tmp_path."""
    spec = load_scenario(path)
    export = spec.get("export") or {}
    for key in ("servo_csv", "csv", "json"):
        if key in export:
            export[key] = str(tmp_path / f"{path.stem}_{key}.out")
    if "report_folder" in spec:
        spec["report_folder"] = str(tmp_path / "report")
    return spec


def watch(path: Path, spec: dict, tmp_path: Path):
    """Run, play and export one scenario; (report, animation, viewer, page commands, page size)."""
    report, animation = scenario_animation(path, spec)
    viewer = animation_viewer(animation)
    page = viewer.export_html(tmp_path / f"{path.stem}.html")
    html = page.read_text(encoding="utf-8")
    return report, animation, viewer, page_commands(html), len(html.encode("utf-8"))


def check_page(animation, viewer, commands: list[dict], size: int) -> None:
    """Meshes of every robot geometry, one key per sample for each, timed like the animation, and
    the robot at the first and last configuration (geometry placements by Pinocchio's FK)."""
    assert size < MAX_HTML_BYTES, f"page of {size / 1e6:.1f} MB"
    objects = {c["path"] for c in commands
               if c["type"] == "set_object" and c["path"].startswith(ROBOT_PREFIX)}
    geometry = viewer.geometry
    assert len(objects) == len(geometry.geometryObjects) > 0
    animations = [c for c in commands if c["type"] == "set_animation"]
    assert len(animations) == 1
    clips = {entry["path"]: entry["clip"] for entry in animations[0]["animations"]}
    samples = max(animation.frames, 2)  # a still picture is played as two identical keys
    model, data = animation.robot.model, animation.robot.model.createData()
    geometry_data = geometry.createData()
    first, last = animation.configurations[0], animation.configurations[-1]
    for index, geometry_object in enumerate(geometry.geometryObjects):
        node = viewer._pinocchio.getViewerNodeName(geometry_object, pin.GeometryType.VISUAL)
        clip = clips["/meshcat/" + node]
        keys = next(track for track in clip["tracks"] if track["name"] == ".position")["keys"]
        assert len(keys) == samples
        if animation.frames > 1:
            assert keys[-1]["time"] / clip["fps"] == pytest.approx(animation.duration)
        for key, q in ((keys[0], first), (keys[-1], last)):
            pin.forwardKinematics(model, data, q)
            pin.updateGeometryPlacements(model, data, geometry, geometry_data)
            np.testing.assert_allclose(key["value"], geometry_data.oMg[index].translation, atol=1e-6)


def check_support(animation, commands: list[dict]) -> None:
    """A robot with soles draws the CoM and one support polygon per stretch on the same soles."""
    if animation.overlays.support is None or not animation.robot.soles:
        return
    paths = {c["path"] for c in commands if c["type"] == "set_object"}
    assert "/meshcat/wbik/support/com" in paths
    if any(animation.overlays.support):
        assert "/meshcat/wbik/support/polygon_0" in paths


@pytest.mark.parametrize("path", [p for p in TASK_FILES if p != RIVETING], ids=lambda p: p.stem)
def test_every_task_file_is_watchable(path, tmp_path):
    spec = quiet_spec(path, tmp_path)
    report, animation, viewer, commands, size = watch(path, spec, tmp_path)
    assert report.animation is animation and report.as_dict()["animation_frames"] == animation.frames
    if spec["kind"] == "bioloid_stance_sensors":
        assert animation.frames == 1
    else:
        assert animation.frames >= 20 and animation.duration > 0
    check_page(animation, viewer, commands, size)
    check_support(animation, commands)
    if spec["kind"] in ("bioloid_walk", "bioloid_turn") or spec.get("generators") == ["wholebody"]:
        # whole-body samples: every sole the animation calls down is on the floor (z = 0)
        robot = animation.robot
        heights = [abs(robot.frame_placement(q, sole).translation[2])
                   for q, feet in zip(animation.configurations, animation.overlays.support, strict=True)
                   for sole in feet]
        assert len(heights) >= animation.frames and max(heights) < 1e-6


def test_riveting_short_variant_is_watchable(tmp_path):
    spec = quiet_spec(RIVETING, tmp_path)
    spec.update(max_cycles=1, planners=spec["planners"][:1], expect=None)
    report, animation, viewer, commands, size = watch(RIVETING, spec, tmp_path)
    assert animation.name == f"riveting, {spec['planners'][0]['name']}"
    assert 100 < animation.frames <= 401
    check_page(animation, viewer, commands, size)


@pytest.mark.heavy
def test_riveting_task_file_is_watchable(tmp_path):
    spec = quiet_spec(RIVETING, tmp_path)
    report, animation, viewer, commands, size = watch(RIVETING, spec, tmp_path)
    assert report.passed  # the verdict of the task file is unchanged by the animation
    assert 100 < animation.frames <= 401
    check_page(animation, viewer, commands, size)
