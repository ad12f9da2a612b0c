"""Robots nobody here wrote: example-robot-data's URDFs load as they are (continuous joints, a joint and a
link sharing a name, mimic joints, trees, floating bases, SRDF reference postures), chains are found from
a base and a tip, and every chain method solves them."""

from __future__ import annotations

import json
import math

import example_robot_data
import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.cli import main
from wbik.errors import RobotDescriptionError, UnknownChainError, UnknownRobotError
from wbik.study.definition import study_from_dict


def faithful_model(robot: wbik.Robot) -> pin.Model:
    """Pinocchio's own parse of the robot's URDF (continuous joints as cos, sin), built here."""
    if robot.has_floating_base:
        return pin.buildModelFromXML(robot.urdf_text, pin.JointModelFreeFlyer())
    return pin.buildModelFromXML(robot.urdf_text)


def faithful_configuration(robot: wbik.Robot, faithful: pin.Model, q: np.ndarray) -> np.ndarray:
    """wbik's full configuration q written in the faithful model's form (cos, sin per continuous joint)."""
    out = pin.neutral(faithful)
    for joint_id in range(1, faithful.njoints):
        ours, theirs = robot.model.joints[joint_id], faithful.joints[joint_id]
        values = q[ours.idx_q:ours.idx_q + ours.nq]
        if theirs.nq == 2 and ours.nq == 1:
            out[theirs.idx_q:theirs.idx_q + 2] = math.cos(values[0]), math.sin(values[0])
        else:
            out[theirs.idx_q:theirs.idx_q + theirs.nq] = values
    return out


@pytest.mark.parametrize("name", ["kinova", "bravo7_no_ee", "pr2", "tiago", "double_pendulum_continuous"])
def test_continuous_joints_load_as_one_angle_with_the_same_kinematics(name):
    robot = wbik.load(f"example-robot-data:{name}")
    faithful = faithful_model(robot)
    assert robot.continuous_joints, "the URDF has continuous joints"
    assert robot.model.nq == faithful.nq - len(robot.continuous_joints) and robot.model.nv == faithful.nv
    rng = np.random.default_rng(3)
    data, faithful_data = robot.model.createData(), faithful.createData()
    for _ in range(5):
        q = robot.nominal.copy()
        for joint_id in range(1, robot.model.njoints):
            joint = robot.model.joints[joint_id]
            if joint.nq == 1:
                low = max(robot.model.lowerPositionLimit[joint.idx_q], -4.0)
                high = min(robot.model.upperPositionLimit[joint.idx_q], 4.0)
                q[joint.idx_q] = rng.uniform(low, high)
        pin.framesForwardKinematics(robot.model, data, q)
        pin.framesForwardKinematics(faithful, faithful_data, faithful_configuration(robot, faithful, q))
        for frame in range(len(faithful.frames)):
            assert np.allclose(data.oMf[frame].homogeneous, faithful_data.oMf[frame].homogeneous, atol=1e-12)
    for joint in robot.continuous_joints:
        index = robot.model.joints[robot.model.getJointId(joint)].idx_q
        assert robot.model.lowerPositionLimit[index] == -math.pi
        assert robot.model.upperPositionLimit[index] == math.pi


def test_reference_posture_is_the_nominal_configuration():
    for name in ("talos", "solo12", "kinova"):
        robot = wbik.load(f"example-robot-data:{name}")
        reference = example_robot_data.load(name).q0
        faithful = faithful_model(robot)
        assert np.allclose(faithful_configuration(robot, faithful, robot.nominal), reference, atol=1e-12)
    assert wbik.load("erd:talos").has_floating_base


def test_unknown_and_sdf_robots_are_typed_errors():
    with pytest.raises(UnknownRobotError, match="talos"):
        wbik.load("example-robot-data:taloss")
    with pytest.raises(RobotDescriptionError, match="SDF"):
        wbik.load("example-robot-data:cassie")


@pytest.mark.parametrize("method", ["bounded_lm", "trac_ik", "kdl", "qp", "placo", "dls"])
def test_every_chain_method_solves_a_chain_with_continuous_joints(method):
    robot = wbik.load("example-robot-data:kinova")
    chain = robot.chain_between("base", "j2s6s200_end_effector")
    assert chain.continuous.tolist() == [True, False, False, True, False, True]
    solver = wbik.solver(method, robot, chain=chain.name, timeout_s=0.05)
    rng = np.random.default_rng(7)
    solved = 0
    for _ in range(8):
        q = chain.random(rng)
        # a start half a turn away on the continuous joints: reaching q may cross the +-pi seam
        q0 = np.where(chain.continuous, chain.wrap_continuous(q + 3.0), q + 0.2 * rng.standard_normal(6))
        result = solver.solve(chain.fk(q), chain.clip(q0))
        if result.success:
            solved += 1
            assert chain.in_limits(result.q)
            assert np.all(np.abs(result.q[chain.continuous]) <= math.pi)
            assert np.linalg.norm(chain.fk(result.q).translation - chain.fk(q).translation) < 1e-6
    assert solved >= (6 if method in ("bounded_lm", "trac_ik") else 1)


