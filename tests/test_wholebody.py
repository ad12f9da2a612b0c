"""Whole-body problems behind one interface: the shared check, every method, the whole-body study."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull

import wbik
from wbik.errors import InvalidSettingError, UnsupportedError, WbikError
from wbik.qp.tasks import ComTask, FrameTask, OrientationTask, PositionTask
from wbik.solvers.check import check_problem
from wbik.solvers.peer import NO_POLYGON
from wbik.wholebody.problem import WholeBody


@pytest.fixture(scope="module")
def bioloid():
    return wbik.load("bioloid")


@pytest.fixture(scope="module")
def golem():
    return wbik.load("golem3")


def hull_margin(points: np.ndarray, point: np.ndarray) -> float:
    """Distance of ``point`` inside the convex hull of ``points`` (negative outside), from scipy's
    ConvexHull equations (unit normals n, offsets d with n.x + d <= 0 inside)."""
    hull = ConvexHull(points)
    return float(np.min(-(hull.equations[:, :2] @ point + hull.equations[:, 2])))


def sole_points(robot, q, soles) -> np.ndarray:
    points = []
    for sole in soles:
        placement = robot.frame_placement(q, sole)
        corners = np.asarray(robot.soles[sole], dtype=float)
        points.append((corners @ placement.rotation.T + placement.translation)[:, :2])
    return np.vstack(points)


def com_shift_problem(robot, target_xy) -> WholeBody:
    q0 = robot.nominal
    com = robot.center_of_mass(q0)
    pelvis = robot.frame_placement(q0, "pelvis").rotation
    return WholeBody(robot, [ComTask([target_xy[0], target_xy[1], com[2]], axes="xy", name="com"),
                             OrientationTask("pelvis", pelvis, weight=0.1, goal=False)],
                     contacts=["r_sole", "l_sole"], support=["r_sole", "l_sole"], margin=0.005)


def golem_problem(robot, seed=5) -> tuple[WholeBody, np.ndarray]:
    rng = np.random.default_rng(seed)
    q_true = rng.uniform(robot.model.lowerPositionLimit, robot.model.upperPositionLimit)
    tasks = [PositionTask(frame, robot.frame_placement(q_true, frame).translation, name=frame)
             for frame in ("r_eef", "l_eef")]
    return WholeBody(robot, tasks, limits="position"), q_true


# -- the shared check ---------------------------------------------------------------------------------
def test_check_on_hand_built_configuration_matches_independent_fk_and_convex_hull(bioloid):
    q0 = bioloid.nominal.copy()
    right = bioloid.frame_placement(q0, "r_sole").translation
    problem = com_shift_problem(bioloid, right[:2])
    # hand-built: the whole robot moved 3 mm along x and 2 mm along y, a knee bent 0.05 rad
    q = q0.copy()
    q[0] += 0.003
    q[1] += 0.002
    knee = bioloid.model.joints[bioloid.model.getJointId("l_knee")].idx_q
    q[knee] += 0.05
    result = check_problem(problem, q, q0=q0)
    # contact drift: the largest sole position/rotation error against the soles at q0, by FK
    drifts = []
    for sole in ("r_sole", "l_sole"):
        held, reached = bioloid.frame_placement(q0, sole), bioloid.frame_placement(q, sole)
        drifts += [np.linalg.norm(reached.translation - held.translation),
                   np.linalg.norm(pin.log3(held.rotation.T @ reached.rotation))]
    assert result.contact_drift == pytest.approx(max(drifts), abs=1e-12)
    assert result.contact_drift >= math.hypot(0.003, 0.002) - 1e-12
    # CoM margin: scipy's hull of the sole corners at q, the CoM by Pinocchio's centerOfMass
    expected = hull_margin(sole_points(bioloid, q, ["r_sole", "l_sole"]), bioloid.center_of_mass(q)[:2])
    assert result.com_margin == pytest.approx(expected, abs=1e-9)
    com = bioloid.center_of_mass(q)
    assert result.task_errors["com"] == pytest.approx(np.linalg.norm(com[:2] - right[:2]), abs=1e-12)
    assert not result.success
    assert "contact" in result.reason and "task com" in result.reason


def test_check_passes_a_configuration_that_meets_everything_and_flags_the_com_margin(bioloid):
    q0 = bioloid.nominal.copy()
    com = bioloid.center_of_mass(q0)
    problem = com_shift_problem(bioloid, com[:2])  # the task is met at q0 itself
    result = check_problem(problem, q0, q0=q0)
    assert result.success, result.reason
    assert result.contact_drift == 0.0
    expected = hull_margin(sole_points(bioloid, q0, ["r_sole", "l_sole"]), com[:2])
    assert result.com_margin == pytest.approx(expected, abs=1e-9)
    # the same configuration with a margin larger than the CoM's: fails on the margin alone
    strict = WholeBody(bioloid, problem.tasks, contacts=["r_sole", "l_sole"], margin=expected + 0.001)
    failed = check_problem(strict, q0, q0=q0)
    assert not failed.success and "CoM margin" in failed.reason
    assert failed.com_margin == pytest.approx(expected, abs=1e-9)


def test_check_limit_excess_and_typed_errors(bioloid):
    q0 = bioloid.nominal.copy()
    problem = com_shift_problem(bioloid, bioloid.center_of_mass(q0)[:2])
    joint = bioloid.model.joints[bioloid.model.getJointId("r_elbow")]
    q = q0.copy()
    q[joint.idx_q] = bioloid.model.upperPositionLimit[joint.idx_q] + 0.1
    result = check_problem(problem, q, q0=q0)
    assert result.limit_excess == pytest.approx(0.1, abs=1e-12)
    assert not result.success
    with pytest.raises(InvalidSettingError):
        check_problem(problem, q)  # contacts need q0 to know where they are held
    with pytest.raises(WbikError):
        WholeBody(bioloid, [], contacts=["r_sole"])  # no goal task
    with pytest.raises(WbikError):
        WholeBody(bioloid, problem.tasks, contacts=["no_such_frame"])
    with pytest.raises(WbikError):
        wbik.solver("qp", bioloid).solve(problem, np.zeros(3))


def test_problem_from_a_task_file_dict(bioloid):
    q0 = bioloid.nominal
    problem = WholeBody.from_dict(bioloid, {
        "contacts": ["r_sole", "l_sole"], "margin": 0.005,
        "tasks": [{"type": "com", "over": "r_sole", "axes": "xy"},
                  {"type": "orientation", "frame": "pelvis", "keep": True, "weight": 0.1, "goal": False}]})
    assert problem.support == ["r_sole", "l_sole"]  # default: the contacts with sole corners
    right = bioloid.frame_placement(q0, "r_sole").translation
    assert np.allclose(problem.tasks[0].target[:2], right[:2])
    result = wbik.solver("qp", bioloid).solve(problem, q0)
    assert result.success, result.reason
    with pytest.raises(InvalidSettingError):
        WholeBody.from_dict(bioloid, {"tasks": [], "contact": ["r_sole"]})


# -- every method on a Bioloid CoM shift and a Golem-III two-gripper case ------------------------------------
@pytest.mark.parametrize("method", ["qp", "placo", "pink", "mink", "thesis_legs"])
def test_each_method_solves_a_bioloid_com_shift(bioloid, method):
    q0 = bioloid.nominal
    right = bioloid.frame_placement(q0, "r_sole").translation
    left = bioloid.frame_placement(q0, "l_sole").translation
    target = right[:2] + 0.3 * (left[:2] - right[:2])  # 30 % of the way from the right sole to the left
    problem = com_shift_problem(bioloid, target)
    solver = wbik.solver(method, bioloid)
    assert solver.cannot_express(problem, q0) is None
    result = solver.solve(problem, q0)
    assert result.method == method
    assert result.success, result.reason
    com = bioloid.center_of_mass(result.q)
    assert np.linalg.norm(com[:2] - target) <= 1e-6
    for sole in ("r_sole", "l_sole"):
        held, reached = bioloid.frame_placement(q0, sole), bioloid.frame_placement(result.q, sole)
        assert np.linalg.norm(reached.translation - held.translation) <= 1e-6
    assert result.com_margin >= 0.005
    if method in ("pink", "mink", "thesis_legs"):
        assert any(NO_POLYGON in item for item in result.unsupported)
    else:
        assert result.unsupported == []


@pytest.mark.parametrize("method", ["qp", "placo", "pink", "mink"])
def test_each_method_solves_a_golem_two_gripper_case(golem, method):
    problem, _ = golem_problem(golem)
    result = wbik.solver(method, golem, max_iterations=300).solve(problem, golem.nominal)
    assert result.success, result.reason
    for task in problem.tasks:
        assert np.linalg.norm(golem.frame_placement(result.q, task.frame).translation - task.target) <= 1e-6
    assert math.isnan(result.com_margin)  # no support polygon on a fixed base
    assert result.unsupported == []


def test_thesis_legs_refuses_the_golem_and_lists_a_hand_task(bioloid, golem):
    with pytest.raises(UnsupportedError):
        wbik.solver("thesis_legs", golem)
    q0 = bioloid.nominal
    hand = bioloid.frame_placement(q0, "r_hand").translation + np.array([0.02, 0.0, 0.0])
    problem = WholeBody(bioloid, [PositionTask("r_hand", hand, name="r_hand")], contacts=["r_sole", "l_sole"])
    solver = wbik.solver("thesis_legs", bioloid)
    assert solver.cannot_express(problem, q0) == ("cannot express the goal task(s) r_hand (thesis_legs "
                                                  "places the soles and the CoM only)")
    result = solver.solve(problem, q0)
    assert not result.success
    assert any("r_hand" in item for item in result.unsupported)
    assert result.extra["cannot_express"] == ["r_hand"]
    assert result.task_errors["r_hand"] == pytest.approx(0.02, abs=1e-9)  # the hand did not move


def test_thesis_legs_lifts_a_foot_with_the_closed_form(bioloid):
    from wbik.apps.bioloid.wholebody_cases import standing_on

    q0 = standing_on("r")
    target = bioloid.frame_placement(q0, "l_sole")
    target.translation = target.translation + np.array([0.01, 0.0, 0.015])
    problem = WholeBody(bioloid, [FrameTask("l_sole", target, name="l_sole")], contacts=["r_sole"])
    solver = wbik.solver("thesis_legs", bioloid)
    assert solver.cannot_express(problem, q0) is None  # a sole and the CoM: what the legs place
    result = solver.solve(problem, q0)
    assert result.success, result.reason
    reached = bioloid.frame_placement(result.q, "l_sole")
    assert np.linalg.norm(reached.translation - target.translation) <= 1e-6
    # the CoM was kept where it started (over the right sole), by the hip shift
    assert np.linalg.norm(bioloid.center_of_mass(result.q)[:2] - bioloid.center_of_mass(q0)[:2]) <= 1e-6


def test_pink_results_carry_the_no_hard_polygon_mark_and_are_judged_by_the_same_check(bioloid):
    from wbik.wholebody.cases import sample_case

    case = sample_case("bioloid_reach_two_feet", 1, 0)
    result = wbik.solver("pink", bioloid).solve(case.problem, case.q0)
    assert [item for item in result.unsupported if NO_POLYGON in item]
    again = check_problem(case.problem, result.q, q0=case.q0)
    assert again.success == result.success
    assert again.com_margin == pytest.approx(result.com_margin, abs=1e-12)


def test_samplers_are_deterministic_per_index():
    from wbik.wholebody.cases import CASE_REGISTRY, sample_case

    for name in CASE_REGISTRY.entries():
        first, again = sample_case(name, 11, 3), sample_case(name, 11, 3)
        assert np.array_equal(first.anchor, again.anchor) and np.array_equal(first.q0, again.q0)
        assert not np.array_equal(first.anchor, sample_case(name, 11, 4).anchor)


# -- the whole-body study ------------------------------------------------------------------------------------
def test_whole_body_study_runs_and_reports(tmp_path):
    from wbik.study import run_study, study_from_dict
    from wbik.study.results import read_json

    study = study_from_dict({
        "name": "wholebody_tiny", "seed": 3, "poses": 3, "chunk_size": 2, "timeout_s": 0.05, "baseline": "qp",
        "cases": [{"target": "wholebody", "scenario": "bioloid_com_shift"},
                  {"target": "wholebody", "scenario": "bioloid_reach_two_feet"}],
        "methods": ["qp", "pink", "thesis_legs"]}, source="test")
    output = run_study(study, tmp_path / "out", jobs=1, backend="sequential", progress=False,
                       log=lambda m: None)
    report = (output / "report.md").read_text()
    for case in ("bioloid_com_shift", "bioloid_reach_two_feet"):
        assert f"## Case {case}" in report
        summary = (output / case / "summary.csv").read_text().splitlines()
        labels = [line.split(",")[0] for line in summary[1:]]
        expected = ["qp", "pink", "thesis_legs"] if case == "bioloid_com_shift" else ["qp", "pink"]
        assert labels == expected
        assert (output / case / "significance.csv").is_file()
        assert (output / case / "figures" / "com_margin.png").is_file()
    reason = read_json(output / "bioloid_reach_two_feet" / "not_applicable.json")["thesis_legs"]
    assert reason.startswith("cannot express the goal task(s) ") and "_hand (thesis_legs places" in reason
    assert "no hard polygon" in report  # pink's mark in the table
    # resume: a second run computes nothing
    run_study(study, output, jobs=1, backend="sequential", progress=False, log=lambda m: None)
    assert read_json(output / "run.json")["computed_tasks"] == 0
