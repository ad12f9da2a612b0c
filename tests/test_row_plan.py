"""The QP step's constraint rows written by compiled calls (``wbik.qp.row_plan``: the ``frame_rows`` kernel's
held form for a contact, ``polygon_rows`` for the CoM in its polygon, ``position_bounds`` for the joint
limits, ``step_box`` for the box) against the rows the constraints stack through Python.

The contact, the limits and the box give the Python path's bits. The polygon's rows are sums of two products
that NumPy leaves to BLAS (which may fuse them): those agree to rounding.
"""

from __future__ import annotations

import copy

import numpy as np
import pinocchio as pin
import pytest
from compiled_twins import compared_with_its_twin
from hypothesis import given, settings
from hypothesis import strategies as st

import wbik
from wbik.kernels.twins import PURE_PYTHON_VARIABLE
from wbik.qp import FrameTask, IKProblem, OrientationTask, PositionTask, RegularizationTask, row_plan
from wbik.qp.constraint import InequalityConstraint
from wbik.qp.humanoid import stance_constraints
from wbik.qp.rows import InequalityRows
from wbik.qp.support_polygon import SupportPolygon

pytestmark = compared_with_its_twin(row_plan._STEP_BOX)
ROUNDING = 1e-14
"""The polygon rows' agreement (their entries are below 1 in size: a few ulp)."""


@pytest.fixture(scope="module")
def bioloid():
    return wbik.load("bioloid")


@pytest.fixture(scope="module")
def talos():
    """Talos with its soles and start as tasks/talos_reach.yaml gives them."""
    from pathlib import Path

    from wbik.scenarios import load_scenario
    from wbik.scenarios.kinds import robot_of, start_of
    from wbik.scenarios.schema import validate

    path = Path(__file__).resolve().parents[1] / "tasks" / "talos_reach.yaml"
    spec = validate(load_scenario(path), str(path))
    robot = robot_of(spec)
    robot.start = start_of(spec, robot)
    return robot


def one_foot_problem(robot) -> tuple[IKProblem, np.ndarray]:
    """The Bioloid on its right sole, the left sole lifted (benchmarks/qp.py's problem)."""
    q0 = robot.nominal
    lifted = robot.frame_placement(q0, "l_sole")
    lifted.translation = lifted.translation + np.array([0.01, 0.0, 0.03])
    tasks = [FrameTask("l_sole", lifted, tolerance=1e-8),
             OrientationTask("pelvis", robot.frame_placement(q0, "pelvis").rotation, weight=0.1, goal=False),
             RegularizationTask(1e-6)]
    return IKProblem(robot.model, tasks, stance_constraints(robot, q0, ["r_sole"], margin=0.005)), q0


def two_feet_problem(robot) -> tuple[IKProblem, np.ndarray]:
    """Talos on both soles reaching with its right gripper (tasks/talos_reach.yaml's first reach)."""
    q0 = robot.start
    soles = list(robot.soles)
    hand = robot.frame_placement(q0, "gripper_right_base_link").translation + np.array([0.1, -0.05, 0.1])
    tasks = [PositionTask("gripper_right_base_link", hand),
             OrientationTask("base_link", robot.frame_placement(q0, "base_link").rotation, weight=0.1,
                             goal=False), RegularizationTask(1e-6)]
    return IKProblem(robot.model, tasks, stance_constraints(robot, q0, soles, margin=0.02)), q0


def python_twin(problem: IKProblem) -> IKProblem:
    """The same problem, started at the same q, with its rows always stacked through Python: its
    constraints offer no compiled rows, so no start or step makes it a plan."""
    twin = copy.deepcopy(problem)
    for constraint in twin.constraints:
        constraint.compiled_rows = lambda kinematics, rows: None
    twin.start(problem.kinematics.q, clip=False)  # (a copy's tasks make their compiled rows at the start)
    return twin


def stacked(problem: IKProblem, q: np.ndarray, radius: float, recover: bool) -> dict[str, np.ndarray]:
    problem.kinematics.update(q)
    stack = problem.qp.build_constraints(1.0, radius, recover)
    return {name: getattr(stack, name).copy() for name in ("matrix", "upper", "lower", "sense")}


def assert_same_rows(planned: dict, python: dict, polygon_rows: slice) -> None:
    """Bit for bit but the polygon's rows (general rows ``polygon_rows``), which agree to rounding."""
    for name in ("matrix", "sense"):
        assert planned[name].shape == python[name].shape, name
    ours, theirs = planned["matrix"].copy(), python["matrix"].copy()
    assert np.abs(ours[polygon_rows] - theirs[polygon_rows]).max() <= ROUNDING
    ours[polygon_rows] = theirs[polygon_rows] = 0.0
    assert ours.tobytes() == theirs.tobytes()
    n = planned["upper"].size - planned["matrix"].shape[0]
    bounds = slice(n + polygon_rows.start, n + polygon_rows.stop)
    for name in ("upper", "lower"):
        ours, theirs = planned[name].copy(), python[name].copy()
        assert np.abs(ours[bounds] - theirs[bounds]).max() <= ROUNDING, name
        ours[bounds] = theirs[bounds] = 0.0
        assert ours.tobytes() == theirs.tobytes(), name  # (signed zeros alike)
    assert planned["sense"].tobytes() == python["sense"].tobytes()


