"""Helpers of the tests that watch a task file: its spec with outputs sent to a temporary folder, its
animation exported as an HTML page, and the checks of that page (tests/test_view_every_task.py,
tests/test_bioloid_stairs.py)."""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import umsgpack

from wbik.scenarios import load_scenario, scenario_animation
from wbik.viz.viewer import animation_viewer

TASKS = Path(__file__).resolve().parents[1] / "tasks"
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
            assert keys[-1]["time"] / clip["fps"] == pytest.approx(animation.times[-1] - animation.times[0])
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
