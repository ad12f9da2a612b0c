"""Cartesian paths: the seed-001 waypoints are all reached, straight lines are tracked to 1e-6 m,
continuity holds, and unreachable points and branch jumps are reported."""

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.motion import FunctionReference, follow, joint_path, linear_path, waypoint_path
from wbik.targets import Target

SEED_WAYPOINTS = [(2.0, -3.0, 3.0), (0.0, -2.0, 2.0), (0.0, -2.0, 5.0)]
UR5_START = np.array([0.3, -1.2, 1.5, -1.8, -1.4, 0.2])


def distance_to_line(points, a, b):
    direction = (b - a) / np.linalg.norm(b - a)
    offsets = points - a
    return np.linalg.norm(offsets - np.outer(offsets @ direction, direction), axis=1)


@pytest.mark.parametrize("method", ["dls", "newton"])
def test_seed_001_reaches_every_waypoint(method):
    robot = wbik.load("arm3r")
    solver = wbik.solver(method, robot, timeout_s=0.05)
    path = waypoint_path(solver, np.full(3, np.pi / 2), SEED_WAYPOINTS, samples=10)
    assert len(path.s) == 31  # the seed's 31 rows: start + 3 segments x 10 sub-points
    assert path.success, path.summary()
    chain = robot.chain()
    for knot, waypoint in zip(path.waypoint_knots, SEED_WAYPOINTS, strict=True):
        assert np.linalg.norm(chain.fk(path.q[knot]).translation - waypoint) <= 1e-6
    # every sub-point lies on its segment (hand-made line points, not the reference object)
    points = [np.array([0.0, -2.0, 5.0]), *map(np.array, SEED_WAYPOINTS)]
    for segment in range(3):
        for k in range(1, 11):
            wanted = points[segment] + k / 10 * (points[segment + 1] - points[segment])
            reached = chain.fk(path.q[10 * segment + k]).translation
            assert np.linalg.norm(reached - wanted) <= 1e-6
    assert path.max_step() < 0.3  # continuity: small steps, no branch change


def test_ur5_pose_line_tracked_to_1e_6():
    robot = wbik.load("ur5")
    solver = wbik.solver("dls", robot, chain="arm", timeout_s=0.05)
    chain = solver.chain
    start = chain.fk(UR5_START)
    goal = pin.SE3(start.rotation @ pin.exp3(np.array([0.2, -0.1, 0.3])),
                   start.translation + np.array([0.12, -0.08, 0.05]))
    path = linear_path(solver, UR5_START, goal, samples=20)
    assert path.success, path.summary()
    position_errors, rotation_errors = path.knot_errors()
    assert position_errors.max() <= 1e-6 and rotation_errors.max() <= 1e-6
    tips = np.array([chain.fk(q).translation for q in path.q])
    assert distance_to_line(tips, start.translation, goal.translation).max() <= 1e-6
    # the orientation turns about one fixed axis at a uniform rate (geodesic)
    angles = [np.linalg.norm(pin.log3(start.rotation.T @ chain.fk(q).rotation)) for q in path.q]
    assert np.allclose(angles, np.linspace(0, np.linalg.norm([0.2, -0.1, 0.3]), 21), atol=1e-6)


def test_unreachable_point_is_reported_in_bounded_time():
    robot = wbik.load("arm3r")
    solver = wbik.solver("dls", robot, timeout_s=0.01)
    # the shoulder is at (0, 0, 3); l2 + l3 = 4, so (0, 0, 8) is 5 away: out of reach
    path = waypoint_path(solver, np.full(3, np.pi / 2), [(0.0, 0.0, 8.0)], samples=5, refinements=0)
    assert not path.success
    assert not path.solved[-1]
    assert path.reasons[len(path.s) - 1]
    assert path.summary()["unsolved_knots"]


def test_branch_jump_is_detected():
    robot = wbik.load("arm3r")
    solver = wbik.solver("dls", robot, timeout_s=0.05)
    chain = solver.chain
    q0 = np.full(3, np.pi / 2)
    near, far = chain.fk(q0).translation, np.array([2.5, 1.5, 2.0])

    def teleport(s):  # a reference with a discontinuity at s = 0.5: no sampling can follow it
        return Target(near if s < 0.5 else far)

    path = follow(solver, FunctionReference(teleport), np.linspace(0, 1, 5), q0, jump_threshold=0.3)
    assert path.jumps == [2]  # s = 0.5, after halving the interval three times did not help
    assert "branch jump" in path.reasons[2]
    assert len(path.s) == 5  # failed refinements leave no extra knots
    assert not path.success


def test_joint_path_is_linear_in_joints():
    chain = wbik.load("pincher").chain()
    start, end = np.array([0.1, 0.2, -0.3, 0.4]), np.array([-0.5, 0.6, 0.3, -0.2])
    path = joint_path(chain, [start, end], samples=4)
    assert np.allclose(path.q, [start + k / 4 * (end - start) for k in range(5)])
    with pytest.raises(wbik.InvalidConfigurationError, match="outside the joint limits"):
        joint_path(chain, [start, [4.0, 0, 0, 0]])
