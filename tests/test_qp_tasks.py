"""Task and constraint Jacobians against central finite differences, and the support polygon by hand."""

import numpy as np
import pinocchio as pin
import pytest
from qp_models import build_biped

import wbik
from wbik.qp import (
    ComTask,
    FrameTask,
    Kinematics,
    OrientationTask,
    PositionTask,
    RelativeFrameTask,
    SupportPolygon,
)
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.distances import MinimumDistance


def numeric_jacobian(model, q, error_of, step=1e-6):
    kinematics = Kinematics(model, q)
    columns = []
    for i in range(model.nv):
        delta = np.zeros(model.nv)
        delta[i] = step
        kinematics.update(pin.integrate(model, q, delta))
        plus = error_of(kinematics).copy()
        kinematics.update(pin.integrate(model, q, -delta))
        minus = error_of(kinematics).copy()
        columns.append((plus - minus) / (2 * step))
    return np.column_stack(columns)


@pytest.fixture(scope="module")
def biped():
    return build_biped()


def random_q(model, seed):
    rng = np.random.default_rng(seed)
    return pin.integrate(model, pin.neutral(model), rng.normal(scale=0.4, size=model.nv))


@pytest.mark.parametrize("make_task", [
    lambda: FrameTask("r_hand", pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.2, 1.0), np.array([0.1, -0.1, 0.3]))),
    lambda: PositionTask("l_sole", [0.0, 0.1, 0.0], axes="xz"),
    lambda: OrientationTask("pelvis", pin.rpy.rpyToMatrix(0.1, 0.2, -0.3)),
    lambda: RelativeFrameTask("r_hand", "l_sole", pin.SE3(pin.rpy.rpyToMatrix(-0.4, 0.1, 0.2),
                                                           np.array([0.05, -0.1, 0.25]))),
    lambda: ComTask([0.01, -0.02, 0.15]),
])
def test_task_jacobian_matches_finite_differences(biped, make_task):
    model = biped.model
    task = make_task()
    for seed in (1, 2):
        q = random_q(model, seed)
        kinematics = Kinematics(model, q)
        task.start(kinematics)
        analytic = task.jacobian(kinematics)
        numeric = numeric_jacobian(model, q, task.error)
        assert np.max(np.abs(analytic - numeric)) < 1e-6


@pytest.mark.parametrize("frame_task", [True, False])
def test_fill_writes_the_geometry_kernels_pose_error_and_its_jacobian(biped, frame_task):
    """The step's fused rows: e from wbik.geometry.pose_error on an independent FK, J against
    central finite differences of that error."""
    from wbik.geometry import pose_error

    model = biped.model
    target = pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.2, 1.0), np.array([0.1, -0.1, 0.3]))
    task = FrameTask("r_hand", target) if frame_task else OrientationTask("r_hand", target.rotation)
    for seed in (4, 5, 6):
        q = random_q(model, seed)
        kinematics = Kinematics(model, q)
        task.start(kinematics)
        jacobian, error = np.zeros((task.dimension, model.nv)), np.zeros(task.dimension)
        task.fill(kinematics, jacobian, error)
        reached = biped.frame_placement(q, "r_hand")
        expected = pose_error(reached.rotation, reached.translation, target.rotation, target.translation)
        np.testing.assert_allclose(error, expected if frame_task else expected[3:], rtol=0, atol=1e-12)

        def geometry_error(k, rotation=target.rotation, translation=target.translation):
            placement = k.placement(k.frame_id("r_hand"))
            full = pose_error(placement.rotation, placement.translation, rotation, translation)
            return full if frame_task else full[3:]

        assert np.max(np.abs(jacobian - numeric_jacobian(model, q, geometry_error))) < 1e-6


def test_com_polygon_and_distance_rows_match_finite_differences(biped):
    model = biped.model
    q = random_q(model, 3)
    kinematics = Kinematics(model, q)
    polygon = SupportPolygon(np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]]))
    com_constraint = CoMInSupportPolygon(polygon, margin=0.005)
    distance = MinimumDistance("r_hand", "l_sole", 0.05)
    distance.start(kinematics)
    for constraint in (com_constraint, distance):
        G, h = constraint.inequality(kinematics)
        numeric = numeric_jacobian(model, q, lambda k, c=constraint: -c.inequality(k)[1])
        assert np.max(np.abs(G - numeric)) < 1e-6


def test_support_polygon_by_hand():
    # a 0.10 x 0.06 rectangle plus an interior point (dropped by the hull)
    points = np.array([[0.05, 0.03], [-0.05, 0.03], [-0.05, -0.03], [0.05, -0.03], [0.0, 0.0]])
    polygon = SupportPolygon(points)
    assert len(polygon.vertices) == 4
    assert polygon.margin_of([0.0, 0.0]) == pytest.approx(0.03)        # nearest edges y = +-0.03
    assert polygon.margin_of([0.04, 0.0]) == pytest.approx(0.01)       # x edge at 0.05
    assert polygon.margin_of([0.06, 0.0]) == pytest.approx(-0.01)      # outside
    assert polygon.margin_of([0.0, 0.024]) >= 0.005
    assert not polygon.margin_of([0.0, 0.026]) >= 0.005
    normals, offsets = polygon.halfplanes(0.005)
    # shrunk by 5 mm: the corners of the inner rectangle are on the boundary
    inner = np.array([0.045, 0.025])
    assert np.max(normals @ inner - offsets) == pytest.approx(0.0, abs=1e-15)


def test_two_feet_polygon_is_the_hull_of_both_soles(biped):
    from wbik.qp.humanoid import support_polygon

    polygon = support_polygon(biped, biped.nominal, ["r_sole", "l_sole"])
    # soles centred at y = -+0.05, 0.10 x 0.06: hull x in [-0.05, 0.05], y in [-0.08, 0.08]
    assert sorted(map(tuple, np.round(polygon.vertices, 12))) == sorted(
        [(0.05, 0.08), (-0.05, 0.08), (-0.05, -0.08), (0.05, -0.08)])


def test_panda_chain_through_qp_method():
    robot = wbik.load("panda")
    chain = robot.chain("arm")
    solver = wbik.solver("qp", robot, chain="arm", backend="daqp", timeout_s=1.0)
    q_goal = np.array([0.3, -0.4, 0.2, -2.0, 0.1, 1.9, 0.5])
    result = solver.solve(chain.fk(q_goal))
    assert result.success, result.reason
    assert result.position_error <= 1e-6 and result.rotation_error <= 1e-6
    assert chain.in_limits(result.q)
