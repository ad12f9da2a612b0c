"""Bioloid model: naming contract, the seed's geometry through FK, masses, mirror symmetry.

Expected numbers come from bioloid.md (tables of 1.5, 1.6, 2.6 and 3.8), not from the solvers.
The thesis -> joint conversion used here is the one documented in wbik/robot_packages/bioloid/model.py:
arm q = (theta1, -theta3, -theta5); leg q = (-theta7, -theta9, theta11 - 90, 180 - theta13,
theta15 - 90, theta17) in degrees.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from wbik.models import load
from wbik.robot_packages.bioloid import model as bioloid

MIRROR = np.diag([1.0, -1.0, 1.0])


@pytest.fixture(scope="module")
def robot():
    return load("bioloid")


def rot(axis: str, degrees: float) -> np.ndarray:
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return {"x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
            "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


def leg_q(theta7, theta9, theta11, theta13, theta15, theta17) -> np.ndarray:
    return np.radians([-theta7, -theta9, theta11 - 90.0, 180.0 - theta13, theta15 - 90.0, theta17])


def test_committed_urdf_is_the_generator_output():
    assert bioloid.URDF_PATH.read_text() == bioloid.urdf_text()


def test_naming_contract(robot):
    assert robot.has_floating_base
    assert robot.model.names[1] == "root_joint" or robot.model.joints[1].nq == 7
    for frame in ("pelvis", "chest", "r_hip", "l_hip", "r_ankle", "l_ankle", "r_sole", "l_sole",
                  "r_hand", "l_hand"):
        robot.frame_id(frame)
    expected_ids = {"r_shoulder_pitch": 1, "l_shoulder_pitch": 2, "r_shoulder_roll": 3, "l_shoulder_roll": 4,
                    "r_elbow": 5, "l_elbow": 6, "r_hip_yaw": 7, "l_hip_yaw": 8, "r_hip_roll": 9,
                    "l_hip_roll": 10, "r_hip_pitch": 11, "l_hip_pitch": 12, "r_knee": 13, "l_knee": 14,
                    "r_ankle_pitch": 15, "l_ankle_pitch": 16, "r_ankle_roll": 17, "l_ankle_roll": 18}
    assert robot.facts.servo_ids == expected_ids
    assert robot.model.nq == 7 + 18
    for joint, servo in expected_ids.items():
        assert robot.model.existJointName(joint)
        assert f"{joint}: Dynamixel ID {servo}." in robot.urdf_text
    assert robot.chain("right_leg").joint_names == ["r_hip_yaw", "r_hip_roll", "r_hip_pitch", "r_knee",
                                                     "r_ankle_pitch", "r_ankle_roll"]
    assert (robot.chain("left_leg").base_frame, robot.chain("left_leg").tip_frame) == ("l_hip", "l_ankle")
    assert robot.chain("right_arm").joint_names == ["r_shoulder_pitch", "r_shoulder_roll", "r_elbow"]
    assert (robot.chain("left_arm").base_frame, robot.chain("left_arm").tip_frame) == ("chest", "l_hand")
    corners = robot.soles
    assert set(corners) == {"r_sole", "l_sole"}
    assert corners["r_sole"].shape == (4, 3) and np.all(corners["r_sole"][:, 2] == 0.0)
    assert "ASSUMPTION" in robot.urdf_text


def test_frames_at_zero_joints(robot):
    """Hip yaw axis vertical through r_hip; r_ankle oriented like the pelvis; sole below the ankle."""
    q = pin.neutral(robot.model)
    hip = robot.frame_placement(q, "r_hip")
    ankle = robot.frame_placement(q, "r_ankle")
    sole = robot.frame_placement(q, "r_sole")
    np.testing.assert_allclose(ankle.rotation, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(ankle.translation - hip.translation, [0, 0, -0.150], atol=1e-12)
    np.testing.assert_allclose(sole.rotation, np.eye(3), atol=1e-12)
    assert sole.translation[2] < ankle.translation[2]
    yaw_id = robot.model.getJointId("r_hip_yaw")
    hip_frame = robot.model.frames[robot.frame_id("r_hip")]
    assert robot.model.jointPlacements[yaw_id].isApprox(hip_frame.placement)
    assert robot.model.joints[yaw_id].shortname() == "JointModelRZ"


def test_leg_lengths_match_the_thesis_geometry(robot):
    chain = robot.chain("right_leg")
    assert np.linalg.norm(chain.fk(np.zeros(6)).translation) == pytest.approx(0.150, abs=1e-12)
    alpha = math.atan2(0.0145, 0.075)
    q = np.array([0, 0, 0, 2 * alpha, 0, 0])
    assert np.linalg.norm(chain.fk(q).translation) == pytest.approx(0.152778, abs=1e-6)
    sweep = [np.linalg.norm(chain.fk(np.array([0, 0, 0, k, 0, 0])).translation)
             for k in np.linspace(chain.lower[3], chain.upper[3], 2001)]
    assert max(sweep) == pytest.approx(0.152778, abs=1e-6)
    # with the knee straight and at 4 alpha the hip-ankle distance is 2 L8 (the table's "straight" row)
    q = np.array([0, 0, 0, 4 * alpha, 0, 0])
    assert np.linalg.norm(chain.fk(q).translation) == pytest.approx(0.150, abs=1e-9)


# bioloid.md 3.8: (x, y, z) hip relative to foot, Pitch, theta17, theta13, theta15, theta11, theta9 (deg)
LEG_TABLE = [
    ((0, 0, 0.14), 0, 0, 110.916, 55.458, 55.458, 0),
    ((0, 0, 0.14), 20, 0, 110.916, 55.458, 35.458, 0),
    ((0, -0.018, 0.14), 20, -7.326, 113.124, 56.562, 36.562, -7.326),
    ((0, -0.033, 0.14), 20, -13.263, 118.718, 59.359, 39.359, -13.263),
    ((-0.02, -0.03, 0.10), 20, -16.699, 66.296, 43.993, 2.304, -16.699),
    ((-0.02, 0.03, 0.10), 20, 16.699, 66.296, 43.993, 2.304, 16.699),
    ((-0.03, -0.033, 0.14), 20, -13.263, 126.314, 74.938, 31.376, -13.263),
    ((-0.03, 0.033, 0.14), 20, 13.263, 126.314, 74.938, 31.376, 13.263),
    ((0.03, 0, 0.14), 20, 0, 117.278, 46.544, 50.734, 0),
    ((0.03, -0.033, 0.14), 20, -13.263, 126.314, 51.376, 54.938, -13.263),
    ((0, 0, 0.150), 0, 0, 136.231, 68.116, 68.116, 0),
    ((0, 0, 0.152778), 0, 0, 158.116, 79.058, 79.058, 0),
]


@pytest.mark.parametrize("row", LEG_TABLE)
@pytest.mark.parametrize("chain_name", ["right_leg", "left_leg"])
def test_leg_table_angles_reach_the_tabulated_hip_points(robot, row, chain_name):
    """FK of the table's joint angles puts the hip at the tabulated point, with the thesis orientation."""
    point, pitch, theta17, theta13, theta15, theta11, theta9 = row
    q = leg_q(0.0, theta9, theta11, theta13, theta15, theta17)
    ankle_in_hip = robot.chain(chain_name).fk(q)
    hip_in_ankle = ankle_in_hip.inverse()
    np.testing.assert_allclose(hip_in_ankle.translation, point, atol=2e-5)
    # the thesis's hip orientation: pitch about the leg plane's lateral axis, roll = theta9 - theta17
    expected = rot("x", -theta17) @ rot("y", pitch) @ rot("x", theta9)
    np.testing.assert_allclose(hip_in_ankle.rotation, expected, atol=1e-4)


