"""A QP solve that does not succeed says why: cases whose blocking constraint, conflicting set or
conflicting task is known by construction, and the diagnosis must name exactly them.

- a planar two-link arm whose elbow cannot bend past 2.5 rad, asked for a point nearer than the
  bent arm reaches: its elbow's upper limit, alone;
- the UR5 asked for a point 1.5 m away with no joint at a limit: a stationary point, nothing blocks;
- a Panda hand held by two contacts 5 cm apart along x: the two x rows, and nothing else, conflict;
- Solo12 on the triangle of three point feet with its CoM target on the fourth foot: the polygon's
  edge facing that foot (between the two feet it joins), alone;
- a posture on the goals' level: the task in conflict, with the fix (one priority lower), which
  then converges;
- a start with the elbow beyond its limit: reported, clipped into the limits (solve) or moved back
  at its velocity bound (a control step), and solved.
"""

from __future__ import annotations

import json
import pickle
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.errors import NoQPSolutionError
from wbik.qp import (
    ComTask,
    Contact,
    IKProblem,
    JointPositionLimits,
    JointVelocityLimits,
    PositionTask,
    PostureTask,
    RegularizationTask,
)
from wbik.qp.elastic import conflict
from wbik.qp.hard_rows import HardRows
from wbik.qp.rows import RowLabel
from wbik.robot import ChainSpec, robot_from_urdf_text
from wbik.wholebody.problem import WholeBody

LINK = 0.3
FEET = ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"]


def planar_arm():
    """Two revolute joints about z, 0.3 m links, 3 rad/s; the elbow (joint1) limited to [0, 2.5] rad."""
    inertia = '<inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/>'
    parts = ['<robot name="planar_arm">', '<link name="base"/>']
    parent = "base"
    for index, (lower, upper) in enumerate(((-2.5, 2.5), (0.0, 2.5))):
        parts.append(f'<link name="link{index}"><inertial><mass value="1"/>{inertia}</inertial></link>')
        parts.append(f'<joint name="joint{index}" type="revolute"><parent link="{parent}"/>'
                     f'<child link="link{index}"/><origin xyz="{0.0 if index == 0 else LINK} 0 0"/>'
                     f'<axis xyz="0 0 1"/><limit lower="{lower}" upper="{upper}" effort="1" velocity="3"/>'
                     "</joint>")
        parent = f"link{index}"
    parts.append(f'<link name="tip"/><joint name="tip_fixed" type="fixed"><parent link="{parent}"/>'
                 f'<child link="tip"/><origin xyz="{LINK} 0 0"/></joint></robot>')
    return robot_from_urdf_text("planar_arm", "\n".join(parts), [ChainSpec("arm", "base", "tip",
                                                                           ("joint0", "joint1"))],
                                floating_base=False)


@pytest.fixture(scope="module")
def arm():
    return planar_arm()


@pytest.fixture(scope="module")
def panda():
    return wbik.load("panda")


@pytest.fixture(scope="module")
def solo():
    return wbik.load("example-robot-data:solo12", soles={foot: [0.0, 0.0, 0.0] for foot in FEET})


def test_a_target_beyond_a_joint_limit_names_that_limit_alone(arm):
    # nearer than 2 * 0.3 * cos(2.5 / 2) = 0.189 m: only an elbow bent past 2.5 rad would reach it
    result = wbik.solver("qp", arm, chain="arm").solve([0.1, 0.05, 0.0], [0.3, 1.0])
    assert not result.success
    diagnosis = result.diagnosis
    assert [(b.label.kind, b.label.subject, b.label.side) for b in diagnosis.blockers] == [
        ("joint limit", "joint1", "upper")]
    assert diagnosis.blockers[0].gain > 0 and not diagnosis.stationary and not diagnosis.tasks
    assert "blocked by: joint joint1 at its upper limit (2.5 rad)" in result.reason
    assert "joint1 beyond its upper limit" in result.reason  # the advice


