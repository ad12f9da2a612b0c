"""Robot-specific moves (Pincher, Golem-III) and the motion scenario files in tasks/."""

import math
from pathlib import Path

import numpy as np
import pytest

import wbik
from wbik.apps.golem3.approach import approach
from wbik.apps.pincher import teleoperation as pincher

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def test_pincher_jog_stops_at_the_limit():
    chain = wbik.load("pincher").chain()
    path = pincher.jog(chain, np.zeros(4), "joint2", math.radians(200))
    assert path.q[-1, 1] == pytest.approx(math.radians(150))
    assert path.info["clipped"] and np.allclose(path.q[:, [0, 2, 3]], 0.0)


def test_pincher_plane_pose_matches_the_seed_closed_form():
    # pincher.md's analytic IK with theta = 0 at (x, y, z) = (200, 100, 137) mm, by hand here
    px, py, pz = 200.0, 100.0, 137.0
    q1 = math.atan2(py, px)
    wx, wy, wz = px - 95 * math.cos(q1), py - 95 * math.sin(q1), pz
    cos3 = (wx**2 + wy**2 + (wz - 137) ** 2 - 2 * 105**2) / (2 * 105**2)
    q3 = math.atan2(math.sqrt(1 - cos3**2), cos3)
    q2 = math.atan2(math.hypot(wx, wy), wz - 137) - math.atan2(105 * math.sin(q3), 105 * (1 + cos3))
    q4 = math.pi / 2 - q2 - q3
    chain = wbik.load("pincher").chain()
    target = pincher.ToolPathReference(chain, [(0.2, 0.1, 0.137, 0.0), (0.2, 0.1, 0.137, 0.0)]).target(0.5)
    reached = chain.fk(np.array([q1, q2, q3, q4]))
    assert np.allclose(reached.translation, target.position, atol=1e-12)
    assert np.allclose(reached.rotation, target.rotation, atol=1e-12)


@pytest.mark.parametrize("method", ["dls", "analytic"])
def test_pincher_plane_line_is_straight_and_flat(method):
    solver = wbik.solver(method, wbik.load("pincher"), timeout_s=0.05)
    path = pincher.plane_line(solver, (0.25, -0.1), (0.15, 0.2), samples=20)
    assert path.success, path.summary()
    chain = solver.chain
    for k, q in enumerate(path.q):
        pose = chain.fk(q)
        wanted = np.array([0.25, -0.1]) + k / 20 * np.array([-0.1, 0.3])
        assert np.allclose(pose.translation, [*wanted, 0.137], atol=1e-6)
        assert abs(pose.rotation[2, 2]) <= 1e-6  # tool z axis horizontal (pitch 0)
        assert abs(q[1] + q[2] + q[3] - math.pi / 2) <= 1e-5


def test_pincher_plane_reports_points_beyond_reach():
    solver = wbik.solver("dls", wbik.load("pincher"), timeout_s=0.01)
    path = pincher.plane_line(solver, (0.25, -0.1), (0.32, 0.1), samples=10)
    assert not path.success
    outside = path.info["outside_plane"]
    assert outside and all("beyond the 305 mm reach" in reason for reason in outside.values())
    assert set(outside) <= set(np.flatnonzero(~path.solved))  # every point past 305 mm fails its IK


def _pincher_dh_fk(q):
    """The note's standard DH table (pincher.md), written out here: TCP position (m), tool rotation."""
    rows = [(-math.pi / 2, 0.0, 0.137, 0.0), (0.0, 0.105, 0.0, -math.pi / 2), (0.0, 0.105, 0.0, 0.0),
            (0.0, 0.095, 0.0, 0.0)]
    transform = np.eye(4)
    for (alpha, a, d, offset), angle in zip(rows, q, strict=True):
        theta = angle + offset
        ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
        transform = transform @ np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
                                          [0.0, sa, ca, d], [0.0, 0.0, 0.0, 1.0]])
    tool = transform[:3, :3] @ np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    return transform[:3, 3], tool


def test_pincher_dh_written_here_matches_the_note():
    position, rotation = _pincher_dh_fk(np.radians([15.0, 30.0, 45.0, 60.0]))
    np.testing.assert_allclose(position * 1e3, [213.5636, 57.2242, 187.9335], atol=1e-3)
    np.testing.assert_allclose(rotation, [[0.6830, 0.2588, 0.6830], [0.1830, -0.9659, 0.1830],
                                          [0.7071, 0.0, -0.7071]], atol=1e-4)


