"""The task error of the iterative methods: geometry's pose-error convention and its SE(3) form,
checked against Pinocchio's log6 and finite differences (not against the code under test)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.solvers.task_error import batch_se3_error, task_error
from wbik.targets import Target


def test_task_error_is_reached_minus_target_and_its_jacobian_is_exact(rng):
    chain = wbik.load("panda").chain("arm")
    for q_goal, q in zip(chain.random(rng, 5), chain.random(rng, 5), strict=True):
        goal = chain.fk(q_goal)
        target = Target(goal.translation.copy(), goal.rotation.copy())
        error, jacobian = task_error(chain, target, q)
        reached = chain.fk(q)
        assert np.allclose(error[:3], reached.translation - goal.translation, atol=1e-14)
        # the rotation part: the rotation vector taking the target onto the reached, in target axes
        assert np.allclose(goal.rotation @ pin.exp3(error[3:]), reached.rotation, atol=1e-12)
        step = 1e-5  # central differences: O(step^2) error, rounding stays small near pi too
        numeric = np.column_stack([(task_error(chain, target, q + step * unit, False)[0]
                                    - task_error(chain, target, q - step * unit, False)[0]) / (2 * step)
                                   for unit in np.eye(chain.nq)])
        assert np.allclose(jacobian, numeric, atol=1e-6)
        point, point_jacobian = task_error(chain, Target(goal.translation.copy()), q)
        assert point.shape == (3,) and np.allclose(point_jacobian, jacobian[:3])


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-4, 0.3, 2.0, np.pi - 1e-7, np.pi])
def test_batched_se3_error_matches_pinocchio_log6_at_every_angle(angle, rng):
    count = 8
    axes = rng.normal(size=(count, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    target = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3))
    relative = [pin.SE3(pin.exp3(angle * axis), rng.normal(size=3)) for axis in axes]
    reached = [target * offset for offset in relative]
    rotations, positions = np.array([m.rotation for m in reached]), np.array([m.translation for m in reached])
    batched = batch_se3_error(rotations, positions, target.rotation, target.translation)
    for row, pose, offset in zip(batched, reached, relative, strict=True):
        expected = pin.log6(offset).vector  # T*^-1 T
        assert np.allclose(row, expected, atol=1e-12)
        # its rotation part is geometry's e_R = log3(R*^T R)
        assert np.allclose(row[3:], pin.log3(target.rotation.T @ pose.rotation), atol=1e-12)
