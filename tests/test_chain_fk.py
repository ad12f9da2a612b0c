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
from wbik.geometry import _python_pose_errors
from wbik.kernels import chain_fk
from wbik.kernels.twins import can_build, pure_python
from wbik.solvers.check import evaluate
from wbik.solvers.result import Candidate, Tolerances
from wbik.targets import Target

BUILT = chain_fk.tip_pose is not None
IN_USE = BUILT and not pure_python("chain_fk")  # WBIK_PURE_PYTHON=chain_fk (or 1) runs the binding
NEEDS_KERNEL = pytest.mark.skipif(not IN_USE, reason="the C++ kernel is not built here (no compiler or no "
                                  "Pinocchio headers: test_the_kernel_is_built_where_it_can_be says why) or "
                                  "WBIK_PURE_PYTHON switched it off")

SEED_CHAINS = [("ur5", "arm"), ("golem3", "right_arm"), ("panda", "arm"), ("bioloid", "right_leg"),
               ("pincher", "arm")]
ZOO_CHAINS = [  # (robot, base frame, tip frame): the joint types they bring besides RX, RY and RZ
    ("example-robot-data:pr2", "base_link", "r_gripper_r_finger_tip_link"),  # PZ (the torso lift)
    ("example-robot-data:finger_edu", "base_link", "finger_tip_link"),  # RevoluteUnaligned
    ("example-robot-data:panda", "panda_link0", "panda_leftfinger"),  # PY (a finger)
    ("example-robot-data:icub", "root_link", "r_hand"),  # RevoluteUnaligned, a floating base's tree
    ("example-robot-data:tiago", "base_link", "arm_7_link"),  # PZ (the torso)
    ("example-robot-data:kinova", "j2s6s200_link_base", "j2s6s200_end_effector"),
]
"""PX and PrismaticUnaligned: no chain of example-robot-data has them outside a mimic joint, so
:func:`_every_joint_type` builds a model that has."""
LIMITS = (np.full(1, -1.0), np.full(1, 1.0), None)
"""A one-joint copy's limits and base (build's last three arguments)."""


def _copy(chain):
    """A new kernel copy of ``chain`` (what ``chain.compiled_fk`` holds)."""
    return chain_fk.compiled_chain(chain.model, chain.tip_id, chain.lower, chain.upper,
                                   chain.base_inverse_matrix)


def _every_joint_type() -> tuple[pin.Model, int]:
    """A model built in code with each of the 8 joint types the kernel copies, in a row, unaligned axes
    and skewed placements, and a tip frame on its last joint: (model, tip frame id)."""
    model, rng, parent = pin.Model(), np.random.default_rng(5), 0
    kinds = [pin.JointModelRX(), pin.JointModelPX(), pin.JointModelRevoluteUnaligned(0.6, -0.48, 0.64),
             pin.JointModelPY(), pin.JointModelPrismaticUnaligned(-0.36, 0.48, 0.8), pin.JointModelRY(),
             pin.JointModelPZ(), pin.JointModelRZ()]
    for index, joint in enumerate(kinds):
        placement = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.2, size=3))
        parent = model.addJoint(parent, joint, placement, f"joint_{index}")
        model.lowerPositionLimit[parent - 1], model.upperPositionLimit[parent - 1] = -2.0, 2.0
    tip = model.addFrame(pin.Frame("tip", parent, pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3)),
                                   pin.FrameType.OP_FRAME))
    return model, tip


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
    assert (chain.compiled_fk is not None) == (BUILT and not pure_python("chain_fk"))


