"""Closed-form IK of the UR5 (ur_kinematics port) on chains ``ee`` (ee_link) and ``arm`` (tcp)."""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin
import pytest
from closed_form_checks import angle_difference, assert_pose_round_trip

import wbik

ROUND_TRIP_POSES = 10_000
CHAINS = ["ee", "arm"]


@pytest.fixture(scope="module")
def robot():
    return wbik.load("ur5")


@pytest.fixture(scope="module")
def solvers(robot):
    return {name: wbik.solver("analytic", robot, chain=name) for name in CHAINS}


def test_zero_configuration_by_hand(solvers):
    """At q = 0 the URDF offsets add up: x = 0.425 + 0.39225, y = 0.13585 - 0.1197 + 0.093 + 0.0823,
    z = 0.089159 - 0.09465 (ee_link in base_link); the tcp is 0.13 m further along ee_link's x."""
    expected = np.array([0.81725, 0.19145, -0.005491])
    position, _ = solvers["ee"].closed_form("pose").fk(np.zeros(6))
    np.testing.assert_allclose(position, expected, atol=1e-12)
    np.testing.assert_allclose(solvers["ee"].chain.fk(np.zeros(6)).translation, expected, atol=1e-12)
    tool_position, _ = solvers["arm"].closed_form("pose").fk(np.zeros(6))
    ee_x_axis = solvers["ee"].chain.fk(np.zeros(6)).rotation[:, 0]
    np.testing.assert_allclose(tool_position, expected + 0.13 * ee_x_axis, atol=1e-12)


@pytest.mark.parametrize("chain_name", CHAINS)
def test_closed_form_fk_equals_pinocchio(solvers, chain_name):
    solver = solvers[chain_name]
    joints = solver.chain.random(np.random.default_rng(55), 1000)
    positions, rotations = solver.closed_form("pose").fk(joints)
    worst = 0.0
    for q, position, rotation in zip(joints, positions, rotations, strict=True):
        pose = solver.chain.fk(q)
        worst = max(worst, np.abs(pose.translation - position).max(), np.abs(pose.rotation - rotation).max())
    assert worst < 1e-10


@pytest.mark.parametrize("chain_name", CHAINS)
def test_round_trip_10000(solvers, chain_name):
    solver = solvers[chain_name]
    chain = solver.chain
    joints = chain.random(np.random.default_rng(5005), ROUND_TRIP_POSES)
    poses = [chain.fk(q) for q in joints]
    assert_pose_round_trip(solver, joints, poses, branch_starts=joints)
    # started at the original joints, the nearest branch is the original (same 2 pi representation)
    again = solver.solve_many(poses[:1000], joints[:1000])
    recovered = [np.allclose(r.q, q, atol=1e-6) for r, q in zip(again, joints[:1000], strict=True)]
    assert np.mean(recovered) >= 0.999


@pytest.mark.parametrize("chain_name", CHAINS)
def test_solve_all_lists_every_real_branch_once(solvers, chain_name):
    solver = solvers[chain_name]
    chain = solver.chain
    form = solver.closed_form("pose")
    joints = chain.random(np.random.default_rng(8), 200)
    counts = []
    for q in joints:
        pose = chain.fk(q)
        results = solver.solve_all(pose)
        # every real branch reaching the pose, counted once (+-2 pi and elbow +-pi limits hold them all)
        branches, valid = form.branches(pose.translation[None], pose.rotation[None], q[None])
        reached, _ = form.fk(branches[0])
        real = valid[0] & (np.linalg.norm(reached - pose.translation, axis=1) < 1e-7)
        assert len(results) == real.sum()
        counts.append(len(results))
        assert all(r.success and chain.in_limits(r.q) for r in results)
        for i in range(len(results)):
            for j in range(i):
                assert np.max(angle_difference(results[i].q, results[j].q)) > 1e-6
        assert any(np.all(angle_difference(r.q, q) < 1e-7) for r in results)
    assert set(counts) <= {2, 4, 6, 8} and counts.count(8) > len(counts) // 4


@pytest.mark.numerics
def test_wrist_singularity_keeps_q6_of_the_start(solvers):
    solver = solvers["ee"]
    q = np.array([0.3, -1.0, 1.2, -0.5, 0.0, 0.8])
    q0 = q + np.array([0.01, 0.01, -0.01, 0.01, 0.01, 0.2])
    result = solver.solve(solver.chain.fk(q), q0=q0)
    assert result.success, result.reason
    assert abs(result.q[5] - q0[5]) < 1e-12  # q6 is free at s5 = 0: kept at the start's value
    assert abs(result.q[4]) < 1e-9


@pytest.mark.parametrize("chain_name", CHAINS)
def test_batch_equals_scalar(solvers, chain_name):
    solver = solvers[chain_name]
    chain = solver.chain
    rng = np.random.default_rng(31)
    poses = [chain.fk(q) for q in chain.random(rng, 300)]
    starts = chain.random(rng, 300)
    for pose, start, batched in zip(poses, starts, solver.solve_many(poses, starts), strict=True):
        single = solver.solve(pose, q0=start)
        assert single.success and batched.success
        np.testing.assert_allclose(single.q, batched.q, atol=1e-12)


@pytest.mark.parametrize("chain_name", CHAINS)
def test_unreachable_targets_fail_quickly_with_a_reason(solvers, chain_name):
    solver = solvers[chain_name]
    far = pin.SE3(np.eye(3), np.array([2.0, 0.5, 0.3]))  # the UR5 reaches about 0.95 m
    on_axis = pin.SE3(pin.rpy.rpyToMatrix(np.pi, 0.0, 0.0), np.array([0.0, 0.0, 0.5]))
    start = time.perf_counter()
    results = [solver.solve(far), *solver.solve_many([far, on_axis])]
    assert time.perf_counter() - start < 0.5
    for result in results:
        assert not result.success and "unreachable" in result.reason