def test_left_leg_mirrors_right(robot):
    rng = np.random.default_rng(3)
    right, left = robot.chain("right_leg"), robot.chain("left_leg")
    sign = np.array([-1, -1, 1, 1, 1, -1.0])
    for q in right.random(rng, 50):
        if not left.in_limits(sign * q):
            continue
        a, b = right.fk(q), left.fk(sign * q)
        np.testing.assert_allclose(b.translation, MIRROR @ a.translation, atol=1e-12)
        np.testing.assert_allclose(b.rotation, MIRROR @ a.rotation @ MIRROR, atol=1e-12)
    hips = [robot.frame_placement(pin.neutral(robot.model), f).translation for f in ("r_hip", "l_hip")]
    np.testing.assert_allclose(hips[1], MIRROR @ hips[0], atol=1e-15)


def test_left_arm_mirrors_right(robot):
    rng = np.random.default_rng(4)
    right, left = robot.chain("right_arm"), robot.chain("left_arm")
    sign = np.array([1, -1, -1.0])
    for q in right.random(rng, 50):
        a, b = right.fk(q), left.fk(sign * q)
        np.testing.assert_allclose(b.translation, MIRROR @ a.translation, atol=1e-12)
        np.testing.assert_allclose(b.rotation, MIRROR @ a.rotation @ MIRROR, atol=1e-12)


# bioloid.md 2.6: L4, target, theta1, theta3 (code variant), theta5 (deg)
ARM_TABLE = [
    (0.1445, (0.15, -0.10, 0.0), 0.000, 14.576, -115.276),
    (0.1445, (0.10, -0.12, -0.05), -26.565, 56.298, -137.923),
    (0.1445, (0.05, -0.20, 0.05), 45.000, 57.181, -102.327),
    (0.1445, (0.0, -0.15, -0.12), -90.000, 41.228, -116.091),
    (0.1000, (0.15, -0.10, 0.0), 0.000, -24.223, -79.108),
    (0.1000, (0.10, -0.12, -0.05), -26.565, 11.014, -105.462),
    (0.1000, (0.05, -0.20, 0.05), 45.000, 18.233, -60.169),
    (0.1000, (0.0, -0.15, -0.12), -90.000, 2.342, -80.186),
    (0.1000, (0.12, -0.09, -0.08), -33.690, -21.940, -88.005),
]


