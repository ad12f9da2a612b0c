"""Point feet: a quadruped's feet as soles with one contact point, held in position only.

Checked against Pinocchio FK and Jacobians computed here and against hand geometry (the feet's
rectangle, the distance to a segment), never against earlier output of the code under test.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.qp import ComTask, FrameTask, PositionTask
from wbik.qp.contacts import Contact, PointContact
from wbik.qp.humanoid import contact_constraint, is_point_foot
from wbik.qp.kinematics import Kinematics
from wbik.qp.support_polygon import DegenerateSupportPolygonError
from wbik.solvers.check import check_problem
from wbik.wholebody.problem import WholeBody

FEET = ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"]


@pytest.fixture(scope="module")
def solo():
    return wbik.load("example-robot-data:solo12", soles={foot: [0.0, 0.0, 0.0] for foot in FEET})


def feet_xy(robot, q) -> np.ndarray:
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    return np.array([data.oMf[robot.model.getFrameId(foot)].translation[:2] for foot in FEET])


def test_a_point_foot_is_held_in_position_only(solo):
    q = solo.nominal
    assert all(is_point_foot(solo, foot) for foot in FEET)
    contact = contact_constraint(solo, "FL_FOOT")
    assert isinstance(contact, PointContact)
    kinematics = Kinematics(solo.model, q)
    contact.start(kinematics)
    rows = contact.equality(kinematics)
    data = solo.model.createData()
    pin.computeJointJacobians(solo.model, data, q)
    pin.updateFramePlacements(solo.model, data)
    frame = solo.model.getFrameId("FL_FOOT")
    expected = pin.getFrameJacobian(solo.model, data, frame, pin.LOCAL_WORLD_ALIGNED)[:3]
    np.testing.assert_allclose(rows.A, expected, atol=1e-12)
    np.testing.assert_allclose(rows.b, 0.0, atol=1e-15)
    moved = pin.integrate(solo.model, q, np.r_[0.01, 0.0, 0.0, 0.0, 0.0, 0.2, np.zeros(12)])
    kinematics.update(moved)
    shift = data.oMf[frame].translation.copy()
    pin.framesForwardKinematics(solo.model, data, moved)
    shift = data.oMf[frame].translation - shift
    assert contact.violation(kinematics) == pytest.approx(np.linalg.norm(shift), abs=1e-12)
    assert isinstance(contact_constraint(wbik.load("bioloid"), "r_sole"), Contact)  # a flat sole


def test_problem_lists_point_contacts_and_checks_their_position_only(solo):
    q0 = solo.nominal.copy()
    problem = WholeBody(solo, [ComTask([0.0, 0.0, 0.0], axes="xy")], contacts=FEET, margin=0.02)
    point_contacts = {c.frame for c in problem.constraints if isinstance(c, PointContact)}
    assert point_contacts == set(FEET) and problem.support == FEET
    # turn the whole robot 0.3 rad about the vertical through FL_FOOT: FL_FOOT stays, rotated
    turn = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, 0.3), np.zeros(3))
    foot = solo.frame_placement(q0, "FL_FOOT").translation
    about = pin.SE3(np.eye(3), foot) * turn * pin.SE3(np.eye(3), -foot)
    q = q0.copy()
    q[:7] = pin.SE3ToXYZQUAT(about * pin.XYZQUATToSE3(q0[:7]))
    one_foot = WholeBody(solo, [ComTask([0.0, 0.0, 0.0], axes="xy")], contacts=["FL_FOOT"], support=[])
    result = check_problem(one_foot, q, q0=q0, tolerances=wbik.Tolerances(1e-6, 1e-6))
    assert result.contact_drift < 1e-12  # its rotation (0.3 rad) is free
    assert "contact" not in result.reason


def test_four_point_feet_margin_is_the_hand_rectangle(solo):
    q = solo.nominal
    feet = feet_xy(solo, q)
    problem = WholeBody(solo, [ComTask([0.0, 0.0, 0.0], axes="xy")], contacts=FEET, margin=0.02)
    com = solo.center_of_mass(q)[:2]
    low, high = feet.min(axis=0), feet.max(axis=0)  # the feet stand on an axis-aligned rectangle
    by_hand = min(com[0] - low[0], high[0] - com[0], com[1] - low[1], high[1] - com[1])
    result = check_problem(problem, q, q0=q)
    assert result.com_margin == pytest.approx(by_hand, abs=1e-9)


def test_two_point_feet_are_degenerate_input_and_a_failed_check(solo):
    q = solo.nominal
    diagonal = ["FL_FOOT", "HR_FOOT"]
    problem = WholeBody(solo, [PositionTask("FR_FOOT", np.zeros(3))], contacts=diagonal, margin=0.0)
    with pytest.raises(DegenerateSupportPolygonError) as info:
        wbik.solver("qp", solo).solve(problem, q)
    assert "FL_FOOT" in str(info.value) and "HR_FOOT" in str(info.value)
    # the check reports instead: minus the CoM's hand distance to the segment of the left feet
    left = ["FL_FOOT", "HL_FOOT"]
    one_side = WholeBody(solo, [PositionTask("FR_FOOT", np.zeros(3))], contacts=left, margin=0.0)
    a, b = feet_xy(solo, q)[[0, 2]]
    com = solo.center_of_mass(q)[:2]
    direction = (b - a) / np.linalg.norm(b - a)
    distance = abs(direction[0] * (com - a)[1] - direction[1] * (com - a)[0])
    result = check_problem(one_side, q, q0=q)
    assert not result.success and "support polygon is degenerate" in result.reason
    assert result.com_margin == pytest.approx(-distance, abs=1e-9) and distance > 0.1


@pytest.mark.parametrize("method", ["qp", "placo", "pink"])
def test_each_method_moves_the_trunk_on_point_feet(solo, method):
    """4 cm of trunk shift with four point feet held: every method must solve it (a 6-DOF contact on
    each 3-joint leg would leave the trunk no motion); feet kept by independent FK."""
    q0 = solo.nominal
    base = solo.frame_placement(q0, "base_link")
    target = pin.SE3(base.rotation, base.translation + [0.0, 0.04, 0.0])
    problem = WholeBody(solo, [FrameTask("base_link", target)], contacts=FEET, margin=0.02, limits="position")
    result = wbik.solver(method, solo, max_iterations=100).solve(problem, q0)
    assert result.success, result.reason
    reached = solo.frame_placement(result.q, "base_link")
    assert np.linalg.norm(reached.translation - target.translation) < 1e-6
    np.testing.assert_allclose(feet_xy(solo, result.q), feet_xy(solo, q0), atol=1e-6)
