"""The one interface: round trips on every chain, the shared check, limits, bad input."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.solvers.base import Solver
from wbik.solvers.check import evaluate
from wbik.solvers.method_registry import IK_METHOD_REGISTRY
from wbik.solvers.result import Candidate

ROBOTS = list(wbik.robots())


def all_chains():
    for name in ROBOTS:
        robot = wbik.load(name)
        for chain in robot.chains:
            yield robot, chain


@pytest.mark.parametrize("robot_name", ROBOTS)
def test_round_trip_on_every_chain(robot_name, rng):
    """solve(FK(q)) from a start near q recovers a pose that passes the shared check."""
    robot = wbik.load(robot_name)
    for chain_name in robot.chains:
        solver = wbik.solver("dls", robot, chain=chain_name, timeout_s=0.5)
        chain = solver.chain
        for _ in range(5):
            q = chain.random(rng)
            q0 = chain.clip(q + rng.normal(0.0, 0.05, size=chain.nq))
            result = solver.solve(chain.fk(q), q0=q0)
            assert result.success, (robot_name, chain_name, result.reason)
            assert result.position_error <= 1e-6 and result.rotation_error <= 1e-6
            assert chain.in_limits(result.q)
            reached = chain.fk(result.q)
            assert np.allclose(reached.translation, chain.fk(q).translation, atol=1e-6)


def test_position_only_target_ignores_orientation(rng):
    robot = wbik.load("panda")
    solver = wbik.solver("dls", robot, chain="arm", timeout_s=0.5)
    q = solver.chain.random(rng)
    result = solver.solve(solver.chain.fk(q).translation, q0=solver.chain.clip(q + 0.1))
    assert result.success and np.allclose(result.rotation_error_xyz, 0.0)


def test_result_fields_and_per_axis_errors():
    robot = wbik.load("ur5")
    chain = robot.chain("arm")
    target = chain.fk(chain.nominal) * pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.0]))
    result = wbik.solver("dls", robot, chain="arm").solve(target)
    assert result.success and result.iterations == 0 and result.time_s >= 0.0
    assert result.position_error_xyz.shape == (3,) and result.rotation_error_xyz.shape == (3,)
    assert set(result.as_dict()) >= {"q", "success", "reason", "position_error", "rotation_error",
                                       "time_s", "iterations"}


def test_shared_check_decides_success_for_every_method():
    """A candidate 1 mm off fails the default check and passes a looser one."""
    chain = wbik.load("ur5").chain("arm")
    q = chain.nominal.copy()
    target = wbik.as_target(chain.fk(q).translation + np.array([1e-3, 0, 0]))
    strict = evaluate(chain, target, Candidate(q), wbik.Tolerances(), 0.0, "test")
    loose = evaluate(chain, target, Candidate(q), wbik.Tolerances(position=2e-3), 0.0, "test")
    assert not strict.success and "position error" in strict.reason
    assert loose.success and abs(loose.position_error - 1e-3) < 1e-12
    assert np.allclose(strict.position_error_xyz, [-1e-3, 0, 0], atol=1e-12)


def test_joints_outside_limits_are_never_returned():
    class Wild(Solver):
        name = "wild"

        def _solve(self, target, q0, deadline):
            return Candidate(self.chain.upper + 1.0)

    robot = wbik.load("pincher")
    result = Wild(robot, "arm").solve(np.array([0.1, 0.1, 0.2]))
    chain = robot.chain("arm")
    assert chain.in_limits(result.q) and not result.success and "limits" in result.reason


def test_unreachable_target_returns_reason_in_bounded_time():
    solver = wbik.solver("dls", "pincher", timeout_s=0.02)
    result = solver.solve(np.array([5.0, 0.0, 0.0]))
    assert not result.success and result.reason
    assert result.time_s < 0.5


def test_solve_many_matches_solve(rng):
    robot = wbik.load("ur5")
    solver = wbik.solver("dls", robot, chain="arm", timeout_s=0.5)
    chain = solver.chain
    qs = chain.random(rng, 5)
    targets = [chain.fk(q) for q in qs]
    starts = chain.clip(qs + 0.05)
    batch = solver.solve_many(targets, starts)
    single = [solver.solve(t, s) for t, s in zip(targets, starts, strict=True)]
    for a, b in zip(batch, single, strict=True):
        assert a.success == b.success and np.allclose(a.q, b.q)


def test_register_a_user_method():
    class Nominal(Solver):
        name = "nominal"

        def _solve(self, target, q0, deadline):
            return Candidate(self.chain.nominal)

    with IK_METHOD_REGISTRY.isolated():  # gone afterwards
        wbik.register("nominal_test", Nominal, "returns the nominal configuration")
        assert "nominal_test" in wbik.methods()
        chain = wbik.load("arm3r").chain()
        result = wbik.solver("nominal_test", "arm3r").solve(chain.fk(chain.nominal).translation)
        assert result.success
    assert "nominal_test" not in wbik.methods()


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_joints_from_a_method_are_refused(bad):
    """The shared check turns NaN or infinite joints into a failed result without joints (clipping
    an infinite value into the limits must not pass it off as a solution)."""
    chain = wbik.load("ur5").chain("arm")
    q = chain.nominal.copy()
    target = wbik.as_target(chain.fk(q))
    q[2] = bad
    result = evaluate(chain, target, Candidate(q), wbik.Tolerances(), 0.0, "test")
    assert result.q is None and not result.success and "invalid joints" in result.reason
    assert np.isnan(result.position_error) and np.isnan(result.rotation_error)
    short = evaluate(chain, target, Candidate(q[:3]), wbik.Tolerances(), 0.0, "test")
    assert short.q is None and "invalid joints" in short.reason


def test_a_target_from_an_se3_owns_its_values():
    """as_target copies the SE3: changing the SE3 afterwards leaves the target as it was."""
    pose = pin.SE3(pin.exp3(np.array([0.1, -0.2, 0.3])), np.array([0.4, 0.5, 0.6]))
    expected = pose.homogeneous.copy()
    target = wbik.as_target(pose)
    pose.translation = np.zeros(3)
    pose.rotation = np.eye(3)
    assert np.array_equal(target.position, expected[:3, 3])
    assert np.array_equal(target.rotation, expected[:3, :3])


def test_a_4x4_matrix_takes_the_fast_path_with_the_general_paths_verdict():
    """A float64 4x4 pose gives the Target the general path gives (an SE3 of it), owns its values, and
    anything the fast test does not accept (a near-[0, 0, 0, 1] last row, a bent rotation, NaN, float32,
    a far position) still gets the general path's answer or error."""
    from wbik.errors import InvalidTargetError

    rng = np.random.default_rng(12)
    for _ in range(50):
        pose = pin.SE3(pin.exp3(rng.uniform(-3.0, 3.0, 3)), rng.uniform(-2.0, 2.0, 3))
        matrix = pose.homogeneous.copy()
        target = wbik.as_target(matrix)
        assert np.array_equal(target.position, pose.translation)
        assert np.array_equal(target.rotation, pose.rotation)
        matrix[:3, 3] = 0.0
        assert np.array_equal(target.position, pose.translation)  # a copy, not a view of the input
    good = pin.SE3(pin.exp3(np.array([0.2, 0.1, -0.4])), np.array([0.3, 0.0, 0.5])).homogeneous
    near_row = good.copy()
    near_row[3, 2] = 1e-12  # allclose to [0, 0, 0, 1]: the general path accepts it
    assert np.array_equal(wbik.as_target(near_row).rotation, good[:3, :3])
    assert np.array_equal(wbik.as_target(good.astype(np.float32)).position, good[:3, 3].astype(np.float32))
    for change in ({(0, 0): good[0, 0] + 1e-3}, {(1, 3): np.nan}, {(2, 3): 2e6}, {(3, 0): 0.5}):
        bad = good.copy()
        for index, value in change.items():
            bad[index] = value
        with pytest.raises(InvalidTargetError):
            wbik.as_target(bad)


