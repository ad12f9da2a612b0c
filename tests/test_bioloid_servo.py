"""Bioloid servo map: units round trip, the note's servo columns (2.6, 3.8), the Robotis ready pose (1.7)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbik.apps.bioloid import servo
from wbik.errors import InvalidConfigurationError
from wbik.models import load
from wbik.robot_packages.bioloid import closed_form as ik


@pytest.fixture(scope="module")
def robot():
    return load("bioloid")


def test_units_radians_units_round_trip():
    for joint, spec in servo.SERVOS.items():
        low = math.ceil(spec.min_deg / servo.DEG_PER_UNIT)
        high = math.floor(spec.max_deg / servo.DEG_PER_UNIT)
        for units in range(low, high + 1):
            angle = servo.from_servo_units({spec.servo_id: units})[joint]
            command = servo.to_servo({joint: angle})
            assert command.units[spec.servo_id] == units
            assert command.ok


def test_centre_and_scale():
    assert servo.units_to_degrees(512) == pytest.approx(150.15, abs=0.01)  # the AX-12 centre
    assert servo.units_to_degrees(1023) == pytest.approx(300.0)
    assert servo.degrees_to_units(300.0) == 1023
    assert servo.degrees_to_units(servo.units_to_degrees(512)) == 512


def test_limits_agree_with_the_model(robot):
    """The URDF's joint limits map onto the servo limits (both ends), for all 18 joints."""
    model = robot.model
    for joint, spec in servo.SERVOS.items():
        j = model.joints[model.getJointId(joint)]
        ends = [spec.servo_degrees(model.lowerPositionLimit[j.idx_q]),
                spec.servo_degrees(model.upperPositionLimit[j.idx_q])]
        np.testing.assert_allclose(sorted(ends), [spec.min_deg, spec.max_deg], atol=1e-8)


# bioloid.md 3.8: (side, code ang[], servo deg, note)
LEG_SERVO_TABLE = [
    ("r", [0, 0, 35, -69, 35, 0], [105, 150, 115, 81, 185, 150]),
    ("r", [0, 0, 55, -69, 35, 0], [105, 150, 95, 81, 185, 150]),
    ("l", [0, 0, 55, -69, 35, 0], [195, 150, 205, 219, 115, 150]),
    ("r", [0, -7, 53, -67, 33, -7], [105, 157, 97, 83, 183, 157]),
    ("l", [0, -13, 51, -61, 31, -13], [195, 163, 201, 211, 119, 163]),
    ("l", [0, -17, 88, -114, 46, -17], [195, 167, 238, 254, 104, 167]),
    ("r", [0, 17, 88, -114, 46, 17], [105, 133, 62, 46, 196, 133]),
    ("l", [0, -13, 59, -54, 15, -13], [195, 163, 209, 204, 135, 163]),
    ("r", [0, 13, 59, -54, 15, 13], [105, 137, 91, 96, 165, 137]),
    ("r", [0, 0, 39, -63, 43, 0], [105, 150, 111, 87, 193, 150]),
    ("l", [0, -13, 35, -54, 39, -13], [195, 163, 185, 204, 111, 163]),
    ("r", [0, 0, 22, -44, 22, 0], [105, 150, 128, 106, 172, 150]),
    ("r", [0, 0, 11, -22, 11, 0], [105, 150, 139, 128, 161, 150]),
]


@pytest.mark.parametrize("side,ang,expected", LEG_SERVO_TABLE)
def test_leg_servo_column_through_the_code_pipeline(side, ang, expected):
    got, notes = servo.code_leg_servo_degrees(ang, side)
    np.testing.assert_array_equal(got, expected)
    if ang[3] == -114:  # the table's knee clamps: left 264 -> 254, right 36 -> 46
        assert notes == [f"{side}_knee: clamped from {264 if side == 'l' else 36} to {expected[3]}"]
    else:
        assert notes == []


@pytest.mark.parametrize("side,ang,expected", LEG_SERVO_TABLE)
def test_leg_servo_column_through_joint_angles(side, ang, expected):
    """Joint angles of the code's ang[] through the joint-level map give the same servo degrees."""
    q = servo.leg_q_from_ang(ang)
    names = [f"{side}_{name}" for name in servo.LEG_ORDER]
    command = servo.to_servo(dict(zip(names, q, strict=True)))
    ids = [servo.SERVOS[name].servo_id for name in names]
    np.testing.assert_allclose([command.degrees[i] for i in ids], expected, atol=1e-9)
    assert set(command.clamped) == ({f"{side}_knee"} if ang[3] == -114 else set())


def test_leg_ang_matches_the_ik_module():
    a = ik.leg_thesis_angles(np.array([[-0.03, 0.033, 0.14], [0.01, -0.02, 0.12]]), 0.05, 0.35, -0.1)
    np.testing.assert_allclose(servo.leg_ang_from_q(a.q), a.ang, atol=1e-12)
    np.testing.assert_allclose(servo.leg_q_from_ang(a.ang), a.q, atol=1e-12)


# bioloid.md 2.6: theta (deg, code variant) -> servo (base, shoulder, elbow)
ARM_SERVO_TABLE = [
    ((0.000, 14.576, -115.276), (62, 135, 240)),
    ((-26.565, 56.298, -137.923), (35, 94, 240)),
    ((45.000, 57.181, -102.327), (107, 93, 240)),
    ((-90.000, 41.228, -116.091), (-28, 109, 240)),
    ((0.000, -24.223, -79.108), (62, 174, 229)),
    ((-26.565, 11.014, -105.462), (35, 139, 240)),
    ((45.000, 18.233, -60.169), (107, 132, 210)),
    ((-90.000, 2.342, -80.186), (-28, 148, 230)),
    ((-33.690, -21.940, -88.005), (28, 172, 238)),
]


