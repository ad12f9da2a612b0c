"""``analytic``'s search-based geometric forms (wbik.solvers.analytic.one_d_search) on the arms no family or
EAIK decomposition solves. Targets are FK poses (Pinocchio) of seeded random joints inside the limits;
answers are judged by Pinocchio's FK again, never by the code under test."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from closed_form_checks import fk_error, solved_inside_limits

import wbik
from wbik.errors import UnsupportedError
from wbik.geometry import joint_gap
from wbik.solvers.analytic import solver as solver_module
from wbik.solvers.analytic.closed_form import BRANCH_MERGE
from wbik.solvers.analytic.one_d_search import TwoParallelForm
from wbik.solvers.analytic.structure import chain_lines

BRAVO = ("example-robot-data:bravo7_no_ee", "link1", "end_effector_ball")
POSES = 30



@pytest.fixture(scope="module")
def bravo():
    """Bravo 7 recognised without the nearby arm (which solves it by default, its 1-D search after it)."""
    name, base, tip = BRAVO
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(solver_module, "nearby_arm", refuse)
        return wbik.solver("analytic", wbik.load(name), base=base, tip=tip)


def refuse(*args) -> None:
    raise UnsupportedError("no nearby arm")


def test_bravo_gets_the_two_parallel_search(bravo):
    assert bravo.family == "search: joints 2 and 3 parallel (1-D)"
    assert isinstance(bravo.closed_form("pose"), TwoParallelForm)


def test_bravo_solves_reachable_poses_to_the_shared_tolerance(bravo):
    solved = solved_inside_limits(bravo, bravo.chain.random(np.random.default_rng(11), POSES))
    assert solved >= POSES - 1  # the benchmark measures the share on 500 poses (at least 99 %)


def test_bravo_solve_all_branches_are_distinct_and_reach_the_target(bravo):
    chain = bravo.chain
    revolute = ~chain.is_prismatic
    counts = []
    for q in chain.random(np.random.default_rng(12), 6):
        target = chain.fk(q)
        results = bravo.solve_all(target)
        counts.append(len(results))
        for index, result in enumerate(results):
            assert result.success and fk_error(chain, result.q, target) <= 1e-6
            for other in results[:index]:
                assert joint_gap(result.q, other.q, revolute) >= BRANCH_MERGE
    assert sum(count >= 1 for count in counts) >= 5


def test_every_branch_of_the_form_reproduces_its_root(bravo):
    """The form's branches at a target are joint vectors whose FK (the lines' product of exponentials,
    checked against Pinocchio) reaches the target, and the joints the target was made from are among them."""
    chain, form = bravo.chain, bravo.closed_form("pose")
    q = chain.random(np.random.default_rng(13), 1)[0]
    target = chain.fk(q)
    branches, real = form.branches(target.translation[None], target.rotation[None], chain.nominal[None])
    found = branches[0][real[0]]
    errors = [fk_error(chain, branch, target) for branch in found]
    assert min(errors) <= 1e-9
    assert min(joint_gap(branch, q, ~chain.is_prismatic) for branch in found) <= 1e-6


def test_unreachable_target_is_a_failure_with_a_reason(bravo):
    chain = bravo.chain
    target = chain.fk(chain.nominal)
    far = pin.SE3(target.rotation, target.translation + np.array([2.0, 0.0, 0.0]))  # 2 m beyond a 0.5 m arm
    result = bravo.solve(far, q0=chain.nominal)
    assert not result.success and "unreachable" in result.reason


def test_a_general_6r_is_refused_saying_which_search_it_needs():
    """The Tiago Pro arm's first six joints: no neighbouring axes parallel or meeting (the whole 7-joint arm
    is solved through a nearby arm, tests/test_analytic_nearby_arm.py)."""
    robot = wbik.load("example-robot-data:tiago_pro")
    with pytest.raises(UnsupportedError, match="2-D search"):
        wbik.solver("analytic", robot, base="torso_lift_link", tip="arm_right_6_link")


def test_the_search_form_is_only_for_axes_two_and_three_parallel():
    lines = chain_lines(wbik.solver("dls", wbik.load(BRAVO[0]), base=BRAVO[1], tip=BRAVO[2]).chain)
    assert lines.parallel(1, 2) and not lines.parallel(0, 1) and not lines.parallel(2, 3)


def test_baxter_without_its_first_joint_is_searched_in_1d():
    """Baxter's right arm from the link after right_s0: a 6R whose axes 1, 2 and 5, 6 meet, recognised
    without the nearby arm (which solves it by default, the 1-D search after it; the whole 7-joint arm takes
    a nearby arm with a held joint)."""
    robot = wbik.load("example-robot-data:baxter")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(solver_module, "nearby_arm", refuse)
        solver = wbik.solver("analytic", robot, base="right_upper_shoulder", tip="right_gripper_base_link")
    assert solver.family == "search: axes 1, 2 and axes 5, 6 meet (1-D)"
    assert wbik.solver("analytic", robot, base="right_upper_shoulder",
                       tip="right_gripper_base_link").family.endswith(", else " + solver.family)
    assert wbik.solver("analytic", robot, base="torso", tip="right_gripper_base_link").family.startswith(
        "nearby arm")
    chain = solver.chain
    solved = 0
    for q in chain.random(np.random.default_rng(14), 8):
        target = chain.fk(q)
        result = solver.solve(target, q0=chain.nominal)
        if result.success:
            solved += 1
            assert fk_error(chain, result.q, target) <= 1e-6
    assert solved >= 7


def test_the_intersecting_search_finds_the_joints_a_pose_was_made_from():
    """The 6R left by holding Baxter's first joint: among the form's branches, the joints of the pose."""
    from wbik.solvers.analytic.one_d_search import TwoIntersectingForm
    from wbik.solvers.analytic.redundancy import LockedChain

    chain = wbik.solver("dls", wbik.load("example-robot-data:baxter"), base="torso",
                        tip="right_gripper_base_link").chain
    locked = LockedChain(chain, 0, 0.3)
    form = TwoIntersectingForm(locked, locked.lines)
    for q in locked.random(np.random.default_rng(15), 5):
        target = locked.fk(q)
        branches, real = form.branches(target.translation[None], target.rotation[None], q[None])
        found = branches[0][real[0]]
        assert min(joint_gap(branch, q, np.ones(6, dtype=bool)) for branch in found) <= 1e-6
        errors = np.array([fk_error(locked, branch, target) for branch in found])
        assert not np.any((errors > 1e-6) & (errors < 1e-3))  # a refined root is a solution, not a near miss


def test_a_search_form_that_misses_fk_poses_is_refused(monkeypatch):
    """The form is probed on FK poses of random joints when recognised: one that finds no root is refused."""
    def nothing(self, x, positions, rotations, full=False):
        return np.full((len(x), 4), np.nan), np.full((len(x), 4, 2), np.nan), np.full((len(x), 4, 6), np.nan)

    monkeypatch.setattr(TwoParallelForm, "evaluate", nothing)
    monkeypatch.setattr(solver_module, "nearby_arm", refuse)
    name, base, tip = BRAVO
    with pytest.raises(UnsupportedError, match="reproduces 0 of 8 FK poses"):
        wbik.solver("analytic", wbik.load(name), base=base, tip=tip)
