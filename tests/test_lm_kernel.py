"""The compiled Levenberg-Marquardt trial (``wbik/kernels/_lm_trial.c``) against its Python twin
(:meth:`LevenbergMarquardt.trial`: NumPy's products, LAPACK's Cholesky).

The kernel sums in index order, BLAS and LAPACK in their own: the trials agree to rounding (1e-12 here,
more for ill-conditioned systems). ``bounded_lm``'s decisions with either: tests/test_lm_attempt.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from compiled_twins import compared_with_its_twin

from wbik.solvers import levenberg_marquardt as lm
from wbik.solvers.levenberg_marquardt import JointBounds, LevenbergMarquardt

pytestmark = compared_with_its_twin(lm._LM_TRIAL)
AGREE = 1e-12


def tolerance(jacobian, error, damping, q, bounds, theirs):
    """1e-12, or more where the damped systems solved (all joints; the free ones when some froze) are
    ill-conditioned: both sides' rounding is amplified by the condition number."""
    rows, joints = jacobian.shape
    unconstrained = q - np.linalg.lstsq(jacobian.T @ jacobian + damping * np.eye(joints), jacobian.T @ error,
                                        rcond=None)[0]
    blocked = (np.clip(unconstrained, bounds.lower, bounds.upper) == q) & bounds.clipped
    systems = [np.arange(joints), np.flatnonzero(~blocked)]
    condition = 1.0
    for free in systems:
        if free.size:
            part = jacobian[:, free]
            system = part.T @ part if free.size <= rows else part @ part.T
            condition = max(condition, np.linalg.cond(system + damping * np.eye(system.shape[0])))
    return max(AGREE, 1e-15 * condition) * max(1.0, np.abs(theirs).max())


def both_trials(policy, bounds, jacobian, error, cost, base, q):
    compiled = policy.trial_function(bounds)
    assert compiled != policy.trial
    return (compiled(jacobian, error, cost, base, q, bounds),
            policy.trial(jacobian, error, cost, base, q, bounds, policy.workspace(*jacobian.shape)))


@pytest.mark.parametrize("rows, joints", [(6, 6), (6, 7), (3, 6), (6, 4), (3, 3)])
@pytest.mark.parametrize("max_step", [None, 0.3, 0.0])
def test_trials_agree_with_the_python_twin(rows, joints, max_step):
    """Random systems from seeds on and near the limits: free steps, clipped ones, frozen joints
    (re-solved on the free ones), wrapped full-turn joints and the step cap."""
    rng = np.random.default_rng(rows * 100 + joints)
    policy = LevenbergMarquardt(max_step=max_step)
    lower, upper = -rng.uniform(0.5, 3.0, joints), rng.uniform(0.5, 3.0, joints)
    wraps = rng.random(joints) < 0.3
    lower[wraps], upper[wraps] = -np.pi, np.pi
    bounds = JointBounds(lower, upper, wraps)
    frozen = 0
    for _ in range(300):
        jacobian = rng.normal(size=(rows, joints))
        error = rng.normal(scale=rng.choice([1e-3, 0.1, 2.0]), size=rows)
        q = rng.uniform(lower, upper)
        on_bound = rng.random(joints) < 0.3
        q[on_bound] = np.where(rng.random(on_bound.sum()) < 0.5, lower[on_bound], upper[on_bound])
        cost, base = float(error @ error), float(rng.choice([1e-6, 1e-3, 1.0]))
        ours, theirs = both_trials(policy, bounds, jacobian, error, cost, base, q)
        damping = policy.cost_weight * cost + base
        allowed = tolerance(jacobian, error, damping, q, bounds, theirs)
        assert np.abs(ours - theirs).max() <= allowed, (q, error)
        assert np.all((lower <= ours) & (ours <= upper))
        frozen += bool(np.any((ours == q) & on_bound))
    if max_step != 0.0:  # (a zero cap leaves every joint where it is)
        assert frozen > 10  # the frozen-joint path was taken


def test_a_failed_cholesky_hands_the_trial_to_the_python_twin():
    """A zero Jacobian without damping: no Cholesky; the Python twin's least squares decides."""
    policy, bounds = LevenbergMarquardt(), JointBounds(-np.ones(3), np.ones(3))
    jacobian, error, q = np.zeros((3, 3)), np.array([0.1, 0.0, 0.0]), np.zeros(3)
    inside = np.empty(3)
    assert lm._LM_TRIAL(jacobian, error, 0.0, q, bounds.lower, bounds.upper, None, -1.0, inside) is False
    ours, theirs = both_trials(policy, bounds, jacobian, error, 0.0, 0.0, q)
    assert np.array_equal(ours, theirs)


def test_a_nan_error_gives_the_python_twins_nan_trial():
    policy, bounds = LevenbergMarquardt(), JointBounds(-np.ones(4), np.ones(4))
    jacobian, error = np.eye(6, 4), np.array([np.nan, 0.1, 0, 0, 0, 0])
    ours, theirs = both_trials(policy, bounds, jacobian, error, 0.01, 1e-6, np.zeros(4))
    assert np.array_equal(ours, theirs, equal_nan=True) and np.isnan(ours[0])


def test_bad_buffers_are_refused_with_the_argument_named():
    trial, bounds = lm._LM_TRIAL, JointBounds(-np.ones(3), np.ones(3))
    good = [np.eye(3), np.ones(3), 1e-3, np.zeros(3), bounds.lower, bounds.upper, None, -1.0, np.empty(3)]
    assert trial(*good) is True
    for index, bad, name in [(0, np.eye(3).astype(np.float32), "jacobian"), (1, np.ones(4), "error"),
                             (3, [0.0, 0.0, 0.0], "q"), (6, np.ones(2), "wraps"),
                             (8, np.empty(3)[::-1], "out"),
                             (2, "x", "damping")]:
        arguments = list(good)
        arguments[index] = bad
        with pytest.raises(TypeError, match=name):
            trial(*arguments)
    assert trial(np.zeros((33, 3)), np.zeros(33), 1e-3, *good[3:]) is False  # too large: the Python twin


def test_other_bounds_or_large_systems_take_the_python_twin():
    policy, bounds = LevenbergMarquardt(), JointBounds(-np.ones(3), np.ones(3))
    trial = policy.trial_function(bounds)
    other = JointBounds(-0.1 * np.ones(3), 0.1 * np.ones(3))
    jacobian, error, q = np.eye(3), np.array([0.5, -0.5, 0.2]), np.zeros(3)
    assert np.array_equal(trial(jacobian, error, 0.54, 1e-6, q, other),
                          policy.trial(jacobian, error, 0.54, 1e-6, q, other))
    wide_bounds = JointBounds(-np.ones(40), np.ones(40))
    jacobian, error = np.eye(6, 40), np.full(6, 0.1)  # 40 joints: over the kernel's 32
    wide = policy.trial_function(wide_bounds)
    assert np.array_equal(wide(jacobian, error, 0.06, 1e-6, np.zeros(40), wide_bounds),
                          policy.trial(jacobian, error, 0.06, 1e-6, np.zeros(40), wide_bounds))
