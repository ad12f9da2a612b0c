"""The compiled twin of the QP step's task rows and quadratic (``wbik/kernels/_qp_rows.c``) against the
Python path (Pinocchio's getFrameJacobian, log3 and Jlog3; NumPy's products).

Unlike the closed-form kernels these are not the same bits: Pinocchio's Eigen code and BLAS sum in
their own orders. They agree to rounding (a few 1e-16 on these unit-scale rows); the checks here allow
1e-12 and compare the whole QP IK's answer under both paths.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from compiled_twins import compared_with_its_twin
from hypothesis import given, settings
from hypothesis import strategies as st

import wbik
from wbik.kernels.twins import PURE_PYTHON_VARIABLE
from wbik.qp import FrameTask, IKProblem, OrientationTask, RegularizationTask
from wbik.qp import step as qp_step
from wbik.qp import tasks as qp_tasks
from wbik.qp.humanoid import stance_constraints
from wbik.qp.kinematics import Kinematics

pytestmark = compared_with_its_twin(qp_tasks._FRAME_ROWS)
AGREE = 1e-12


@pytest.fixture(scope="module")
def bioloid():
    return wbik.load("bioloid")


def python_fill(task, kinematics, rows):
    """The task's rows by the Python twin (the compiled rows switched off for one call)."""
    jacobian, error = np.zeros((rows, kinematics.nv)), np.zeros(rows)
    saved, task._compiled_for = task._compiled_for, None
    try:
        task.fill(kinematics, jacobian, error)
    finally:
        task._compiled_for = saved
    return jacobian, error


def compiled_fill(task, kinematics, rows):
    jacobian, error = np.full((rows, kinematics.nv), np.nan), np.full(rows, np.nan)
    assert task._compiled_for is kinematics
    task.fill(kinematics, jacobian, error)
    return jacobian, error


def random_configuration(robot, rng, spread=1.0):
    q = robot.nominal.copy()
    if robot.model.joints[1].nq == 7:  # a free flyer: a random base pose too
        q[:3] = rng.uniform(-0.3, 0.3, 3)
        q[3:7] = pin.Quaternion(pin.exp3(rng.uniform(-2.0, 2.0, 3))).coeffs()
        q[7:] += rng.uniform(-spread, spread, q.size - 7)
    else:
        q += rng.uniform(-spread, spread, q.size)
    return q


@pytest.mark.parametrize("robot_name, frames", [("bioloid", ["l_sole", "r_sole", "pelvis", "r_hand"]),
                                                ("golem3", None), ("ur5", None)])
