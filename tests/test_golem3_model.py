"""Golem-III model: the committed URDF, the thesis closed-form FK (golem3.md), mirroring, torso lift.

The expected values are written here from golem3.md, independently of wbik's code.
"""

from __future__ import annotations

import math
from xml.etree import ElementTree

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.robot_packages.golem3 import model as golem3

# golem3.md, thesis Table 3.1 and the robot's joint limits
L1, L2, L4, L5, L6, H = 0.1225, 0.212, 0.256, 0.034, 0.4, 1.283
RHO = math.radians(13.43)
LOWER = np.array([-1.00, -1.14, -3.00, -1.55, -1.67, -1.50])
UPPER = np.array([1.00, 1.75, 3.00, 1.55, 1.67, 1.50])


def rz(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def ry(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rx(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def thesis_fk(q):
    """golem3.md eq. 3.3-3.9 with the rho correction; orientation Rz(gamma) Ry(beta) Rx(alpha)."""
    t1, t2, t3, t4, t5, t6 = q
    l3 = L4 * math.sin(t4 + RHO) + L5 * math.sin(t4 + t5) + L6 * math.cos(t4 + t5)
    x = L1 * math.sin(t1) + L2 * math.sin(t1 + t2) + l3 * math.cos(t1 + t2 + t3)
    y = -L1 * math.cos(t1) - L2 * math.cos(t1 + t2) + l3 * math.sin(t1 + t2 + t3)
    z = H - L4 * math.cos(t4 + RHO) - L5 * math.cos(t4 + t5) + L6 * math.sin(t4 + t5)
    rotation = rz(t1 + t2 + t3) @ ry(-t4 - t5) @ rx(t6)
    return np.array([x, y, z]), rotation


@pytest.fixture(scope="module")
def robot():
    return wbik.load("golem3")


def test_committed_urdf_is_the_generator_output():
    assert golem3.URDF_PATH.read_text() == golem3.urdf_text(), \
        (f"{golem3.URDF_PATH} is stale: run python -c "
         "'from wbik.robot_packages.golem3 import model; model.write_urdf()'")


def test_urdf_file_loads_with_pinocchio_and_has_the_contract_names():
    ElementTree.parse(golem3.URDF_PATH)  # strict XML (e.g. no '--' inside comments)
    model = pin.buildModelFromUrdf(str(golem3.URDF_PATH))
    joints = set(model.names)
    expected = {"mb", "m0", "m1", "m2", "m10", "m11", "m12", "m13", "m14", "m15", "m17",
                "m20", "m21", "m22", "m23", "m24", "m25", "m27"}
    assert expected <= joints
    assert model.nq == len(expected)
    for frame in ("base_link", "torso_link", "r_eef", "l_eef"):
        assert model.existFrame(frame)
    assert model.frames[model.getFrameId("base_link")].parentJoint == 0


def test_joint_limits_and_velocities(robot):
    model = robot.model
    for side in ("1", "2"):
        names = ["m0"] + [f"m{side}{i}" for i in range(5)]
        ids = [model.joints[model.getJointId(n)].idx_q for n in names]
        np.testing.assert_allclose(model.lowerPositionLimit[ids], LOWER)
        np.testing.assert_allclose(model.upperPositionLimit[ids], UPPER)
        np.testing.assert_allclose(model.velocityLimit[ids], 1.0)
    lift = model.joints[model.getJointId("mb")].idx_q
    assert (model.lowerPositionLimit[lift], model.upperPositionLimit[lift]) == (0.0, 0.55)
    assert model.velocityLimit[lift] == 0.005
    for finger in ("m15", "m17", "m25", "m27"):
        index = model.joints[model.getJointId(finger)].idx_q
        assert (model.lowerPositionLimit[index], model.upperPositionLimit[index]) == (0.0, 1.6)
    for head in ("m1", "m2"):
        index = model.joints[model.getJointId(head)].idx_q
        assert (model.lowerPositionLimit[index], model.upperPositionLimit[index]) == (-1.0, 1.0)


def test_chains_nominal_and_closed_forms(robot):
    assert robot.chain("right_arm").joint_names == ["m0", "m10", "m11", "m12", "m13", "m14"]
    assert robot.chain("left_arm").joint_names == ["m0", "m20", "m21", "m22", "m23", "m24"]
    lift = robot.chain("right_arm_lift")
    assert lift.joint_names == ["mb", "m0", "m10", "m11", "m12", "m13", "m14"]
    assert (lift.base_frame, lift.tip_frame) == ("base_link", "r_eef")
    model = robot.model
    assert robot.nominal[model.joints[model.getJointId("mb")].idx_q] == 0.0
    assert np.all(robot.nominal >= model.lowerPositionLimit)
    assert np.all(robot.nominal <= model.upperPositionLimit)
    forms = robot.closed_forms
    for chain in ("right_arm", "left_arm"):
        assert {(chain, "pose"), (chain, "position")} <= set(forms)


def test_right_arm_fk_equals_the_thesis_closed_form(robot):
    chain = robot.chain("right_arm")
    rng = np.random.default_rng(2017)
    worst_position = worst_rotation = 0.0
    for q in rng.uniform(LOWER, UPPER, size=(1000, 6)):
        pose = chain.fk(q)
        position, rotation = thesis_fk(q)
        worst_position = max(worst_position, float(np.max(np.abs(pose.translation - position))))
        worst_rotation = max(worst_rotation, float(np.max(np.abs(pose.rotation - rotation))))
    assert worst_position < 1e-12
    assert worst_rotation < 1e-12


def test_zero_configuration_by_hand(robot):
    """At q = 0: l3 = l4 sin(rho) + l6, gripper at (l3, -l1 - l2, h - l4 cos(rho) - l5), frame = base."""
    pose = robot.chain("right_arm").fk(np.zeros(6))
    l3 = L4 * math.sin(RHO) + L6
    np.testing.assert_allclose(pose.translation, [l3, -(L1 + L2), H - L4 * math.cos(RHO) - L5],
                               atol=1e-15)
    np.testing.assert_allclose(pose.rotation, np.eye(3), atol=1e-15)


def test_left_arm_is_the_mirror_of_the_right(robot):
    right, left = robot.chain("right_arm"), robot.chain("left_arm")
    mirror = np.diag([1.0, -1.0, 1.0])
    rng = np.random.default_rng(3)
    for q in rng.uniform(LOWER, UPPER, size=(200, 6)):
        q_left = q.copy()
        q_left[0] = -q[0]  # the chest yaw is shared, not mirrored
        expected = right.fk(q)
        reached = left.fk(q_left)
        np.testing.assert_allclose(reached.translation, mirror @ expected.translation, atol=1e-12)
        np.testing.assert_allclose(reached.rotation, mirror @ expected.rotation @ mirror, atol=1e-12)


def test_both_arms_move_together_with_the_chest_yaw(robot):
    """In the full model, m0 turns both grippers about the torso's z axis."""
    q = robot.nominal.copy()
    before = [robot.frame_placement(q, f).translation for f in ("r_eef", "l_eef")]
    q[robot.model.joints[robot.model.getJointId("m0")].idx_q] = 0.4
    after = [robot.frame_placement(q, f).translation for f in ("r_eef", "l_eef")]
    for start, end in zip(before, after, strict=True):
        np.testing.assert_allclose(end, rz(0.4) @ start, atol=1e-12)


def test_torso_lift_adds_to_z(robot):
    arm, lift = robot.chain("right_arm"), robot.chain("right_arm_lift")
    rng = np.random.default_rng(4)
    for _ in range(50):
        q = rng.uniform(LOWER, UPPER)
        height = rng.uniform(0.0, 0.55)
        pose = lift.fk(np.concatenate([[height], q]))
        expected = arm.fk(q)
        np.testing.assert_allclose(pose.translation, expected.translation + [0.0, 0.0, height], atol=1e-12)
        np.testing.assert_allclose(pose.rotation, expected.rotation, atol=1e-12)
