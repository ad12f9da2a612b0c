"""Closed-form IK of the PhantomX Pincher (chain ``arm``): pincher.md's regression values and round trips."""

from __future__ import annotations

import math
import time

import numpy as np
import pinocchio as pin
import pytest
from closed_form_checks import angle_difference, assert_pose_round_trip

import wbik
from wbik.robot_packages.pincher.closed_form import (
    PINCHER,
    pose_from_position_pitch,
    position_pitch_branches,
)
from wbik.solvers.analytic.closed_form import wrap_into_limits
from wbik.solvers.analytic.yaw_planar import pitch_arm_branches, pitch_arm_fk

ROUND_TRIP_POSES = 10_000


@pytest.fixture(scope="module")
def solver():
    return wbik.solver("analytic", wbik.load("pincher"), chain="arm")


@pytest.fixture(scope="module")
def samples(solver):
    """10,000 random joint vectors inside the limits (seeded) and their Pinocchio FK poses."""
    chain = solver.chain
    joints = chain.random(np.random.default_rng(4004), ROUND_TRIP_POSES)
    return joints, [chain.fk(q) for q in joints]


def test_seed_example_position_and_pitch():
    """pincher.md: [150, 200, 200] mm with pitch 60 deg gives [53.1301, 81.0504, 28.7724, -79.8228] deg."""
    branches, valid = position_pitch_branches(np.array([[0.150, 0.200, 0.200]]), np.radians([60.0]))
    assert valid.all()
    np.testing.assert_allclose(np.degrees(branches[0, 0]), [53.1301, 81.0504, 28.7724, -79.8228], atol=1e-4)
    # every branch (both elbows, both shoulder sides) reaches the point with the seed's tool pitch
    positions, rotations = pitch_arm_fk(PINCHER, branches[0])
    np.testing.assert_allclose(positions, np.tile([0.150, 0.200, 0.200], (4, 1)), atol=1e-12)
    np.testing.assert_allclose(np.degrees(np.arcsin(rotations[:, 2, 2])), 60.0, atol=1e-9)


def test_seed_example_through_the_solver(solver):
    target = pose_from_position_pitch([0.150, 0.200, 0.200], math.radians(60.0))
    expected = np.radians([53.1301, 81.0504, 28.7724, -79.8228])
    result = solver.solve(target, q0=expected + 0.01)
    assert result.success, result.reason
    np.testing.assert_allclose(result.q, expected, atol=1e-5)
    assert len(solver.solve_all(target)) == 2  # both elbows, the yaw is fixed by the rotation


def test_seed_fk_check_closed_form_and_round_trip(solver):
    """pincher.md: q = [15, 30, 45, 60] deg gives p = [213.5636, 57.2242, 187.9335] mm and this R."""
    q = np.radians([15.0, 30.0, 45.0, 60.0])
    position, rotation = pitch_arm_fk(PINCHER, q)
    np.testing.assert_allclose(position * 1000.0, [213.5636, 57.2242, 187.9335], atol=1e-4)
    np.testing.assert_allclose(rotation, [[0.6830, 0.2588, 0.6830], [0.1830, -0.9659, 0.1830],
                                          [0.7071, 0.0, -0.7071]], atol=1e-4)
    target = pin.SE3(rotation, position)
    assert any(np.allclose(result.q, q, atol=1e-9) for result in solver.solve_all(target))
    result = solver.solve(target, q0=np.zeros(4))
    assert result.success and solver.chain.in_limits(result.q)


def test_closed_form_fk_equals_pinocchio(solver, samples):
    joints, poses = samples
    positions, rotations = pitch_arm_fk(PINCHER, joints[:500])
    for position, rotation, pose in zip(positions, rotations, poses[:500], strict=True):
        np.testing.assert_allclose(position, pose.translation, atol=1e-12)
        np.testing.assert_allclose(rotation, pose.rotation, atol=1e-12)


def test_pose_round_trip_10000(solver, samples):
    joints, poses = samples
    assert_pose_round_trip(solver, joints, poses, branch_starts=np.zeros_like(joints))


