"""The optimised QP step (fused task rows, reused buffers, DAQP on stacked constraints) gives the
same dq as a plain reference step built from each task's ``error`` and ``jacobian`` and each
constraint's rows, stacked with numpy and solved by the general backend call."""

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.errors import NoQPSolutionError
from wbik.qp import ComTask, FrameTask, IKProblem, OrientationTask, PostureTask, RegularizationTask, backends
from wbik.qp.humanoid import stance_constraints
from wbik.qp.rows import BoundRows, EqualityRows, InequalityRows


def reference_step(problem: IKProblem, q: np.ndarray, dt: float = 1.0, tasks=None,
                   extra=None) -> np.ndarray | None:
    """One QP step over ``tasks`` (default: all, as one level), written out plainly (no relaxation);
    ``extra``: more inequality rows (G, h). None: no solution."""
    tasks = problem.tasks if tasks is None else tasks
    kinematics = problem.kinematics
    kinematics.update(q)
    lower, upper = np.full(problem.nv, -problem.max_step), np.full(problem.nv, problem.max_step)
    equalities, inequalities = [], []
    for constraint in problem.constraints:
        rows = constraint.rows(kinematics, dt)
        if isinstance(rows, BoundRows):
            lower[rows.index] = np.maximum(lower[rows.index], rows.lower)
            upper[rows.index] = np.minimum(upper[rows.index], rows.upper)
        elif isinstance(rows, EqualityRows):
            equalities.append((rows.A.copy(), rows.b.copy()))
        else:
            assert isinstance(rows, InequalityRows)
            inequalities.append((rows.G.copy(), rows.h.copy()))
    np.minimum(lower, upper, out=lower)
    if extra is not None:
        inequalities.append(extra)
    rows, errors, weights, goal_cost = [], [], [], 0.0
    for task in tasks:
        error = np.array(task.error(kinematics))
        rows.append(np.array(task.jacobian(kinematics)))
        errors.append(task.gain * error)
        weights.append(task.weight)
        goal_cost += float(error @ error) if task.goal else 0.0
    J, e, w = np.vstack(rows), np.concatenate(errors), np.concatenate(weights)
    H = J.T @ (w[:, None] * J) + (problem.damping + problem.lm_damping * goal_cost) * np.eye(problem.nv)
    c = J.T @ (w * e)
    G = np.vstack([g for g, _ in inequalities]) if inequalities else None
    h = np.concatenate([h for _, h in inequalities]) if inequalities else None
    A = np.vstack([a for a, _ in equalities]) if equalities else None
    b = np.concatenate([b for _, b in equalities]) if equalities else None
    try:
        return backends.solve("daqp", H, c, G, h, A, b, lower, upper)
    except NoQPSolutionError:
        return None


def weighted_rows(problem: IKProblem, tasks) -> np.ndarray:
    return np.vstack([np.sqrt(task.weight)[:, None] * task.jacobian(problem.kinematics) for task in tasks])


@pytest.fixture(scope="module")
def bioloid():
    return wbik.load("bioloid")


def test_the_step_agrees_with_the_reference_on_random_configurations(bioloid):
    rng = np.random.default_rng(3)
    q0 = bioloid.nominal
    target = bioloid.frame_placement(q0, "l_sole")
    target.translation = target.translation + np.array([0.01, 0.0, 0.03])
    tasks = [FrameTask("l_sole", target, gain=0.8),
             OrientationTask("pelvis", bioloid.frame_placement(q0, "pelvis").rotation, weight=0.1,
                             goal=False),
             ComTask([0.0, 0.0, 0.0], axes="xy", weight=0.5),
             PostureTask(q0), RegularizationTask(1e-6)]
    problem = IKProblem(bioloid.model, tasks, stance_constraints(bioloid, q0, ["r_sole"], margin=0.0),
                        lm_damping=1e-3)
    problem.start(q0)
    compared = 0
    for _ in range(20):
        dv = rng.normal(scale=0.05, size=bioloid.model.nv)
        q = problem.clip(pin.integrate(bioloid.model, q0, dv))
        expected = reference_step(problem, q)
        try:
            dq = problem.step(q)
        except NoQPSolutionError:
            dq = None
        assert (expected is None) == (dq is None)
        if dq is not None:
            np.testing.assert_allclose(dq, expected, rtol=0, atol=1e-10)
            compared += 1
    assert compared >= 10


def test_fused_task_rows_agree_with_error_and_jacobian(bioloid):
    rng = np.random.default_rng(4)
    q0 = bioloid.nominal
    tasks = [FrameTask("l_sole", bioloid.frame_placement(q0, "r_sole"), gain=0.5),
             OrientationTask("pelvis", pin.exp3(np.array([0.1, -0.2, 0.3])))]
    problem = IKProblem(bioloid.model, tasks)
    problem.start(q0)
    for _ in range(10):
        dv = rng.normal(scale=0.2, size=bioloid.model.nv)
        problem.kinematics.update(pin.integrate(bioloid.model, q0, dv))
        for task in tasks:
            jacobian, error = np.zeros((task.dimension, bioloid.model.nv)), np.zeros(task.dimension)
            task.fill(problem.kinematics, jacobian, error)
            np.testing.assert_allclose(error, task.error(problem.kinematics), rtol=0, atol=1e-12)
            np.testing.assert_allclose(jacobian, task.jacobian(problem.kinematics), rtol=0, atol=1e-12)


def test_a_two_level_step_agrees_with_the_plain_hierarchy(bioloid):
    """Level 0 (a foot task and the regularisation, whose J = I rows go onto H's diagonal) solved
    first; level 1 (posture) keeps level 0's achieved rows, regularisation rows included, to the
    slack: the same dq as two plain QPs with every row stacked."""
    rng = np.random.default_rng(5)
    q0 = bioloid.nominal
    target = bioloid.frame_placement(q0, "l_sole")
    target.translation = target.translation + np.array([0.0, 0.01, 0.02])
    first = [FrameTask("l_sole", target), RegularizationTask(1e-4)]
    second = [PostureTask(q0, weight=1.0, priority=1)]
    problem = IKProblem(bioloid.model, first + second,
                        stance_constraints(bioloid, q0, ["r_sole"], margin=0.0),
                        hierarchy_slack=1e-6)
    problem.start(q0)
    for _ in range(5):
        q = problem.clip(pin.integrate(bioloid.model, q0, rng.normal(scale=0.03, size=bioloid.model.nv)))
        dq0 = reference_step(problem, q, tasks=first)
        kept = weighted_rows(problem, first)
        achieved = kept @ dq0
        expected = reference_step(problem, q, tasks=second,
                                  extra=(np.vstack((kept, -kept)), np.r_[achieved + 1e-6, -achieved + 1e-6]))
        np.testing.assert_allclose(problem.step(q), expected, rtol=0, atol=1e-8)
