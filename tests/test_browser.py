"""A real browser opens exported pages: no JavaScript errors, and the robot is actually drawn.

Headless Chromium (Debian packages chromium + chromium-driver, installed by scripts/setup.sh)
renders each page with software WebGL. Screenshots stay in tests/artifacts/ (git-ignored) to look
at. "Drawn" is measured on pixels: the stick model's orange, or the difference between the same
scene with and without the robot.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from wbik.viz import Viewer
from wbik.viz.browser import render
from wbik.viz.geometry import STICK_COLOR

ARTIFACTS = Path(__file__).resolve().parent / "artifacts"


pytestmark = pytest.mark.usefixtures("require_chromium")  # a missing Chromium fails, it does not skip


def pixels(path: Path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB"), dtype=int)


def orange_pixels(image: np.ndarray) -> int:
    """Pixels whose hue is the stick colour's (red well above green well above blue), any shading."""
    red, green, blue = image[..., 0], image[..., 1], image[..., 2]
    return int(np.count_nonzero((red > 90) & (red > 1.4 * green) & (green > 1.5 * blue + 10)))


def render_checked(viewer: Viewer, name: str):
    page = viewer.export_html(ARTIFACTS / f"{name}.html")
    result = render(page, ARTIFACTS / f"{name}.png")
    assert result.ready, f"the scene script did not finish; console: {result.console}"
    assert result.errors == [], f"JavaScript errors in {name}: {result.errors}"
    return pixels(result.screenshot)


def test_stick_robot_is_drawn_without_errors():
    viewer = Viewer("pincher")
    viewer.show([0.3, 0.6, 0.5, -0.4], chain="arm")
    viewer.show_frames("arm")
    image = render_checked(viewer, "pincher")
    assert STICK_COLOR[0] > STICK_COLOR[1] > STICK_COLOR[2]  # what orange_pixels looks for
    count = orange_pixels(image)
    assert count > 1000, f"only {count} robot-coloured pixels: the robot was not drawn"
    viewer.meshcat["wbik/robot"].set_property("visible", False)
    hidden = render_checked(viewer, "pincher_hidden")
    # the orange came from the robot (meshcat's own x axis line is orange too, a few hundred pixels)
    assert count - orange_pixels(hidden) > 800


def test_meshed_robot_with_target_and_animation():
    viewer = Viewer("ur5")
    chain = viewer.robot.chain("arm")
    times = np.linspace(0.0, 1.0, 11)
    qs = chain.nominal + np.outer(times, [0.6, 0.3, -0.4, 0.2, 0.5, 0.0])
    viewer.animate(times, qs, chain="arm", trace_frame="tcp", play=False)
    viewer.show_target(chain.fk(qs[-1]), chain="arm")
    image = render_checked(viewer, "ur5_animation")
    viewer.meshcat["wbik/robot"].set_property("visible", False)
    empty = render_checked(viewer, "ur5_without_robot")
    changed = np.count_nonzero(np.abs(image - empty).sum(axis=2) > 60)
    assert changed > 3000, f"only {changed} pixels change when the robot is hidden: meshes not drawn"


def test_bioloid_com_and_support_polygon_page():
    viewer = Viewer("bioloid")
    viewer.show_com_and_polygon()
    image = render_checked(viewer, "bioloid_support")
    # the robot's light-grey boxes: bright, unsaturated pixels, unlike the blue background
    grey = (image.min(axis=2) > 120) & (image.max(axis=2) - image.min(axis=2) < 25)
    assert np.count_nonzero(grey) > 3000


def test_walk_scenario_page_draws_the_robot():
    """``wbik view tasks/bioloid_walk_turn.yaml --html``: the walk's page loads without errors and
    shows the Bioloid (the screenshot stays in tests/artifacts/bioloid_walk_turn.png)."""
    from wbik.scenarios import load_scenario, scenario_animation
    from wbik.viz.viewer import animation_viewer

    task = Path(__file__).resolve().parents[1] / "tasks" / "bioloid_walk_turn.yaml"
    spec = load_scenario(task)
    spec["export"]["servo_csv"] = str(ARTIFACTS / "bioloid_walk_turn_servos.csv")  # not runs/
    _, animation = scenario_animation(task, spec)
    viewer = animation_viewer(animation)
    assert animation.frames > 100
    image = render_checked(viewer, "bioloid_walk_turn")
    grey = (image.min(axis=2) > 120) & (image.max(axis=2) - image.min(axis=2) < 25)
    viewer.meshcat["wbik/robot"].set_property("visible", False)
    empty = render_checked(viewer, "bioloid_walk_turn_without_robot")
    grey_empty = (empty.min(axis=2) > 120) & (empty.max(axis=2) - empty.min(axis=2) < 25)
    assert np.count_nonzero(grey) - np.count_nonzero(grey_empty) > 3000, "the walking robot was not drawn"


