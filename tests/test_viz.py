"""Visualisation without a browser: the recorded meshcat scene, exported HTML, markers, CLI.

Positions are checked against hand formulas (arm3r's DH FK from the robot notes) or against
numbers derived by hand from the robot's declared sole rectangles, not against the viewer's code.
"""

from __future__ import annotations

import base64
import json
import math
import re
import subprocess
import sys
import urllib.request

import meshcat.geometry as mg
import numpy as np
import pinocchio as pin
import pytest
import umsgpack

import wbik
from wbik.errors import InvalidConfigurationError, MissingDependencyError, UnknownRobotError, UnsupportedError
from wbik.viz import SceneRecorder, Viewer
from wbik.viz.geometry import stick_segments

L1, L2, L3 = 3.0, 2.0, 2.0  # arm3r's default lengths (arm3r.md worked example)


def arm3r_joint3_origin(q):
    """End of link 2 for arm3r.md's DH table: (l2 c1 c2, l2 s1 c2, l1 + l2 s2)."""
    c1, s1, c2, s2 = math.cos(q[0]), math.sin(q[0]), math.cos(q[1]), math.sin(q[1])
    return np.array([L2 * c1 * c2, L2 * s1 * c2, L1 + L2 * s2])


def arm3r_tip(q):
    """arm3r.md's end-point formula."""
    c1, s1 = math.cos(q[0]), math.sin(q[0])
    c2, s2 = math.cos(q[1]), math.sin(q[1])
    c3, s3 = math.cos(q[2]), math.sin(q[2])
    return np.array([L3 * c1 * c2 * c3 - L3 * c1 * s2 * s3 + L2 * c1 * c2,
                     L3 * s1 * c2 * c3 - L3 * s1 * s2 * s3 + L2 * s1 * c2,
                     L1 + L2 * s2 + L3 * c2 * s3 + L3 * s2 * c3])


def recorded(viewer: Viewer, path: str, what: str = "transform") -> dict:
    node = viewer.window.node(f"meshcat/{path}")
    packed = getattr(node, what)
    assert packed is not None, f"nothing recorded at {path} ({what})"
    return umsgpack.unpackb(packed)


def recorded_matrix(viewer: Viewer, path: str) -> np.ndarray:
    return np.array(recorded(viewer, path)["matrix"]).reshape(4, 4).T  # meshcat stores column-major


def page_commands(html: str) -> list[dict]:
    encoded = re.search(r"var commands = (\[.*?\]);", html, re.S).group(1)
    return [umsgpack.unpackb(base64.b64decode(item)) for item in json.loads(encoded)]


# -- the in-process scene -------------------------------------------------------------------------
def test_recorder_keeps_latest_state_like_the_meshcat_server():
    import meshcat

    recorder = SceneRecorder()
    vis = meshcat.Visualizer(window=recorder)
    vis["a/b"].set_object(mg.Box([1, 1, 1]))
    vis["a/b"].set_property("visible", False)
    vis["a/b"].set_transform(np.eye(4))
    vis["a/b"].set_object(mg.Sphere(0.5))  # a new object drops the old properties
    vis["a/c"].set_object(mg.Sphere(0.1))
    vis["a/c"].delete()
    kinds = [umsgpack.unpackb(c)["type"] for c in recorder.commands()]
    assert kinds == ["set_object", "set_transform"]
    obj = umsgpack.unpackb(recorder.commands()[0])
    assert obj["path"] == "/meshcat/a/b"
    assert obj["object"]["geometries"][0]["type"] == "SphereGeometry"
    vis.delete()
    assert recorder.commands() == []


def test_exported_page_is_self_contained(tmp_path):
    viewer = Viewer("pincher")
    page = viewer.export_html(tmp_path / "sub" / "pincher.html")
    text = page.read_text()
    from wbik.viz.scene import viewer_javascript

    skeleton = text.replace(viewer_javascript().replace("</script", "<\\/script"), "")
    assert len(skeleton) < len(text) - 500_000  # meshcat's viewer is inlined
    assert "<script src" not in skeleton and "<link" not in skeleton and "fetch(" not in skeleton
    assert not re.search(r"https?://(?!www\.w3\.org)", text), "the page must not load anything from the web"
    assert "MeshCat.Viewer" in text
    commands = page_commands(text)
    objects = {c["path"] for c in commands if c["type"] == "set_object"}
    for geometry_object in viewer.geometry.geometryObjects:
        assert f"/meshcat/wbik/robot/visuals/{geometry_object.name}" in objects
    assert '<iframe srcdoc="' in viewer._repr_html_()