def random_configurations(robot, q0, count: int, seed: int, spread: float = 0.3):
    rng = np.random.default_rng(seed)
    lower, upper = robot.model.lowerPositionLimit[7:], robot.model.upperPositionLimit[7:]
    for _ in range(count):
        q = q0.copy()
        q[:3] += rng.uniform(-0.05, 0.05, 3)
        q[3:7] = pin.Quaternion(pin.exp3(rng.uniform(-0.2, 0.2, 3))).coeffs()
        # some joints past their limits too: the box then recovers (or not) toward them
        q[7:] = np.clip(q0[7:] + rng.uniform(-spread, spread, q.size - 7), lower - 0.05, upper + 0.05)
        yield q


@pytest.mark.parametrize("which", ["bioloid", "talos"])
def test_the_plans_rows_are_the_python_rows(which, request):
    robot = request.getfixturevalue(which)
    problem, q0 = (one_foot_problem if which == "bioloid" else two_feet_problem)(robot)
    problem.start(q0)
    twin = python_twin(problem)
    problem.step(q0)
    assert problem.qp._plan is not None and twin.qp._plan is None
    contacts = 6 * (1 if which == "bioloid" else 2)
    edges = len(problem.constraints[-2].offsets)
    polygon = slice(contacts, contacts + edges)
    for index, q in enumerate(random_configurations(robot, q0, 60, seed=3)):
        radius, recover = (0.2, 0.05, 1e-3)[index % 3], bool(index % 2)
        assert_same_rows(stacked(problem, q, radius, recover), stacked(twin, q, radius, recover), polygon)
    assert problem.qp._plan is not None  # (written by the plan every time)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), noise=st.floats(1e-14, 1e-9))
def test_the_rows_agree_under_tiny_relative_noise(bioloid, seed, noise):
    problem, q0 = one_foot_problem(bioloid)
    problem.start(q0)
    twin = python_twin(problem)
    problem.step(q0)
    q = next(random_configurations(bioloid, q0, 1, seed))
    q = q * (1.0 + noise * np.random.default_rng(seed).standard_normal(q.size))
    q[3:7] /= np.linalg.norm(q[3:7])
    assert_same_rows(stacked(problem, q, 0.2, True), stacked(twin, q, 0.2, True), slice(6, 10))


def test_the_ik_and_its_steps_are_the_same_with_and_without_the_plan(bioloid):
    problem, q0 = one_foot_problem(bioloid)
    twin = python_twin(problem)
    planned, python = problem.solve(q0), twin.solve(q0)
    assert twin.qp._plan is None and twin.qp._planned  # (asked at the solve's start, and refused)
    assert planned.success and python.success
    assert planned.iterations == python.iterations
    assert np.abs(planned.q - python.q).max() <= 1e-12
    # the plan was made at the first step and kept across the solves' starts
    plan = problem.qp._plan
    assert plan is not None and problem.solve(q0).success and problem.qp._plan is plan
    for q in random_configurations(bioloid, q0, 5, seed=8, spread=0.1):
        assert np.abs(problem.step(problem.clip(q)) - twin.step(twin.clip(q))).max() <= 1e-12


class AbovePlane(InequalityConstraint):
    """A constraint of the user's own, without compiled rows: the pelvis above z = 0."""

    name = "pelvis above the floor"

    def start(self, kinematics):
        super().start(kinematics)
        self.frame_id = kinematics.frame_id("pelvis")

    def inequality(self, kinematics):
        height = kinematics.placement(self.frame_id).translation[2]
        return InequalityRows(-kinematics.jacobian(self.frame_id)[2:3], np.array([height]))


def test_a_constraint_without_compiled_rows_keeps_every_row_in_python(bioloid):
    problem, q0 = one_foot_problem(bioloid)
    problem.constraints.append(AbovePlane())
    problem = IKProblem(bioloid.model, problem.tasks, problem.constraints)
    problem.start(q0)
    problem.step(q0)
    assert problem.qp._plan is None and problem.qp._planned
    assert problem.solve(q0).success


def test_a_polygon_with_other_edges_is_stacked_in_python_and_planned_again(bioloid):
    problem, q0 = one_foot_problem(bioloid)
    problem.start(q0)
    problem.step(q0)
    first = problem.qp._plan
    balance = problem.constraints[1]
    pentagon = SupportPolygon(np.array([[-0.03, -0.09], [0.03, -0.09], [0.04, -0.05], [0.0, -0.02],
                                        [-0.04, -0.05]]))
    assert len(pentagon.offsets) == 5 != len(balance.offsets)
    balance._use(pentagon)
    twin = python_twin(problem)
    q = next(random_configurations(bioloid, q0, 1, seed=5))
    assert_same_rows(stacked(problem, q, 0.2, True), stacked(twin, q, 0.2, True), slice(6, 11))
    assert problem.qp._plan is not None and problem.qp._plan is not first
    assert_same_rows(stacked(problem, q0, 0.2, True), stacked(twin, q0, 0.2, True), slice(6, 11))


