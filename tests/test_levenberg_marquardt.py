"""The one Levenberg-Marquardt policy: its scalar and batched forms make the same decisions, and its
steps are the damped least-squares steps written out here with plain numpy."""

from __future__ import annotations

import numpy as np
import pytest

from wbik.solvers.levenberg_marquardt import JointBounds, LevenbergMarquardt

POLICIES = [LevenbergMarquardt(), LevenbergMarquardt(max_step=0.2),
            LevenbergMarquardt(cost_weight=0.0, floor=1e-12, start=1e-3, increase=4.0, reject_floor=0.0,
                               stall=0, max_damping=1e6)]


def _case(rng, n: int, size: int):
    """Random residual Jacobians, errors and configurations, about a third of them on a bound."""
    lower, upper = -np.ones(n), np.ones(n)
    wraps = np.zeros(n, dtype=bool)
    wraps[0] = True
    lower[0], upper[0] = -np.pi, np.pi
    bounds = JointBounds(lower, upper, wraps)
    jacobian = rng.normal(size=(size, 6, n))
    error = rng.normal(size=(size, 6))
    q = rng.uniform(lower, upper, size=(size, n))
    on_bound = rng.random((size, n)) < 0.3
    q = np.where(on_bound, np.where(rng.random((size, n)) < 0.5, lower, upper), q)
    cost = np.einsum("bi,bi->b", error, error)
    base = 10.0 ** rng.uniform(-3, 1, size=size)  # J^T J of 7 joints is singular: keep it conditioned
    return bounds, jacobian, error, q, cost, base


def _reference_trial(policy: LevenbergMarquardt, jacobian, error, cost, base, q, bounds
                     ) -> tuple[np.ndarray, bool]:
    """The policy's trial written out: damped step, cap, freeze clipped joints pushed outwards, project."""
    n = q.size
    system = jacobian.T @ jacobian + (policy.cost_weight * cost + base) * np.eye(n)
    gradient = jacobian.T @ error
    step = -np.linalg.solve(system, gradient)

    def cap(step):
        if policy.max_step is not None and np.abs(step).max() > policy.max_step:
            return step * policy.max_step / np.abs(step).max()
        return step

    step = cap(step)
    froze = False
    if np.any((q + step < bounds.lower) | (q + step > bounds.upper)):
        blocked = ~bounds.wraps & (((q <= bounds.lower) & (step < 0)) | ((q >= bounds.upper) & (step > 0)))
        if blocked.any():
            froze = True
            free = ~blocked
            step = np.zeros(n)
            step[free] = -np.linalg.solve(system[np.ix_(free, free)], gradient[free])
            step = cap(step)
    trial = q + step
    wrapped = trial.copy()
    for k in np.flatnonzero(bounds.wraps):
        if not bounds.lower[k] <= wrapped[k] <= bounds.upper[k]:
            wrapped[k] = bounds.lower[k] + np.mod(wrapped[k] - bounds.lower[k], 2 * np.pi)
    return np.clip(wrapped, bounds.lower, bounds.upper), froze


@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("n", [4, 6, 7])  # normal equations (n <= 6 rows) and minimum-norm form (7)
def test_scalar_and_batched_trials_agree_with_the_written_out_step(policy, n, rng):
    bounds, jacobian, error, q, cost, base = _case(rng, n, 64)
    batched = policy.trial_batch(jacobian, error, cost, base, q, bounds)
    froze = 0
    workspace = policy.workspace(6, n)
    for b in range(len(q)):
        expected, froze_here = _reference_trial(policy, jacobian[b], error[b], cost[b], base[b], q[b], bounds)
        scalar = policy.trial(jacobian[b], error[b], float(cost[b]), float(base[b]), q[b], bounds)
        np.testing.assert_allclose(scalar, expected, rtol=0, atol=1e-12)
        reused = policy.trial(jacobian[b], error[b], float(cost[b]), float(base[b]), q[b], bounds, workspace)
        np.testing.assert_allclose(reused, scalar, rtol=0, atol=1e-12)  # a run's buffers: the same trial
        np.testing.assert_allclose(batched[b], expected, rtol=0, atol=1e-12)
        froze += froze_here
        assert np.all(batched[b] >= bounds.lower) and np.all(batched[b] <= bounds.upper)
    assert froze > 0  # the case exercises bound freezing


