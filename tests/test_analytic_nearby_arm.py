"""``analytic`` on 6- and 7-joint arms whose neighbouring axes pass close by without meeting (Bravo 7's wrist;
a general 6R whichever joint of Alex's or Tiago Pro's arm is held): the nearby arm's closed form refined by
Newton (wbik.solvers.analytic.nearby_arm).
Targets are Pinocchio FK poses of seeded random joints inside the limits; answers are judged by Pinocchio's
FK again, never by the code under test."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest
from closed_form_checks import fk_error, solved_inside_limits

import wbik
from wbik.errors import UnsupportedError
from wbik.solvers.analytic import nearby_arm as nearby_arm_module
from wbik.solvers.analytic.nearby_arm import NEARBY_ARMS, NearbyArmForm, nearby_lines
from wbik.solvers.analytic.solver import FAMILIES
from wbik.solvers.analytic.structure import chain_lines

ARMS = {"alex": ("example-robot-data:alex_nub_hands", "Torso", "RightGripperYawLink"),
        "tiago_pro": ("example-robot-data:tiago_pro", "torso_lift_link", "arm_right_tool_link"),
        "bravo": ("example-robot-data:bravo7_no_ee", "link1", "end_effector_ball")}
POSES = 20



@pytest.fixture(scope="module", params=sorted(ARMS))
def arm(request):
    name, base, tip = ARMS[request.param]
    return wbik.solver("analytic", wbik.load(name), base=base, tip=tip)


def test_no_neighbouring_axes_meet_or_are_parallel(arm):
    """Of a 7-joint arm none; of Bravo 7 axes 3 to 6 (axes 2 and 3 are parallel)."""
    lines = chain_lines(arm.chain)
    for k in range(1, 7) if arm.chain.nq == 7 else range(3, 6):
        assert not lines.parallel(k - 1, k) and lines.meeting_point(k - 1, k) is None


def test_the_family_names_the_nearby_arm_and_the_refinement(arm):
    assert isinstance(arm.closed_form("pose"), NearbyArmForm)
    assert arm.family.startswith(f"nearby arm with {NEARBY_ARMS[arm.chain.nq][0][0]}")
    assert "Newton-refined on the chain" in arm.family


def test_bravo_names_its_spherical_wrist_and_the_1d_search_after_it():
    """Bravo 7's axes 4, 5, 6 are 40.8 mm apart pairwise: moved to meet, EAIK solves the arm."""
    name, base, tip = ARMS["bravo"]
    family = wbik.solver("analytic", wbik.load(name), base=base, tip=tip).family
    assert family == ("nearby arm with axes 3, 4 meeting and axes 4, 5, 6 meeting (axes moved by up to "
                      "40.8 mm): eaik:6R-SPHERICAL_SECOND_TWO_PARALLEL, Newton-refined on the chain, else "
                      "search: joints 2 and 3 parallel (1-D)")


def test_the_nearby_arm_has_the_moved_axes_meeting_and_every_axis_direction():
    lines = chain_lines(wbik.solver("dls", wbik.load(ARMS["alex"][0]), base=ARMS["alex"][1],
                                    tip=ARMS["alex"][2]).chain)
    moved = NEARBY_ARMS[7][0][1]
    near, largest = nearby_lines(lines, moved)
    np.testing.assert_array_equal(near.axes, lines.axes)
    for k in moved:
        assert near.meeting_point(k - 1, k) is not None
    assert 0.0 < largest < 0.1 * lines.length


def test_reachable_poses_are_solved_to_the_shared_tolerance_inside_the_limits(arm):
    solved = solved_inside_limits(arm, arm.chain.random(np.random.default_rng(38), POSES))
    assert solved >= POSES - 1  # the measured share is 100 % of 300 poses per arm


def test_solve_many_and_solve_all_reach_the_targets(arm):
    chain = arm.chain
    targets = [chain.fk(q) for q in chain.random(np.random.default_rng(39), 4)]
    results = arm.solve_many(targets)
    assert sum(result.success for result in results) >= 3
    for result, target in zip(results, targets, strict=True):
        if result.success:
            assert fk_error(chain, result.q, target) <= 1e-6
    every = arm.solve_all(targets[0])
    assert every and all(fk_error(chain, result.q, targets[0]) <= 1e-6 for result in every)


def test_an_unreachable_target_is_a_failure_with_a_reason(arm):
    chain = arm.chain
    target = chain.fk(chain.nominal)
    far = pin.SE3(target.rotation, target.translation + np.array([2.0, 0.0, 0.0]))  # beyond a < 1 m arm
    result = arm.solve(far, q0=chain.nominal)
    assert not result.success and "unreachable" in result.reason


def test_positions_are_refused_saying_the_nearby_arm_needs_full_poses(arm):
    with pytest.raises(UnsupportedError, match="nearby arm refined by Newton: for full poses"):
        arm.closed_form("position")


def test_a_nearby_arm_too_far_from_the_chain_is_refused_saying_how_far(arm, monkeypatch):
    monkeypatch.setattr(nearby_arm_module, "NEARBY_SHARE", 1e-3)
    first = re.escape(NEARBY_ARMS[arm.chain.nq][0][0])
    with pytest.raises(UnsupportedError, match=rf"no nearby arm has a closed form \({first}.*"
                                               r"mm, more than 0.001 x the chain's length"):
        nearby_arm_module.nearby_arm(arm.chain, "pose", {}, {}, FAMILIES)