def test_a_target_out_of_reach_with_nothing_active_is_a_stationary_point():
    ur5 = wbik.load("ur5")
    result = wbik.solver("qp", ur5, chain="arm").solve([1.5, 0.2, 0.3])
    diagnosis = result.diagnosis
    assert not result.success and diagnosis.stationary
    assert not diagnosis.blockers and not diagnosis.tasks and not diagnosis.infeasible
    assert "stationary point" in result.reason and "another start" in result.reason


def test_two_contradictory_contacts_are_exactly_the_conflicting_rows(panda):
    model = panda.model
    held = panda.frame_placement(panda.nominal, "panda_hand_tcp")
    apart = held.copy()
    apart.translation = apart.translation + np.array([0.05, 0.0, 0.0])
    first, second = Contact("panda_hand_tcp", held), Contact("panda_hand_tcp", apart)
    first.name, second.name = "hold here", "hold 5 cm ahead"
    problem = IKProblem(model, [PositionTask("panda_link4", panda.frame_placement(panda.nominal,
                                                                                  "panda_link4").translation)],
                        [first, second, JointPositionLimits()])
    with pytest.raises(NoQPSolutionError) as caught:
        problem.step(panda.nominal)
    named = {(row.label.constraint, row.label.side) for row in caught.value.conflict}
    assert named == {("hold here", "x"), ("hold 5 cm ahead", "x")}
    solution = problem.solve(panda.nominal)
    assert not solution.success
    assert {(row.label.constraint, row.label.side) for row in solution.diagnosis.infeasible} == named
    assert "the hard constraints of the step conflict: contact panda_hand_tcp" in solution.reason
    copy = pickle.loads(pickle.dumps(caught.value))  # a study worker's error keeps its conflict
    assert [row.label for row in copy.conflict] == [row.label for row in caught.value.conflict]


def test_rows_that_hold_together_have_no_conflict():
    labels = [RowLabel("c", "inequality", f"row {i}") for i in range(3)]
    rows = HardRows(np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]]), np.array([1.0, 1.0, 0.5]),
                    np.array([False, False, True]), labels)
    assert conflict(rows) == []
    contradiction = HardRows(np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]]), np.array([-1.0, -0.5, 0.5]),
                             np.array([False, False, True]), rows.labels)
    assert [row.label.subject for row in conflict(contradiction)] == ["row 0", "row 1"]


def test_a_com_target_outside_a_triangle_of_point_feet_names_the_edge_it_faces(solo):
    q0 = solo.nominal
    target = solo.frame_placement(q0, "HR_FOOT").translation  # beyond the diagonal FR-HL
    problem = WholeBody(solo, [ComTask(target, axes="xy")], contacts=FEET, support=FEET[:3],
                        margin=0.01)
    result = wbik.solver("qp", solo).solve(problem, q0)
    assert not result.success and result.com_margin >= 0.01 - 1e-9
    polygon = [b for b in result.diagnosis.blockers if b.label.kind == "support polygon"]
    assert [set(b.label.subject.split("-")) for b in polygon] == [{"HL_FOOT", "FR_FOOT"}]
    assert polygon[0].label.value == pytest.approx(0.01, abs=1e-5)  # on the shrunk edge (+ 2 um safety)
    assert result.diagnosis.blockers[0] is polygon[0]  # what holds the CoM back most
    # the start's CoM is on that diagonal (0 mm < 10 mm): reported, and repaired by the first steps
    assert [v.kind for v in result.diagnosis.start] == ["support polygon"]
    json.dumps(result.as_dict())  # the JSON form carries the diagnosis