@pytest.mark.parametrize("policy", POLICIES)
def test_scalar_and_batched_damping_and_stall_decisions_agree(policy, rng):
    """Along random runs (random accept/reject, random costs), the scalar update and its batched twin
    give the same dampings and stall at the same iteration as the rule written out here."""
    runs, length = 60, 14
    accepted = rng.random((runs, length)) < 0.5
    costs = np.cumprod(rng.uniform(0.7, 1.05, size=(runs, length)), axis=1)
    start = 10.0 ** rng.uniform(-8, 5, size=runs)
    base, best, since = start.copy(), np.full(runs, np.inf), np.zeros(runs, dtype=int)
    batch_stall = np.full(runs, -1)
    batch_bases = []
    for k in range(length):
        base, best, since, stalled = policy.update_batch(accepted[:, k], base, costs[:, k], best, since)
        batch_stall = np.where((batch_stall < 0) & stalled, k, batch_stall)
        batch_bases.append(base.copy())
    stalls = 0
    for b in range(runs):
        scalar_base, scalar_best, scalar_since, scalar_stall = float(start[b]), np.inf, 0, -1
        expected_base, expected_best, count, expected_stall = float(start[b]), np.inf, 0, -1
        for k in range(length):
            scalar_base, scalar_best, scalar_since, stalled = policy.update(
                bool(accepted[b, k]), scalar_base, float(costs[b, k]), scalar_best, scalar_since)
            if stalled and scalar_stall < 0:
                scalar_stall = k
            # the rule in words
            expected_base = (max(policy.decrease * expected_base, policy.floor) if accepted[b, k]
                             else policy.increase * max(expected_base, policy.reject_floor))
            if costs[b, k] < policy.progress * expected_best:
                expected_best, count = costs[b, k], 0
            else:
                count += 1
            saturated = policy.max_damping is not None and expected_base > policy.max_damping
            if expected_stall < 0 and ((policy.stall and count >= policy.stall) or saturated):
                expected_stall = k
            assert scalar_base == expected_base == batch_bases[k][b]
        assert scalar_stall == expected_stall == batch_stall[b]
        stalls += expected_stall >= 0
    assert 0 < stalls < runs  # the runs exercise both outcomes


def test_projection_wraps_full_turns_and_clips_the_rest():
    bounds = JointBounds(np.array([-np.pi, -1.0]), np.array([np.pi, 1.0]), np.array([True, False]))
    projected = bounds.project(np.array([np.pi + 0.5, 1.5]))
    np.testing.assert_allclose(projected, [-np.pi + 0.5, 1.0], atol=1e-15)
    both = bounds.project(np.array([[np.pi + 0.5, 1.5], [0.2, -3.0]]))
    np.testing.assert_allclose(both, [[-np.pi + 0.5, 1.0], [0.2, -1.0]], atol=1e-15)


def test_keep_better_takes_the_trial_row_by_row_where_it_lowers_the_cost():
    from wbik.solvers.levenberg_marquardt import keep_better

    cost = np.array([1.0, 2.0, 3.0])
    trial_cost = np.array([0.5, 2.0, 4.0])  # better, equal (kept: not lower), worse
    q, trial_q = np.zeros((3, 2)), np.ones((3, 2))
    jacobian, trial_jacobian = np.zeros((3, 2, 2)), np.ones((3, 2, 2))
    accepted, new_cost, (kept_q, kept_jacobian) = keep_better(trial_cost, cost, (trial_q, q),
                                                              (trial_jacobian, jacobian))
    assert accepted.tolist() == [True, False, False]
    assert new_cost.tolist() == [0.5, 2.0, 3.0]
    assert kept_q.tolist() == [[1, 1], [0, 0], [0, 0]]
    assert kept_jacobian[0].sum() == 4 and kept_jacobian[1:].sum() == 0
