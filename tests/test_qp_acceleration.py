"""Acceleration limits on the differential step: the change of joint velocity between periods is
bounded, each joint keeps room to brake before its position limits, and the chatter of a joint
bouncing off its limit at full velocity goes away (benchmarks/chatter.py's constructed case).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import wbik
from wbik.errors import InvalidSettingError
from wbik.qp import ComTask, IKProblem, JointPositionLimits, JointVelocityLimits, PositionTask
from wbik.qp.limits import JointAccelerationLimits, stopping_velocity
from wbik.scenarios import load_scenario
from wbik.scenarios.kinds import UnknownScenarioKeyError
from wbik.wholebody.problem import WholeBody

ROOT = Path(__file__).resolve().parents[1]


def chatter_benchmark():
    spec = importlib.util.spec_from_file_location("chatter", ROOT / "benchmarks" / "chatter.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def chatter():
    return chatter_benchmark()


def braking_distance(velocity: float, acceleration: float, dt: float) -> float:
    """dt sum_k max(v - k a dt, 0): the distance covered braking at a from v, one period at a time."""
    steps = np.arange(0, int(velocity / (acceleration * dt)) + 2)
    return float(dt * np.maximum(velocity - steps * acceleration * dt, 0.0).sum())


@settings(max_examples=200, deadline=None)
@given(distance=st.floats(0.0, 3.0), acceleration=st.floats(0.5, 500.0), dt=st.floats(1e-3, 0.05))
def test_the_stopping_velocity_is_the_largest_that_stops_in_time(distance, acceleration, dt):
    velocity = float(stopping_velocity(np.array([distance]), np.array([acceleration]), dt)[0])
    assert braking_distance(velocity, acceleration, dt) <= distance * (1 + 1e-12) + 1e-15
    faster = velocity * (1 + 1e-6) + 1e-9
    assert braking_distance(faster, acceleration, dt) > distance


def test_acceleration_limits_remove_the_chatter_at_a_joint_limit(chatter):
    robot = chatter.planar_arm()
    alone = chatter.track(robot, None, seconds=2.0)
    limited = chatter.track(robot, 20.0, seconds=2.0)
    # velocity limits alone: the elbow bounces off its limit at full velocity period after period
    assert alone["sign_changes_per_s"].sum() > 4 * limited["sign_changes_per_s"].sum()
    assert alone["max_acceleration"].max() > 500.0
    # held to DAQP's primal tolerance on a bound, 1e-6 rad of dq: 1e-6 / dt^2 = 0.01 rad/s^2 here
    assert limited["max_acceleration"].max() <= 20.0 + 1e-6 / 0.01 ** 2
    assert limited["elbow_min_rad"] >= -1e-6  # the elbow keeps its limit (to the same tolerance)


def test_a_joint_driven_at_its_limit_brakes_in_time(chatter):
    """The shoulder pulled past its upper limit (2.5 rad) from rest: it accelerates, then brakes at
    the acceleration limit so as to stop on its limit, never beyond, never faster than allowed."""
    robot = chatter.planar_arm()
    model, dt, limit = robot.model, 0.01, 30.0
    task = PositionTask("tip", np.array([-0.6 * np.cos(0.3), -0.6 * np.sin(0.3), 0.0]), axes="xy")
    problem = IKProblem(model, [task], [JointPositionLimits(), JointVelocityLimits(),
                                        JointAccelerationLimits(limit)])
    q, velocity = np.array([1.0, 0.0]), np.zeros(2)
    for _ in range(150):
        dq = problem.step(q, dt=dt)
        assert np.all(np.abs(dq / dt - velocity) <= limit * dt * (1 + 1e-9) + 1e-12)
        q, velocity = q + dq, dq / dt
        assert q[0] <= 2.5 + 1e-6
    assert q[0] == pytest.approx(2.5, abs=1e-4) and abs(velocity[0]) < 1e-2


def test_a_measured_velocity_is_the_previous_one(chatter):
    robot = chatter.planar_arm()
    model = robot.model
    problem = IKProblem(model, [PositionTask("tip", np.array([0.0, 0.6, 0.0]), axes="xy")],
                        [JointAccelerationLimits(10.0)])
    dq = problem.step(np.array([0.0, 1.0]), dt=0.01, velocity=np.array([2.0, -1.0]))
    assert np.all(np.abs(dq / 0.01 - [2.0, -1.0]) <= 10.0 * 0.01 + 1e-12)


def test_a_whole_body_with_acceleration_limits_converges_and_peers_say_they_cannot():
    bioloid = wbik.load("bioloid")
    q0 = bioloid.nominal
    right = bioloid.frame_placement(q0, "r_sole").translation
    shift, soles = [ComTask([right[0], right[1], 0.0], axes="xy")], ["r_sole", "l_sole"]
    problem = WholeBody(bioloid, shift, contacts=soles, step_dt=0.01, acceleration_limit=10.0)
    free = WholeBody(bioloid, shift, contacts=soles)
    limited = wbik.solver("qp", bioloid, max_iterations=500).solve(problem, q0)
    unlimited = wbik.solver("qp", bioloid, max_iterations=500).solve(free, q0)
    assert limited.success and unlimited.success and limited.iterations > unlimited.iterations
    assert any("acceleration limits" in item for item in wbik.solver("placo", bioloid)
               .unsupported(problem))
    with pytest.raises(InvalidSettingError, match="acceleration_limit"):
        WholeBody(bioloid, [ComTask([0.0, 0.0, 0.0], axes="xy")], acceleration_limit=-1.0)


BALANCE = """kind: wholebody_ik
robot: bioloid
phases:
  - name: shift
    contacts: [r_sole, l_sole]
    dt: 0.01
    acceleration_limit: 20
    max_iterations: 500
    tasks:
      - {type: com, over: r_sole, axes: xy}
"""


def test_task_files_take_acceleration_limits_and_correct_a_misspelling(tmp_path):
    path = tmp_path / "accel.yaml"
    path.write_text(BALANCE)
    report = wbik.scenarios.run_scenario(str(path))
    assert report["passed"], report
    path.write_text(BALANCE.replace("acceleration_limit:", "acceleration_limt:"))
    with pytest.raises(UnknownScenarioKeyError, match="did you mean 'acceleration_limit'"):
        load_scenario(path)