def test_trac_ik_and_the_qp_leave_continuous_joints_unbounded():
    import pytracik

    robot = wbik.load("example-robot-data:kinova")
    chain = robot.chain_between("base", "j2s6s200_end_effector")
    tracik = wbik.solver("trac_ik", robot, chain=chain.name)
    lower = np.array(pytracik.get_joint_lower_bounds(tracik._thread_state()))
    upper = np.array(pytracik.get_joint_upper_bounds(tracik._thread_state()))
    extreme = float(np.finfo(np.float32).max)  # TRAC-IK's mark of a continuous joint
    assert np.all(lower[chain.continuous] <= -extreme) and np.all(upper[chain.continuous] >= extreme)
    assert np.allclose(lower[~chain.continuous], chain.lower[~chain.continuous])
    qp = wbik.solver("qp", robot, chain=chain.name)
    limits = qp._thread_state()["pose"][1].constraints[0]
    bounded = {chain.model.names[j] for j in range(1, chain.model.njoints)
               if chain.model.joints[j].idx_q in limits.q_index}
    assert bounded == {name for name, wraps in zip(chain.joint_names, chain.continuous, strict=True)
                       if not wraps}


def test_a_joint_and_a_link_sharing_a_name_load_and_the_link_keeps_it():
    robot = wbik.load("example-robot-data:z1")
    assert robot.renamed_frames == {"gripperStator_joint": "gripperStator"}
    frame = robot.model.frames[robot.frame_id("gripperStator")]
    assert frame.type == pin.FrameType.BODY
    chain = robot.chain()
    result = wbik.solver("bounded_lm", robot).solve(chain.fk(chain.random(np.random.default_rng(0))))
    assert result.success
    tool = robot.chain_between("link00", "gripperStator")
    assert tool.joint_names == [f"joint{i}" for i in range(1, 7)]
    # PlaCo reads the URDF itself and looks frames up by name alone: it gets the joint renamed too
    placo = wbik.solver("placo", robot, chain=tool.name, timeout_s=0.02)
    rng = np.random.default_rng(1)
    results = [placo.solve(tool.fk(q), q + 0.05) for q in tool.random(rng, 10)]
    assert sum(r.success for r in results) >= 5, [r.reason for r in results]


def test_chains_between_base_and_tip_on_tree_robots():
    icub = wbik.load("example-robot-data:icub")
    with pytest.raises(UnknownChainError, match="chain_between"):
        icub.chain()
    arm = icub.chain_between("chest", "r_hand")
    assert arm.joint_names == ["r_shoulder_pitch", "r_shoulder_roll", "r_shoulder_yaw", "r_elbow",
                               "r_wrist_prosup", "r_wrist_pitch", "r_wrist_yaw"]
    assert icub.chain(arm.name) is arm
    # TRAC-IK reads the same URDF and counts the same joints between the frames
    assert wbik.solver("trac_ik", icub, chain=arm.name).chain.nq == 7
    with pytest.raises(RobotDescriptionError, match="upstream"):
        icub.chain_between("r_hand", "l_hand")
    with pytest.raises(RobotDescriptionError, match="root_joint|1-DOF"):
        icub.chain_between("universe", "r_hand")  # the floating base lies between them


def test_mimic_joints_on_the_way_are_locked_and_named():
    robot = wbik.load("example-robot-data:panda")
    assert robot.mimic["panda_finger_joint2"].leader == "panda_finger_joint1"
    finger = robot.chain_between("panda_link0", "panda_rightfinger")
    assert finger.locked_mimic == ("panda_finger_joint2",)
    assert finger.joint_names == [f"panda_joint{i}" for i in range(1, 8)]


def test_cli_solves_a_chain_named_by_base_and_tip(capsys):
    code = main(["solve", "example-robot-data:talos", "--base", "torso_2_link", "--tip",
                 "gripper_right_base_link", "--xyz", "0.35", "-0.3", "-0.1", "--method", "bounded_lm",
                 "--json"])
    out = capsys.readouterr().out
    assert code == 0 and json.loads(out)["success"] and len(json.loads(out)["q"]) == 7
    assert main(["solve", "example-robot-data:talos", "--base", "torso_2_link", "--xyz", "0", "0", "0"]) == 2
    assert "--tip" in capsys.readouterr().err


def test_study_files_name_chains_by_base_and_tip():
    study = study_from_dict({"robot": "example-robot-data:icub", "base": "chest", "tip": "r_hand",
                             "methods": ["bounded_lm"]}, "inline.yaml")
    case = study.cases[0]
    assert (case.base, case.tip, case.chain) == ("chest", "r_hand", "chest_to_r_hand")
    with pytest.raises(wbik.WbikError, match="tip"):
        study_from_dict({"robot": "example-robot-data:icub", "base": "chest", "methods": ["dls"]},
                        "inline.yaml")
