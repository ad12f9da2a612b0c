"""Ours (bounded_lm): solutions pass an independent FK check and respect limits on every chain."""

from __future__ import annotations

import time
from functools import cache

import numpy as np
import pytest

import wbik
from wbik.solvers.base import Tolerances

CHAINS = [("ur5", "arm"), ("golem3", "right_arm"), ("pincher", "arm"), ("bioloid", "right_leg"),
          ("panda", "arm")]
PROTOCOL = Tolerances(1e-5, 1e-5)


@cache
def robot(name: str) -> wbik.Robot:
    return wbik.load(name)


def independent_errors(chain, q, target) -> tuple[float, float]:
    """Position and rotation errors from the chain's FK, computed here (not by the solver)."""
    reached = chain.fk(q)
    position = float(np.linalg.norm(reached.translation - target.translation))
    cosine = (np.trace(target.rotation.T @ reached.rotation) - 1.0) / 2.0
    return position, float(np.arccos(np.clip(cosine, -1.0, 1.0)))


@pytest.mark.parametrize(("robot_name", "chain_name"), CHAINS)
def test_solutions_pass_fk_check_and_limits(robot_name, chain_name, rng):
    solver = wbik.solver("bounded_lm", robot(robot_name), chain=chain_name, tolerances=PROTOCOL)
    chain = solver.chain
    solved = 0
    for q in chain.random(rng, 200):
        target = chain.fk(q)
        result = solver.solve(target, chain.mid_range)
        assert result.q is not None and chain.in_limits(result.q, tolerance=0.0)
        if result.success:
            solved += 1
            position, rotation = independent_errors(chain, result.q, target)
            assert position <= 1e-5 and rotation <= 1e-5
        else:
            assert result.reason
    # measured 98.5-100 % on an idle machine (5 ms budget); a loaded machine costs a little
    assert solved >= 0.9 * 200


@pytest.mark.parametrize(("robot_name", "chain_name"), [("ur5", "arm"), ("arm3r", "arm"), ("panda", "arm")])
def test_position_only_targets(robot_name, chain_name, rng):
    # every target must be solved: a generous budget keeps this a correctness test on a loaded machine
    solver = wbik.solver("bounded_lm", robot(robot_name), chain=chain_name, timeout_s=0.2)
    chain = solver.chain
    for q in chain.random(rng, 20):
        point = chain.fk(q).translation
        result = solver.solve(point)
        assert result.success, result.reason
        assert np.linalg.norm(chain.fk(result.q).translation - point) <= 1e-6


def test_unreachable_target_ends_in_budget_with_reason():
    solver = wbik.solver("bounded_lm", robot("ur5"), chain="arm", timeout_s=0.01)
    start = time.perf_counter()
    result = solver.solve([3.0, 0.0, 0.0])  # UR5 reach is under 1 m
    elapsed = time.perf_counter() - start
    assert not result.success
    assert "time budget" in result.reason and "out of reach" in result.reason
    assert elapsed < 0.01 + 0.05
    assert result.extra["attempts"] >= 2  # it restarted from random seeds


def test_batched_seeds_solve(rng):
    solver = wbik.solver("bounded_lm", robot("ur5"), chain="arm", batch_size=4, timeout_s=0.05)
    chain = solver.chain
    for q in chain.random(rng, 10):
        target = chain.fk(q)
        result = solver.solve(target, chain.mid_range)
        assert result.success, result.reason
        assert independent_errors(chain, result.q, target)[0] <= 1e-6


def test_full_turn_joints_wrap_instead_of_clip():
    solver = wbik.solver("bounded_lm", robot("ur5"), chain="arm")
    chain = solver.chain
    q = chain.mid_range.copy()
    q[0] = chain.upper[0] + 0.3  # shoulder pan, range [-2 pi, 2 pi]
    q[2] = chain.upper[2] + 0.3  # elbow, range [-pi, pi]: also one full turn
    projected = solver.project(q)
    assert chain.in_limits(projected, tolerance=0.0)
    turns = (projected - q) / (2 * np.pi)
    assert np.allclose(turns, np.round(turns)) and round(turns[0]) != 0 and round(turns[2]) != 0
    assert np.allclose(chain.fk(projected).homogeneous, chain.fk(q).homogeneous, atol=1e-12)
    pincher = wbik.solver("bounded_lm", robot("pincher"))
    assert np.allclose(pincher.project(np.full(4, 3.0)), pincher.chain.upper)  # +-150 deg: clipped
