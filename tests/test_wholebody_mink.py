"""Method ``mink`` on whole bodies: MuJoCo's model of the same URDF (a free joint on the root link for a
floating base, a site per frame) is the robot wbik knows, and mink solves with its own tasks.

mink's centre of mass (``subtree_com`` of the root body, what its ComTask reads) and every frame (its
site) are measured through a mink Configuration at wbik's configurations and compared with Pinocchio's
FK: Talos and Solo12 of example-robot-data at the nominal and seeded random configurations (the base
anywhere within 1 m with any orientation, joints anywhere in their limits).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.mujoco_model import mujoco_body, random_configurations
from wbik.qp.support_polygon import sole_rectangle
from wbik.qp.tasks import ComTask, PositionTask
from wbik.wholebody.problem import WholeBody

pytest.importorskip("mink")

FEET = {  # each robot's feet: flat 0.20 x 0.12 m soles (tasks/talos_reach.yaml) or point feet
    "example-robot-data:talos": {sole: sole_rectangle(0.20, 0.12, [-0.005, 0.0, 0.0])
                                 for sole in ("left_sole_link", "right_sole_link")},
    "example-robot-data:solo12": {foot: [0.0, 0.0, 0.0]
                                  for foot in ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")},
}


def mink_com(solver, q: np.ndarray) -> np.ndarray:
    """mink's centre of mass (m, world) at wbik's configuration q, as its ComTask reads it."""
    body = mujoco_body(solver.robot)
    configuration = solver._configuration(body)
    configuration.update(body.qpos(np.asarray(q, dtype=float)))
    return configuration.data.subtree_com[1].copy()


def mink_placement(solver, q: np.ndarray, frame: str, masses: bool = True) -> pin.SE3:
    """mink's world placement of a wbik frame (its site) at wbik's configuration q."""
    body = mujoco_body(solver.robot, masses, frames=[frame])
    configuration = solver._configuration(body)
    configuration.update(body.qpos(np.asarray(q, dtype=float)))
    return pin.SE3(configuration.get_transform_frame_to_world(body.site(frame), "site").as_matrix())


@pytest.fixture(scope="module", params=sorted(FEET))
def robot_and_solver(request):
    robot = wbik.load(request.param, soles=FEET[request.param])
    return robot, wbik.solver("mink", robot)


def test_mink_com_and_frames_equal_wbik_to_1e_9(robot_and_solver):
    robot, solver = robot_and_solver
    assert robot.has_floating_base
    configurations = [robot.nominal, *random_configurations(robot, 4, seed=11)]
    frames = list(dict.fromkeys(robot.frame_names))
    assert len(frames) > 20
    for q in configurations:
        np.testing.assert_allclose(mink_com(solver, q), robot.center_of_mass(q), rtol=0, atol=1e-9)
        for frame in frames:
            ours, theirs = robot.frame_placement(q, frame), mink_placement(solver, q, frame)
            assert np.max(np.abs(theirs.translation - ours.translation)) <= 1e-9, frame
            assert np.linalg.norm(pin.log3(ours.rotation.T @ theirs.rotation)) <= 1e-9, frame


def test_configurations_go_to_mujoco_and_back(robot_and_solver):
    robot, solver = robot_and_solver
    for q in random_configurations(robot, 3, seed=2):
        np.testing.assert_array_equal(solver.built.q(solver.built.qpos(q)), q)
    assert solver.built.model.nq == robot.model.nq and solver.built.model.nv == robot.model.nv


def test_mink_moves_the_com_with_its_feet_held(robot_and_solver):
    """The CoM 1 cm forward and 5 mm sideways on every foot held: solved, judged by the shared check,
    the missing hard support polygon said (and nothing else)."""
    robot, solver = robot_and_solver
    q0 = robot.nominal
    target = robot.center_of_mass(q0) + np.array([0.01, 0.005, 0.0])
    problem = WholeBody(robot, [ComTask(target, axes="xy")], contacts=sorted(robot.soles), limits="position")
    result = solver.solve(problem, q0)
    assert result.success, result.reason
    assert np.linalg.norm(robot.center_of_mass(result.q)[:2] - target[:2]) <= 1e-6
    assert result.contact_drift <= 1e-6 and result.com_margin >= problem.margin
    assert [(item.peer, item.what) for item in result.unsupported] == [("mink", "CoM in support polygon "
                                                                                "(margin 5 mm)")]


def test_a_position_on_some_axes_is_held_in_world_axes():
    """A position task on z alone moves the frame's world z only as far as asked; x and y are free."""
    bioloid = wbik.load("bioloid")
    q0 = bioloid.nominal
    start = bioloid.frame_placement(q0, "r_hand").translation
    task = PositionTask("r_hand", start + [0.0, 0.0, 0.02], axes="z", name="hand up")
    problem = WholeBody(bioloid, [task], contacts=["r_sole", "l_sole"], support=[])
    result = wbik.solver("mink", bioloid).solve(problem, q0)
    assert result.success, result.reason
    reached = bioloid.frame_placement(result.q, "r_hand").translation
    assert reached[2] == pytest.approx(start[2] + 0.02, abs=1e-6)
    assert result.unsupported == []


def test_options_are_checked():
    from wbik.errors import InvalidSettingError

    bioloid = wbik.load("bioloid")
    with pytest.raises(InvalidSettingError, match="limit_gain"):
        wbik.solver("mink", bioloid, limit_gain=0.0)
    with pytest.raises(InvalidSettingError, match="damping"):
        wbik.solver("mink", bioloid, damping=-1.0)
