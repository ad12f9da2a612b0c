"""Golem-III closed forms (golem3.md ch. 4.1 and 4.2.1) through wbik.solver("analytic", ...).

Targets come from Pinocchio FK of random joints inside the limits (the thesis' study protocol), so
every one of them has a solution; success is the shared FK check (1e-6 m, 1e-6 rad).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import wbik
from wbik.solvers.analytic.closed_form import wrap_into_limits

RHO = math.radians(13.43)  # golem3.md


@pytest.fixture(scope="module")
def robot():
    return wbik.load("golem3")


@pytest.fixture(scope="module")
def right(robot):
    return wbik.solver("analytic", robot, chain="right_arm")


@pytest.fixture(scope="module")
def left(robot):
    return wbik.solver("analytic", robot, chain="left_arm")


def study(chain, count: int, seed: int):
    joints = chain.random(np.random.default_rng(seed), count)
    return joints, [chain.fk(q) for q in joints]


def branch_distance_to(solver, joints: np.ndarray, poses) -> np.ndarray:
    """Per pose, the smallest max-abs joint difference between the original joints and a real,
    in-limit branch of the closed form (the set solve_all draws from)."""
    chain = solver.chain
    form = solver.closed_form("pose")
    positions = np.array([p.translation for p in poses])
    rotations = np.array([p.rotation for p in poses])
    q_all, real = form.branches(positions, rotations, joints)
    wrapped, inside = wrap_into_limits(q_all, joints[:, None, :], chain.lower, chain.upper,
                                       ~chain.is_prismatic)
    difference = np.max(np.abs(wrapped - joints[:, None, :]), axis=-1)
    return np.min(np.where(real & inside, difference, np.inf), axis=1)


def assert_round_trip(solver, count: int, seed: int):
    chain = solver.chain
    joints, poses = study(chain, count, seed)
    results = solver.solve_many(poses)
    found = np.array([r.success for r in results])
    failures = [(i, results[i].reason) for i in np.flatnonzero(~found)]
    assert found.mean() >= 0.9999, f"{len(failures)} of {count} not solved: {failures[:5]}"
    for result in results:
        if result.success:
            assert chain.in_limits(result.q, tolerance=0.0)
            assert result.position_error <= 1e-6 and result.rotation_error <= 1e-6
    contains = branch_distance_to(solver, joints, poses) < 1e-6
    assert contains.mean() >= 0.999, f"original joints missing for poses {np.flatnonzero(~contains)[:10]}"


def test_right_arm_round_trip_10000_poses(right):
    assert_round_trip(right, 10_000, seed=2017)


def test_left_arm_round_trip(left):
    assert_round_trip(left, 2_000, seed=2018)


def test_solve_all_lists_each_distinct_branch_once(right):
    chain = right.chain
    joints, poses = study(chain, 200, seed=5)
    counts = []
    for q, pose in zip(joints, poses, strict=True):
        solutions = right.solve_all(pose)
        counts.append(len(solutions))
        assert 1 <= len(solutions) <= 4  # 2 signs of sin(t4 + rho) x 2 planar elbows
        for result in solutions:
            assert result.success and chain.in_limits(result.q, tolerance=0.0)
        for i, a in enumerate(solutions):
            for b in solutions[i + 1:]:
                assert np.max(np.abs(a.q - b.q)) > 1e-6
        assert min(np.max(np.abs(r.q - q)) for r in solutions) < 1e-6
    assert max(counts) > 1  # several branches do occur


def test_batch_and_scalar_answers_agree(right, left):
    for solver, seed in ((right, 6), (left, 7)):
        chain = solver.chain
        joints, poses = study(chain, 300, seed)
        starts = chain.random(np.random.default_rng(seed + 100), 300)
        batch = solver.solve_many(poses, starts)
        for pose, start, together in zip(poses, starts, batch, strict=True):
            alone = solver.solve(pose, start)
            assert alone.success and together.success
            np.testing.assert_allclose(alone.q, together.q, atol=1e-9)


def test_the_nearest_branch_to_q0_is_returned(right):
    chain = right.chain
    joints, poses = study(chain, 100, seed=8)
    for q, pose in zip(joints, poses, strict=True):
        every = right.solve_all(pose)
        nearest = min(every, key=lambda r: np.linalg.norm(r.q - q))
        np.testing.assert_allclose(right.solve(pose, q).q, nearest.q, atol=1e-9)


def test_singular_poses_are_solved_thanks_to_the_clamp(right):
    """Poses where a cosine of the inverse is exactly +-1 up to rounding (the thesis' failures):
    t4 + rho = 0 (cos(t4 + rho) = 1), t2 = 0 (planar elbow stretched), both, and beta = -pi/2."""
    chain = right.chain
    cases = [
        [0.3, 0.5, -0.4, -RHO, 0.8, 0.2],
        [-0.2, 0.0, 1.0, 0.5, -0.3, -0.7],
        [0.7, 0.0, -2.0, -RHO, 1.2, 1.0],
        [0.1, 0.4, 0.3, -0.5, 0.5 - math.pi / 2 + 1.0, 0.4],
        [0.1, 0.4, 0.3, 0.5, math.pi / 2 - 0.5, 0.4],  # beta = -pi/2: t6 and gamma coupled
    ]
    for q in cases:
        q = np.array(q)
        assert chain.in_limits(q)
        result = right.solve(chain.fk(q))
        assert result.success, (q, result.reason)


def test_targets_of_joints_at_their_limits(right, left):
    """Half the joints exactly at a limit (a robot resting on its stops): rounding puts the inverse a
    few 1e-12 rad outside, which must not lose the solution."""
    for solver, seed in ((right, 12), (left, 13)):
        chain = solver.chain
        rng = np.random.default_rng(seed)
        joints = chain.random(rng, 1000)
        at_limit = rng.random(joints.shape) < 0.5
        joints = np.where(at_limit, np.where(rng.random(joints.shape) < 0.5, chain.lower, chain.upper),
                          joints)
        poses = [chain.fk(q) for q in joints]
        batch = solver.solve_many(poses)
        assert all(r.success for r in batch), [r.reason for r in batch if not r.success][:3]
        for pose, together in list(zip(poses, batch, strict=True))[:200]:
            np.testing.assert_allclose(solver.solve(pose).q, together.q, atol=1e-9)
        assert branch_distance_to(solver, joints, poses).max() < 1e-6
        positions = solver.solve_many([p.translation for p in poses])
        assert all(r.success for r in positions)


def test_position_only_1000(robot, right):
    chain = right.chain
    joints, poses = study(chain, 1000, seed=9)
    results = right.solve_many([p.translation for p in poses])
    failures = [i for i, r in enumerate(results) if not r.success]
    assert not failures, f"unsolved positions {failures[:10]}"
    for result in results:
        assert chain.in_limits(result.q, tolerance=0.0)
        assert result.q[5] == 0.0  # the default yaw
        assert result.position_error <= 1e-6


def test_position_only_scalar_left_arm_and_yaw_option(robot):
    solver = wbik.solver("analytic", robot, chain="left_arm", closed_form_options={"position": {"yaw": 0.7}})
    chain = solver.chain
    joints, poses = study(chain, 100, seed=10)
    for pose in poses:
        result = solver.solve(pose.translation)
        assert result.success, result.reason
        assert result.q[5] == 0.7 and chain.in_limits(result.q, tolerance=0.0)
    with pytest.raises(wbik.InvalidConfigurationError):
        wbik.solver("analytic", robot, chain="right_arm",
                    closed_form_options={"position": {"yaw": 2.0}}).solve([0.4, -0.3, 1.0])


def test_position_only_prefers_solutions_near_q0(right):
    """Starting at the joints that produced the position, the answer is (close to) those joints."""
    chain = right.chain
    joints, poses = study(chain, 50, seed=11)
    for q, pose in zip(joints, poses, strict=True):
        q = q.copy()
        q[5] = 0.0
        result = right.solve(pose.translation, q)
        assert result.success
        assert np.linalg.norm(result.q - q) < 1e-6


def test_position_only_10000_both_arms(robot):
    for name, seed in (("right_arm", 2017), ("left_arm", 2018)):
        solver = wbik.solver("analytic", robot, chain=name)
        joints, poses = study(solver.chain, 10_000, seed)
        results = solver.solve_many([p.translation for p in poses])
        failures = [i for i, r in enumerate(results) if not r.success]
        assert not failures, f"{name}: unsolved positions {failures[:10]}"


@pytest.mark.parametrize("name, seed, index", [("right_arm", 2017, 1462), ("right_arm", 9, 6260),
                                               ("right_arm", 100, 8870), ("left_arm", 103, 162)])
def test_position_only_slow_convergence_near_the_boundary(robot, name, seed, index):
    """Reachable positions (FK of joints inside the limits) whose search converges slowly: 40 LM trials
    left them unsolved on some machines; they need 70-150."""
    solver = wbik.solver("analytic", robot, chain=name)
    joints, poses = study(solver.chain, index + 1, seed)
    result = solver.solve(poses[index].translation)
    assert result.success, result.reason
    assert result.position_error <= 1e-9


@settings(max_examples=12, deadline=None)
@given(case=st.sampled_from([("right_arm", 2017, 1462), ("right_arm", 100, 8870), ("left_arm", 103, 162)]),
       scale=st.sampled_from([1e-14, 1e-12, 1e-10]), seed=st.integers(0, 2**32 - 1))
def test_position_only_slow_convergence_survives_rounding_noise(robot, case, scale, seed):
    """Those positions' joints moved by relative noise of 1e-14 to 1e-10 (another machine's last bits):
    the FK of joints inside the limits is still solved."""
    name, study_seed, index = case
    solver = wbik.solver("analytic", robot, chain=name)
    chain = solver.chain
    joints = chain.random(np.random.default_rng(study_seed), index + 1)[index]
    noisy = joints * (1.0 + scale * np.random.default_rng(seed).uniform(-1.0, 1.0, joints.shape))
    noisy = np.clip(noisy, chain.lower, chain.upper)
    result = solver.solve(chain.fk(noisy).translation)
    assert result.success, result.reason


def test_unreachable_targets_fail_quickly_with_a_reason(right, left):
    far_pose = pin.SE3(np.eye(3), np.array([1.5, -0.3, 1.0]))
    twisted = right.chain.fk(np.zeros(6))  # reachable position, but t6 = 3 rad is outside +-1.5 rad
    twisted = pin.SE3(twisted.rotation @ pin.rpy.rpyToMatrix(3.0, 0.0, 0.0), twisted.translation)
    for solver in (right, left):
        for target in (far_pose, twisted, [1.5, -0.3, 1.0], [0.0, 0.0, 2.5], [0.0, 0.0, 0.1]):
            result = solver.solve(target)
            assert not result.success and result.q is None
            assert "unreachable" in result.reason or "limits" in result.reason, result.reason
            assert result.time_s < 0.5  # bounded: a grid and at most 40 LM steps
    results = right.solve_many([[1.5, -0.3, 1.0], [0.0, 0.0, 2.5]])
    assert not any(r.success for r in results)


# --- the compiled choice (wbik/kernels/_stacked_planar.c) against its twin, the vectorised choice --------
def against_the_twin(test):
    """Skip where the kernel is not built; the compiled choice even in a WBIK_PURE_PYTHON=1 run."""
    from compiled_twins import compared_with_its_twin

    from wbik.solvers.analytic import stacked_planar

    for mark in compared_with_its_twin(stacked_planar._stacked_kernel):
        test = mark(test)
    return test


@against_the_twin
@pytest.mark.numerics
@pytest.mark.parametrize("arm", ["right_arm", "left_arm"])
def test_kernel_is_its_twin(robot, arm):
    """The same decisions as the vectorised choice (branch, status, solve_all's branches) on random poses,
    at gimbal lock, at the joint limits and at singular poses; the same bits where NumPy's arctan2 and
    arccos are libm's, else within TWIN_TOLERANCE (SINGULAR_TOLERANCE at the singular poses)."""
    from compiled_twins import SINGULAR_TOLERANCE, assert_twins_agree, numpy_is_libm

    solver = wbik.solver("analytic", robot, chain=arm)
    assert solver.closed_form("pose").kernel is not None
    chain = solver.chain
    rng = np.random.default_rng(2027)
    joints = chain.random(rng, 600)
    joints[:60, 4] = np.pi / 2 - joints[:60, 3]  # gimbal lock
    joints[60:120] = np.where(rng.random((60, 6)) < 0.5, chain.lower, chain.upper)
    singular = np.zeros(len(joints), dtype=bool)
    singular[120:180], joints[120:150, 3], joints[150:180, 1] = True, -RHO, 0.0  # t4 + rho = 0; t2 = 0
    starts = chain.random(rng, len(joints))
    bits = numpy_is_libm()
    for q, q0, at_singularity in zip(joints, starts, singular, strict=True):
        tolerance = SINGULAR_TOLERANCE if at_singularity else 1e-12
        assert_twins_agree(solver, wbik.targets.as_target(chain.fk(q)), q0, bits, tolerance)


@against_the_twin
def test_kernel_is_its_twin_bit_for_bit_where_numpy_is_libm():
    """NumPy without its AVX-512 code (libm's arctan2 and arccos): the kernel's joints are its twin's bits."""
    from compiled_twins import assert_same_bits_without_avx512

    assert_same_bits_without_avx512([("golem3", "right_arm"), ("golem3", "left_arm")])
