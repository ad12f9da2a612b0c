"""Method ``eaik`` (EAIK 1.2.2 behind the one interface): accepted and refused chains, branches, batches.

Expected poses come from Pinocchio FK of random joints inside the limits; branches are checked with an
independent FK on the robot's full model (not the chain's reduced model that the solver uses).
"""

from __future__ import annotations

import math
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.errors import InvalidSettingError, MissingDependencyError, UnsupportedError
from wbik.solvers.check import evaluate
from wbik.solvers.result import Candidate
from wbik.targets import Target

POSES = 200
PANDA_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
# Chains EAIK accepts: (robot, chain); "panda-lockK" is the Panda with joint K locked at its nominal.
ACCEPTED = [("ur5", "arm"), ("ur5", "ee"), ("bioloid", "right_leg"), ("bioloid", "left_leg"),
            ("bioloid", "right_arm"), ("bioloid", "left_arm"), ("arm3r", "arm"),
            ("panda-lock4", "arm6"), ("panda-lock5", "arm6"), ("panda-lock6", "arm6"),
            ("panda-lock7", "arm6")]
# Chains it refuses, with a word of the reason the error must name.
REFUSED = [("golem3", "right_arm", "Unknown Kinematic Class"),
           ("golem3", "left_arm", "Unknown Kinematic Class"),
           ("golem3", "right_arm_lift", "prismatic"),
           ("panda", "arm", "1-6R"),
           ("panda-lock1", "arm6", "Unknown Kinematic Class"),
           ("pincher", "arm", "reproduce only 0 of 8")]

_ROBOTS: dict[str, wbik.Robot] = {}


def load(name: str) -> wbik.Robot:
    if name not in _ROBOTS:
        if name.startswith("panda-lock"):
            locked = int(name.removeprefix("panda-lock"))
            panda = load("panda")
            joints = tuple(j for k, j in enumerate(PANDA_JOINTS, start=1) if k != locked)
            spec = wbik.ChainSpec("arm6", "panda_link0", "panda_hand_tcp", joints,
                                  f"the Panda with joint {locked} locked at its nominal")
            _ROBOTS[name] = wbik.load(str(panda.urdf_path), chains=[spec], nominal=panda.nominal,
                                      package_dirs=panda.package_dirs, name="panda")
        else:
            _ROBOTS[name] = wbik.load(name)
    return _ROBOTS[name]


def independent_fk(chain, q) -> pin.SE3:
    """Base -> tip pose on the robot's full model (the solver works on the chain's reduced model)."""
    model = chain.robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, chain.full_configuration(q))
    base, tip = model.getFrameId(chain.base_frame), model.getFrameId(chain.tip_frame)
    return data.oMf[base].inverse() * data.oMf[tip]


def reaches(chain, q, target: Target, tolerance: float = 1e-6) -> bool:
    pose = independent_fk(chain, q)
    return bool(np.linalg.norm(pose.translation - target.position) <= tolerance
                and np.linalg.norm(pin.log3(target.rotation.T @ pose.rotation)) <= tolerance)


def angle_gap(a, b) -> float:
    return float(np.max(np.abs(np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b)))))))


@pytest.fixture(scope="module", params=ACCEPTED, ids=[f"{r}.{c}" for r, c in ACCEPTED])
def case(request):
    robot_name, chain_name = request.param
    solver = wbik.solver("eaik", load(robot_name), chain_name)
    chain = solver.chain
    joints = chain.random(np.random.default_rng(2024), POSES)
    targets = []
    for q in joints:
        pose = independent_fk(chain, q)
        targets.append(Target(pose.translation.copy(), pose.rotation.copy()))
    return solver, joints, targets


def test_registered():
    assert "eaik" in wbik.methods()


def test_solve_reaches_random_reachable_poses(case):
    """Measured: 200/200 on every accepted chain (UR5 arm/ee, Bioloid legs and arms, arm3r, Panda with
    joint 4, 5, 6 or 7 locked)."""
    solver, _, targets = case
    results = [solver.solve(target) for target in targets]
    successes = [r for r in results if r.success]
    assert len(successes) >= 0.99 * POSES
    for result, target in zip(results, targets, strict=True):
        if result.success:
            assert solver.chain.in_limits(result.q)
            assert reaches(solver.chain, result.q, target)


def test_solve_all_branches_pass_fk_and_contain_the_original(case):
    """Measured: the original joints are among the branches for 200/200 poses on every accepted chain."""
    solver, joints, targets = case
    found = 0
    for q, target in zip(joints, targets, strict=True):
        branches = solver.solve_all(target)
        for branch in branches:
            assert solver.chain.in_limits(branch.q)
            assert reaches(solver.chain, branch.q, target)
        for i, first in enumerate(branches):  # distinct
            for second in branches[i + 1:]:
                assert angle_gap(first.q, second.q) > 1e-6
        found += any(angle_gap(branch.q, q) < 1e-6 for branch in branches)
    assert found >= 0.99 * POSES