def wood_pixels(image: np.ndarray) -> int:
    """Pixels of the staircase's wood browns (wbik.viz.environment.STAIR_COLORS), any shading: red
    above green above blue, all three well apart (the robot is grey, the sky blue, the grid grey)."""
    red, green, blue = image[..., 0], image[..., 1], image[..., 2]
    return int(np.count_nonzero((red > 70) & (red > 1.15 * green) & (green > 1.2 * blue) & (red - blue > 40)))


def test_stair_walk_page_shows_the_staircase_and_the_floor_under_the_feet():
    """``wbik view tasks/bioloid_stairs.yaml``: the page draws the staircase (not only the robot), the
    floor grid at the soles' height, the camera on the robot (one step up and down, to keep it short)."""
    from wbik.scenarios import load_scenario, scenario_animation
    from wbik.viz.environment import STAIR_COLORS
    from wbik.viz.viewer import animation_viewer

    task = Path(__file__).resolve().parents[1] / "tasks" / "bioloid_stairs.yaml"
    spec = load_scenario(task)
    spec["stairs"].update(steps=1, top_depth=0.2)
    spec.pop("physics")  # the page of the plan; the run in physics is tests/test_bioloid_stairs.py's
    for judged_in_physics in ("physics_fell", "physics_cop_margin_min_m"):
        spec["expect"].pop(judged_in_physics)
    report, animation = scenario_animation(task, spec)
    assert report.verdict == "PASSED" and {box.name for box in animation.environment} == {"stair step 1"}
    viewer = animation_viewer(animation)
    image = render_checked(viewer, "bioloid_stairs_page")
    colour = STAIR_COLORS[0]
    assert wood_pixels(np.array([[[colour >> 16, (colour >> 8) & 255, colour & 255]]])) == 1
    wood = wood_pixels(image)
    assert wood > 5000, f"only {wood} staircase-coloured pixels: the staircase was not drawn"
    # the wood is the staircase's: hidden, it goes
    viewer.meshcat["wbik/environment"].set_property("visible", False)
    assert wood - wood_pixels(render_checked(viewer, "bioloid_stairs_page_without_steps")) > 5000
    # the grid lies under the feet (the soles on the floor at z = 0), scaled to the robot
    import umsgpack

    commands = [umsgpack.unpackb(c) for c in viewer.window.commands()]
    grid = next(c for c in commands if c["path"] == "/Grid")
    matrix = np.array(grid["matrix"]).reshape(4, 4).T  # meshcat sends column-major
    assert matrix[2, 3] == pytest.approx(-1e-4, abs=1e-9) and matrix[0, 0] == pytest.approx(viewer.grid_scale)


def test_simulated_walk_page_draws_the_cop_and_a_push_arrow():
    """A walk with ``physics`` plays as simulated, with its measured CoP beside the planned ZMP; a push record
    is drawn as an arrow ending on the pushed frame while it lasts (one short step, to keep it fast)."""
    from dataclasses import replace

    from wbik.scenarios import run_scenario_report
    from wbik.viz.animation import PushArrow
    from wbik.viz.viewer import animation_viewer

    arms = [f"{s}_{n}" for s in "rl" for n in ("shoulder_pitch", "shoulder_roll", "elbow")]
    spec = {"kind": "walk", "name": "one step", "robot": "bioloid", "trunk": "pelvis", "locked": arms,
            "timing": {"single_support_s": 0.25, "double_support_s": 0.1, "start_s": 0.3, "end_s": 0.3},
            "clearance": 0.015, "margin": 0.004, "preview": {"horizon_s": 1.0, "q": 1.0, "r": 1.0e-5},
            "physics": {"servos": {"kp": 37.05, "damping": 0.243, "torque_limit": 1.5, "armature": 1e-3},
                        "settle_s": 0.2},
            "walks": [{"steps": 1, "length": 0.01}]}
    animation = run_scenario_report(spec, source="one step").animation
    assert animation.name.endswith("(simulated, closed loop)")
    assert not np.isnan(animation.overlays.cop).any() and not np.isnan(animation.overlays.zmp).all()
    planned = animation.robot.frame_placement(animation.configurations[0], "pelvis").translation
    assert 0 < np.linalg.norm(planned - animation.robot.frame_placement(animation.robot.nominal, "pelvis")
                              .translation) < 0.01  # the simulated robot, a tick after the start
    push = PushArrow("pelvis", 0.0, float(animation.times[-1] - animation.times[0]), (0.0, -15.0, 0.0))
    pushed = replace(animation, overlays=replace(animation.overlays, pushes=(push,)))
    viewer = animation_viewer(pushed)
    image = render_checked(viewer, "bioloid_walk_simulated_push")
    viewer.meshcat["wbik/pushes"].set_property("visible", False)
    without = render_checked(viewer, "bioloid_walk_simulated_without_push")
    changed = np.count_nonzero(np.abs(image - without).sum(axis=2) > 60)
    assert changed > 300, f"only {changed} pixels change when the push arrow is hidden: no arrow drawn"