@NEEDS_KERNEL
def test_every_joint_type_is_copied(chains):
    """The zoo chains bring PY, PZ and RevoluteUnaligned besides RX, RY, RZ; the model built in code the
    other two (PX, PrismaticUnaligned); every chain and that model are copied."""
    kinds = {chain.model.joints[j].shortname() for chain in chains for j in range(1, chain.model.njoints)}
    brought = {"JointModelPY", "JointModelPZ", "JointModelRevoluteUnaligned"}
    assert brought <= kinds <= set(chain_fk.JOINT_KINDS)
    model, tip = _every_joint_type()
    assert {model.joints[j].shortname() for j in range(1, model.njoints)} == set(chain_fk.JOINT_KINDS)
    assert chain_fk.compiled_chain(model, tip, model.lowerPositionLimit, model.upperPositionLimit, None)
    for chain in chains:
        assert _copy(chain) is not None, chain


@NEEDS_KERNEL
def test_tip_pose_and_errors_are_the_bindings_bits(chains):
    """2,000 configurations per chain, inside the limits and up to a quarter turn outside them, on pose
    and position targets (a moved base: the Bioloid leg and the zoo's trees): the tip pose is the binding's,
    the errors the Python twin's (geometry._python_pose_errors) of the binding's pose (the errors are the pose
kernel's: WBIK_PURE_PYTHON=pose leaves them to the twin)."""
    rng = np.random.default_rng(7)
    for chain in chains:
        core = _copy(chain)
        lower, upper = chain.lower, chain.upper
        span = np.minimum(upper - lower, 2 * math.pi)
        pose = np.empty((4, 4))
        for q in rng.uniform(lower - span / 4, upper + span / 4, (2000, chain.nq)):
            reached = _binding_tip(chain, q)
            chain_fk.tip_pose(core, q, pose)
            assert pose.tobytes() == reached.tobytes(), chain
            target = chain.fk(chain.random(rng))
            for rotation in (target.rotation, None) if chain_fk.tip_errors is not None else ():
                expected_p, expected_r, got_p, got_r = (np.empty(3) for _ in range(4))
                expected = _python_pose_errors(reached, target.translation, rotation, expected_p, expected_r,
                                               chain.base_inverse_matrix)
                got = chain_fk.tip_errors(core, q, target.translation, rotation, got_p, got_r,
                                          chain.base_inverse_matrix)
                assert got == expected and got_p.tobytes() == expected_p.tobytes() \
                    and got_r.tobytes() == expected_r.tobytes(), chain


@NEEDS_KERNEL
def test_every_joint_type_places_the_tip_as_the_binding_does():
    model, tip = _every_joint_type()
    core = chain_fk.compiled_chain(model, tip, model.lowerPositionLimit, model.upperPositionLimit, None)
    data, pose = model.createData(), np.empty((4, 4))
    for q in np.random.default_rng(8).uniform(-3.0, 3.0, (5000, model.nq)):
        pin.forwardKinematics(model, data, q)
        chain_fk.tip_pose(core, q, pose)
        assert pose.tobytes() == pin.updateFramePlacement(model, data, tip).homogeneous.tobytes()


@NEEDS_KERNEL
@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(-4.0, 4.0), min_size=6, max_size=6), st.floats(-1e-12, 1e-12))
def test_the_same_bits_under_tiny_relative_noise(values, noise):
    """Any UR5 configuration, and the same one nudged by a relative 1e-12: both paths agree bit for bit."""
    chain = wbik.load("ur5").chain("arm")
    pose = np.empty((4, 4))
    for q in (np.array(values), np.array(values) * (1.0 + noise)):
        chain_fk.tip_pose(chain.compiled_fk, q, pose)
        assert pose.tobytes() == _binding_tip(chain, q).tobytes()


