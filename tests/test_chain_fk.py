"""The compiled chain FK (:mod:`wbik.kernels._chain_fk`, Pinocchio's own C++ FK on a copy of a chain's
model): the same bits as Pinocchio's binding for the tip pose and as :func:`wbik.geometry.pose_errors` of
that pose for the shared check's errors, on the seed chains and on example-robot-data chains with every
joint type it copies; the twin wherever it cannot copy a model; the same answers from ``solve``."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import wbik
from wbik.geometry import pose_errors
from wbik.kernels import chain_fk
from wbik.kernels.twins import can_build, pure_python

BUILT = chain_fk.tip_pose is not None
NEEDS_KERNEL = pytest.mark.skipif(not BUILT, reason="the C++ kernel is not built here (no compiler or no "
                                  "Pinocchio headers): test_the_kernel_is_built_where_it_can_be says why")

SEED_CHAINS = [("ur5", "arm"), ("golem3", "right_arm"), ("panda", "arm"), ("bioloid", "right_leg"),
               ("pincher", "arm")]
ZOO_CHAINS = [  # (robot, base frame, tip frame): the joint types they bring besides RX, RY and RZ
    ("example-robot-data:pr2", "base_link", "r_gripper_r_finger_tip_link"),  # PZ, RevoluteUnaligned
    ("example-robot-data:finger_edu", "base_link", "finger_tip_link"),  # RevoluteUnaligned
    ("example-robot-data:panda", "panda_link0", "panda_leftfinger"),  # PY (a finger)
    ("example-robot-data:panda", "panda_link0", "panda_rightfinger"),  # PrismaticUnaligned where not mimic
    ("example-robot-data:romeo", "body", "LFinger23Link"),  # RevoluteUnaligned, a floating base's tree
    ("example-robot-data:tiago", "base_link", "arm_7_link"),  # PZ (the torso)
    ("example-robot-data:kinova", "j2s6s200_link_base", "j2s6s200_end_effector"),
]


def _binding_tip(chain, q: np.ndarray) -> np.ndarray:
    """The tip pose by Pinocchio's binding, as Chain.root_tip computes it without the kernel."""
    data = chain.model.createData()
    pin.forwardKinematics(chain.model, data, q)
    return pin.updateFramePlacement(chain.model, data, chain.tip_id).homogeneous


def _chains():
    for robot, name in SEED_CHAINS:
        yield wbik.load(robot).chain(name)
    for robot, base, tip in ZOO_CHAINS:
        yield wbik.load(robot).chain_between(base, tip)


@pytest.fixture(scope="module")
def chains():
    return list(_chains())


def test_the_kernel_is_built_where_it_can_be():
    """The set-up builds it wherever a C++ compiler exists (its headers are build requirements);
    WBIK_PURE_PYTHON=chain_fk or 1 runs the binding instead."""
    if can_build() and shutil.which("c++"):
        assert BUILT
    chain = wbik.load("ur5").chain("arm")
    assert (chain._compiled is not None) == (BUILT and not pure_python("chain_fk"))


@NEEDS_KERNEL
def test_every_joint_type_of_the_zoo_chains_is_copied(chains):
    kinds = {chain.model.joints[j].shortname() for chain in chains for j in range(1, chain.model.njoints)}
    assert {"JointModelPZ", "JointModelRevoluteUnaligned"} <= kinds
    assert "JointModelPY" in kinds
    assert kinds <= set(chain_fk.JOINT_KINDS)
    for chain in chains:
        assert chain_fk.compiled_chain(chain.model, chain.tip_id) is not None, chain


@NEEDS_KERNEL
def test_tip_pose_and_errors_are_the_bindings_bits(chains):
    """2,000 configurations per chain, inside the limits and up to a turn outside them, on pose and
    position targets (a moved base: the Bioloid leg and the zoo's trees)."""
    rng = np.random.default_rng(7)
    for chain in chains:
        core = chain_fk.compiled_chain(chain.model, chain.tip_id)
        lower, upper = chain.lower, chain.upper
        span = np.minimum(upper - lower, 2 * math.pi)
        pose = np.empty((4, 4))
        for q in rng.uniform(lower - span / 4, upper + span / 4, (2000, chain.nq)):
            reached = _binding_tip(chain, q)
            chain_fk.tip_pose(core, q, pose)
            assert pose.tobytes() == reached.tobytes(), chain
            target = chain.fk(chain.random(rng))
            for rotation in (target.rotation, None):
                expected_p, expected_r, got_p, got_r = (np.empty(3) for _ in range(4))
                expected = pose_errors(reached, target.translation, rotation, expected_p, expected_r,
                                       chain.base_inverse_matrix)
                got = chain_fk.tip_errors(core, q, target.translation, rotation, got_p, got_r,
                                          chain.base_inverse_matrix)
                assert got == expected and got_p.tobytes() == expected_p.tobytes() \
                    and got_r.tobytes() == expected_r.tobytes(), chain