def test_position_round_trip_10000(solver, samples):
    joints, poses = samples
    positions = [p.translation for p in poses]
    from_nominal = solver.solve_many(positions)
    assert np.mean([r.success for r in from_nominal]) >= 0.9999
    assert all(solver.chain.in_limits(r.q) for r in from_nominal if r.success)
    # started at the original joints, the rule (pitch nearest to q0's) gives back the original joints
    from_original = solver.solve_many(positions, joints)
    recovered = [r.success and np.allclose(r.q, q, atol=1e-7)
                 for r, q in zip(from_original, joints, strict=True)]
    assert np.mean(recovered) >= 0.999


def test_position_rule_takes_the_nearest_pitch_with_a_branch_in_limits(solver):
    """Brute force over a fine pitch grid: no in-limits branch has a pitch nearer to q0's than ours."""
    chain = solver.chain
    rng = np.random.default_rng(7)
    grid = np.linspace(-np.pi, np.pi, 3601)
    for _ in range(100):
        target = chain.fk(chain.random(rng)).translation
        q0 = chain.random(rng)
        result = solver.solve(target, q0=q0)
        assert result.success, result.reason
        pitch0 = math.pi / 2 - q0[1:].sum()
        pitch = math.pi / 2 - result.q[1:].sum()
        yaw = math.atan2(target[1], target[0])
        reach = math.hypot(target[0], target[1])
        best = np.inf
        for side_yaw, side_reach, side_pitch in ((yaw, reach, grid), (yaw + math.pi, -reach, grid)):
            branches, valid = pitch_arm_branches(PINCHER, np.full_like(grid, side_yaw),
                                                 np.full_like(grid, side_reach),
                                                 np.full_like(grid, target[2]), side_pitch)
            _, inside = wrap_into_limits(branches, q0, chain.lower, chain.upper, ~chain.is_prismatic)
            ok = (valid & inside).any(axis=1)
            if ok.any():
                best = min(best, angle_difference(grid[ok], pitch0).min())
        assert angle_difference(pitch, pitch0) <= best + 1e-9


def test_solve_all_lists_distinct_branches_once(solver, samples):
    joints, poses = samples
    for q, pose in zip(joints[:300], poses[:300], strict=True):
        results = solver.solve_all(pose)
        assert 1 <= len(results) <= 2
        assert all(r.success and solver.chain.in_limits(r.q) for r in results)
        assert any(np.all(angle_difference(r.q, q) < 1e-7) for r in results)
        if len(results) == 2:
            assert np.max(angle_difference(results[0].q, results[1].q)) > 1e-6


@pytest.mark.parametrize("kind", ["pose", "position"])
def test_batch_equals_scalar(solver, samples, kind):
    joints, poses = samples
    rng = np.random.default_rng(11)
    starts = solver.chain.random(rng, 300)
    targets = poses[:300] if kind == "pose" else [p.translation for p in poses[:300]]
    batch = solver.solve_many(targets, starts)
    for target, start, batched in zip(targets, starts, batch, strict=True):
        single = solver.solve(target, q0=start)
        assert single.success == batched.success
        if single.success:
            np.testing.assert_allclose(single.q, batched.q, atol=1e-12)


def test_unreachable_targets_fail_quickly_with_a_reason(solver):
    far = np.array([0.6, 0.0, 0.2])  # the arm reaches 0.305 m from the shoulder at most
    start = time.perf_counter()
    results = [solver.solve(far), solver.solve(pin.SE3(np.eye(3), far)),
               *solver.solve_many([far, far + 0.1])]
    assert time.perf_counter() - start < 0.5
    for result in results:
        assert not result.success and "unreachable" in result.reason
    # a reachable point with a rotation the 4-DOF arm cannot take (tool y axis tilted)
    tilted = pin.SE3(pin.rpy.rpyToMatrix(0.3, 0.2, 0.1), np.array([0.15, 0.0, 0.2]))
    result = solver.solve(tilted)
    assert not result.success and "unreachable" in result.reason