def test_models_it_cannot_copy_keep_the_binding(monkeypatch):
    """A free-flyer (no chain has one, a whole robot has) and WBIK_PURE_PYTHON=chain_fk give None; a model
    built in code (limits of +-1.8e308) is probed within +-pi."""
    talos = wbik.load("example-robot-data:talos")
    assert talos.model.joints[1].shortname() == "JointModelFreeFlyer"
    limits = (talos.model.lowerPositionLimit, talos.model.upperPositionLimit)
    assert chain_fk.compiled_chain(talos.model, talos.model.getFrameId("gripper_left_joint"), *limits,
                                   None) is None
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "z")
    tip = model.addFrame(pin.Frame("tip", joint, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    assert model.upperPositionLimit[0] > 1e300
    assert (chain_fk.compiled_chain(model, tip, model.lowerPositionLimit, model.upperPositionLimit, None)
            is None) == (not IN_USE)
    chain = wbik.load("ur5").chain("arm")
    monkeypatch.setenv("WBIK_PURE_PYTHON", "chain_fk")
    assert _copy(chain) is None


@NEEDS_KERNEL
def test_a_copy_that_disagrees_with_the_binding_is_not_used():
    """The copy must place the tip as the binding does at its probes: a model whose first joint sits a
    micrometre off is refused against the original."""
    chain = wbik.load("ur5").chain("arm")
    moved = chain.model.copy()
    moved.jointPlacements[1] = pin.SE3(np.eye(3), np.array([0.0, 0.0, 1e-6])) * moved.jointPlacements[1]
    copy = chain_fk.compiled_chain(moved, chain.tip_id, chain.lower, chain.upper, None)
    assert copy is not None
    assert not chain_fk._agrees(copy, chain.model, chain.tip_id)
    assert chain_fk._agrees(_copy(chain), chain.model, chain.tip_id)


@NEEDS_KERNEL
def test_bad_arguments_raise_and_name_what_is_wrong():
    chain = wbik.load("ur5").chain("arm")
    with pytest.raises(TypeError, match="q: expected a .6,. float64 array"):
        chain_fk.tip_pose(chain.compiled_fk, np.zeros(5), np.empty((4, 4)))
    with pytest.raises(TypeError, match="float64"):
        chain_fk.tip_pose(chain.compiled_fk, np.zeros(6, dtype=np.float32), np.empty((4, 4)))
    with pytest.raises(TypeError, match="out"):
        chain_fk.tip_pose(chain.compiled_fk, np.zeros(6), np.empty((4, 4)).T)
    with pytest.raises(ValueError, match="parent"):
        chain_fk._build([2], [1], np.zeros((1, 3)), np.eye(4).reshape(1, 16), 1, np.eye(4), *LIMITS)
    with pytest.raises(ValueError, match="tip joint"):
        chain_fk._build([2], [0], np.zeros((1, 3)), np.eye(4).reshape(1, 16), 2, np.eye(4), *LIMITS)
    with pytest.raises(ValueError, match="kind"):
        chain_fk._build([9], [0], np.zeros((1, 3)), np.eye(4).reshape(1, 16), 1, np.eye(4), *LIMITS)
    with pytest.raises(TypeError, match="lower"):
        chain_fk._build([2], [0], np.zeros((1, 3)), np.eye(4).reshape(1, 16), 1, np.eye(4), np.zeros(2),
                        *LIMITS[1:])
    with pytest.raises(TypeError, match="a chain made by build, got object"):
        chain_fk.tip_pose(object(), np.zeros(6), np.empty((4, 4)))
    with pytest.raises(TypeError, match="field 0 is not an object slot"):  # (the registered type stays)
        chain_fk.result_type(type("Plain", (), {"q": None}), ["__doc__"] * 17)
    # the binding keeps what the kernel does not take: integer joints, a wrong length (Pinocchio's error)
    assert chain.root_tip(np.zeros(6, dtype=int)).tobytes() == chain.root_tip(np.zeros(6)).tobytes()
    with pytest.raises(ValueError):
        chain.root_tip(np.zeros(5))


def _answers_agree(ours, theirs) -> None:
    """Every field of two answers but the time, bit for bit (the arrays: their dtype, shape and flags too)."""
    assert ours.success == theirs.success and ours.reason == theirs.reason
    assert ours.iterations == theirs.iterations and ours.method == theirs.method
    assert ours.extra == theirs.extra
    assert (ours.q is None) == (theirs.q is None)
    for name in ("q", "position_error_xyz", "rotation_error_xyz"):
        mine, other = getattr(ours, name), getattr(theirs, name)
        if mine is not None:
            assert mine.tobytes() == other.tobytes()
            assert (mine.dtype, mine.shape) == (other.dtype, other.shape)
            assert mine.flags.writeable and mine.flags.c_contiguous and mine.flags.owndata
    for name in ("position_error", "rotation_error"):
        assert np.asarray(getattr(ours, name)).tobytes() == np.asarray(getattr(theirs, name)).tobytes()
    for name in ("task_errors", "task_position_errors", "task_rotation_errors", "measures", "unsupported"):
        mine, other = getattr(ours, name), getattr(theirs, name)
        assert mine == other and mine is not other
    assert ours.diagnosis is None and theirs.diagnosis is None


@NEEDS_KERNEL
@pytest.mark.parametrize("method", ["analytic", "bounded_lm", "dls"])
def test_solve_gives_the_same_answers_with_and_without_the_kernel(method):
    """Every field but the time, bit for bit, over 200 poses (some unreachable, some from far starts)."""
    compiled = wbik.solver(method, wbik.load("ur5"), chain="arm")
    binding = wbik.solver(method, wbik.load("ur5"), chain="arm")
    binding.chain.__dict__["compiled_fk"] = None  # the cached copy replaced: the binding's path
    assert compiled.chain.compiled_fk is not None and binding.chain is not compiled.chain
    rng = np.random.default_rng(3)
    chain = compiled.chain
    for index in range(200):
        target = chain.fk(chain.random(rng))
        if index % 10 == 0:
            target.translation = target.translation * 3.0  # out of reach
        q0 = chain.random(rng)
        _answers_agree(compiled.solve(target, q0), binding.solve(target, q0))


@NEEDS_KERNEL
def test_the_whole_check_is_the_python_checks_answer(chains, monkeypatch):
    """evaluate with the kernel (checked_result: a passing answer whole, else the Python check) against
    evaluate on the binding, on every chain: answers that pass, fail by a hair, fail near a half turn (the
    formula loses the axis: Pinocchio's log3), lie outside the limits, or are not float64 arrays."""
    rng = np.random.default_rng(12)
    tolerances = Tolerances()
    half_turn = pin.SE3(pin.exp3(np.array([0.0, 0.0, np.pi - 1e-9])), np.zeros(3))
    for chain in chains:
        core = chain.compiled_fk
        assert core is not None
        for index in range(300):
            q = chain.random(rng)
            reached = chain.fk(q)
            kind = index % 6
            target = (reached if kind == 0 else reached * half_turn if kind == 1
                      else pin.SE3(reached.rotation, reached.translation + 2e-6) if kind == 2
                      else chain.fk(chain.random(rng)))
            joints = (q.tolist() if kind == 3 else np.where(np.arange(chain.nq) == 0, chain.upper + 0.1, q)
                      if kind == 4 else q)
            candidate = Candidate(joints, 3, "a reason" if index % 2 else "", {"branches": index})
            for rotation in (target.rotation, None):
                goal = Target(target.translation.copy(), None if rotation is None else rotation.copy())
                ours = evaluate(chain, goal, candidate, tolerances, 1e-6, "m")
                monkeypatch.setitem(chain.__dict__, "compiled_fk", None)
                theirs = evaluate(chain, goal, candidate, tolerances, 1e-6, "m")
                monkeypatch.setitem(chain.__dict__, "compiled_fk", core)
                _answers_agree(ours, theirs)
            if kind == 0:
                assert ours.success
            if kind == 0 and chain_fk.checked_result is not None:  # the compiled check answers it whole
                assert chain_fk.checked_result(core, q, goal.position, goal.rotation, 1e-6, 1e-6, 0.0, 1, "m",
                                               {}) is not None
