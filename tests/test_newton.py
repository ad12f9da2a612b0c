"""Newton-Raphson (seed 001): the worked path example, unreachable points, n joints, prismatic joints."""

from __future__ import annotations

import time

import numpy as np
import pytest

import wbik
from wbik.robot_packages.arm3r import model as arm3r
from wbik.solvers.newton import newton_step
from wbik.solvers.path import follow_path

# arm3r.md, worked example: l = (3, 2, 2), start theta = (pi/2, pi/2, pi/2) -> P0 = (0, -2, 5)
P0 = np.array([0.0, -2.0, 5.0])
WAYPOINTS = [np.array([2.0, -3.0, 3.0]), np.array([0.0, -2.0, 2.0]), np.array([0.0, -2.0, 5.0])]


def fk_seed(theta, lengths=(3.0, 2.0, 2.0)):
    """The seed's closed-form position (arm3r.md), independent of the Pinocchio model."""
    l1, l2, l3 = lengths
    c1, s1, c2, s2, c3, s3 = (np.cos(theta[0]), np.sin(theta[0]), np.cos(theta[1]), np.sin(theta[1]),
                              np.cos(theta[2]), np.sin(theta[2]))
    return np.array([l3 * c1 * c2 * c3 - l3 * c1 * s2 * s3 + l2 * c1 * c2,
                     l3 * s1 * c2 * c3 - l3 * s1 * s2 * s3 + l2 * s1 * c2,
                     l1 + l2 * s2 + l3 * c2 * s3 + l3 * s2 * c3])


@pytest.fixture(scope="module")
def arm():
    return wbik.load("arm3r")


def test_seed_path_reaches_every_waypoint(arm):
    solver = wbik.solver("newton", arm, tolerances=wbik.Tolerances(1e-9, 1e-9))
    start = arm3r.start_configuration()
    assert np.allclose(fk_seed(start), P0, atol=1e-12)
    path = follow_path(solver, WAYPOINTS, start, substeps=10)
    assert path.success, path.failures
    assert path.reached == [True, True, True]
    # every waypoint is the end of its segment: the seed stopped one sub-point short (arm3r.md)
    assert len(path.joints) == 1 + 3 * 10
    for row, point in zip(path.joints[10::10], WAYPOINTS, strict=True):
        assert np.linalg.norm(fk_seed(row) - point) <= 1e-9
    # sub-points lie on the straight segments: the first one is P0 + (P1 - P0) / 10
    assert np.linalg.norm(fk_seed(path.joints[1]) - (P0 + 0.1 * (WAYPOINTS[0] - P0))) <= 1e-9
    # continuation: consecutive rows stay close (no branch jumps)
    assert np.abs(np.diff(path.joints, axis=0)).max() < 0.5


def test_unreachable_point_returns_quickly_with_a_reason(arm):
    solver = wbik.solver("newton", arm, timeout_s=1.0)
    start = time.perf_counter()
    result = solver.solve([10.0, 0.0, 3.0])  # 10 from the shoulder axis, reach is l2 + l3 = 4
    assert time.perf_counter() - start < 0.2
    assert not result.success
    assert "out of reach" in result.reason
    assert result.iterations <= 100


def test_path_reports_unreachable_waypoint(arm):
    solver = wbik.solver("newton", arm, tolerances=wbik.Tolerances(1e-9, 1e-9))
    path = follow_path(solver, [WAYPOINTS[0], [0.0, 0.0, 12.0], WAYPOINTS[2]], arm3r.start_configuration())
    assert path.reached == [True, False, True]
    assert any("waypoint 2" in failure for failure in path.failures)


def test_newton_step_lu_and_least_squares(rng):
    square = rng.normal(size=(6, 6))
    error = rng.normal(size=6)
    assert np.allclose(square @ newton_step(square, error), error, atol=1e-10)
    wide = rng.normal(size=(3, 7))  # redundant: the minimum-norm solution
    assert np.allclose(newton_step(wide, error[:3]), np.linalg.pinv(wide) @ error[:3], atol=1e-10)
    singular = square.copy()
    singular[:, 0] = 0.0  # falls back to least squares instead of failing
    assert np.all(np.isfinite(newton_step(singular, error)))


@pytest.mark.parametrize(("robot_name", "chain_name"),
                         [("panda", "arm"), ("golem3", "right_arm_lift"), ("pincher", "arm")])
def test_newton_converges_near_the_solution(robot_name, chain_name, rng):
    """7 joints (least squares), a prismatic lift joint, and a 4-joint arm with pose targets."""
    robot = wbik.load(robot_name)
    chain = robot.chain(chain_name)
    solver = wbik.solver("newton", robot, chain=chain_name, timeout_s=1.0)  # convergence, not speed
    if chain_name == "right_arm_lift":
        assert chain.is_prismatic[0]
    for q in chain.random(rng, 10):
        q = np.clip(q, chain.lower + 0.1, chain.upper - 0.1)
        result = solver.solve(chain.fk(q), chain.clip(q + 0.05))
        assert result.success, result.reason
        reached = chain.fk(result.q)
        assert np.linalg.norm(reached.translation - chain.fk(q).translation) <= 1e-6


@pytest.mark.parametrize(("robot_name", "chain_name"),
                         [("ur5", "arm"), ("golem3", "right_arm"), ("pincher", "arm"),
                          ("bioloid", "right_leg"), ("panda", "arm")])
def test_solutions_pass_fk_check_and_limits(robot_name, chain_name, rng):
    robot = wbik.load(robot_name)
    solver = wbik.solver("newton", robot, chain=chain_name, tolerances=wbik.Tolerances(1e-5, 1e-5))
    chain = solver.chain
    solved = 0
    for q in chain.random(rng, 200):
        target = chain.fk(q)
        result = solver.solve(target, chain.mid_range)
        assert chain.in_limits(result.q, tolerance=0.0)
        assert result.iterations <= solver.max_iterations
        if result.success:
            solved += 1
            assert np.linalg.norm(chain.fk(result.q).translation - target.translation) <= 1e-5
        else:
            assert result.reason
    assert solved >= 0.1 * 200  # pure Newton from the mid-range seed: measured 18-90 %