def test_solve_picks_the_branch_nearest_to_q0(case):
    """solve from a random start returns, among solve_all's branches shifted by 2 pi into the limits
    nearest to q0, the one nearest to q0 (Euclidean)."""
    solver, _, targets = case
    chain = solver.chain
    starts = chain.random(np.random.default_rng(77), 40)
    for target, q0 in zip(targets[:40], starts, strict=True):
        result = solver.solve(target, q0)
        candidates = []
        for branch in solver.solve_all(target):
            q = branch.q.copy()
            for j in range(chain.nq):
                options = [q[j] + k * 2 * np.pi for k in range(-2, 3)
                           if chain.lower[j] - 1e-9 <= q[j] + k * 2 * np.pi <= chain.upper[j] + 1e-9]
                q[j] = min(options, key=lambda value, j=j: abs(value - q0[j]))
            candidates.append(q)
        best = min(candidates, key=lambda q: np.linalg.norm(q - q0))
        assert result.success
        np.testing.assert_allclose(result.q, best, atol=1e-6)


def test_solve_many_equals_solve(case):
    solver, _, targets = case
    starts = solver.chain.random(np.random.default_rng(5), POSES)
    batch = solver.solve_many(targets, starts)
    assert len(batch) == POSES
    for result, target, q0 in zip(batch, targets, starts, strict=True):
        single = solver.solve(target, q0)
        assert result.success == single.success
        np.testing.assert_array_equal(result.q, single.q)
        assert result.extra.get("batched") is True


def test_ur5_joints_beyond_pi_come_back_from_a_start_beside_them():
    """The UR5's joints span +-2 pi: EAIK returns angles in (-pi, pi], the solver shifts them by 2 pi
    into the limits nearest to q0, so a start at the original joints gives them back exactly."""
    chain = load("ur5").chain("ee")
    solver = wbik.solver("eaik", load("ur5"), "ee")
    q = np.array([4.0, -1.2, 1.5, -4.5, 5.2, -5.9])
    pose = independent_fk(chain, q)
    target = Target(pose.translation.copy(), pose.rotation.copy())
    result = solver.solve(target, q + 0.01)
    assert result.success
    np.testing.assert_allclose(result.q, q, atol=1e-7)
    assert np.all(np.abs(solver._library_branches(target)) <= np.pi + 1e-9)


@pytest.mark.parametrize(("robot_name", "chain_name", "word"), REFUSED,
                         ids=[f"{r}.{c}" for r, c, _ in REFUSED])
def test_refused_chains_raise_unsupported(robot_name, chain_name, word):
    with pytest.raises(UnsupportedError) as info:
        wbik.solver("eaik", load(robot_name), chain_name)
    assert f".{chain_name}" in str(info.value)
    assert word in str(info.value)


def test_position_target_is_unsupported():
    solver = wbik.solver("eaik", load("arm3r"), "arm")
    with pytest.raises(UnsupportedError, match="full pose"):
        solver.solve([0.1, 0.1, 0.2])
    with pytest.raises(UnsupportedError, match="full pose"):
        solver.solve_many([[0.1, 0.1, 0.2]])


def test_unreachable_pose_fails_with_a_reason():
    solver = wbik.solver("eaik", load("ur5"), "ee")
    result = solver.solve(Target(np.array([3.0, 0.0, 0.0]), np.eye(3)))
    assert not result.success
    assert "unreachable" in result.reason


def test_bad_batch_threads():
    with pytest.raises(InvalidSettingError):
        wbik.solver("eaik", load("ur5"), "ee", batch_threads=0)


def test_missing_eaik_raises_missing_dependency(monkeypatch):
    monkeypatch.setitem(sys.modules, "eaik", None)
    monkeypatch.setitem(sys.modules, "eaik.IK_HP", None)
    monkeypatch.setitem(sys.modules, "eaik.pybindings", None)
    with pytest.raises(MissingDependencyError, match=r"pip install 'wbik\[eaik\]'"):
        wbik.solver("eaik", load("ur5"), "ee")


# --- the branch choice against the rule it implements ---------------------------------------------------
CHOICE_POSES = 1000


def _wrapped(raw: list[float], reference: list[float], lower: list[float], upper: list[float]):
    """Each angle's 2 pi shift (0, +-2 pi, +-4 pi) inside its limits (within 1e-9) nearest the reference,
    the first on a tie, set into the limits; None where an angle has none."""
    wrapped = []
    for value, ref, low, high in zip(raw, reference, lower, upper, strict=True):
        inside = [value + shift for shift in (0.0, 2 * math.pi, -2 * math.pi, 4 * math.pi, -4 * math.pi)
                  if low - 1e-9 <= value + shift <= high + 1e-9]
        if not inside:
            return None
        wrapped.append(min(high, max(low, min(inside, key=lambda shifted: abs(shifted - ref)))))
    return wrapped


