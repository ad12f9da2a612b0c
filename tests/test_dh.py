"""DH builder: the Pinocchio model built from a DH table equals hand-multiplied DH matrices."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from wbik.dh import DHJoint, DHTable
from wbik.errors import RobotDescriptionError


# Elementary transforms written out here, independently of wbik.dh.
def Rz(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])


def Rx(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]])


def T(x=0.0, z=0.0):
    m = np.eye(4)
    m[0, 3], m[2, 3] = x, z
    return m


def standard_product(rows, q):
    """prod Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i), joint variable added to theta or d."""
    total = np.eye(4)
    for (a, alpha, d, theta, kind), value in zip(rows, q, strict=True):
        th = theta + value if kind == "revolute" else theta
        dd = d + value if kind == "prismatic" else d
        total = total @ Rz(th) @ T(z=dd) @ T(x=a) @ Rx(alpha)
    return total


def modified_product(rows, q, tool):
    """prod Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i), then the tool."""
    total = np.eye(4)
    for (a, alpha, d, theta, kind), value in zip(rows, q, strict=True):
        th = theta + value if kind == "revolute" else theta
        dd = d + value if kind == "prismatic" else d
        total = total @ Rx(alpha) @ T(x=a) @ Rz(th) @ T(z=dd)
    return total @ tool


def random_rows(rng, n):
    kinds = ["revolute"] * n
    kinds[rng.integers(n)] = "prismatic"
    return [(rng.uniform(-0.5, 0.5), rng.uniform(-math.pi, math.pi), rng.uniform(-0.5, 0.5),
             rng.uniform(-math.pi, math.pi), kind) for kind in kinds]


def pinocchio_fk(table: DHTable, q):
    model = table.model()
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q))
    return data.oMf[model.getFrameId("tool")].homogeneous


@pytest.mark.parametrize("trial", range(5))
def test_random_table_standard_and_modified_match_hand_products(rng, trial):
    n = 6
    rows = random_rows(rng, n)
    limits = dict(lower=-10.0, upper=10.0)
    standard = DHTable([DHJoint(a, al, d, th, k, **limits) for a, al, d, th, k in rows])
    # The same chain in the modified convention: row i takes alpha_{i-1}, a_{i-1} of the standard
    # row before it; the last standard Tx(a_n) Rx(alpha_n) becomes the tool.
    shifted = [(0.0, 0.0, *rows[0][2:])]
    shifted += [(rows[i - 1][0], rows[i - 1][1], *rows[i][2:]) for i in range(1, n)]
    tool = T(x=rows[-1][0]) @ Rx(rows[-1][1])
    modified = DHTable([DHJoint(a, al, d, th, k, **limits) for a, al, d, th, k in shifted],
                       convention="modified", tool=tool)
    for _ in range(10):
        q = rng.uniform(-2.0, 2.0, size=n)
        expected = standard_product(rows, q)
        assert np.allclose(modified_product(shifted, q, tool), expected, atol=1e-12)
        assert np.allclose(pinocchio_fk(standard, q), expected, atol=1e-12)
        assert np.allclose(pinocchio_fk(modified, q), expected, atol=1e-12)


def test_limits_and_joint_types_reach_the_model():
    table = DHTable([DHJoint(0.1, 0.0, 0.0, lower=-1.0, upper=2.0),
                     DHJoint(0.0, 0.0, 0.2, type="prismatic", lower=0.0, upper=0.3)])
    model = table.model()
    assert np.allclose(model.lowerPositionLimit, [-1.0, 0.0])
    assert np.allclose(model.upperPositionLimit, [2.0, 0.3])
    assert model.joints[2].shortname() == "JointModelPZ"


def test_base_transform_is_applied(rng):
    base = Rz(0.3) @ T(x=0.5, z=0.1)
    rows = random_rows(rng, 3)
    table = DHTable([DHJoint(a, al, d, th, k, lower=-9, upper=9) for a, al, d, th, k in rows], base=base)
    q = rng.uniform(-1, 1, size=3)
    assert np.allclose(pinocchio_fk(table, q), base @ standard_product(rows, q), atol=1e-12)


@pytest.mark.parametrize("bad", [
    dict(joints=[]),
    dict(joints=[DHJoint(0, 0, 0)], convention="craig"),
    dict(joints=[DHJoint(0, 0, 0, type="spherical")]),
    dict(joints=[DHJoint(0, 0, 0, lower=1.0, upper=-1.0)]),
])
def test_bad_tables_raise(bad):
    with pytest.raises(RobotDescriptionError):
        DHTable(**bad)