def test_robots_without_visuals_are_drawn_as_sticks():
    arm = wbik.load("arm3r")
    viewer = Viewer(arm)
    assert viewer.style == "stick"
    lengths = sorted(float(np.linalg.norm(end - start)) for _, _, start, end in stick_segments(arm))
    assert sum(lengths) == pytest.approx(L1 + L2 + L3)  # the sticks follow the arm's links
    assert lengths[-1] == pytest.approx(L1)
    for name in ("pincher", "golem3"):
        assert Viewer(name).geometry.ngeoms > 0
    assert Viewer("ur5").style == "visual"
    assert Viewer("ur5", style="stick").style == "stick"


def test_show_places_the_bodies_at_the_hand_computed_pose():
    viewer = Viewer("arm3r")
    q = np.array([0.3, -0.4, 1.1])
    full = viewer.show(q, chain="arm")
    np.testing.assert_allclose(full, q)
    joint3 = recorded_matrix(viewer, "wbik/robot/visuals/joint_joint3")
    np.testing.assert_allclose(joint3[:3, 3], arm3r_joint3_origin(q), atol=1e-12)
    # the last stick (joint3 -> tip) is centred half-way between joint 3 and the end point
    tip_stick = recorded_matrix(viewer, "wbik/robot/visuals/link_tip_fixed")
    np.testing.assert_allclose(tip_stick[:3, 3], 0.5 * (arm3r_joint3_origin(q) + arm3r_tip(q)), atol=1e-12)


def test_show_rejects_bad_configurations():
    viewer = Viewer("golem3")
    with pytest.raises(InvalidConfigurationError, match="chain=NAME"):
        viewer.show([0.1, 0.2])
    with pytest.raises(InvalidConfigurationError, match="joints"):
        viewer.show([0.1, 0.2], chain="right_arm")
    with pytest.raises(UnknownRobotError, match="known robots"):
        Viewer("no_such_robot")


def test_target_in_a_chain_base_frame_is_placed_in_the_world():
    viewer = Viewer("golem3")
    lift = 0.3  # mb raises torso_link along z; torso_link = base_link at mb = 0 (naming contract)
    q = viewer.robot.nominal.copy()
    q[viewer.robot.model.joints[viewer.robot.model.getJointId("mb")].idx_q] = lift
    viewer.show(q)
    rotation = pin.rpy.rpyToMatrix(0.2, -0.1, 0.4)
    world = viewer.show_target(pin.SE3(rotation, np.array([0.4, -0.3, 1.0])), chain="right_arm")
    np.testing.assert_allclose(world.translation, [0.4, -0.3, 1.0 + lift], atol=1e-12)
    np.testing.assert_allclose(recorded_matrix(viewer, "wbik/target/point")[:3, 3], [0.4, -0.3, 1.0 + lift])
    np.testing.assert_allclose(recorded_matrix(viewer, "wbik/target/axes")[:3, :3], rotation, atol=1e-12)
    viewer.show_target([0.1, 0.2, 0.3])  # position only: no axes
    assert "axes" not in viewer.window.node("meshcat/wbik/target").children


def test_ik_result_shows_target_and_reached_pose():
    robot = wbik.load("arm3r")
    chain = robot.chain("arm")
    viewer = Viewer(robot)
    q = np.array([0.5, 0.2, -0.7])
    result = wbik.solver("dls", robot, chain="arm").solve(arm3r_tip(q), q0=q + 0.05)
    assert result.success
    viewer.show_ik_result(result, arm3r_tip(q), chain)
    np.testing.assert_allclose(recorded_matrix(viewer, "wbik/reached/point")[:3, 3], arm3r_tip(q), atol=1e-5)
    np.testing.assert_allclose(recorded_matrix(viewer, "wbik/target/point")[:3, 3], arm3r_tip(q), atol=1e-12)


def test_frames_of_a_chain():
    viewer = Viewer("arm3r")
    q = np.array([0.1, 0.7, -0.2])
    viewer.show(q)
    names = viewer.show_frames("arm")
    assert names == ["base_link", "joint1", "joint2", "joint3", "tip"]
    np.testing.assert_allclose(recorded_matrix(viewer, "wbik/frames/tip")[:3, 3], arm3r_tip(q), atol=1e-12)
    np.testing.assert_allclose(recorded_matrix(viewer, "wbik/frames/joint3")[:3, 3], arm3r_joint3_origin(q),
                               atol=1e-12)


