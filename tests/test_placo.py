"""Method placo: PlaCo's kinematics solver on the same URDF, chain joints only."""

import numpy as np
import pytest

import wbik
from wbik.solvers.placo import kinematic_urdf_path, placo_configuration, placo_robot


def test_kinematic_urdf_has_no_geometry_and_same_kinematics():
    robot = wbik.load("ur5")  # example-robot-data URDF naming package:// meshes
    text = kinematic_urdf_path(robot).read_text()
    assert "<mesh" not in text and "<visual" not in text
    wrapper = placo_robot(robot)
    q = np.array([0.3, -1.2, 1.0, -0.5, 0.8, 0.2])
    from wbik.solvers.placo import set_placo_configuration

    set_placo_configuration(robot, wrapper, q)
    ours = robot.frame_placement(q, "tcp").homogeneous
    assert np.allclose(wrapper.get_T_world_frame("tcp"), ours, atol=1e-12)
    assert np.allclose(placo_configuration(robot, wrapper), q)


@pytest.mark.parametrize("robot_name, chain_name, q_goal", [
    ("panda", "arm", [0.2, -0.3, 0.1, -2.1, 0.2, 1.8, 0.4]),
    ("golem3", "right_arm_lift", [0.2, 0.1, 0.3, 0.2, 0.5, 0.3, 0.1]),
])
def test_placo_reaches_a_pose_and_moves_only_the_chain(robot_name, chain_name, q_goal):
    robot = wbik.load(robot_name)
    chain = robot.chain(chain_name)
    solver = wbik.solver("placo", robot, chain=chain_name, timeout_s=1.0)
    result = solver.solve(chain.fk(np.array(q_goal)))
    assert result.success, result.reason
    assert result.position_error <= 1e-6 and result.rotation_error <= 1e-6
    assert chain.in_limits(result.q)
    # joints outside the chain stayed at the nominal inside PlaCo
    full = placo_configuration(robot, solver._thread_state())
    others = np.setdiff1d(np.arange(robot.model.nq), chain.q_index)
    assert np.allclose(full[others], robot.nominal[others])


def test_placo_position_target_on_the_bioloid_leg():
    robot = wbik.load("bioloid")
    chain = robot.chain("right_leg")
    q_goal = chain.nominal + np.array([0.05, 0.05, -0.1, 0.15, -0.05, -0.05])
    target = chain.fk(q_goal).translation
    result = wbik.solver("placo", robot, chain="right_leg", timeout_s=1.0).solve(target)
    assert result.success, result.reason
    assert np.linalg.norm(chain.fk(result.q).translation - target) <= 1e-6


def test_placo_agrees_with_qp_on_the_same_target():
    robot = wbik.load("golem3")
    chain = robot.chain("right_arm")
    target = chain.fk(np.array([0.1, 0.3, 0.2, 0.4, 0.3, 0.2])).translation
    ours = wbik.solver("qp", robot, chain="right_arm", backend="daqp", timeout_s=1.0).solve(target)
    theirs = wbik.solver("placo", robot, chain="right_arm", timeout_s=1.0).solve(target)
    assert ours.success and theirs.success
    assert np.linalg.norm(chain.fk(ours.q).translation - chain.fk(theirs.q).translation) < 2e-6