def _passes_screen(chain, q: list[float], target: Target) -> bool:
    """|p - p*| <= 1e-7 and angle(R*^T R) <= 1e-7 by the chain's own FK (Pinocchio)."""
    pose = chain.fk(np.asarray(q))
    if not math.dist(pose.translation, target.position) <= 1e-7:
        return False
    trace = float(np.sum(pose.rotation * target.rotation))
    return math.acos(min(1.0, max(-1.0, 0.5 * (trace - 1.0)))) <= 1e-7


def _rule_choice(solver, q_all: np.ndarray, target: Target, q0: np.ndarray):
    """The branch rule spelled out: every branch wrapped into the limits nearest q0, the nearest (squared
    distance, the first on a tie) whose FK passes the 1e-7 screen; where none does, the solver's reasons
    (``_pick``)."""
    chain, reference = solver.chain, q0.tolist()
    wrapped = [_wrapped(raw, reference, chain.lower.tolist(), chain.upper.tolist()) for raw in q_all.tolist()]
    inside = [q for q in wrapped if q is not None and all(map(math.isfinite, q))]
    for q in sorted(inside, key=lambda q: sum((a - b) ** 2 for a, b in zip(q, reference, strict=True))):
        if _passes_screen(chain, q, target):
            return Candidate(np.array(q), 1)
    return solver._pick(q_all, target, q0)


def _choice_chains():
    ur10 = wbik.load("example-robot-data:ur10")
    kinova = wbik.load("example-robot-data:kinova")
    kinova_arm = kinova.chain_between("base", "j2s6s200_end_effector")
    return {"ur10": (ur10, None), "ur5.ee": (load("ur5"), "ee"),
            "bioloid.right_leg": (load("bioloid"), "right_leg"), "kinova": (kinova, kinova_arm.name)}


@pytest.mark.parametrize("name", ["ur10", "ur5.ee", "bioloid.right_leg", "kinova"])
def test_choice_is_the_nearest_branch_rule(name):
    """On FK poses of random joints, the same poses moved by up to 1 mm and 1 mrad, and random far poses
    (least-squares branches only), from random starts and from the nominal: the solver's choice gives
    the joints, the reason and the success of the rule spelled out (:func:`_rule_choice`)."""
    robot, chain_name = _choice_chains()[name]
    solver = wbik.solver("eaik", robot, chain_name)
    chain = solver.chain
    rng = np.random.default_rng(11)
    targets = []
    for q in chain.random(rng, CHOICE_POSES):
        pose = chain.fk(q)
        targets.append(Target(pose.translation.copy(), pose.rotation.copy()))
        if len(targets) % 4 == 0:
            moved = pose * pin.exp6(pin.Motion(rng.uniform(-1e-3, 1e-3, 6)))
            targets.append(Target(moved.translation.copy(), moved.rotation.copy()))
    targets += [Target(rng.uniform(-3.0, 3.0, 3), pin.exp3(rng.uniform(-3.0, 3.0, 3))) for _ in range(20)]
    starts = list(chain.random(rng, len(targets)))
    starts[::5] = [chain.nominal] * len(starts[::5])
    counts = {"found": 0, "none": 0}
    for target, q0 in zip(targets, starts, strict=True):
        q_all = solver._library_branches(target)
        chosen, _ = solver._choose(q_all, target, q0)
        expected = _rule_choice(solver, q_all, target, q0)
        assert (chosen.q is None) == (expected.q is None)
        assert chosen.reason == expected.reason
        counts["found" if chosen.q is not None else "none"] += 1
        if chosen.q is not None:
            np.testing.assert_array_equal(chosen.q, expected.q)
        checked, reference = (evaluate(chain, target, candidate, solver.tolerances, 0.0, "eaik")
                              for candidate in (chosen, expected))
        assert checked.success == reference.success
        result = solver.solve(target, q0)
        assert result.success == reference.success
        if result.q is not None:
            np.testing.assert_array_equal(result.q, reference.q)
    assert counts["found"] >= CHOICE_POSES and counts["none"] > 0  # every FK pose solved, far ones not


def test_four_threads_on_one_solver_match_the_sequential_run():
    """Each thread has its own EAIK robot and pose buffer: threads switching every microsecond give the
    sequential answers exactly."""
    solver = wbik.solver("eaik", load("ur5"), "ee")
    chain = solver.chain
    rng = np.random.default_rng(3)
    targets = [chain.fk(q) for q in chain.random(rng, 64)] + [pin.SE3(np.eye(3), np.array([3.0, 0.0, 0.0]))]
    starts = chain.random(rng, len(targets))
    sequential = [solver.solve(target, q0) for target, q0 in zip(targets, starts, strict=True)]
    previous = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        with ThreadPoolExecutor(max_workers=4) as pool:
            threaded = list(pool.map(solver.solve, targets, starts))
    finally:
        sys.setswitchinterval(previous)
    for alone, shared in zip(sequential, threaded, strict=True):
        assert shared.success == alone.success
        if alone.q is None:
            assert shared.q is None
        else:
            np.testing.assert_array_equal(shared.q, alone.q)