def test_a_posture_on_the_goals_level_is_named_with_the_fix_that_converges(panda):
    model = panda.model
    goal = panda.nominal.copy()
    goal[:7] = [0.4, -0.1, 0.2, -1.9, -0.1, 1.9, 0.8]
    target = panda.frame_placement(goal, "panda_hand_tcp").translation
    far = panda.nominal.copy()
    far[:7] = [-1.0, 0.5, -1.0, -1.0, 1.0, 1.0, -1.0]

    def solve(priority: int):
        tasks = [PositionTask("panda_hand_tcp", target), PostureTask(far, weight=1e-2, priority=priority),
                 RegularizationTask(1e-9, priority=priority)]
        return IKProblem(model, tasks, [JointPositionLimits()]).solve(panda.nominal)

    same_level = solve(0)
    assert not same_level.success
    conflicts = same_level.diagnosis.tasks
    assert conflicts[0].task == "PostureTask" and not conflicts[0].goal
    assert conflicts[0].holds_back == ("PositionTask[panda_hand_tcp]",)
    assert "move PostureTask to a lower priority level (priority=1)" in same_level.reason
    assert solve(1).success


def test_a_start_beyond_a_limit_is_reported_and_recovered(arm):
    target = [0.35, 0.3, 0.0]  # within reach
    result = wbik.solver("qp", arm, chain="arm").solve(target, [0.2, 3.0])
    assert result.success
    start = result.diagnosis.start
    assert [(v.subject, v.side, v.value, v.bound) for v in start] == [("joint1", "upper", 3.0, 2.5)]
    assert start[0].text == "joint joint1 at 3 rad > 2.5"
    # a control step moves the joint back at its velocity bound, not all the way in one period
    model = arm.model
    problem = IKProblem(model, [PositionTask("tip", np.array([*target]))],
                        [JointPositionLimits(), JointVelocityLimits()])
    dq = problem.step(np.array([0.2, 3.0]), dt=0.01)
    assert dq[1] == pytest.approx(-3.0 * 0.01)


def test_the_cli_prints_the_diagnosis():
    out = subprocess.run([sys.executable, "-m", "wbik.cli", "solve", "pincher", "--method", "qp", "--xyz",
                          "0.05", "0.05", "-0.2"], capture_output=True, text=True)
    assert out.returncode == 1, out.stderr
    assert "blocked by (relaxing it alone would bring the goals closer by, in one step):" in out.stdout
    assert "- joint joint2 at its upper limit (2.618 rad)" in out.stdout
    assert "to converge: the goal needs joint2 beyond its upper limit" in out.stdout


def test_talos_reaching_far_keeps_its_com_margin_with_every_backend():
    """Talos (half-sitting, both feet, CoM margin 20 mm) reaching to [0.75, -0.3, 0.7], which PlaCo
    solves. On the way the loop keeps an iterate whose soles drift 4.3 mm and shrinks its step box to
    3.1 mm after rejected steps: the step's sole rows and its box then conflict (the elastic re-solve
    names exactly them), so the loop projects onto the soles, under the CoM rows, and goes on. It
    converges with the margin held, with every backend."""
    soles = {frame: wbik.qp.support_polygon.sole_rectangle(0.20, 0.12, (-0.005, 0.0, 0.0))
             for frame in ("left_sole_link", "right_sole_link")}
    talos = wbik.load("example-robot-data:talos", soles=soles)
    q0 = talos.nominal
    base = talos.frame_placement(q0, "base_link").rotation
    problem = WholeBody(talos, [PositionTask("gripper_right_base_link", [0.75, -0.3, 0.7]),
                                wbik.qp.OrientationTask("base_link", base, weight=0.1, goal=False)],
                        contacts=list(soles), margin=0.02)
    for backend in wbik.qp.available_backends():
        result = wbik.solver("qp", talos, backend=backend).solve(problem, q0)
        assert result.success, (backend, result.reason)
        assert result.com_margin >= 0.02 - 1e-9, backend
        reached = talos.frame_placement(result.q, "gripper_right_base_link").translation
        assert np.linalg.norm(reached - [0.75, -0.3, 0.7]) < 1e-6
        assert pin.log3(base.T @ talos.frame_placement(result.q, "base_link").rotation).shape == (3,)
