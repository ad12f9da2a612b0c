"""Damped least squares: valid solutions inside the limits, bounded time on unreachable targets."""

from __future__ import annotations

import time

import numpy as np
import pytest

import wbik
from wbik.solvers.result import Tolerances


@pytest.mark.parametrize(("robot_name", "chain_name"),
                         [("ur5", "arm"), ("golem3", "right_arm"), ("pincher", "arm"),
                          ("bioloid", "right_leg"), ("panda", "arm")])
def test_solutions_pass_fk_check_and_limits(robot_name, chain_name, rng):
    # 100 poses: a failing DLS solve uses its whole 5 ms budget
    solver = wbik.solver("dls", wbik.load(robot_name), chain=chain_name, tolerances=Tolerances(1e-5, 1e-5))
    chain = solver.chain
    solved = 0
    for q in chain.random(rng, 100):
        target = chain.fk(q)
        result = solver.solve(target, chain.mid_range)
        assert chain.in_limits(result.q, tolerance=0.0)
        if result.success:
            solved += 1
            assert np.linalg.norm(chain.fk(result.q).translation - target.translation) <= 1e-5
    assert solved >= 20  # from the mid-range seed alone; measured 43-94 %


def test_unreachable_returns_in_budget():
    solver = wbik.solver("dls", wbik.load("arm3r"), timeout_s=0.01)
    start = time.perf_counter()
    result = solver.solve([10.0, 0.0, 3.0])
    assert time.perf_counter() - start < 0.06
    assert not result.success and result.reason