def test_no_plan_where_the_python_twin_is_asked_for(bioloid, monkeypatch):
    monkeypatch.setenv(PURE_PYTHON_VARIABLE, "qp_rows")
    problem, q0 = one_foot_problem(bioloid)
    problem.start(q0)
    problem.step(q0)
    assert problem.qp._plan is None


def test_a_copy_writes_its_own_rows(bioloid):
    """A deep copy (wbik.wholebody copies problems) holds no plan of the original's buffers, and its stack's
    box is a view of its own bounds: it makes its own plan and steps as the original does."""
    problem, q0 = one_foot_problem(bioloid)
    problem.start(q0)
    problem.step(q0)
    for clone in (copy.deepcopy(problem), copy.deepcopy(copy.deepcopy(problem))):
        assert clone.qp._plan is None and not clone.qp._planned
        clone.start(q0)
        q = next(random_configurations(bioloid, q0, 1, seed=9))
        before = problem.qp.stack.matrix.copy()
        clone.kinematics.update(q)
        clone.qp.build_constraints(1.0, 0.2)
        clone.kinematics.update(q0)
        clone.qp.build_constraints(1.0, 0.2)
        assert clone.qp._plan is not None and clone.qp._plan.stack is clone.qp.stack
        assert clone.qp.stack.matrix is not problem.qp.stack.matrix
        assert problem.qp.stack.matrix.tobytes() == before.tobytes()
        clone.kinematics.update(q)
        problem.kinematics.update(q)
        twin_rows = problem.qp.build_constraints(1.0, 0.2).matrix.copy()
        assert np.array_equal(clone.qp.build_constraints(1.0, 0.2).matrix, twin_rows)
        assert np.array_equal(clone.step(q0, max_step=0.01), problem.step(q0, max_step=0.01))


def test_the_kernels_follow_numpy_on_nan_and_signed_zeros():
    from wbik.kernels._qp_rows import position_bounds, step_box

    rng = np.random.default_rng(2)
    q = rng.normal(size=9)
    q[4] = np.nan
    q_index, v_index = np.array([1, 4, 5, 8]), np.array([0, 2, 3, 6])
    lower, upper = np.array([q[1], -1.0, np.nan, -0.5]), np.array([q[1], 1.0, 2.0, np.nan])
    for toward_rest in (False, True):
        ours = [np.full(7, -0.3), np.full(7, 0.3)]
        ours[0][5], ours[1][1] = np.nan, -0.0
        python = [array.copy() for array in ours]
        step_box(*ours, 0.3, False, False)
        position_bounds(q, q_index, v_index, lower, upper, *ours)
        step_box(*ours, 0.3, True, toward_rest)
        lb, ub = python
        lb.fill(-0.3)
        ub.fill(0.3)
        lb[v_index] = np.maximum(lb[v_index], lower - q[q_index])
        ub[v_index] = np.minimum(ub[v_index], upper - q[q_index])
        if toward_rest:
            np.maximum(ub, np.minimum(lb, np.zeros(7)), out=ub)
        np.minimum(lb, ub, out=lb)
        assert ours[0].tobytes() == lb.tobytes() and ours[1].tobytes() == ub.tobytes()


def test_the_kernels_refuse_bad_buffers_with_the_argument_named():
    from wbik.kernels._qp_rows import polygon_rows, position_bounds, step_box

    normals, offsets, com, jacobian = np.ones((4, 2)), np.ones(4), np.zeros(3), np.zeros((3, 5))
    with pytest.raises(TypeError, match="polygon_rows"):
        polygon_rows(normals, offsets, com, jacobian, np.zeros((4, 6)), np.zeros(4))
    with pytest.raises(TypeError, match="offsets"):
        polygon_rows(normals, np.ones(3), com, jacobian, np.zeros((4, 5)), np.zeros(4))
    with pytest.raises(TypeError, match="G"):
        polygon_rows(normals, offsets, com, jacobian, np.zeros((4, 5))[:, ::2], np.zeros(4))
    lb, ub = np.zeros(3), np.zeros(3)
    with pytest.raises(IndexError, match="outside"):
        position_bounds(np.zeros(2), np.array([2]), np.array([0]), np.zeros(1), np.zeros(1), lb, ub)
    with pytest.raises(IndexError, match="outside"):
        position_bounds(np.zeros(2), np.array([0]), np.array([3]), np.zeros(1), np.zeros(1), lb, ub)
    with pytest.raises(TypeError, match="q_index"):
        position_bounds(np.zeros(2), np.array([0.0]), np.array([0]), np.zeros(1), np.zeros(1), lb, ub)
    with pytest.raises(TypeError, match="lb"):
        step_box(np.zeros(3, dtype=np.float32), ub, 0.2, False, False)
    with pytest.raises(TypeError, match="differ"):
        step_box(lb, np.zeros(4), 0.2, False, False)
