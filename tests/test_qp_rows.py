"""Typed constraint rows: each constraint contributes one row type, the rows write themselves into the
stacked QP, and a constraint written against the old ``kind`` contract is still read."""

import numpy as np
import pytest
from qp_models import build_biped

from wbik.qp import backends
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.constraint import Constraint
from wbik.qp.contacts import Contact
from wbik.qp.distances import MinimumDistance
from wbik.qp.kinematics import Kinematics
from wbik.qp.limits import JointPositionLimits, JointVelocityLimits
from wbik.qp.rows import BoundRows, EqualityRows, InequalityRows, as_index
from wbik.qp.support_polygon import SupportPolygon


@pytest.fixture(scope="module")
def biped():
    return build_biped()


def test_each_constraint_contributes_its_row_type(biped):
    model = biped.model
    kinematics = Kinematics(model, biped.nominal)
    polygon = SupportPolygon(np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]]))
    expected = [(JointPositionLimits(), BoundRows), (JointVelocityLimits(), BoundRows),
                (Contact("r_sole"), EqualityRows), (CoMInSupportPolygon(polygon, 0.01), InequalityRows),
                (MinimumDistance("r_hand", "l_sole", 0.05), InequalityRows)]
    for constraint, row_type in expected:
        constraint.start(kinematics)
        rows = constraint.rows(kinematics, 0.01)
        assert type(rows) is row_type, constraint
    # joint limits: q + dq stays inside [q_min, q_max] on the bounded joints, exactly
    limits = JointPositionLimits()
    limits.start(kinematics)
    rows = limits.rows(kinematics, 1.0)
    q = biped.nominal[limits.q_index]
    np.testing.assert_array_equal(rows.lower, model.lowerPositionLimit[limits.q_index] - q)
    np.testing.assert_array_equal(rows.upper, model.upperPositionLimit[limits.q_index] - q)
    assert rows.index == slice(6, model.nv)  # the biped's joints after its free flyer, in order


def test_rows_write_themselves_into_the_stack():
    stack = backends.StackedConstraints(4, capacity=1)
    lower, upper = stack.clear(1.0)
    BoundRows(np.array([0, 2]), np.array([-0.5, 0.2]), np.array([2.0, 0.1])).add_to(stack)
    BoundRows(slice(3, 4), 0.0, 0.0).add_to(stack)
    stack.close_box()
    np.testing.assert_array_equal(lower, [-0.5, -1.0, 0.1, 0.0])  # max(-1, l); an empty box closes
    np.testing.assert_array_equal(upper, [1.0, 1.0, 0.1, 0.0])
    InequalityRows(np.ones((2, 4)), np.array([3.0, 4.0])).add_to(stack)
    EqualityRows(np.eye(4)[:1], np.array([0.5])).add_to(stack)
    G, h, A, b, _, _ = stack.split()
    np.testing.assert_array_equal(G, np.ones((2, 4)))
    np.testing.assert_array_equal(h, [3.0, 4.0])
    np.testing.assert_array_equal(A, np.eye(4)[:1])
    np.testing.assert_array_equal(b, [0.5])


def test_a_constraint_that_declares_no_row_type_is_an_error(biped):
    class Untyped(Constraint):
        pass

    with pytest.raises(NotImplementedError, match="InequalityConstraint"):
        Untyped().rows(Kinematics(biped.model, biped.nominal), 1.0)


def test_the_riveting_clearance_contributes_typed_inequality_rows():
    from wbik.apps.riveting.qp_terms import WorkpieceClearance
    from wbik.qp.constraint import InequalityConstraint
    assert issubclass(WorkpieceClearance, InequalityConstraint)
    assert not hasattr(WorkpieceClearance, "kind")


def test_as_index_makes_consecutive_indices_a_slice():
    assert as_index(np.array([3, 4, 5])) == slice(3, 6)
    np.testing.assert_array_equal(as_index(np.array([3, 5])), [3, 5])
    assert as_index(np.array([], dtype=int)).size == 0


def test_com_margin_follows_the_configuration_and_matches_the_polygon(biped):
    """The CoM constraint keeps N c_xy per configuration for its rows and its margin: after every
    update the margin is SupportPolygon.margin_of of the CoM computed by Pinocchio apart."""
    import pinocchio as pin

    model = biped.model
    polygon = SupportPolygon(np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]]))
    constraint = CoMInSupportPolygon(polygon, 0.01)
    kinematics = Kinematics(model, biped.nominal)
    rng = np.random.default_rng(2)
    for _ in range(5):
        q = pin.integrate(model, biped.nominal, rng.normal(scale=0.2, size=model.nv))
        kinematics.update(q)
        com = pin.centerOfMass(model, model.createData(), q)
        assert constraint.com_margin(kinematics) == pytest.approx(polygon.margin_of(com[:2]), abs=1e-15)
        G, h = constraint.rows(kinematics, 1.0)
        np.testing.assert_allclose(h, polygon.offsets - 0.01 - constraint.safety - polygon.normals @ com[:2],
                                   rtol=0, atol=1e-15)