def test_pincher_automatic_cycle_reaches_every_waypoint():
    """Checked with the note's DH model (not the chain under test): every waypoint reached with the
    tool pitch it asks for, straight segments between them, joints within +-150 deg (pincher.md)."""
    solver = wbik.solver("dls", wbik.load("pincher"), timeout_s=0.05)
    path = pincher.automatic_path(solver)
    assert path.success, path.summary()
    cycle = np.array(pincher.AUTOMATIC_CYCLE)
    tips = np.array([_pincher_dh_fk(q)[0] for q in path.q])
    for knot, point in zip(path.waypoint_knots, cycle[1:], strict=True):
        position, rotation = _pincher_dh_fk(path.q[knot])
        assert np.allclose(position, point[:3], atol=1e-6)
        # tool pitch from the horizontal plane: the approach axis (third column) dips by -pitch
        pitch = math.asin(float(np.clip(rotation[2, 2], -1.0, 1.0)))
        assert pitch == pytest.approx(point[3], abs=1e-5)
    # every knot between two waypoints lies on the straight segment joining them
    knots = [0, *path.waypoint_knots]
    for (start, end), (a, b) in zip(zip(knots[:-1], knots[1:], strict=True),
                                    zip(cycle[:-1, :3], cycle[1:, :3], strict=True), strict=True):
        direction = (b - a) / np.linalg.norm(b - a)
        for tip in tips[start:end + 1]:
            offset = tip - a
            assert np.linalg.norm(offset - np.dot(offset, direction) * direction) <= 1e-6
    assert np.all(np.abs(path.q) <= math.radians(150.0) + 1e-9)
    assert np.allclose(cycle[0], cycle[-1])  # a cycle: it ends where it starts


@pytest.fixture(scope="module")
def golem():
    return wbik.load("golem3")


def test_golem3_reachable_grasp_keeps_the_lift_still(golem):
    chain = golem.chain("right_arm_lift")
    q0 = np.array([0.0, 0.0, 0.3, 0.2, 0.3, 0.6, 0.0])
    goal = chain.fk(np.array([0.0, 0.3, 0.6, -0.2, 0.5, 0.4, 0.2]))
    path = approach(golem, q0, goal, samples=20, timeout_s=0.05)
    assert path.success and path.info["lift_samples"] == []
    assert np.all(path.q[:, 0] == 0.0)
    errors = path.knot_errors()
    assert errors[0].max() <= 1e-6 and errors[1].max() <= 1e-6


def test_golem3_lift_only_where_the_arm_cannot_reach(golem):
    chain = golem.chain("right_arm_lift")
    q0 = np.array([0.0, 0.0, 0.3, 0.2, 0.3, 0.6, 0.0])
    goal = chain.fk(np.array([0.35, 0.3, 0.6, -0.2, 0.5, 0.4, 0.2]))
    path = approach(golem, q0, goal, samples=20, timeout_s=0.05)
    assert path.success, path.summary()
    lift = path.info["lift_samples"]
    assert lift and path.info["lift_travel_m"] > 0
    moved = set(np.flatnonzero(np.abs(np.diff(path.q[:, 0])) > 0) + 1)
    assert moved <= set(lift)  # mb changes only on samples reported as lift samples
    assert np.linalg.norm(chain.fk(path.q[-1]).translation - goal.translation) <= 1e-6


@pytest.mark.parametrize("name", sorted(p.name for p in TASKS.glob("motion_*.yaml")))
def test_motion_scenario_files_run_and_pass(name, tmp_path):
    from wbik.motion.scenarios import format_report
    from wbik.scenarios import load_scenario, run_scenario

    spec = load_scenario(TASKS / name)
    if "export" in spec:
        spec["export"] = {key: str(tmp_path / Path(value).name) for key, value in spec["export"].items()}
    report = run_scenario(spec, output=tmp_path / "report.json")
    assert report["passed"], format_report(report)
    assert (tmp_path / "report.json").is_file()
    for key in spec.get("export", {}):
        assert Path(report[key]).is_file()
