"""Whole-body scenario files (tasks/*.yaml) with their stated goals, checked independently by FK."""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.scenarios import ScenarioError, load_scenario, run_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def contact_error(robot, q, frame, placement):
    reached = robot.frame_placement(q, frame)
    return max(np.linalg.norm(reached.translation - placement.translation),
               np.linalg.norm(pin.log3(placement.rotation.T @ reached.rotation)))


def sole_margin(robot, q, sole):
    """CoM distance inside a sole rectangle, by hand: the sole stays flat (z up), so in the sole
    frame the margin is min(0.05 - |x|, 0.03 - |y|) for the Bioloid's 100 x 60 mm soles."""
    placement = robot.frame_placement(q, sole)
    local = placement.rotation.T @ (robot.center_of_mass(q) - placement.translation)
    half = np.max(np.abs(robot.soles[sole]), axis=0)
    return min(half[0] - abs(local[0]), half[1] - abs(local[1]))


def in_limits(robot, q):
    model = robot.model
    rows = [model.joints[j].idx_q for j in range(1, model.njoints) if model.joints[j].nq == 1]
    return bool(np.all(q[rows] >= model.lowerPositionLimit[rows] - 1e-12)
                and np.all(q[rows] <= model.upperPositionLimit[rows] + 1e-12))


@pytest.fixture(scope="module")
def bioloid():
    return wbik.load("bioloid")


@pytest.fixture(scope="module")
def reach_report():
    return run_scenario(TASKS / "bioloid_reach.yaml")


@pytest.mark.numerics
def test_bioloid_balance_file(bioloid):
    report = run_scenario(TASKS / "bioloid_balance.yaml")
    assert report["passed"]
    shift, lift = report["phases"]
    q0 = bioloid.nominal
    soles = {f: bioloid.frame_placement(q0, f) for f in ("r_sole", "l_sole")}
    q1, q2 = np.array(shift["q"]), np.array(lift["q"])
    for frame, placement in soles.items():
        assert contact_error(bioloid, q1, frame, placement) <= 1e-6
    # CoM over the right sole centre
    assert np.linalg.norm(bioloid.center_of_mass(q1)[:2] - soles["r_sole"].translation[:2]) <= 1e-6
    # left foot 40 mm up, right sole still fixed, CoM >= 5 mm inside the right sole
    left = bioloid.frame_placement(q2, "l_sole")
    assert left.translation[2] - soles["l_sole"].translation[2] == pytest.approx(0.04, abs=1e-6)
    assert contact_error(bioloid, q2, "r_sole", soles["r_sole"]) <= 1e-6
    assert sole_margin(bioloid, q2, "r_sole") >= 0.005 - 1e-9
    assert in_limits(bioloid, q1) and in_limits(bioloid, q2)


@pytest.mark.numerics
def test_bioloid_reach_on_one_foot(bioloid, reach_report):
    assert reach_report["passed"]
    r_sole = bioloid.frame_placement(bioloid.nominal, "r_sole")
    lift, reach, too_far = reach_report["phases"][1:]
    q_lift, q_reach = np.array(lift["q"]), np.array(reach["q"])
    hand_before = bioloid.frame_placement(q_lift, "r_hand").translation
    hand_after = bioloid.frame_placement(q_reach, "r_hand").translation
    assert np.linalg.norm(hand_after - (hand_before + [0.04, 0.0, 0.0])) <= 1e-6
    for phase in (reach, too_far):
        q = np.array(phase["q"])
        assert contact_error(bioloid, q, "r_sole", r_sole) <= 1e-6
        assert sole_margin(bioloid, q, "r_sole") >= 0.005 - 1e-9
        assert in_limits(bioloid, q)


def test_bioloid_conflicting_target_gives_a_balanced_best_effort(bioloid, reach_report):
    too_far = reach_report["phases"][-1]
    assert too_far["success"] is False
    assert too_far["task_errors"]["PositionTask[r_hand]"] > 0.01  # the error is reported
    assert too_far["reason"]
    assert too_far["checks"]["com_margin"] >= 0.005 - 1e-9


def test_golem3_two_grippers_share_lift_and_chest_yaw():
    golem = wbik.load("golem3")
    report = run_scenario(TASKS / "golem3_two_grippers.yaml")
    assert report["passed"]
    q = np.array(report["phases"][0]["q"])
    spec = load_scenario(TASKS / "golem3_two_grippers.yaml")
    targets = {t["frame"]: np.array(t["target"]) for t in spec["phases"][0]["tasks"]}
    for frame, target in targets.items():
        assert np.linalg.norm(golem.frame_placement(q, frame).translation - target) <= 1e-6
    moved = q - golem.nominal
    index = {name: golem.model.joints[golem.model.getJointId(name)].idx_q for name in ("mb", "m0")}
    assert abs(moved[index["mb"]]) > 1e-3 or abs(moved[index["m0"]]) > 1e-3
    assert in_limits(golem, q)


def test_golem3_lift_reaches_what_the_arms_cannot():
    golem = wbik.load("golem3")
    report = run_scenario(TASKS / "golem3_lift_reach.yaml")
    assert report["passed"]
    arms_only, with_lift = report["phases"]
    target = np.array([-0.135, 0.012, 2.15])
    mb = golem.model.joints[golem.model.getJointId("mb")].idx_q
    assert not arms_only["success"] and abs(np.array(arms_only["q"])[mb] - golem.nominal[mb]) < 1e-9
    assert arms_only["task_errors"]["PositionTask[r_eef]"] > 0.1
    q = np.array(with_lift["q"])
    assert with_lift["success"] and q[mb] > 0.3
    assert np.linalg.norm(golem.frame_placement(q, "r_eef").translation - target) <= 1e-6


def test_run_command_writes_the_report(tmp_path):
    from wbik.cli import main

    output = tmp_path / "report.json"
    assert main(["run", str(TASKS / "golem3_two_grippers.yaml"), "--output", str(output)]) == 0
    import json

    assert json.loads(output.read_text())["passed"] is True


def test_bad_scenarios_raise_typed_errors(tmp_path):
    with pytest.raises(ScenarioError, match="does not exist"):
        load_scenario(tmp_path / "missing.yaml")
    unknown = tmp_path / "x.yaml"
    unknown.write_text("kind: dance\nrobot: golem3\n")
    with pytest.raises(ScenarioError, match="kind must be .*'wholebody_ik', got 'dance'"):
        run_scenario(unknown)
    bad_frame = tmp_path / "y.yaml"
    bad_frame.write_text("kind: wholebody_ik\nrobot: golem3\nphases:\n"
                         "  - tasks: [{type: position, frame: nose, offset: [0, 0, 0.1]}]\n")
    with pytest.raises(ScenarioError, match="nose"):
        run_scenario(bad_frame)
