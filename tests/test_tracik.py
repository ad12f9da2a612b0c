"""TRAC-IK through pytracik: same URDF and chain, valid solutions, limits, unsupported target kinds."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

import wbik
from wbik.errors import UnsupportedError
from wbik.solvers.result import Tolerances

CHAINS = [("ur5", "arm"), ("golem3", "right_arm"), ("pincher", "arm"), ("bioloid", "right_leg"),
          ("panda", "arm")]


@cache
def robot(name: str) -> wbik.Robot:
    return wbik.load(name)


@pytest.mark.parametrize(("robot_name", "chain_name"), CHAINS)
def test_solutions_pass_fk_check_and_limits(robot_name, chain_name, rng):
    solver = wbik.solver("trac_ik", robot(robot_name), chain=chain_name, tolerances=Tolerances(1e-5, 1e-5))
    chain = solver.chain
    solved = 0
    for q in chain.random(rng, 200):
        target = chain.fk(q)
        result = solver.solve(target, chain.mid_range)
        if result.q is not None:
            assert chain.in_limits(result.q, tolerance=0.0)
        if result.success:
            solved += 1
            reached = chain.fk(result.q)
            assert np.linalg.norm(reached.translation - target.translation) <= 1e-5
            assert np.linalg.norm(wbik.targets.pose_error(reached, wbik.as_target(target))[1]) <= 1e-5
    assert solved >= 0.85 * 200  # measured 92-100 %


def test_tracik_limits_are_the_chains():
    solver = wbik.solver("trac_ik", robot("panda"))
    lower = np.array(solver.pytracik.get_joint_lower_bounds(solver._thread_state()))
    upper = np.array(solver.pytracik.get_joint_upper_bounds(solver._thread_state()))
    assert np.allclose(lower, solver.chain.lower) and np.allclose(upper, solver.chain.upper)


def test_position_only_is_unsupported():
    solver = wbik.solver("trac_ik", robot("ur5"), chain="arm")
    with pytest.raises(UnsupportedError, match="position-only"):
        solver.solve([0.3, 0.2, 0.4])