@NEEDS_KERNEL
@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(-4.0, 4.0), min_size=6, max_size=6), st.floats(-1e-12, 1e-12))
def test_the_same_bits_under_tiny_relative_noise(values, noise):
    """Any UR5 configuration, and the same one nudged by a relative 1e-12: both paths agree bit for bit."""
    chain = wbik.load("ur5").chain("arm")
    pose = np.empty((4, 4))
    for q in (np.array(values), np.array(values) * (1.0 + noise)):
        chain_fk.tip_pose(chain._compiled, q, pose)
        assert pose.tobytes() == _binding_tip(chain, q).tobytes()


def test_models_it_cannot_copy_keep_the_binding(monkeypatch):
    """A free-flyer (no chain has one, a whole robot has) and WBIK_PURE_PYTHON=chain_fk give None."""
    talos = wbik.load("example-robot-data:talos")
    assert talos.model.joints[1].shortname() == "JointModelFreeFlyer"
    assert chain_fk.compiled_chain(talos.model, talos.model.getFrameId("gripper_left_joint")) is None
    chain = wbik.load("ur5").chain("arm")
    monkeypatch.setenv("WBIK_PURE_PYTHON", "chain_fk")
    assert chain_fk.compiled_chain(chain.model, chain.tip_id) is None


@NEEDS_KERNEL
def test_a_copy_that_disagrees_with_the_binding_is_not_used():
    """The copy must place the tip as the binding does at its probes: a model whose first joint sits a
    micrometre off is refused against the original."""
    chain = wbik.load("ur5").chain("arm")
    moved = chain.model.copy()
    moved.jointPlacements[1] = pin.SE3(np.eye(3), np.array([0.0, 0.0, 1e-6])) * moved.jointPlacements[1]
    copy = chain_fk.compiled_chain(moved, chain.tip_id)
    assert copy is not None
    assert not chain_fk._agrees(copy, chain.model, chain.tip_id)
    assert chain_fk._agrees(chain_fk.compiled_chain(chain.model, chain.tip_id), chain.model, chain.tip_id)


@NEEDS_KERNEL
def test_bad_arguments_raise_and_name_what_is_wrong():
    chain = wbik.load("ur5").chain("arm")
    with pytest.raises(TypeError, match="q: expected a .6,. float64 array"):
        chain_fk.tip_pose(chain._compiled, np.zeros(5), np.empty((4, 4)))
    with pytest.raises(TypeError, match="float64"):
        chain_fk.tip_pose(chain._compiled, np.zeros(6, dtype=np.float32), np.empty((4, 4)))
    with pytest.raises(TypeError, match="out"):
        chain_fk.tip_pose(chain._compiled, np.zeros(6), np.empty((4, 4)).T)
    with pytest.raises(ValueError, match="parent"):
        chain_fk._build([2], [1], np.zeros((1, 3)), np.eye(4).reshape(1, 16), 1, np.eye(4))
    with pytest.raises(ValueError, match="tip joint"):
        chain_fk._build([2], [0], np.zeros((1, 3)), np.eye(4).reshape(1, 16), 2, np.eye(4))
    with pytest.raises(ValueError, match="kind"):
        chain_fk._build([9], [0], np.zeros((1, 3)), np.eye(4).reshape(1, 16), 1, np.eye(4))
    with pytest.raises(ValueError, match="PyCapsule"):
        chain_fk.tip_pose(object(), np.zeros(6), np.empty((4, 4)))


@NEEDS_KERNEL
@pytest.mark.parametrize("method", ["analytic", "bounded_lm", "dls"])
def test_solve_gives_the_same_answers_with_and_without_the_kernel(method):
    """Every field but the time, bit for bit, over 200 poses (some unreachable, some from far starts)."""
    robot = wbik.load("ur5")
    compiled = wbik.solver(method, robot, chain="arm")
    binding = wbik.solver(method, wbik.load("ur5"), chain="arm")
    binding.chain.__dict__["_compiled"] = None  # the cached copy replaced: the binding's path
    assert compiled.chain._compiled is not None and binding.chain is not compiled.chain
    rng = np.random.default_rng(3)
    chain = compiled.chain
    for index in range(200):
        target = chain.fk(chain.random(rng))
        if index % 10 == 0:
            target.translation = target.translation * 3.0  # out of reach
        q0 = chain.random(rng)
        ours, theirs = compiled.solve(target, q0), binding.solve(target, q0)
        assert ours.success == theirs.success and ours.reason == theirs.reason
        assert ours.iterations == theirs.iterations
        assert (ours.q is None) == (theirs.q is None)
        if ours.q is not None:
            assert ours.q.tobytes() == theirs.q.tobytes()
        for name in ("position_error", "rotation_error", "position_error_xyz", "rotation_error_xyz"):
            assert np.asarray(getattr(ours, name)).tobytes() == np.asarray(getattr(theirs, name)).tobytes()