def test_bioloid_com_and_support_polygon():
    viewer = Viewer("bioloid")
    robot = viewer.robot
    # by hand: each sole rectangle's corners moved to its sole frame at the nominal stance
    corners = {name: np.asarray(c) for name, c in robot.soles.items()}
    sole_xy = {name: robot.frame_placement(robot.nominal, name).translation[:2] for name in corners}
    both = np.vstack([corners[n][:, :2] + sole_xy[n] for n in corners])
    support = viewer.show_com_and_polygon()
    assert support.polygon.shape == (4, 2)  # two side-by-side rectangles make one rectangle
    np.testing.assert_allclose(support.polygon.min(axis=0), both.min(axis=0), atol=1e-12)
    np.testing.assert_allclose(support.polygon.max(axis=0), both.max(axis=0), atol=1e-12)
    com = robot.center_of_mass(robot.nominal)
    expected_margin = min(com[0] - both[:, 0].min(), both[:, 0].max() - com[0],
                          com[1] - both[:, 1].min(), both[:, 1].max() - com[1])
    assert support.inside and support.margin == pytest.approx(expected_margin)
    np.testing.assert_allclose(recorded_matrix(viewer, "wbik/support/com")[:3, 3], com)
    # on the right foot alone the CoM (y = 0 by symmetry) projects outside, left of the foot's edge
    right = corners["r_sole"][:, :2] + sole_xy["r_sole"]
    single = viewer.show_com_and_polygon(feet=["r_sole"])
    assert not single.inside
    assert single.margin == pytest.approx(-(com[1] - right[:, 1].max()))
    colour = recorded(viewer, "wbik/support/polygon", "object")["object"]["materials"][0]["color"]
    assert colour == 0xDD2222
    with pytest.raises(UnsupportedError, match="sole"):
        Viewer("ur5").show_com_and_polygon()


def test_animation_with_trace():
    viewer = Viewer("arm3r")
    times = np.linspace(0.0, 2.0, 21)
    qs = np.column_stack([np.linspace(0.0, 1.0, 21), np.linspace(0.2, -0.3, 21), np.full(21, 0.5)])
    trace = viewer.animate(times, qs, chain="arm", trace_frame="tip", fps=10)
    np.testing.assert_allclose(trace, [arm3r_tip(q) for q in qs], atol=1e-12)
    animation = umsgpack.unpackb(viewer.window.root.animation)["animations"]  # meshcat keeps it at /
    clips = {entry["path"]: entry["clip"] for entry in animation}
    marker = clips["/meshcat/wbik/trace/marker"]
    position = next(track for track in marker["tracks"] if track["name"] == ".position")
    assert [key["time"] for key in position["keys"]] == pytest.approx(list(times * 10))
    np.testing.assert_allclose(position["keys"][-1]["value"], arm3r_tip(qs[-1]), atol=1e-6)
    assert "/meshcat/wbik/robot/visuals/joint_joint3" in clips
    line = recorded(viewer, "wbik/trace/path", "object")["object"]
    assert line["object"]["type"] == "Line"
    with pytest.raises(InvalidConfigurationError, match="increasing"):
        viewer.animate([0.0, 0.0], [qs[0], qs[1]], chain="arm")


# -- server, browser lookup, command line ---------------------------------------------------------
def test_server_mode_serves_the_viewer_and_shuts_down():
    with Viewer("arm3r", server=True) as viewer:
        assert viewer.url.startswith("http://127.0.0.1:")
        with urllib.request.urlopen(viewer.url, timeout=10) as response:
            assert b"<html" in response.read().lower()
        process = viewer.window.server_process
        assert process.poll() is None
        assert page_commands(viewer.html())  # a served scene exports like an offline one
    assert process.wait(timeout=5) is not None


def test_missing_browser_says_how_to_install_it(monkeypatch):
    from wbik.viz import browser

    monkeypatch.setenv("WBIK_CHROMIUM", "/nonexistent/chromium")
    with pytest.raises(MissingDependencyError, match="scripts/setup.sh"):
        browser.find_chromium()
    monkeypatch.delenv("WBIK_CHROMIUM")
    monkeypatch.setenv("PATH", "/nonexistent")
    with pytest.raises(MissingDependencyError, match="no Chromium browser found.*scripts/setup.sh"):
        browser.find_chromium()


def run_cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "wbik.cli", *args], capture_output=True, text=True,
                          timeout=timeout)


