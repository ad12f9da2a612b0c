"""Path studies (the case kind ``path``): the shapes, the metrics on joint paths whose jumps, branch
changes and lengths are known by construction (a hand-made path, a 2-link planar arm around a circle),
the closed-form branch labels on the UR5, the ``path:`` checks, and a small study end to end."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from wbik.study import run_study, study_from_dict
from wbik.study.path_metrics import (
    branch_labels,
    circle_points,
    line_points,
    path_metrics,
    random_plane,
    slerped_rotations,
)
from wbik.study.paths import describe, sample_paths
from wbik.study.spec import StudyDefinitionError
from wbik.targets import Target


# -- the shapes --------------------------------------------------------------------------------------
def test_a_line_runs_its_length_from_the_tip():
    start, direction = np.array([0.3, -0.1, 0.5]), np.array([0.0, 0.6, 0.8])
    points = line_points(start, direction, 0.2, 5)
    assert np.allclose(points[0], start) and np.allclose(points[-1], start + 0.2 * direction)
    assert np.allclose(np.linalg.norm(np.diff(points, axis=0), axis=1), 0.05)


def test_a_circle_goes_round_its_centre_in_its_plane_and_closes():
    rng = np.random.default_rng(4)
    u, v = random_plane(rng)
    assert abs(u @ v) < 1e-12 and np.isclose(np.linalg.norm(u), 1) and np.isclose(np.linalg.norm(v), 1)
    start = np.array([0.1, 0.2, 0.3])
    points = circle_points(start, u, v, 0.07, 9)
    centre = start + 0.07 * u
    assert np.allclose(np.linalg.norm(points - centre, axis=1), 0.07)
    assert np.allclose((points - centre) @ np.cross(u, v), 0.0)  # in the plane of u and v
    assert np.allclose(points[0], start) and np.allclose(points[-1], start)
    assert np.allclose(points[2], centre + 0.07 * v)  # a quarter turn (t = pi / 2)


def test_the_orientation_is_held_or_slerped_by_the_stated_angle():
    start = pin.rpy.rpyToMatrix(0.3, -0.2, 1.1)
    held = slerped_rotations(start, None, 0.0, 4)
    assert np.allclose(held, start)
    axis = np.array([0.0, 0.0, 1.0])
    turned = slerped_rotations(start, axis, 0.6, 4)
    angles = [np.linalg.norm(pin.log3(start.T @ rotation)) for rotation in turned]
    assert np.allclose(angles, [0.0, 0.2, 0.4, 0.6])
    assert np.allclose(start.T @ turned[-1], pin.exp3(0.6 * axis))  # about the axis in the tip frame


# -- the metrics on joint paths built by hand ----------------------------------------------------------
def test_metrics_of_a_hand_made_joint_path():
    q = np.array([[0.0, 0.0], [0.1, -0.1], [0.2, -0.2], [9.0, 9.0], [1.0, -0.2], [1.1, -0.25]])
    solved = np.array([True, True, True, False, True, True])  # point 3 unsolved: skipped
    metrics = path_metrics(q, solved, threshold=0.5)
    # steps between solved points: (0.1, 0.1), (0.1, 0.1), (0.8, 0.0), (0.1, 0.05)
    assert metrics.points_solved == pytest.approx(5 / 6) and not metrics.whole
    assert (metrics.jumps, metrics.branch_changes, metrics.flips) == (1, 0, 1)
    assert metrics.largest_step == pytest.approx(0.8)
    assert metrics.length == pytest.approx(0.2 + 0.2 + 0.8 + 0.15)
    branches = np.array([0, 0, 1, -1, 1, 2])  # a change at the third point, one at the last; -1: unknown
    metrics = path_metrics(q, solved, threshold=0.5, branches=branches)
    assert (metrics.jumps, metrics.branch_changes, metrics.flips) == (1, 2, 3)  # the 0.8 step is both


def test_metrics_of_a_path_with_fewer_than_two_solved_points():
    q = np.zeros((3, 2))
    metrics = path_metrics(q, np.array([False, True, False]), threshold=0.5)
    assert metrics.points_solved == pytest.approx(1 / 3) and not metrics.whole
    assert (metrics.flips, metrics.length) == (0, 0.0)
    assert math.isnan(metrics.largest_step)


def planar_ik(points: np.ndarray, l1: float, l2: float, elbow: float) -> np.ndarray:
    """Joints (q1, q2) of a 2-link planar arm reaching the (x, y) of ``points``, elbow sign ``elbow``."""
    x, y = points[:, 0], points[:, 1]
    q2 = elbow * np.arccos((x * x + y * y - l1 * l1 - l2 * l2) / (2 * l1 * l2))
    q1 = np.arctan2(y, x) - np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2))
    return np.stack([q1, q2], axis=1)


def test_a_two_link_arm_around_a_circle_has_the_known_length_and_flips():
    l1, l2, radius, count = 1.0, 0.8, 1.2, 37
    start = np.array([radius, 0.0, 0.0])  # a circle about the base: u points back to the origin
    points = circle_points(start, np.array([-1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), radius, count)
    assert np.allclose(np.linalg.norm(points[:, :2], axis=1), radius)
    down = planar_ik(points, l1, l2, elbow=1.0)
    reached = np.stack([l1 * np.cos(down[:, 0]) + l2 * np.cos(down[:, 0] + down[:, 1]),
                        l1 * np.sin(down[:, 0]) + l2 * np.sin(down[:, 0] + down[:, 1])], axis=1)
    assert np.allclose(reached, points[:, :2])
    solved = np.ones(count, dtype=bool)
    step = 2 * math.pi / (count - 1)  # q1 turns once around, q2 stays

    continuous = down.copy()
    continuous[:, 0] = np.unwrap(down[:, 0])
    metrics = path_metrics(continuous, solved, threshold=0.5)
    assert metrics.whole and metrics.flips == 0
    assert metrics.length == pytest.approx(2 * math.pi) and metrics.largest_step == pytest.approx(step)

    # the same path with q1 read in (-pi, pi]: one step goes back by 2 pi - step
    metrics = path_metrics(down, solved, threshold=0.5)
    assert metrics.jumps == 1 and metrics.largest_step == pytest.approx(2 * math.pi - step)
    assert metrics.length == pytest.approx((count - 3) * step + 2 * math.pi)

    # elbow down for the first half, elbow up after: the change is a jump of the elbow and a branch change
    up = planar_ik(points, l1, l2, elbow=-1.0)
    up[:, 0] = np.unwrap(up[:, 0])
    switched = np.where(np.arange(count)[:, None] < count // 2, continuous, up)
    branches = np.where(np.arange(count) < count // 2, 0, 1)
    metrics = path_metrics(switched, solved, threshold=0.5, branches=branches)
    elbow = 2 * abs(down[0, 1])
    assert (metrics.jumps, metrics.branch_changes, metrics.flips) == (1, 1, 1)
    shoulder = abs(up[count // 2, 0] - continuous[count // 2 - 1, 0])
    assert metrics.largest_step == pytest.approx(max(elbow, shoulder))


def test_branch_labels_follow_the_ur5_closed_form():
    import wbik
    from wbik.study.closed_form_branches import complete_closed_form

    chain = wbik.load("ur5").chain("arm")
    form = complete_closed_form(chain)
    assert not isinstance(form, str)
    q_start = np.array([0.4, -1.2, 1.3, -1.0, 1.1, 0.3])
    tip = chain.fk(q_start)
    count = 6
    positions = line_points(tip.translation, np.array([0.0, 0.0, 1.0]), 0.05, count)
    rotations = slerped_rotations(tip.rotation, None, 0.0, count)
    solver = wbik.solver("analytic", chain.robot, chain="arm")
    q = np.array([solver.solve(Target(p, r), q_start).q for p, r in zip(positions, rotations,
                                                                                       strict=True)])
    solved = np.ones(count, dtype=bool)
    labels = branch_labels(form, positions, rotations, q, solved, 1e-3)
    assert labels[0] >= 0 and np.all(labels == labels[0])  # the nearest branch all the way: one branch
    other = np.array([a.q for a in solver.solve_all(Target(positions[3], rotations[3]))])
    far = other[np.argmax(np.max(np.abs(other - q[3]), axis=1))]
    q[3] = far
    labels_switched = branch_labels(form, positions, rotations, q, solved, 1e-3)
    assert labels_switched[3] not in (-1, labels[0])
    assert path_metrics(q, solved, 0.5, labels_switched).branch_changes == 2
    labels_unsolved = branch_labels(form, positions, rotations, q, np.array([1, 1, 1, 0, 1, 1], bool), 1e-3)
    assert labels_unsolved[3] == -1


# -- the study file ----------------------------------------------------------------------------------
def _study(case: dict, **top):
    return study_from_dict({"name": "p", "methods": ["bounded_lm"], "cases": [case], **top}, source="f.yaml")


def test_a_path_case_is_completed_with_its_defaults_and_named_by_its_shape():
    study = _study({"robot": "ur5", "chain": "arm", "path": {"shape": "circle", "count": 7}})
    case = study.cases[0]
    assert (case.name, case.target, case.poses) == ("ur5_arm_circle_path", "path", 7)
    assert case.path == {"shape": "circle", "radius": 0.1, "points": 50, "orientation": "hold", "jump": 0.5,
                         "reachable": True, "attempts": 50, "branch_tolerance": 1e-3}
    assert describe(case.path) == "circle of radius 0.1 m, 50 points, orientation held"
    assert _study({"robot": "ur5", "chain": "arm", "target": "path"}).cases[0].path["shape"] == "line"
    other = _study({"robot": "ur5", "chain": "arm", "path": {"shape": "circle", "count": 7, "radius": 0.05}})
    assert other.fingerprint() != study.fingerprint()


@pytest.mark.parametrize(("path", "message"), [
    ({"shape": "line", "radius": 0.1}, r"cases\[0\]\.path\.radius applies to shape: circle only"),
    ({"angle": 0.3}, r"cases\[0\]\.path\.angle applies to orientation: slerp only"),
    ({"points": 1}, r"cases\[0\]\.path\.points must be an integer in \[2, 10000\]"),
    ({"shape": "spiral"}, r"cases\[0\]\.path\.shape must be 'line' or 'circle', got 'spiral'"),
    ({"lenght": 0.2}, r"cases\[0\]\.path has unknown field\(s\) \['lenght'\] \(did you mean 'length'\?\)"),
    ({"count": 0}, r"cases\[0\]\.path\.count must be a positive integer"),
    ({"length": -0.1}, r"cases\[0\]\.path\.length must be a length in m"),
    ({"reachable": "yes"}, r"cases\[0\]\.path\.reachable must be true or false"),
    ("line", r"cases\[0\]\.path must be a mapping"),
])
def test_a_wrong_path_names_its_key(path, message):
    with pytest.raises(StudyDefinitionError, match=message):
        _study({"robot": "ur5", "chain": "arm", "path": path})


def test_path_count_and_poses_must_agree():
    with pytest.raises(StudyDefinitionError, match=r"path\.count \(5\) and poses \(6\)"):
        _study({"robot": "ur5", "chain": "arm", "poses": 6, "path": {"count": 5}})


def test_path_i_does_not_depend_on_how_many_are_drawn():
    import wbik

    chain = wbik.load("ur5").chain("arm")
    case = {"robot": "ur5", "chain": "arm", "path": {"points": 6, "orientation": "slerp"}}
    parameters = _study(case).cases[0].path
    few, more = sample_paths(chain, 2, 11, parameters), sample_paths(chain, 4, 11, parameters)
    assert np.array_equal(few.positions, more.positions[:2]) and np.array_equal(few.q0, more.q0[:2])
    assert few.positions.shape == (2, 6, 3) and few.rotations.shape == (2, 6, 3, 3)
    assert np.allclose(few.positions[:, 0], [chain.fk(q).translation for q in few.q0])


def test_a_small_path_study_end_to_end(tmp_path):
    study = study_from_dict({
        "name": "paths", "seed": 5, "timeout_s": 0.005, "chunk_size": 2, "baseline": "bounded_lm",
        "cases": [{"robot": "ur5", "chain": "arm", "path": {"shape": "line", "length": 0.1, "points": 8,
                                                             "count": 3}}],
        "methods": ["analytic", "bounded_lm", {"method": "dls", "options": {"max_iterations": 60}}]},
        source="test")
    output = run_study(study, tmp_path / "out", jobs=2, backend="loky", progress=False,
                       log=lambda message: None)
    case = output / "ur5_arm_line_path"
    with np.load(case / "poses.npz") as poses:
        assert poses["positions"].shape == (3, 8, 3) and poses["path_verified"].all()
    from wbik.study.results import load_method_rows

    rows = load_method_rows(output, "ur5_arm_line_path", "analytic", 2)
    assert rows["point_success"].shape == (3, 8) and rows["point_q"].shape == (3, 8, 6)
    assert rows["point_success"].all()  # every point has a witness inside the limits: the closed form too
    assert np.all(rows["point_branch"] >= 0)
    for index in range(3):  # the rows' metrics are those of their joint paths
        metrics = path_metrics(rows["point_q"][index], rows["point_success"][index], 0.5,
                               rows["point_branch"][index])
        assert rows["length"][index] == pytest.approx(metrics.length)
        assert rows["flips"][index] == metrics.flips
    raw = (case / "raw.csv").read_text().splitlines()
    assert raw[0].startswith("path,point,method,success,reason,time_s") and len(raw) == 1 + 3 * 8 * 3
    assert len((case / "paths.csv").read_text().splitlines()) == 1 + 3 * 3
    assert "percent_points_solved" in (case / "summary.csv").read_text().splitlines()[0]
    assert (case / "figures" / "paths.png").is_file()
    report = (output / "report.md").read_text()
    assert "## Case ur5_arm_line_path: ur5.arm, line paths" in report
    assert "3 paths (seed 5), each a line of 0.1 m, 8 points, orientation held" in report
    assert "| method | whole paths | % whole (95 % CI) | % points solved | paths with a flip |" in report
    assert "| analytic | 3/3 | 100 " in report