def test_positions_and_targets_take_the_fast_path_with_the_general_paths_verdict():
    """A float64 3-vector or a Target (pose or position) gives what the general path gives for the same
    values as lists, as a copy; what the fast test leaves out gets the general path's answer or error."""
    from wbik.errors import InvalidTargetError
    from wbik.targets import MAX_POSITION

    rng = np.random.default_rng(13)
    for _ in range(50):
        pose = pin.SE3(pin.exp3(rng.uniform(-3.0, 3.0, 3)), rng.uniform(-2.0, 2.0, 3))
        general = wbik.as_target(pose.translation.tolist(), rotation=pose.rotation.tolist())
        for given in (wbik.Target(pose.translation.copy(), pose.rotation.copy()), pose.translation.copy()):
            target = wbik.as_target(given)
            assert np.array_equal(target.position, general.position)
            if isinstance(given, wbik.Target):
                assert np.array_equal(target.rotation, general.rotation)
                assert target.position is not given.position and target.rotation is not given.rotation
            else:
                assert target.rotation is None and target.position is not given
    edge = np.array([MAX_POSITION, -MAX_POSITION, 0.0])
    assert np.array_equal(wbik.as_target(edge).position, wbik.as_target(edge.tolist()).position)
    for bad in (np.array([np.nan, 0.0, 0.0]), np.array([np.inf, 0.0, 0.0]), np.array([2e6, 0.0, 0.0]),
                wbik.Target(np.zeros(3), np.eye(3) * 1.01),
                wbik.Target(np.array([0.0, np.nan, 0.0]), np.eye(3))):
        with pytest.raises(InvalidTargetError):
            wbik.as_target(bad)
    assert wbik.as_target(np.array([1, 2, 3])).position.dtype == np.float64  # ints: the general path