def test_cli_view_exports_html(tmp_path):
    page = tmp_path / "pincher.html"
    done = run_cli("view", "pincher", "--q", "0", "45", "30", "-20", "--deg", "--frames",
                   "--target", "0.1", "0.05", "0.1", "--html", str(page))
    assert done.returncode == 0, done.stderr
    assert str(page) in done.stdout and "no server needed" in done.stdout
    paths = {c["path"] for c in page_commands(page.read_text())}
    assert {"/meshcat/wbik/frames/noa", "/meshcat/wbik/target/point"} <= paths


def test_cli_view_serves_prints_url_and_stops():
    done = run_cli("view", "arm3r", "--seconds", "0")
    assert done.returncode == 0, done.stderr
    assert re.search(r"http://127\.0\.0\.1:\d+/static/", done.stdout)


def test_cli_view_errors_tell_what_to_do(tmp_path):
    done = run_cli("view", "no_such_robot", "--html", str(tmp_path / "x.html"))
    assert done.returncode == 2
    assert "known robots" in done.stderr and "wbik robots" in done.stderr and ".urdf" in done.stderr
    done = run_cli("view", "ur5", "--com", "--html", str(tmp_path / "x.html"))
    assert done.returncode == 2 and "bioloid" in done.stderr


def test_play_a_motion_trajectory():
    from wbik import motion

    robot = wbik.load("arm3r")
    solver = wbik.solver("dls", robot)
    path = motion.waypoint_path(solver, np.full(3, np.pi / 2), [(2, -3, 3), (0, -2, 2)], samples=5)
    trajectory = motion.make_trajectory(motion.time_scale(path, "quintic", velocity_limit=1.0))
    viewer = Viewer(robot)
    trace = viewer.play(trajectory)  # traces the trajectory's tip frame
    np.testing.assert_allclose(trace, [arm3r_tip(q) for q in trajectory.positions], atol=1e-12)
    np.testing.assert_allclose(trace[-1], [0, -2, 2], atol=1e-5)  # arm3r.md's waypoint P2


SCENARIO = """\
name: shift the CoM, then reach
kind: wholebody_ik
robot: bioloid
backend: daqp
phases:
  - name: shift the CoM over the right foot
    contacts: [r_sole, l_sole]
    margin: 0.005
    tasks:
      - {type: com, over: r_sole, axes: xy}
  - name: reach forward with the left hand
    contacts: [r_sole, l_sole]
    margin: 0.005
    tasks:
      - {type: position, frame: l_hand, offset: [0.03, 0.0, 0.02]}
"""


def test_cli_view_plays_a_scenario_file(tmp_path):
    from wbik.scenarios.wholebody import PHASE_SECONDS, SAMPLES_PER_PHASE

    task = tmp_path / "shift.yaml"
    task.write_text(SCENARIO)
    page = tmp_path / "shift.html"
    done = run_cli("view", str(task), "--html", str(page))
    assert done.returncode == 0, done.stderr
    commands = page_commands(page.read_text())
    animation = next(c for c in commands if c["type"] == "set_animation")["animations"]
    clips = {entry["path"]: entry["clip"] for entry in animation}
    marker = clips["/meshcat/wbik/trace/marker"]  # the left hand, the frame the scenario moves
    keys = next(track for track in marker["tracks"] if track["name"] == ".position")["keys"]
    assert len(keys) == 2 * SAMPLES_PER_PHASE + 1
    assert keys[-1]["time"] / marker["fps"] == pytest.approx(2 * PHASE_SECONDS)
    middle, end = np.array(keys[SAMPLES_PER_PHASE]["value"]), np.array(keys[-1]["value"])
    np.testing.assert_allclose(end - middle, [0.03, 0.0, 0.02], atol=1e-4)  # the phase-2 offset
    # the support polygon of each phase: both soles, then (same soles, same places) no new one
    assert any(c["path"] == "/meshcat/wbik/support/polygon_0" for c in commands)
    assert not any(c["path"] == "/meshcat/wbik/support/polygon_1" for c in commands)
    assert "/meshcat/wbik/support/com" in clips and "/meshcat/wbik/contacts/r_sole" in clips


def test_animation_checks_its_samples_and_thins_joins_them():
    from wbik.viz.animation import Animation, Overlays

    robot = wbik.load("arm3r")
    rows = np.tile(robot.nominal, (5, 1))
    with pytest.raises(InvalidConfigurationError, match="shape"):
        Animation(robot, [0.0, 1.0], rows)
    with pytest.raises(InvalidConfigurationError, match="increasing"):
        Animation(robot, [0.0, 1.0, 1.0, 2.0, 3.0], rows)
    with pytest.raises(InvalidConfigurationError, match="one entry per sample"):
        Animation(robot, np.arange(5.0), rows, Overlays(support=[()] * 4))
    animation = Animation(robot, np.arange(5.0), rows, Overlays(contacts=[("tip",)] * 5))
    thin = animation.subsampled(3)
    assert list(thin.times) == [0.0, 3.0, 4.0] and len(thin.overlays.contacts) == 3
    joined = animation.then(thin, pause=0.5)
    assert list(joined.times[4:]) == [4.0, 4.5, 7.5, 8.5]