@pytest.mark.parametrize("theta,expected", ARM_SERVO_TABLE)
def test_arm_servo_column(theta, expected):
    got, notes = servo.code_arm_servo_degrees(theta)
    np.testing.assert_array_equal(got, expected)
    assert any("base" in n for n in notes) == (expected[0] < 0)
    q = np.radians([theta[0], -theta[1], -theta[2]])
    command = servo.to_servo(dict(zip(("r_shoulder_pitch", "r_shoulder_roll", "r_elbow"), q, strict=True)))
    # the table is the code's output: shoulder and elbow clamped, the base left as requested (its bug)
    base = command.clamped.get("r_shoulder_pitch", (command.degrees[1],))[0]
    np.testing.assert_allclose([base, command.degrees[3], command.degrees[5]], expected, atol=0.51)
    assert ("r_elbow" in command.clamped) == (theta[2] < -90)
    assert ("r_shoulder_pitch" in command.out_of_range) == (expected[0] < 0)


def test_ready_pose_maps_to_the_ik_standing_point(robot):
    """Robotis ready pose vs the IK standing pose (0, 0, 0.14), pitch 20 deg (bioloid.md 1.7).

    The note calls the IK standing servos (105, 150, 95, 81, 185, 150) "close to" the ready pose
    (105, 149, 100, 70, 190, 149): whole-degree differences (0, 1, 5, 11, 5, 1), the knee within
    about 10 deg, every other joint within 5 deg. Tolerance: +1 deg per joint, for rounding both
    whole-degree values of the note.
    """
    note_standing = np.array([105, 150, 95, 81, 185, 150], dtype=float)
    note_ready = np.array([105, 149, 100, 70, 190, 149], dtype=float)
    allowed = np.abs(note_standing - note_ready) + 1.0
    ready = servo.from_servo_units(servo.READY_POSE_UNITS)
    standing, ok = ik.leg_foot_to_hip(np.array([0.0, 0.0, 0.14]), pitch=math.radians(20.0))
    assert ok
    for side in ("r", "l"):
        names = [f"{side}_{name}" for name in servo.LEG_ORDER]
        ready_q = np.array([ready[name] for name in names])
        sign = np.array([1, 1, 1, 1, 1, 1.0]) if side == "r" else np.array([-1, -1, 1, 1, 1, -1.0])
        difference = np.degrees(np.abs(ready_q - sign * standing))
        assert np.all(difference <= allowed), (difference, allowed)


def test_ready_pose_reading_of_the_note(robot):
    """bioloid.md 1.7 [I]: ang2 = 50.0, ang3 = -79.6, ang4 = 39.7; hip above the ankle (beta ~ -0.1 deg),
    torso pitch ~ 10.1 deg, hip-ankle ~ 0.1338 m."""
    ready = servo.from_servo_units(servo.READY_POSE_UNITS)
    q = np.array([ready[f"r_{name}"] for name in servo.LEG_ORDER])
    np.testing.assert_allclose(servo.leg_ang_from_q(q)[2:5], [50.0, -79.6, 39.7], atol=0.05)
    hip = robot.chain("right_leg").fk(q).inverse()
    distance = np.linalg.norm(hip.translation)
    assert distance == pytest.approx(0.1338, abs=5e-5)
    beta = math.degrees(math.atan2(hip.translation[0], math.hypot(hip.translation[1], hip.translation[2])))
    assert beta == pytest.approx(-0.1, abs=0.05)
    pitch = math.degrees(math.atan2(hip.rotation[0, 2], hip.rotation[2, 2]))
    assert pitch == pytest.approx(10.1, abs=0.05)


def test_ready_pose_is_mirror_symmetric_under_the_map():
    """Independent check of the left-side offsets and directions (including the assumed left arm)."""
    ready = servo.from_servo_units(servo.READY_POSE_UNITS)
    mirror = {"shoulder_pitch": 1, "shoulder_roll": -1, "elbow": -1, "hip_yaw": -1, "hip_roll": -1,
              "hip_pitch": 1, "knee": 1, "ankle_pitch": 1, "ankle_roll": -1}
    for name, sign in mirror.items():
        assert math.degrees(abs(ready[f"l_{name}"] - sign * ready[f"r_{name}"])) < 0.7, name


def test_clamping_is_reported():
    command = servo.to_servo({"r_knee": math.radians(120.0), "r_hip_yaw": 0.0})
    assert list(command.clamped) == ["r_knee"]
    assert command.clamped["r_knee"] == pytest.approx((30.0, 46.0))
    assert command.degrees[13] == 46.0 and not command.ok
    command = servo.to_servo({"r_shoulder_pitch": math.radians(-80.0)})
    assert command.out_of_range == ["r_shoulder_pitch"]
    with pytest.raises(InvalidConfigurationError):
        servo.to_servo({"neck": 0.0})
    with pytest.raises(InvalidConfigurationError):
        servo.from_servo_units({19: 512})
    with pytest.raises(InvalidConfigurationError):
        servo.from_servo_units({1: 2000})
