"""Time scaling: the joint velocity (and acceleration) limits hold on a dense sampling after scaling,
and they are tight (some joint reaches its limit within 1 %)."""

import numpy as np
import pytest

import wbik
from wbik.errors import InvalidConfigurationError, UnsupportedError
from wbik.motion import joint_path, time_scale, waypoint_path

VELOCITY = np.array([1.0, 0.6, 1.4])
ACCELERATION = np.array([2.0, 1.5, 3.0])


@pytest.fixture(scope="module")
def seed_path():
    """The seed-001 waypoint path (arm3r 3, 2, 2): corners, uneven joint motion."""
    robot = wbik.load("arm3r")
    solver = wbik.solver("dls", robot, timeout_s=0.05)
    return waypoint_path(solver, np.full(3, np.pi / 2), [(2, -3, 3), (0, -2, 2), (0, -2, 5)], 10)


def dense(timed, count=60001):
    times = np.linspace(0.0, timed.duration, count)
    return times, *timed.evaluate(times)


CASES = [(law, mode, accel) for law in ("linear", "cubic", "quintic")
         for mode in ("global", "waypoint", "segment") for accel in (False, True)
         if not (law == "linear" and accel)]


@pytest.mark.parametrize("law,mode,with_acceleration", CASES)
def test_limits_hold_and_are_tight(seed_path, law, mode, with_acceleration):
    acceleration = ACCELERATION if with_acceleration else None
    timed = time_scale(seed_path, law, VELOCITY, acceleration, mode)
    times, q, velocity, accel = dense(timed)
    velocity_ratio = np.max(np.abs(velocity) / VELOCITY)
    assert velocity_ratio <= 1.0 + 1e-9
    # the analytic velocity agrees with finite differences of the positions (independent check)
    numeric = np.gradient(q, times, axis=0)
    assert np.max(np.abs(numeric) / VELOCITY) <= 1.0 + 1e-3
    ratios = [velocity_ratio]
    if with_acceleration:
        acceleration_ratio = np.max(np.abs(accel) / ACCELERATION)
        assert acceleration_ratio <= 1.0 + 1e-9
        ratios.append(acceleration_ratio)
    assert max(ratios) >= 0.99  # tight: no slack left, the duration is the minimum
    # the timed path passes through every IK knot at its knot time
    assert np.allclose(timed.evaluate(timed.knot_times)[0], seed_path.q, atol=1e-12)
    assert np.all(np.diff(timed.knot_times) >= 0)


def test_two_knot_quintic_duration_is_the_hand_formula():
    chain = wbik.load("arm3r").chain()
    path = joint_path(chain, [[0.0, 0.0, 0.0], [0.5, -1.0, 0.2]], samples=1)
    # T = max_j |dq_j| * 15/8 / v_j: joint 2 moves 1.0 rad at 0.6 rad/s -> 3.125 s
    assert time_scale(path, "quintic", VELOCITY).duration == pytest.approx(1.0 * 15 / 8 / 0.6)
    # with a = 1.5 rad/s^2: sqrt(1.0 * (10/sqrt 3) / 1.5) = 1.9620 s < 3.125 s, so velocity still rules
    assert time_scale(path, "quintic", VELOCITY, ACCELERATION).duration == pytest.approx(3.125)
    # a tight acceleration limit rules: sqrt(1.0 * 6 / 0.1) for the cubic law
    assert time_scale(path, "cubic", 10.0, 0.1).duration == pytest.approx(np.sqrt(60.0))


def test_urdf_velocity_limits_are_the_default():
    robot = wbik.load("pincher")
    chain = robot.chain()
    path = joint_path(chain, [np.zeros(4), [1.0, 0.5, -0.5, 0.2]], samples=4)
    timed = time_scale(path, "cubic")
    velocity = timed.evaluate(np.linspace(0, timed.duration, 2001))[1]
    assert np.max(np.abs(velocity) / chain.velocity_limit) == pytest.approx(1.0, rel=1e-6)


def test_bad_requests_raise():
    chain = wbik.load("arm3r").chain()
    path = joint_path(chain, [np.zeros(3), np.ones(3)], samples=2)
    with pytest.raises(UnsupportedError, match="linear"):
        time_scale(path, "linear", 1.0, 1.0)
    with pytest.raises(InvalidConfigurationError, match="positive"):
        time_scale(path, "cubic", [1.0, 0.0, 1.0])
    with pytest.raises(InvalidConfigurationError, match="mode"):
        time_scale(path, "cubic", 1.0, mode="bang-bang")
    still = joint_path(chain, [np.zeros(3), np.zeros(3)], samples=2)
    with pytest.raises(InvalidConfigurationError, match="does not move"):
        time_scale(still, "cubic", 1.0)