def test_frame_rows_agree_with_pinocchio(robot_name, frames):
    robot = wbik.load(robot_name)
    model = robot.model
    names = frames or [model.frames[-1].name, model.frames[len(model.frames) // 2].name]
    kinematics = Kinematics(model)
    rng = np.random.default_rng(7)
    tasks = []
    for name in names:
        target = pin.SE3(pin.exp3(rng.uniform(-2.5, 2.5, 3)), rng.uniform(-0.5, 0.5, 3))
        tasks += [FrameTask(name, target), OrientationTask(name, target.rotation)]
    for task in tasks:
        task.start(kinematics)
    worst = 0.0
    for _ in range(60):
        kinematics.update(random_configuration(robot, rng))
        for task in tasks:
            rows = task.dimension
            ours, theirs = compiled_fill(task, kinematics, rows), python_fill(task, kinematics, rows)
            worst = max(worst, float(np.abs(ours[0] - theirs[0]).max()),
                        float(np.abs(ours[1] - theirs[1]).max()))
    assert worst <= AGREE


@settings(max_examples=150, deadline=None)
@given(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0),
       st.sampled_from([0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1.1e-4, 1.3e-4, 6e-3, 0.5, 2.0, 3.0, np.pi - 0.11,
                        np.pi - 0.09, np.pi - 4e-3, np.pi - 3e-3, np.pi]),
       st.floats(-1e-12, 1e-12))
def test_rotation_rows_agree_near_identity_and_near_a_half_turn(bioloid, x, y, z, angle, noise):
    """log3 and Jlog3 at every Taylor switch of Pinocchio's: tiny angles, around eps^(1/4) (1.2e-4), and
    up to 0.1 rad from a half turn; closer, the kernel declines (returns False) and the Python twin gives
    Pinocchio's own values."""
    axis = np.array([x, y, z])
    if np.linalg.norm(axis) < 1e-3:
        axis = np.array([0.0, 0.0, 1.0])
    kinematics = Kinematics(bioloid.model, bioloid.nominal)
    task = OrientationTask("l_sole", np.eye(3))
    task.start(kinematics)
    reached = kinematics.placement(task.frame_id).rotation
    task.target = reached @ pin.exp3(-angle * axis / np.linalg.norm(axis)) + noise
    ours, theirs = compiled_fill(task, kinematics, 3), python_fill(task, kinematics, 3)
    assert np.abs(ours[0] - theirs[0]).max() <= AGREE and np.abs(ours[1] - theirs[1]).max() <= AGREE
    declined = not task._compiled_rows(None, task.target, np.zeros((3, kinematics.nv)), np.zeros(3))
    relative = task.target.T @ reached
    assert declined == ((np.trace(relative) - 1.0) / 2.0 < -np.cos(0.1))


def test_the_rows_follow_the_target_changed_in_place_or_replaced(bioloid):
    kinematics = Kinematics(bioloid.model, bioloid.nominal)
    target = kinematics.placement(kinematics.frame_id("l_sole")).copy()
    task = FrameTask("l_sole", target)
    task.start(kinematics)
    task.target.translation = task.target.translation + np.array([0.0, 0.0, 0.04])
    assert np.allclose(compiled_fill(task, kinematics, 6)[1][:3], [0.0, 0.0, -0.04], atol=1e-15)
    task.target = pin.SE3(pin.exp3(np.array([0.0, 0.0, 0.3])), target.translation)
    ours, theirs = compiled_fill(task, kinematics, 6), python_fill(task, kinematics, 6)
    assert np.abs(ours[1] - theirs[1]).max() <= AGREE and abs(np.linalg.norm(ours[1][3:]) - 0.3) < 1e-12


def test_quadratic_agrees_with_numpy():
    rng = np.random.default_rng(3)
    for m, nv in [(15, 24), (6, 6), (1, 30), (0, 5)]:
        jacobian = rng.normal(size=(m, nv))
        jacobian[:, rng.random(nv) < 0.3] = 0.0  # columns outside a chain are exact zeros
        row_scale, error_scale = rng.uniform(0.1, 2.0, m), rng.uniform(0.5, 1.5, m)
        error, diagonal = rng.normal(size=m), rng.uniform(0.0, 1e-3, nv)
        weighted, hessian, gradient = np.empty((m, nv)), np.empty((nv, nv)), np.empty(nv)
        qp_step._QUADRATIC(jacobian, row_scale, error, error_scale, diagonal, 1e-6, weighted, hessian,
                           gradient)
        expected_weighted = jacobian * row_scale[:, None]
        expected_hessian = expected_weighted.T @ expected_weighted + np.diag(diagonal + 1e-6)
        assert np.abs(weighted - expected_weighted).max(initial=0.0) == 0.0
        assert np.abs(hessian - expected_hessian).max() <= AGREE * max(1.0, np.abs(expected_hessian).max())
        assert np.array_equal(hessian, hessian.T)
        assert np.abs(gradient - expected_weighted.T @ (error * error_scale)).max(initial=0.0) <= AGREE * 10
        # the Levenberg-Marquardt damping on the goal rows' errors (a NaN on another row does not count)
        goal_rows = (rng.random(m) < 0.5).astype(float)
        if m:
            error[np.argmin(goal_rows)] = np.nan if goal_rows.min() == 0.0 else error[0]
        qp_step._QUADRATIC(jacobian, row_scale, error, error_scale, diagonal, 1e-6, weighted, hessian,
                           gradient, goal_rows, 0.3)
        goals = error[goal_rows == 1.0]
        damped = np.diag(hessian) - np.diag(expected_weighted.T @ expected_weighted) - diagonal
        scale = max(1.0, np.abs(hessian).max())
        assert np.abs(damped - (1e-6 + 0.3 * goals.dot(goals))).max() <= AGREE * scale


def test_bad_buffers_are_refused_with_the_argument_named():
    frame_rows, quadratic = qp_tasks._FRAME_ROWS, qp_step._QUADRATIC
    world, columns = np.zeros((6, 4), order="F"), np.array([0, 1], dtype=np.int64)
    good = dict(translation=np.zeros(3), rotation=np.eye(3), target_translation=np.zeros(3),
                target_rotation=np.eye(3), jacobian=np.zeros((6, 4)), error=np.zeros(6))

    def call(rows=6, world=world, columns=columns, **changes):
        arguments = {**good, **changes}
        return frame_rows(rows, world, columns, *arguments.values())

    assert call() is True
    with pytest.raises(ValueError, match="rows"):
        call(rows=4)
    with pytest.raises(TypeError, match="joint_jacobians"):
        call(world=np.zeros((5, 4)))
    with pytest.raises(TypeError, match="columns"):
        call(columns=np.array([0, 1], dtype=np.int32))
    with pytest.raises(IndexError, match="columns"):
        call(columns=np.array([0, 4], dtype=np.int64))
    with pytest.raises(TypeError, match="jacobian"):
        call(jacobian=np.zeros((6, 4))[:, ::2].copy())
    with pytest.raises(TypeError, match="jacobian"):
        call(jacobian=np.zeros((4, 6)).T)  # right size, not C-contiguous
    with pytest.raises(TypeError, match="error"):
        call(error=np.zeros(3))
    with pytest.raises(TypeError, match="target_rotation"):
        call(target_rotation=[[1.0, 0, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(TypeError, match="hessian"):
        quadratic(np.zeros((2, 3)), np.ones(2), np.zeros(2), np.ones(2), np.zeros(3), 0.0, np.zeros((2, 3)),
                  np.zeros((3, 2)), np.zeros(3))
    with pytest.raises(TypeError, match="jacobian"):
        quadratic(np.zeros((2, 4)), np.ones(2), np.zeros(2), np.ones(2), np.zeros(3), 0.0, np.zeros((2, 3)),
                  np.zeros((3, 3)), np.zeros(3))


def balance_problem(robot):
    q0 = robot.nominal
    lifted = robot.frame_placement(q0, "l_sole")
    lifted.translation = lifted.translation + np.array([0.01, 0.0, 0.02])
    tasks = [FrameTask("l_sole", lifted, tolerance=1e-8),
             OrientationTask("pelvis", robot.frame_placement(q0, "pelvis").rotation, weight=0.1, goal=False),
             RegularizationTask(1e-6)]
    return IKProblem(robot.model, tasks, stance_constraints(robot, q0, ["r_sole"], margin=0.0)), q0


def test_the_qp_ik_gives_the_same_answer_with_either_twin(bioloid, monkeypatch):
    compiled_problem, q0 = balance_problem(bioloid)
    compiled = compiled_problem.solve(q0)
    assert compiled_problem.tasks[0]._compiled_rows is not None
    monkeypatch.setenv(PURE_PYTHON_VARIABLE, "1")
    python_problem, _ = balance_problem(bioloid)
    python = python_problem.solve(q0)
    assert python_problem.tasks[0]._compiled_rows is None
    assert python_problem.qp.levels[0]._compiled_quadratic is None
    assert compiled.success and python.success
    # (identical here; a last-bit decision may differ on another CPU: an iteration more, the same tolerance)
    assert abs(compiled.iterations - python.iterations) <= 1
    assert np.abs(compiled.q - python.q).max() <= 1e-6


def test_the_stack_copies_give_numpys_bits():
    """StackedConstraints.add and .tighten through the kernel against their NumPy twins: strided rows,
    NaN bounds (NumPy's maximum/minimum let a NaN win), int arrays (the kernel refuses them, NumPy
    converts them)."""
    from wbik.qp.backends import StackedConstraints

    rng = np.random.default_rng(11)
    compiled, python = StackedConstraints(5, capacity=1), StackedConstraints(5, capacity=1)
    assert compiled._stack_rows is not None and compiled._tighten_slice is not None
    python._stack_rows = python._tighten_slice = None
    for _ in range(3):
        wide = rng.normal(size=(4, 10))
        lower, upper = rng.normal(size=5) - 1.0, rng.normal(size=5) + 1.0
        lower[1], upper[3] = np.nan, np.nan
        lower[2], upper[4] = -0.5, 0.5  # equal to the box: NumPy keeps its second operand's zero sign...
        lower[0], upper[0] = 0.0, -0.0  # ...which matters between +0 and -0
        additions = [(wide[:, ::2], wide[0, ::2][:4], True),
                     (rng.normal(size=(2, 5)), rng.normal(size=2), False),
                     (np.array([[1, 2, 3, 4, 5]]), np.array([7]), False),
                     (np.asfortranarray(rng.normal(size=(3, 5))), np.ones(3), True)]
        for stack in (compiled, python):
            stack.clear(0.5)
            stack.tighten(slice(0, 5), lower, upper)
            stack.tighten(slice(1, 3), lower[:2] * 0.1, upper[:2] * 0.1)
            stack.tighten(np.array([4]), -0.2, 0.2)
            stack.tighten(slice(3, 5), np.array([-1, 0]), np.array([1, 2]))  # int bounds: NumPy converts
            for matrix, bounds, equality in additions:
                stack.add(matrix, bounds, equality)
        for name in ("matrix", "upper", "lower", "sense"):  # (bytes: signed zeros and NaNs alike)
            assert getattr(compiled, name).tobytes() == getattr(python, name).tobytes(), name


def test_copies_and_restarts_follow_their_own_kinematics(bioloid):
    """A deep copy (wbik.wholebody copies its tasks; a copied problem too) holds no views of the
    original's data; a task restarted on other kinematics, or on another frame, reads those."""
    import copy

    problem, q0 = balance_problem(bioloid)
    problem.start(q0)
    rng = np.random.default_rng(4)
    for clone in (copy.deepcopy(problem), copy.deepcopy(copy.deepcopy(problem))):
        clone.start(q0)
        q = q0.copy()
        q[7:] += rng.uniform(-0.3, 0.3, q.size - 7)
        clone.kinematics.update(q)
        task = clone.tasks[0]
        assert task._compiled_for is clone.kinematics
        task.target.translation = task.target.translation + 0.01  # in place, on the copy's own target
        ours, theirs = compiled_fill(task, clone.kinematics, 6), python_fill(task, clone.kinematics, 6)
        assert np.abs(ours[0] - theirs[0]).max() <= AGREE and np.abs(ours[1] - theirs[1]).max() <= AGREE
    task = FrameTask("l_sole", pin.SE3.Identity())
    first, second = Kinematics(bioloid.model, q0), Kinematics(bioloid.model, q)
    task.start(first)
    task.start(second)
    assert task._compiled_for is second
    task.frame = "r_sole"
    task.start(second)
    ours, theirs = compiled_fill(task, second, 6), python_fill(task, second, 6)
    assert np.abs(ours[0] - theirs[0]).max() <= AGREE and np.abs(ours[1] - theirs[1]).max() <= AGREE
    assert np.allclose(theirs[1][:3], second.placement(second.frame_id("r_sole")).translation)