@pytest.fixture(scope="module")
def thesis_tool_robot():
    return load("bioloid", tool_length=bioloid.TOOL_THESIS)


@pytest.mark.parametrize("row", ARM_TABLE)
def test_arm_table_angles_reach_the_tabulated_targets(robot, thesis_tool_robot, row):
    forearm, target, theta1, theta3, theta5 = row
    model = robot if forearm == 0.1 else thesis_tool_robot
    assert model.facts.arm_lengths[4] == pytest.approx(forearm)
    q = np.radians([theta1, -theta3, -theta5])
    np.testing.assert_allclose(model.chain("right_arm").fk(q).translation, target, atol=2e-5)
    mirrored = np.radians([theta1, theta3, theta5])
    np.testing.assert_allclose(model.chain("left_arm").fk(mirrored).translation, MIRROR @ np.array(target),
                               atol=2e-5)


def test_arm_geometry_at_zero(robot):
    """q = 0: arm straight out sideways, hand at (L2, -(L0 + L1 + L3 + L4), 0) from the chest centre."""
    hand = robot.chain("right_arm").fk(np.zeros(3)).translation
    np.testing.assert_allclose(hand, [0.025, -(0.047 + 0.0145 + 0.0675 + 0.100), 0.0], atol=1e-12)


def test_mass_and_centre_of_mass(robot):
    assert robot.mass == pytest.approx(1.7, abs=0.1)
    bodies = [inertia.mass for inertia in robot.model.inertias[1:]]
    assert all(m > 0 for m in bodies)
    com = robot.center_of_mass(robot.nominal)
    half_length, half_width = bioloid.SOLE_LENGTH / 2, bioloid.SOLE_WIDTH / 2
    soles = [robot.frame_placement(robot.nominal, f).translation for f in ("r_sole", "l_sole")]
    assert abs(com[0] - soles[0][0]) < half_length  # inside the support polygon (front/back)
    assert soles[0][1] - half_width < com[1] < soles[1][1] + half_width
    assert 0.1 < com[2] < 0.3


def test_nominal_is_the_ik_standing_pose_with_soles_on_the_ground(robot):
    q = robot.nominal
    for side in ("r", "l"):
        sole = robot.frame_placement(q, f"{side}_sole")
        assert sole.translation[2] == pytest.approx(0.0, abs=1e-12)
        np.testing.assert_allclose(sole.rotation, np.eye(3), atol=1e-12)
        hip = robot.frame_placement(q, f"{side}_hip")
        ankle = robot.frame_placement(q, f"{side}_ankle")
        np.testing.assert_allclose(hip.translation - ankle.translation, [0, 0, 0.14], atol=1e-12)
        np.testing.assert_allclose(ankle.rotation.T @ hip.rotation, rot("y", 20.0), atol=1e-12)
    # table row "Standing (R), pitch 20": theta11 = 35.458, theta13 = 110.916, theta15 = 55.458
    np.testing.assert_allclose(robot.chain("right_leg").nominal, leg_q(0, 0, 35.458, 110.916, 55.458, 0),
                               atol=1e-4)
    for name in robot.chains:
        assert robot.chain(name).in_limits(robot.chain(name).nominal)


# bioloid.md 1.6: right leg servo limits (deg) and servo = 150 +- ang (3.6); q from ang as documented
def test_leg_limits_follow_the_code_servo_limits(robot):
    chain = robot.chain("right_leg")
    # servo -> ang (right leg, legDir = +1): yaw s = 105 + a0; roll s = 150 - a1; pitch s = 150 - a2;
    # knee s = 150 + a3; ankle pitch s = 150 + a4; ankle roll s = 150 - a5. Then q = (-a0..-a4, a5).
    servo = {"yaw": (55, 160), "roll": (100, 190), "pitch": (50, 175), "knee": (46, 160),
             "ankle_pitch": (120, 210), "ankle_roll": (110, 180)}
    ang = [(servo["yaw"][0] - 105, servo["yaw"][1] - 105),
           (150 - servo["roll"][1], 150 - servo["roll"][0]),
           (150 - servo["pitch"][1], 150 - servo["pitch"][0]),
           (servo["knee"][0] - 150, servo["knee"][1] - 150),
           (servo["ankle_pitch"][0] - 150, servo["ankle_pitch"][1] - 150),
           (150 - servo["ankle_roll"][1], 150 - servo["ankle_roll"][0])]
    signs = [-1, -1, -1, -1, -1, 1]
    for i, ((lo, hi), sign) in enumerate(zip(ang, signs, strict=True)):
        expected = sorted((sign * lo, sign * hi))
        np.testing.assert_allclose(np.degrees([chain.lower[i], chain.upper[i]]), expected, atol=1e-9)
    left = robot.chain("left_leg")
    mirrored = [-chain.upper[0], -chain.upper[1], *chain.lower[2:5], -chain.upper[5]]
    np.testing.assert_allclose(left.lower, mirrored)