def test_played_walk_shows_the_support_of_each_sample():
    """Bioloid standing, first on both soles then (as far as the overlay says) on the right one: two
    polygons, each visible only during its own samples, the CoM's ground marker turns red."""
    from wbik.viz.animation import Animation, Overlays

    robot = wbik.load("bioloid")
    rows = np.array([robot.nominal] * 3)  # the robot stands still; only the soles called down change
    support = [("r_sole", "l_sole"), ("r_sole", "l_sole"), ("r_sole",)]
    viewer = Viewer(robot)
    drawn = viewer.play_animation(Animation(robot, [0.0, 1.0, 2.0], rows, Overlays(None, support, support)),
                                  fps=10)
    # the CoM is between the feet: inside both soles' polygon, outside the right sole's
    assert drawn.frames == 3 and drawn.com_margins[0] > 0.0 > drawn.com_margins[2]
    clips = {entry["path"]: entry["clip"] for entry in
             umsgpack.unpackb(viewer.window.root.animation)["animations"]}

    def visible(path):
        track = next(t for t in clips[f"/meshcat/wbik/{path}"]["tracks"] if t["name"] == ".visible")
        return [(key["time"], key["value"]) for key in track["keys"]]

    assert visible("support/polygon_0") == [(0.0, True), (20.0, False)]
    assert visible("support/polygon_1") == [(0.0, False), (20.0, True)]
    assert visible("support/com_ground_outside") == [(0.0, False), (20.0, True)]
    assert visible("contacts/l_sole") == [(0.0, True), (20.0, False)]


def test_a_push_is_an_arrow_on_its_frame_while_it_lasts_and_joins_shift_it():
    from wbik.viz.animation import Animation, Overlays, PushArrow

    robot = wbik.load("bioloid")
    with pytest.raises(InvalidConfigurationError, match="non-zero force"):
        PushArrow("pelvis", 0.0, 1.0, (0.0, 0.0, 0.0))
    rows = np.array([robot.nominal] * 3)
    cop = np.array([[0.0, 0.0, 0.0], [np.nan] * 3, [0.01, 0.0, 0.0]])
    pushed = Animation(robot, [0.0, 1.0, 2.0], rows, Overlays(cop=cop, pushes=(PushArrow(
        "pelvis", 0.5, 1.5, (0.0, -20.0, 0.0)),)))
    joined = Animation(robot, [0.0, 1.0, 2.0], rows).then(pushed, pause=0.5)
    assert joined.overlays.pushes[0].start_s == pytest.approx(3.0)  # 2.5 s later (it starts at 2.5 s)
    assert np.all(np.isnan(joined.overlays.cop[:3])) and joined.overlays.cop[5, 0] == 0.01
    viewer = Viewer(robot)
    viewer.play_animation(pushed, fps=10)
    clips = {entry["path"]: entry["clip"] for entry in
             umsgpack.unpackb(viewer.window.root.animation)["animations"]}
    tracks = {t["name"]: t["keys"] for t in clips["/meshcat/wbik/pushes/0"]["tracks"]}
    assert [(key["time"], key["value"]) for key in tracks[".visible"]] == [
        (0.0, False), (10.0, True), (20.0, False)]  # shown at the sample in [0.5, 1.5] s only
    x, y, z, w = tracks[".quaternion"][0]["value"]  # meshcat keys a pose as position and quaternion
    rotation = pin.Quaternion(w, x, y, z).toRotationMatrix()
    np.testing.assert_allclose(rotation[:, 1], [0.0, -1.0, 0.0], atol=1e-12)  # the arrow along the force
    tip_gap = robot.frame_placement(robot.nominal, "pelvis").translation - tracks[".position"][0]["value"]
    assert tip_gap[1] < 0 and np.allclose(tip_gap[[0, 2]], 0.0, atol=1e-12)  # short of the frame, before it
    cop_track = {t["name"] for t in clips["/meshcat/wbik/cop/marker"]["tracks"]}
    assert ".visible" in cop_track  # hidden at the sample without contact
