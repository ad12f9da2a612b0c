"""The Golem-III thesis's own solvers (``thesis_literal``, ``thesis_sweep``): agreement with our closed
form on ordinary poses, the thesis's failure on rounding-negative square roots (constructed), the
sweep's visiting order (hand-written from the thesis code's loops) and its exact positions."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.apps.golem3.thesis_solvers import SWEEP_POINTS, sweep_order
from wbik.errors import InvalidSettingError, UnsupportedError, WbikError
from wbik.solvers.check import evaluate
from wbik.solvers.result import Candidate

RHO = math.radians(13.43)  # golem3.md, DH table: rho = 13.43 deg


@pytest.fixture(scope="module")
def golem():
    return wbik.load("golem3")


def _poses(chain, count, seed):
    joints = chain.random(np.random.default_rng(seed), count)
    return joints, [chain.fk(q) for q in joints]


def _same_solution_sets(first, second, tolerance):
    """Every solution of one list has one within ``tolerance`` (max joint difference) in the other."""
    if len(first) != len(second):
        return False
    for q in first:
        if min(np.max(np.abs(q - other)) for other in second) > tolerance:
            return False
    return True


# -- applicability and options ------------------------------------------------------------------------
def test_only_the_golem3_arm_chains(golem):
    for method in ("thesis_literal", "thesis_sweep"):
        for chain in ("right_arm", "left_arm"):
            wbik.solver(method, golem, chain=chain)  # builds
        with pytest.raises(UnsupportedError):
            wbik.solver(method, "ur5", chain="arm")
        others = [name for name in golem.chains if name not in ("right_arm", "left_arm")]
        assert others, "golem3 has chains besides the two arms"
        with pytest.raises(UnsupportedError):
            wbik.solver(method, golem, chain=others[0])


def test_target_kinds_and_bad_yaw(golem):
    chain = golem.chain("right_arm")
    placement = chain.fk(chain.nominal)
    with pytest.raises(UnsupportedError):
        wbik.solver("thesis_literal", golem, chain="right_arm").solve(placement.translation)
    with pytest.raises(UnsupportedError):
        wbik.solver("thesis_sweep", golem, chain="right_arm").solve(placement)
    for yaw in (2.0, float("nan"), "0", True):  # t6 limits are +-1.5 rad
        with pytest.raises(InvalidSettingError) as error:
            wbik.solver("thesis_sweep", golem, chain="right_arm", yaw=yaw)
        assert isinstance(error.value, WbikError)


# -- thesis_literal --------------------------------------------------------------------------------
@pytest.mark.parametrize("arm", ["right_arm", "left_arm"])
def test_literal_agrees_with_the_clamped_closed_form_on_ordinary_poses(golem, arm):
    chain = golem.chain(arm)
    literal = wbik.solver("thesis_literal", golem, chain=arm)
    analytic = wbik.solver("analytic", golem, chain=arm)
    joints, placements = _poses(chain, 60, seed=11)
    for q_true, placement in zip(joints, placements, strict=True):
        ours = [r.q for r in analytic.solve_all(placement)]
        theirs = [r.q for r in literal.solve_all(placement)]
        assert ours, "FK of in-limit joints: the clamped closed form finds it"
        assert _same_solution_sets(theirs, ours, 1e-9), (q_true, theirs, ours)
        assert any(np.max(np.abs(q - q_true)) < 1e-9 for q in theirs), "the sampled joints are a branch"


def test_literal_nearest_branch_is_the_thesis_selection(golem):
    """The returned joints are the accepted branch nearest q0 (thesis ch. 4.4)."""
    chain = golem.chain("right_arm")
    literal = wbik.solver("thesis_literal", golem, chain="right_arm")
    joints, placements = _poses(chain, 30, seed=5)
    q0 = chain.random(np.random.default_rng(6), 1)[0]
    for placement in placements:
        result = literal.solve(placement, q0)
        every = [r.q for r in literal.solve_all(placement)]
        if result.success:
            nearest = min(every, key=lambda q: np.linalg.norm(q - q0))
            assert np.max(np.abs(result.q - nearest)) < 1e-12


def test_literal_loses_a_reachable_pose_to_a_rounding_negative_square_root(golem):
    """At t4 = -rho, cos(t4 + rho) = 1 exactly in theory; rounding puts the computed value above 1 for
    some poses, 1 - cos^2 < 0, and the thesis's closed form (no clamp) answers "no solution" for a pose
    that FK of in-limit joints produced. Our clamped closed form solves the same pose."""
    chain = golem.chain("right_arm")
    literal = wbik.solver("thesis_literal", golem, chain="right_arm")
    analytic = wbik.solver("analytic", golem, chain="right_arm")
    joints = chain.random(np.random.default_rng(0), 100)
    joints[:, 3] = -RHO
    lost = []
    for q_true in joints:
        placement = chain.fk(q_true)
        result = literal.solve(placement)
        if result.q is None:
            lost.append((q_true, placement, result))
    assert lost, "some of 100 poses at t4 = -rho lose every branch to rounding"
    for q_true, placement, result in lost[:5]:
        assert chain.in_limits(q_true)
        reachable = evaluate(chain, wbik.targets.as_target(placement), Candidate(q_true), literal.tolerances,
                             0.0, "fk")
        assert reachable.success and reachable.position_error < 1e-12
        assert not result.success
        assert result.extra["negative_sqrt"] == 8
        assert -1e-12 < result.extra["min_negative_sqrt_argument"] < 0.0  # rounding, not a far target
        assert "negative square-root argument" in result.reason
        # independently: the thesis's cos(t4 + rho) from z and pitch (eq. 4.2 with rho) rounds above 1
        # in the same arithmetic, i.e. the square root's argument is negative
        beta = -(q_true[3] + q_true[4])
        z = placement.translation[2]
        cosine = (1.283 - z - 0.034 * math.cos(-beta) + 0.4 * math.sin(-beta)) / 0.256
        assert abs(cosine - 1.0) < 1e-12
        assert analytic.solve(placement).success


def test_literal_left_arm_is_the_mirror_of_the_right(golem):
    right, left = golem.chain("right_arm"), golem.chain("left_arm")
    solver_right = wbik.solver("thesis_literal", golem, chain="right_arm")
    solver_left = wbik.solver("thesis_literal", golem, chain="left_arm")
    joints = right.random(np.random.default_rng(3), 20)
    mirror = np.diag([1.0, -1.0, 1.0])
    for q in joints:
        q_left = q.copy()
        q_left[0] = -q_left[0]
        placement = right.fk(q)
        mirrored = pin.SE3(mirror @ placement.rotation @ mirror, mirror @ placement.translation)
        assert np.allclose(left.fk(q_left).homogeneous, mirrored.homogeneous, atol=1e-12)
        a, b = solver_right.solve(placement), solver_left.solve(mirrored)
        assert a.success == b.success
        if a.success:
            assert np.allclose(b.q, np.r_[-a.q[0], a.q[1:]], atol=1e-9)


# -- thesis_sweep --------------------------------------------------------------------------------
def test_sweep_order_is_the_thesis_codes():
    order = sweep_order()
    first = [(0.0, 0.0), (0.0, 0.01), (0.0, -0.01), (0.0, 0.02), (0.0, -0.02), (0.0, 0.03), (0.0, -0.03),
             (0.0, 0.04), (0.0, -0.04)]
    assert np.allclose(order[:9], first, atol=1e-12, rtol=0.0)
    assert order.shape == (599 * 599, 2) and SWEEP_POINTS == 358801
    assert np.allclose(order[597:601], [(0.0, 2.99), (0.0, -2.99), (0.01, 0.0), (0.01, 0.01)], atol=1e-12)
    assert np.allclose(order[2 * 599], (-0.01, 0.0), atol=1e-12)
    assert np.allclose(order[-1], (-2.99, -2.99), atol=1e-11)
    assert len(np.unique(np.round(order, 6), axis=0)) == len(order)


@pytest.mark.parametrize("arm", ["right_arm", "left_arm"])
def test_sweep_reaches_positions_exactly_at_the_first_solvable_orientation(golem, arm):
    chain = golem.chain(arm)
    sweep = wbik.solver("thesis_sweep", golem, chain=arm, yaw=0.3)
    assert sweep.max_iterations == SWEEP_POINTS
    order = sweep_order()
    joints, placements = _poses(chain, 4, seed=21)
    for placement in placements:
        target = placement.translation
        result = sweep.solve(target)
        assert result.success and result.position_error <= 1e-6
        assert np.linalg.norm(chain.fk(result.q).translation - target) <= 1e-6
        assert result.q[5] == pytest.approx(0.3, abs=1e-15)
        visited = result.iterations
        roll, pitch = order[visited - 1]
        assert (result.extra["roll"], result.extra["pitch"]) == (roll, pitch)
        # the joints realise that orientation in right-arm coordinates (m0 negated on the left arm):
        # gamma = t1 + t2 + t3 = roll, beta = -t4 - t5 = pitch (golem3.md)
        q_right = result.q.copy()
        if arm == "left_arm":
            q_right[0] = -q_right[0]
        assert abs(math.remainder(q_right[0] + q_right[1] + q_right[2] - roll, 2 * math.pi)) < 1e-9
        assert abs(math.remainder(-(q_right[3] + q_right[4]) - pitch, 2 * math.pi)) < 1e-9
        # one evaluation fewer finds nothing: every earlier point of the order had no solution
        if visited > 1:
            short = wbik.solver("thesis_sweep", golem, chain=arm, yaw=0.3, max_iterations=visited - 1)
            failed = short.solve(target)
            assert not failed.success and failed.q is None and failed.iterations == visited - 1
            assert "iteration budget" in failed.reason


def test_sweep_of_an_unreachable_position_runs_to_the_end(golem):
    sweep = wbik.solver("thesis_sweep", golem, chain="right_arm")
    result = sweep.solve(np.array([2.0, 0.0, 1.3]))  # 2 m from the chest axis: l1 + l2 + l4 + l6 < 1 m
    assert result.q is None and not result.success
    assert result.iterations == SWEEP_POINTS
    assert "whole sweep" in result.reason


def test_sweep_budget_follows_timeout_like_our_other_methods(golem):
    sweep = wbik.solver("thesis_sweep", golem, chain="right_arm", timeout_s=0.003)
    assert sweep.max_iterations == math.ceil(0.003 / type(sweep).iteration_cost_s)
    from wbik.errors import InvalidBudgetError
    with pytest.raises(InvalidBudgetError):
        wbik.solver("thesis_sweep", golem, chain="right_arm", max_iterations=0)
