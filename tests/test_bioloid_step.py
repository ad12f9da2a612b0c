"""The thesis's step forward: (a) faithful per-leg closed form, (b) whole-body QP, timing, servo table.

Reference values come from the note (bioloid.md 3.8, 4.4) and from computations done here by hand
(rotation matrices, scipy's convex hull), not from the code under test.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull

import wbik
from wbik.apps.bioloid.gait import (
    GaitParameters,
    step_forward_faithful,
    step_forward_phases,
    time_scale_motion,
)
from wbik.apps.bioloid.step_wholebody import step_forward_wholebody

SOLE_HALF = np.array([0.05, 0.03])  # bioloid model: 100 x 60 mm soles centred under the ankle


@pytest.fixture(scope="module")
def robot():
    return wbik.load("bioloid")


@pytest.fixture(scope="module")
def faithful(robot):
    return step_forward_faithful(robot)


@pytest.fixture(scope="module")
def wholebody(robot):
    return step_forward_wholebody(robot, margin=0.005)


def hull_margin(points_xy: np.ndarray, point: np.ndarray) -> float:
    """Distance from point to the boundary of the convex hull (positive inside), by scipy."""
    hull = ConvexHull(points_xy)
    return float(-np.max(hull.equations[:, :2] @ point + hull.equations[:, 2]))


def sole_corners_world(placement: pin.SE3) -> np.ndarray:
    local = np.array([[sx * SOLE_HALF[0], sy * SOLE_HALF[1], 0.0] for sx in (1, -1) for sy in (1, -1)])
    return local @ placement.rotation.T + placement.translation


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


# --- gait numbers --------------------------------------------------------------------------------
def test_gait_numbers_are_the_notes():
    gait = GaitParameters()
    assert gait.step_length == pytest.approx(0.030)
    assert gait.stride_length == pytest.approx(0.060)
    assert gait.lift_height == pytest.approx(0.040)
    points = gait.key_points()
    assert points["legDownMiddleRight"] == pytest.approx([0.0, -0.018, 0.14])
    assert points["legUpMiddleLeft"] == pytest.approx([-0.02, -0.03, 0.10])
    assert points["legDownForwardLeft"] == pytest.approx([-0.03, -0.033, 0.14])
    phases = step_forward_phases(gait)
    assert len(phases) == 5 and [p.lifted for p in phases] == [None, "l", "l", None, None]
    mirrored = step_forward_phases(gait, "right")
    assert mirrored[1].lifted == "r"
    assert mirrored[0].end["l"] == pytest.approx([0.0, 0.018, 0.14])


# --- (a) faithful ----------------------------------------------------------------------------------
def test_faithful_start_is_a_consistent_stance(robot, faithful):
    q0 = faithful.motion.q[0]
    for sole in ("r_sole", "l_sole"):
        placement = robot.frame_placement(q0, sole)
        assert abs(placement.translation[2]) < 1e-12
        assert np.allclose(placement.rotation, np.eye(3), atol=1e-12)


def test_faithful_double_support_is_not_a_closed_chain(robot, faithful):
    """End of phase 1: the right hip is 18 mm and the left hip 33 mm right of its foot (bioloid.md 4.5).

    The hip orientations reached by eq. 10-22, Rx(-t17) Ry(pitch) Rx(t17) with t17 = atan2(y, z),
    differ between the legs; the rigid pelvis turns the left foot by that relative rotation.
    """
    pitch = math.radians(20)
    hip_r = rx(-math.atan2(-0.018, 0.14)) @ ry(pitch) @ rx(math.atan2(-0.018, 0.14))
    hip_l = rx(-math.atan2(-0.033, 0.14)) @ ry(pitch) @ rx(math.atan2(-0.033, 0.14))
    expected_deg = math.degrees(np.linalg.norm(pin.log3(hip_r.T @ hip_l)))
    end_of_phase_1 = [s for s in faithful.samples if s["phase"] == 0][-1]
    assert end_of_phase_1["inconsistency_deg"] == pytest.approx(expected_deg, abs=1e-6)
    # the 15 mm lateral disagreement of the two hips, less what the tilt moves back
    assert 10.0 < end_of_phase_1["inconsistency_mm"] < 15.5
    summary = faithful.summary()
    assert summary["max_inconsistency_mm"] > 10.0
    assert summary["unreachable_samples"] == 0


def test_faithful_single_support_margin_is_below_five_mm(robot, faithful):
    """Measured independently: CoM over the right sole (axis-aligned rectangle) in phases 2-3."""
    single = [k + 1 for k, s in enumerate(faithful.samples) if s["phase"] in (1, 2)]
    margins = []
    for k in single:
        q = faithful.motion.q[k]
        sole = robot.frame_placement(q, "r_sole").translation
        com = robot.center_of_mass(q)
        d = SOLE_HALF - np.abs(com[:2] - sole[:2])
        margins.append(float(np.min(d)))
        assert faithful.samples[k - 1]["com_margin_m"] == pytest.approx(margins[-1], abs=1e-9)
    assert min(margins) < 0.005  # the thesis's lateral hip shift leaves less than a 5 mm margin


# --- (b) whole-body ----------------------------------------------------------------------------------
def test_wholebody_every_sample_keeps_contacts_and_com_margin(robot, wholebody):
    margin = 0.005
    motion = wholebody.motion
    q0 = motion.q[0]
    start = {sole: robot.frame_placement(q0, sole) for sole in ("r_sole", "l_sole")}
    landed_left = pin.SE3(start["l_sole"].rotation, start["l_sole"].translation + np.array([0.03, 0, 0]))
    for k in range(1, len(motion.q)):
        q = motion.q[k]
        phase = motion.phase[k]
        planted = {0: start, 1: {"r_sole": start["r_sole"]}, 2: {"r_sole": start["r_sole"]},
                   3: {"r_sole": start["r_sole"], "l_sole": landed_left}, 4: {"l_sole": landed_left}}[phase]
        for sole, wanted in planted.items():
            reached = robot.frame_placement(q, sole)
            assert np.linalg.norm(reached.translation - wanted.translation) <= 1e-6
            assert np.linalg.norm(pin.log3(wanted.rotation.T @ reached.rotation)) <= 1e-6
        last_of_phase = k + 1 == len(motion.q) or motion.phase[k + 1] != phase
        support = dict(planted)
        if last_of_phase and phase == 0:
            support = {"r_sole": start["r_sole"]}
        if last_of_phase and phase == 3:
            support = {"l_sole": landed_left}
        corners = np.vstack([sole_corners_world(p)[:, :2] for p in support.values()])
        com = robot.center_of_mass(q)
        assert hull_margin(corners, com[:2]) >= margin - 1e-9, (k, phase)
        model = robot.model
        joints = q[7:]
        assert np.all(joints >= model.lowerPositionLimit[7:] - 1e-9)
        assert np.all(joints <= model.upperPositionLimit[7:] + 1e-9)
    assert wholebody.passed


def test_wholebody_swing_foot_follows_the_key_points(robot, wholebody):
    """Top of phase 2: 40 mm up and 20 mm ahead; end of phase 3: down 30 mm ahead (bioloid.md 4.4)."""
    motion = wholebody.motion
    start = robot.frame_placement(motion.q[0], "l_sole").translation
    top = robot.frame_placement(motion.q[10], "l_sole").translation
    landed = robot.frame_placement(motion.q[15], "l_sole").translation
    assert top - start == pytest.approx([0.02, 0.0, 0.04], abs=1e-6)
    assert landed - start == pytest.approx([0.03, 0.0, 0.0], abs=1e-6)
    rear = robot.frame_placement(motion.q[-1], "r_sole").translation
    rear_start = robot.frame_placement(motion.q[0], "r_sole").translation
    assert rear - rear_start == pytest.approx([0.03, 0, 0], abs=1e-6)


def test_wholebody_removes_the_mismatch_the_faithful_step_has(faithful, wholebody):
    assert faithful.summary()["max_inconsistency_mm"] > 10.0
    summary = wholebody.summary()
    assert summary["max_contact_error_m"] <= 1e-6 and summary["max_contact_error_rad"] <= 1e-6
    assert summary["min_com_margin_mm"] >= 5.0 - 1e-6
    assert faithful.summary()["min_com_margin_mm"] < summary["min_com_margin_mm"]


def test_time_scaling_keeps_the_servo_speed(wholebody):
    """Finite differences of the timed joints on a 1 ms grid stay under 40 rpm; knots are passed."""
    timed = time_scale_motion(wholebody.motion, speed_rpm=40.0)
    limit = 40.0 * 2 * math.pi / 60
    step = 1e-3
    times = np.arange(0.0, timed.duration, step)
    q, _ = timed.evaluate(times)
    speeds = np.abs(np.diff(q, axis=0)) / step
    assert np.max(speeds) <= limit * (1 + 1e-6)
    assert np.max(speeds) >= 0.9 * limit  # minimum time: some joint runs near the limit
    at_knots, _ = timed.evaluate(timed.sample_times)
    assert np.allclose(at_knots, wholebody.motion.joint_matrix(), atol=1e-9)
    assert timed.peak_velocity_ratio() <= 1 + 1e-9


def test_servo_table_starts_at_the_notes_standing_servos(wholebody):
    """IK standing (0, 0, 0.14), pitch 20 deg -> right leg servo deg (105, 150, 95, 81, 185, 150),
    left leg (195, 150, 205, 219, 115, 150) (bioloid.md 3.8, rounded to whole degrees there)."""
    table = time_scale_motion(wholebody.motion).servo_table(dt=0.05)
    first = table["units"][0] * 300.0 / 1023
    right = first[[6, 8, 10, 12, 14, 16]]
    left = first[[7, 9, 11, 13, 15, 17]]
    assert right == pytest.approx([105, 150, 95, 81, 185, 150], abs=1.0)
    assert left == pytest.approx([195, 150, 205, 219, 115, 150], abs=1.0)
    assert table["units"].shape[1] == 18 and np.all((table["units"] >= 0) & (table["units"] <= 1023))


def test_right_first_step_is_the_mirror_image(robot, wholebody):
    right = step_forward_wholebody(robot, first="right")
    model = robot.model
    mirror = robot.facts.mirror_sign
    for k in (5, 10, 20, 25):
        for side, other in (("r", "l"), ("l", "r")):
            for joint in ("hip_roll", "knee", "ankle_pitch", "hip_yaw"):
                a = wholebody.motion.q[k][model.joints[model.getJointId(f"{side}_{joint}")].idx_q]
                b = right.motion.q[k][model.joints[model.getJointId(f"{other}_{joint}")].idx_q]
                assert b == pytest.approx(mirror[joint] * a, abs=2e-4)
