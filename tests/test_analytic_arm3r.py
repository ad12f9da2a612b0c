"""Closed-form position IK of the 3-DOF arm of seed 001 (chain ``arm``), on (3, 2, 2) and random lengths."""

from __future__ import annotations

import time

import numpy as np
import pytest
from closed_form_checks import angle_difference

import wbik
from wbik.robot_packages.arm3r.model import DEFAULT_LENGTHS, start_configuration

ROUND_TRIP_POSES = 10_000
LENGTH_SETS = [DEFAULT_LENGTHS, tuple(np.random.default_rng(3).uniform(0.3, 3.0, 3).round(6)),
               tuple(np.random.default_rng(5).uniform(0.3, 3.0, 3).round(6))]


def make_solver(lengths):
    return wbik.solver("analytic", wbik.load("arm3r", lengths=lengths), chain="arm")


def test_seed_start_point_and_waypoints():
    """arm3r.md: theta = (pi/2, pi/2, pi/2) gives P0 = (0, -l3, l1 + l2); P1, P2, P3 are reachable."""
    solver = make_solver(DEFAULT_LENGTHS)
    position, _ = solver.closed_form("position").fk(start_configuration())
    np.testing.assert_allclose(position, [0.0, -2.0, 5.0], atol=1e-12)
    for point in ([2.0, -3.0, 3.0], [0.0, -2.0, 2.0], [0.0, -2.0, 5.0]):
        results = solver.solve_all(point)
        assert len(results) == 4  # 2 shoulder x 2 elbow branches, all inside +-pi
        for result in results:
            np.testing.assert_allclose(solver.chain.fk(result.q).translation, point, atol=1e-9)


@pytest.mark.parametrize("lengths", LENGTH_SETS)
def test_round_trip_10000(lengths):
    solver = make_solver(lengths)
    chain = solver.chain
    joints = chain.random(np.random.default_rng(1001), ROUND_TRIP_POSES)
    positions = np.array([chain.fk(q).translation for q in joints])
    results = solver.solve_many(positions)
    assert np.mean([r.success for r in results]) >= 0.9999
    for result in results:
        if result.success:
            assert chain.in_limits(result.q) and result.position_error <= 1e-6
    branches, valid = solver.closed_form("position").branches(positions, None, np.zeros_like(joints))
    match = np.all(angle_difference(branches, joints[:, None, :]) < 1e-7, axis=-1) & valid
    assert match.any(axis=1).mean() >= 0.999
    # started at the original joints, the nearest branch is the original
    again = solver.solve_many(positions[:1000], joints[:1000])
    recovered = [np.allclose(r.q, q, atol=1e-7) for r, q in zip(again, joints[:1000], strict=True)]
    assert np.mean(recovered) >= 0.999


@pytest.mark.parametrize("lengths", LENGTH_SETS[:2])
def test_solve_all_lists_distinct_branches_once(lengths):
    solver = make_solver(lengths)
    chain = solver.chain
    rng = np.random.default_rng(17)
    for q in chain.random(rng, 200):
        results = solver.solve_all(chain.fk(q).translation)
        assert len(results) == 4  # +-pi limits hold every branch, and random targets are not singular
        assert all(r.success and chain.in_limits(r.q) for r in results)
        for i in range(4):
            for j in range(i):
                assert np.max(angle_difference(results[i].q, results[j].q)) > 1e-6
        assert any(np.all(angle_difference(r.q, q) < 1e-7) for r in results)


def test_target_on_the_base_axis_keeps_q1_of_the_start():
    solver = make_solver(DEFAULT_LENGTHS)
    q0 = np.array([0.7, 1.0, 0.5])
    result = solver.solve([0.0, 0.0, 6.0], q0=q0)
    assert result.success
    assert abs(result.q[0] - 0.7) < 1e-12 or abs(angle_difference(result.q[0], 0.7 + np.pi)) < 1e-12


def test_batch_equals_scalar():
    solver = make_solver(LENGTH_SETS[1])
    chain = solver.chain
    rng = np.random.default_rng(23)
    positions = [chain.fk(q).translation for q in chain.random(rng, 300)]
    starts = chain.random(rng, 300)
    for position, start, batched in zip(positions, starts, solver.solve_many(positions, starts), strict=True):
        single = solver.solve(position, q0=start)
        assert single.success and batched.success
        np.testing.assert_allclose(single.q, batched.q, atol=1e-12)


def test_unreachable_targets_fail_quickly_with_a_reason():
    solver = make_solver(DEFAULT_LENGTHS)
    start = time.perf_counter()
    # beyond l2 + l3 = 4 from the shoulder (0, 0, 3)
    results = [solver.solve([5.0, 0.0, 3.0]), *solver.solve_many([[0.0, 0.0, 7.5], [3.0, 3.0, 3.0]])]
    assert time.perf_counter() - start < 0.5
    for result in results:
        assert not result.success and "unreachable" in result.reason
    # with l2 != l3 the inner circle |l2 - l3| is unreachable too
    solver = make_solver((1.0, 2.0, 0.5))
    result = solver.solve([0.5, 0.0, 1.0])  # 0.5 from the shoulder, inside the 1.5 hole
    assert not result.success and "unreachable" in result.reason
