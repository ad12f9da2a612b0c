"""Bioloid closed forms: the thesis tables (bioloid.md 2.6, 3.8), invariants, round trips, unreachability.

Expected numbers are the note's tables (computed there from the thesis equations); round trips
use Pinocchio FK of the URDF chains, not the closed forms' own FK.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest

import wbik
from wbik.errors import InvalidTargetError
from wbik.geometry import rot_x, rot_y, rot_z
from wbik.models import load
from wbik.robot_packages.bioloid import closed_form as ik
from wbik.robot_packages.bioloid import model as bioloid

TWO_LF = 2 * math.hypot(0.0145, 0.075)
ALPHA = math.atan2(0.0145, 0.075)


@pytest.fixture(scope="module")
def robot():
    return load("bioloid")


# bioloid.md 2.6, code-variant columns: L4, target, t, s, L_RA, c5, theta1, theta3, theta5
ARM_TABLE = [
    (0.1445, (0.15, -0.10, 0.0), 0.0385, 0.1250, 0.1308, -0.4270, 0.000, 14.576, -115.276),
    (0.1445, (0.10, -0.12, -0.05), 0.0585, 0.0868, 0.1047, -0.7422, -26.565, 56.298, -137.923),
    (0.1445, (0.05, -0.20, 0.05), 0.1385, 0.0457, 0.1458, -0.2135, 45.000, 57.181, -102.327),
    (0.1445, (0.0, -0.15, -0.12), 0.0885, 0.0950, 0.1298, -0.4398, -90.000, 41.228, -116.091),
    (0.1000, (0.15, -0.10, 0.0), 0.0385, 0.1250, 0.1308, 0.1890, 0.000, -24.223, -79.108),
    (0.1000, (0.10, -0.12, -0.05), 0.0585, 0.0868, 0.1047, -0.2666, -26.565, 11.014, -105.462),
    (0.1000, (0.05, -0.20, 0.05), 0.1385, 0.0457, 0.1458, 0.4974, 45.000, 18.233, -60.169),
    (0.1000, (0.0, -0.15, -0.12), 0.0885, 0.0950, 0.1298, 0.1704, -90.000, 2.342, -80.186),
    (0.1000, (0.12, -0.09, -0.08), 0.0285, 0.1192, 0.1226, 0.0348, -33.690, -21.940, -88.005),
]


@pytest.mark.parametrize("row", ARM_TABLE)
def test_arm_table(row):
    forearm, target, t, s, reach, c5, theta1, theta3, theta5 = row
    lengths = (0.047, 0.0145, 0.025, 0.0675, forearm)
    a = ik.arm_thesis_angles(np.array(target), lengths)
    assert bool(a.reachable)
    np.testing.assert_allclose([a.t, a.s, a.reach, a.c5], [t, s, reach, c5], atol=6e-5)
    got = np.degrees([a.theta1, a.theta3, a.theta5])
    np.testing.assert_allclose(got, [theta1, theta3, theta5], atol=6e-4)
    q, ok = ik.arm_ik(np.array(target), "right", lengths)
    np.testing.assert_allclose(np.degrees(q), [theta1, -theta3, -theta5], atol=6e-4)
    q_left, _ = ik.arm_ik(np.array(target) * [1, -1, 1], "left", lengths)
    np.testing.assert_allclose(np.degrees(q_left), [theta1, theta3, theta5], atol=6e-4)


def test_arm_batch_equals_scalar_and_all_branches_are_exact(robot):
    rng = np.random.default_rng(11)
    chain = robot.chain("right_arm")
    targets = np.array([chain.fk(q).translation for q in chain.random(rng, 200)])
    q_batch, ok = ik.arm_ik(targets)
    assert ok.all()
    for i in range(0, 200, 37):
        q_one, _ = ik.arm_ik(targets[i])
        np.testing.assert_array_equal(q_one, q_batch[i])
    for flip in (False, True):
        for elbow in (False, True):
            a = ik.arm_thesis_angles(targets, bioloid.build().facts.arm_lengths, elbow, flip)
            q = np.stack([a.theta1, -a.theta3, -a.theta5], -1)
            assert a.reachable.any()
            for i in np.flatnonzero(a.reachable)[::7]:
                np.testing.assert_allclose(chain.fk(q[i]).translation, targets[i], atol=1e-12)


def test_arm_unreachable_is_reported_not_nan():
    a = ik.arm_thesis_angles(np.array([[0.5, -0.1, 0.0], [0.0, -0.0615, 0.025]]))
    assert not a.reachable[0]
    assert np.all(np.isfinite([a.theta1, a.theta3, a.theta5]))


# bioloid.md 3.8: point, Pitch, gamma, beta, theta17, theta13, theta15, theta11, theta9, code ang[]
LEG_TABLE = [
    ((0, 0, 0.14), 0, 132.801, 0, 0, 110.916, 55.458, 55.458, 0, [0, 0, 35, -69, 35, 0]),
    ((0, 0, 0.14), 20, 132.801, 0, 0, 110.916, 55.458, 35.458, 0, [0, 0, 55, -69, 35, 0]),
    ((0, -0.018, 0.14), 20, 135.008, 0, -7.326, 113.124, 56.562, 36.562, -7.326, [0, -7, 53, -67, 33, -7]),
    ((0, -0.033, 0.14), 20, 140.602, 0, -13.263, 118.718, 59.359, 39.359, -13.263,
     [0, -13, 51, -61, 31, -13]),
    ((-0.02, -0.03, 0.10), 20, 88.181, -10.845, -16.699, 66.296, 43.993, 2.304, -16.699,
     [0, -17, 88, -114, 46, -17]),
    ((-0.02, 0.03, 0.10), 20, 88.181, -10.845, 16.699, 66.296, 43.993, 2.304, 16.699,
     [0, 17, 88, -114, 46, 17]),
    ((-0.03, -0.033, 0.14), 20, 148.198, -11.781, -13.263, 126.314, 74.938, 31.376, -13.263,
     [0, -13, 59, -54, 15, -13]),
    ((-0.03, 0.033, 0.14), 20, 148.198, -11.781, 13.263, 126.314, 74.938, 31.376, 13.263,
     [0, 13, 59, -54, 15, 13]),
    ((0.03, 0, 0.14), 20, 139.162, 12.095, 0, 117.278, 46.544, 50.734, 0, [0, 0, 39, -63, 43, 0]),
    ((0.03, -0.033, 0.14), 20, 148.198, 11.781, -13.263, 126.314, 51.376, 54.938, -13.263,
     [0, -13, 35, -54, 39, -13]),
    ((0, 0, 0.150), 0, 158.116, 0, 0, 136.231, 68.116, 68.116, 0, [0, 0, 22, -44, 22, 0]),
    ((0, 0, 0.152778), 0, 180.000, 0, 0, 158.116, 79.058, 79.058, 0, [0, 0, 11, -22, 11, 0]),
]


@pytest.mark.parametrize("row", LEG_TABLE)
def test_leg_table(row, robot):
    point, pitch, gamma, beta, theta17, theta13, theta15, theta11, theta9, ang = row
    if point[2] == 0.152778:  # the table's 2 Lf, printed rounded up by 2e-7 m: use the exact value
        point = (0, 0, TWO_LF)
    a = ik.leg_thesis_angles(np.array(point), 0.0, math.radians(pitch), 0.0)
    assert bool(a.reachable)
    got = np.degrees([a.gamma, a.beta, a.theta17, a.theta13, a.theta15, a.theta11, a.theta9, a.theta7])
    np.testing.assert_allclose(got, [gamma, beta, theta17, theta13, theta15, theta11, theta9, 0.0], atol=6e-4)
    np.testing.assert_array_equal(np.rint(a.ang), ang)
    # the joint angles reach the hip point (Pinocchio FK of both legs)
    for chain_name in ("right_leg", "left_leg"):
        q, ok = ik.leg_foot_to_hip(np.array(point), 0.0, math.radians(pitch), 0.0, chain_name.split("_")[0])
        hip = robot.chain(chain_name).fk(q).inverse()
        np.testing.assert_allclose(hip.translation, point, atol=1e-12)


def test_leg_invariants():
    rng = np.random.default_rng(5)
    points = rng.uniform([-0.04, -0.04, 0.09], [0.04, 0.04, 0.15], (500, 3))
    yaw, pitch, roll = (rng.uniform(-0.4, 0.4, 500) for _ in range(3))
    a = ik.leg_thesis_angles(points, yaw, pitch, roll)
    np.testing.assert_allclose(a.theta9 - a.theta17, roll, atol=1e-12)
    np.testing.assert_allclose(a.theta11 - a.theta13 + a.theta15, -pitch, atol=1e-12)
    np.testing.assert_allclose(a.ang[:, 2] + a.ang[:, 3] + a.ang[:, 4], np.degrees(pitch), atol=1e-9)
    np.testing.assert_allclose(a.theta7, yaw)


def test_thesis_leg_ik_is_exact_for_its_orientation(robot):
    """With any yaw, pitch, roll the thesis angles reach the hip point and Rx(-t17) Ry(P) Rx(t17+R) Rz(Y)."""
    rng = np.random.default_rng(6)
    chain = robot.chain("right_leg")
    points = rng.uniform([-0.03, -0.03, 0.10], [0.03, 0.03, 0.145], (50, 3))
    yaw, pitch, roll = (rng.uniform(-0.3, 0.3, 50) for _ in range(3))
    a = ik.leg_thesis_angles(points, yaw, pitch, roll)
    t17 = a.theta17
    rotations = rot_x(-t17) @ rot_y(pitch) @ rot_x(t17 + roll) @ rot_z(yaw)  # eq. 10-22's hip orientation
    for i in range(50):
        hip = chain.fk(a.q[i]).inverse()
        np.testing.assert_allclose(hip.translation, points[i], atol=1e-12)
        np.testing.assert_allclose(hip.rotation, rotations[i], atol=1e-12)
        # the thesis's answer is branch 0 of the general pose closed form
        branches, _ = ik.leg_branches(points[i:i + 1], rotations[i:i + 1])
        np.testing.assert_allclose(branches[0, 0], a.q[i], atol=1e-10)


def test_leg_unreachable_iff_longer_than_two_lf(robot):
    rng = np.random.default_rng(7)
    directions = rng.normal(size=(2000, 3))
    directions[:, 2] = np.abs(directions[:, 2])
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    lengths = rng.uniform(0.12, 0.18, 2000)
    a = ik.leg_thesis_angles(directions * lengths[:, None])
    np.testing.assert_array_equal(a.reachable, lengths <= TWO_LF)
    assert np.all(np.isfinite(a.q))
    solver = wbik.solver("analytic", robot, chain="right_leg")
    result = solver.solve(np.array([0.0, 0.0, -0.16]))
    assert not result.success and "unreachable" in result.reason


def test_leg_batch_equals_scalar():
    rng = np.random.default_rng(8)
    points = rng.uniform([-0.03, -0.03, 0.10], [0.03, 0.03, 0.145], (100, 3))
    q_batch, ok_batch = ik.leg_foot_to_hip(points, 0.1, 0.3, -0.05)
    for i in range(0, 100, 9):
        q_one, ok_one = ik.leg_foot_to_hip(points[i], 0.1, 0.3, -0.05)
        np.testing.assert_array_equal(q_one, q_batch[i])
        assert bool(ok_one) == bool(ok_batch[i])


def test_hip_to_foot_keeps_the_foot_parallel(robot):
    chain = robot.chain("left_leg")
    target = np.array([0.02, 0.015, -0.12])
    q, ok = ik.leg_foot_to_hip(-target, side="left")  # the code's IK6ServoLegtoFoot: foot -> hip of -p
    reached = chain.fk(q)
    np.testing.assert_allclose(reached.translation, target, atol=1e-12)
    np.testing.assert_allclose(reached.rotation, np.eye(3), atol=1e-12)


def test_bad_input_raises_typed_errors():
    with pytest.raises(InvalidTargetError):
        ik.leg_foot_to_hip([0.0, 0.1], side="right")
    with pytest.raises(InvalidTargetError):
        ik.leg_foot_to_hip([0.0, np.nan, 0.1])
    with pytest.raises(InvalidTargetError):
        ik.arm_ik([0.1, -0.1, 0.0], side="middle")


def walking_configurations(chain, rng, count: int) -> np.ndarray:
    """Random joints inside the limits with the knee on the walking branch (flexion >= 2 alpha)."""
    q = chain.random(rng, count)
    q[:, 3] = rng.uniform(2 * ALPHA, chain.upper[3], count)
    return q


def parallel_foot_configurations(chain, rng, count: int) -> np.ndarray:
    """Walking-branch joints with the foot parallel to the hip (reachable by the hip -> foot form)."""
    q = walking_configurations(chain, rng, 4 * count)
    q[:, 0] = 0.0
    q[:, 1] = -q[:, 5]
    q[:, 2] = -(q[:, 3] + q[:, 4])
    q = q[np.all((q >= chain.lower) & (q <= chain.upper), axis=1)]
    assert len(q) >= count
    return q[:count]


@pytest.mark.parametrize("chain_name,kind", [("right_leg", "pose"), ("left_leg", "pose"),
                                             ("right_leg", "position"), ("left_leg", "position"),
                                             ("right_arm", "position"), ("left_arm", "position")])
def test_round_trip_10000(robot, chain_name, kind):
    rng = np.random.default_rng(zlib.crc32(f"{chain_name}-{kind}".encode()))
    chain = robot.chain(chain_name)
    count = 10_000
    if "arm" in chain_name:
        q = chain.random(rng, count)
    elif kind == "pose":
        q = walking_configurations(chain, rng, count)
    else:
        q = parallel_foot_configurations(chain, rng, count)
    poses = [chain.fk(qq) for qq in q]
    targets = poses if kind == "pose" else [pose.translation.copy() for pose in poses]
    results = wbik.solver("analytic", robot, chain=chain_name).solve_many(targets)
    success = np.mean([r.success for r in results])
    assert success >= 0.9999, {r.reason for r in results if not r.success}
    worst = max(r.position_error for r in results if r.success)
    assert worst < 1e-9
    assert all(chain.in_limits(r.q) for r in results if r.success)


def test_solver_batch_equals_scalar(robot):
    rng = np.random.default_rng(12)
    for chain_name, kind in (("right_leg", "pose"), ("left_arm", "position")):
        chain = robot.chain(chain_name)
        q = walking_configurations(chain, rng, 20) if "leg" in chain_name else chain.random(rng, 20)
        targets = [chain.fk(qq) if kind == "pose" else chain.fk(qq).translation for qq in q]
        solver = wbik.solver("analytic", robot, chain=chain_name)
        many = solver.solve_many(targets)
        for target, batched in zip(targets, many, strict=True):
            single = solver.solve(target)
            assert single.success and batched.success
            np.testing.assert_allclose(single.q, batched.q, atol=1e-12)


def test_leg_position_keeps_the_foot_orientation_of_q0(robot):
    """Position targets whose foot is not parallel to the hip: the branch keeping q0's foot orientation."""
    rng = np.random.default_rng(13)
    chain = robot.chain("right_leg")
    solver = wbik.solver("analytic", robot, chain="right_leg")
    for q in walking_configurations(chain, rng, 20):
        target = chain.fk(q).translation
        result = solver.solve(target, q0=q)
        assert result.success
        np.testing.assert_allclose(result.q, q, atol=1e-9)


def test_leg_position_branches_keeping_the_ankle_joints_are_exact(robot):
    rng = np.random.default_rng(14)
    chain = robot.chain("left_leg")
    q = chain.random(rng, 100)
    q0 = chain.random(rng, 100)
    targets = np.array([chain.fk(qq).translation for qq in q])
    branches, reachable = ik.leg_position_branches_keeping_ankle(targets, q0)
    assert reachable.all()
    for i in range(0, 100, 11):
        for k in range(4):
            np.testing.assert_allclose(chain.fk(branches[i, k]).translation, targets[i], atol=1e-12)
            np.testing.assert_allclose(branches[i, k][[0, 4, 5]], q0[i][[0, 4, 5]])
