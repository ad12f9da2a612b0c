"""Unreachable targets, each with its proof: beyond the chain's reach bound (triangle inequality), or
reachable only with a joint beyond its limit where every branch of a complete closed form is outside
the limits. No method of ours reports a false success on them; the report gives the reasons and the
time to refuse."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.study import run_study, study_from_dict
from wbik.study.case_kinds import case_kinds
from wbik.study.chain_reach import reach_bound
from wbik.study.closed_form_branches import branch_excess, complete_closed_form, joint_excess
from wbik.study.context import case_chain
from wbik.study.results import read_raw_csv
from wbik.study.target_parameters import defaults
from wbik.study.unreachable import BEYOND_LIMITS, OUTSIDE_REACH

OURS = ("bounded_lm", "dls", "newton", "qp", "analytic")


def _draw(chain, count: int, seed: int = 11, **parameters):
    kind = case_kinds()["unreachable"]
    return kind.draw(chain, count, seed, {**defaults("unreachable", kind.all_parameters), **parameters})


@pytest.fixture(scope="module")
def golem():
    return case_chain("golem3", (), "right_arm")


@pytest.mark.parametrize(("robot", "chain", "base", "tip"), [
    ("ur5", "arm", None, None), ("panda", "arm", None, None), ("golem3", "right_arm_lift", None, None),
    ("example-robot-data:talos", "talos_arm", "torso_2_link", "gripper_right_base_link")])
def test_the_reach_bound_holds_for_any_joints(robot, chain, base, tip):
    chain = case_chain(robot, (), chain, base, tip)
    bound = reach_bound(chain)
    rng = np.random.default_rng(0)
    # revolute angles anywhere (limits do not enter the bound), prismatic joints inside their limits
    low = np.where(chain.is_prismatic, chain.lower, -2 * math.pi)
    high = np.where(chain.is_prismatic, chain.upper, 2 * math.pi)
    samples = rng.uniform(low, high, (3000, chain.nq))
    farthest = max(np.linalg.norm(chain.fk(q).translation - bound.centre) for q in samples)
    assert farthest <= bound.radius
    assert farthest > 0.7 * bound.radius  # a bound, not a wild one


def test_joint_excess_is_the_distance_to_the_range_on_the_circle(golem):
    q = golem.mid_range.copy()
    assert np.all(joint_excess(q, golem) == 0)
    lower, upper = golem.lower[0], golem.upper[0]  # m0: [-1, 1], a gap of 2 pi - 2 on the circle
    half_gap = (2 * math.pi - 2) / 2
    for value, expected in ((upper + 0.3, 0.3), (lower - 0.2, 0.2), (upper + 2 * math.pi, 0.0),
                            (upper + half_gap, half_gap), (lower - 2 * math.pi - 0.1, 0.1)):
        q[0] = value
        assert joint_excess(q, golem)[0] == pytest.approx(expected, abs=1e-12)


def test_unreachable_targets_are_beyond_the_bound_or_have_no_branch_inside_the_limits(golem):
    drawing = _draw(golem, 40)
    source, extras = drawing.extras["source"], drawing.extras
    positions, rotations = extras["positions"], extras["rotations"]
    assert {OUTSIDE_REACH, BEYOND_LIMITS} == set(source.tolist())
    bound = reach_bound(golem)
    form = complete_closed_form(golem)
    analytic = wbik.solver("analytic", golem.robot, chain="right_arm")
    proved = drawing.facts["proved"]
    assert proved["reach bound (triangle inequality)"] == int(np.sum(source == OUTSIDE_REACH))
    for i in range(40):
        target = pin.SE3(rotations[i], positions[i])
        assert analytic.solve_all(target) == []  # the closed form finds no solution inside the limits
        if source[i] == OUTSIDE_REACH:
            assert np.linalg.norm(positions[i] - bound.centre) > 1.05 * bound.radius - 1e-12
            assert np.all(np.isnan(drawing.q_true[i]))
            continue
        q = drawing.q_true[i]
        assert not golem.in_limits(q)
        assert golem.fk(q).isApprox(target, 1e-12)  # FK of the generating joints
        branches = form.branches(positions[i][None], rotations[i][None])[0]
        assert len(branches) >= 2 and np.min(branch_excess(branches, golem)) >= 1e-3


def test_chains_without_a_proof_of_the_second_source_draw_outside_the_reach():
    panda = case_chain("panda", (), "arm")
    drawing = _draw(panda, 6)
    assert np.all(drawing.extras["source"] == OUTSIDE_REACH)
    assert "holds a joint" in drawing.facts["beyond_limits_impossible"]
    ur5 = case_chain("ur5", (), "arm")
    drawing = _draw(ur5, 6)
    assert np.all(drawing.extras["source"] == OUTSIDE_REACH)
    assert "representative inside the limits" in drawing.facts["beyond_limits_impossible"]


def test_our_methods_report_no_false_success_and_the_report_says_why_they_refused(tmp_path):
    study = study_from_dict({
        "name": "unreachable", "seed": 3, "poses": 10, "chunk_size": 5, "timeout_s": 0.005, "figures": False,
        "cases": [{"robot": "golem3", "chain": "right_arm",
                   "targets": {"set": "unreachable", "beyond_limits": 0.6}}],
        "methods": list(OURS)}, source="t.yaml")
    output = run_study(study, tmp_path / "out", jobs=1, progress=False, log=lambda message: None)
    rows = read_raw_csv(output / "golem3_right_arm_unreachable" / "raw.csv")
    assert set(rows) == set(OURS)
    for label, columns in rows.items():
        assert not columns["success"].any(), label  # no false success
        assert all(reason for reason in columns["reason"]), label
    report = (output / "report.md").read_text()
    assert "### Unreachable targets: false successes, time to refuse, reasons" in report
    header = ("| method | targets | false successes | refused | median ms | p95 ms | median ms (a) | "
              "median ms (b) |")
    assert header in report
    for label in OURS:
        assert f"| {label} | 10 | 0 | 10 |" in report
    assert "| proved unreachable by | targets |" in report and "every branch outside the limits" in report
    assert "| analytic | every real branch is outside the joint limits |" in report
