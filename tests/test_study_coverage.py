"""Solution coverage against a complete closed form, on a UR5 pose whose eight branches are
enumerated here: which branch an answer is, whether it is the one nearest the start, how many
distinct branches restarts reach, the distance from the start."""

from __future__ import annotations

import numpy as np
import pytest

import wbik
from wbik.geometry import joint_gap, wrap_to_pi
from wbik.study.closed_form_branches import complete_closed_form, in_limit_branches
from wbik.study.context import case_chain
from wbik.study.solution_coverage import (
    coverage_columns,
    coverage_summary,
    distinct_solutions,
    restart_starts,
)

PARAMETERS = {"restarts": 6, "restart_targets": 1, "branch_tolerance": 1e-3}


@pytest.fixture(scope="module")
def ur5():
    chain = case_chain("ur5", (), "arm")
    q_true = np.array([0.4, -1.1, 1.3, -0.6, 1.2, 0.3])
    target = chain.fk(q_true)
    return chain, q_true, target


@pytest.fixture(scope="module")
def branches(ur5):
    chain, q_true, target = ur5
    form = complete_closed_form(chain)
    found = form.branches(target.translation[None], target.rotation[None])[0]
    return in_limit_branches(found, chain)


def test_the_pose_has_eight_distinct_branches_each_reaching_it(ur5, branches):
    chain, q_true, target = ur5
    revolute = ~chain.is_prismatic
    assert branches.shape == (8, 6)
    for i, q in enumerate(branches):
        assert chain.fk(q).isApprox(target, 1e-9)
        others = np.delete(branches, i, axis=0)
        assert np.min(joint_gap(others, q, revolute)) > 0.1  # distinct, modulo 2 pi
    assert np.min(joint_gap(branches, q_true, revolute)) < 1e-9  # the generating joints are one


def _nearest_by_hand(branches: np.ndarray, chain, start: np.ndarray) -> int:
    """The branch nearest ``start`` once each angle is shifted by 2 pi k into the limits nearest the start
    (the UR5's ranges are 4 pi or 2 pi: the shift nearest the start is inside)."""
    wrapped = start + wrap_to_pi(branches - start)
    wrapped = np.where((wrapped >= chain.lower) & (wrapped <= chain.upper), wrapped,
                       wrapped - np.sign(wrapped) * 2 * np.pi)
    return int(np.argmin(np.linalg.norm(wrapped - start, axis=1)))


def test_coverage_columns_match_a_hand_computed_chunk(ur5, branches):
    chain, q_true, target = ur5
    revolute = ~chain.is_prismatic
    rng = np.random.default_rng(4)
    q0 = np.array([branches[2] + rng.uniform(-0.05, 0.05, 6), branches[2] + rng.uniform(-0.05, 0.05, 6),
                   chain.nominal])
    answers = np.array([branches[2] + 2 * np.pi * (branches[2] < 0), branches[5], np.full(6, np.nan)])
    columns = {"q": answers, "success": np.array([True, True, False])}
    analytic = wbik.solver("analytic", chain.robot, chain="arm")
    calls = []

    def nearest_branch_answer(pose, start):  # a method that always answers the branch nearest the start
        calls.append(start)
        return analytic.solve(pose, start)

    positions = np.tile(target.translation, (3, 1))
    rotations = np.tile(target.rotation, (3, 1, 1))
    out = coverage_columns(chain, columns, q0, positions, rotations, 0, 17, PARAMETERS, nearest_branch_answer)
    index_of = {i: int(np.argmin(joint_gap(branches, b, revolute))) for i, b in enumerate(branches)}
    assert out["branches_in_limits"].tolist() == [8, 8, 8]
    assert out["branch"].tolist() == [index_of[2], index_of[5], -1]  # 2 pi apart is the same branch
    assert out["same_branch"].tolist() == [1, 0, -1]  # start 0.05 rad from branch 2: its nearest is branch 2
    assert np.allclose(out["start_distance"][:2], np.linalg.norm(answers[:2] - q0[:2], axis=1))
    assert np.isnan(out["start_distance"][2])
    # restarts on pose 0 only (restart_targets 1): six starts, each answered by its nearest branch
    starts = restart_starts(chain, 17, 0, 6)
    assert np.array_equal(np.array(calls), starts)
    expected = len({_nearest_by_hand(branches, chain, start) for start in starts})
    assert out["restart_solved"].tolist() == [6, -1, -1]
    assert out["restart_branches"].tolist() == [expected, -1, -1] and out["restart_others"][0] == 0
    summary = coverage_summary({**columns, **out})
    assert (summary["same_branch"], summary["compared"], summary["percent_on_a_branch"]) == (1, 2, 100.0)
    assert summary["percent_branches_reached"] == pytest.approx(100.0 * expected / 8)


def test_bounded_lm_from_near_each_branch_reaches_every_branch(ur5, branches):
    chain, q_true, target = ur5
    revolute = ~chain.is_prismatic
    solver = wbik.solver("bounded_lm", chain.robot, chain="arm")
    rng = np.random.default_rng(9)
    answers = []
    for branch in branches:
        start = np.clip(branch + rng.uniform(-0.02, 0.02, 6), chain.lower, chain.upper)
        result = solver.solve(target, start)
        assert result.success
        answers.append(result.q)
    assert distinct_solutions(answers, branches, revolute, 1e-3) == (8, 0)
    assert distinct_solutions(answers[:3] + answers[:3], branches, revolute, 1e-3) == (3, 0)
    stranger = branches[0] + 0.01  # equal to no branch within 1e-3
    assert distinct_solutions([stranger, stranger + 1e-4, branches[1]], branches, revolute, 1e-3) == (1, 1)
