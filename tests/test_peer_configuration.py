"""Peers configured as their authors intend: PlaCo's CoM polygon in benchmarks/qp.py.

PlaCo's CoMPolygonConstraint takes a clockwise polygon (com_polygon_constraint.h: "@param polygon
Clockwise polygon"; polygon_constraint.h: the exterior is on the trigonometric normal of the
edges) and, like every PlaCo constraint, is soft unless configured "hard". The benchmark's own
setup function is built here and solved with an extra soft CoM task that pulls the CoM 100 mm
sideways, out of the right sole; the CoM margin is then measured by FK against wbik's
SupportPolygon, independently of PlaCo.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import wbik

placo = pytest.importorskip("placo")

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("benchmark_qp", ROOT / "benchmarks" / "qp.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def start(bench):
    robot = wbik.load("bioloid")
    q_start = bench.stand_on_right_foot(robot)
    foot_target = robot.frame_placement(q_start, "l_sole")
    foot_target.translation = foot_target.translation + bench.LIFT
    return robot, q_start, foot_target


def _solve_pulled(bench, robot, q_start, foot_target, **options) -> float:
    """CoM margin (m, by FK) after 100 PlaCo iterations with the CoM pulled 100 mm to the left."""
    from wbik.solvers.placo import placo_configuration

    setup = bench.placo_problem(robot, q_start, foot_target, **options)
    pull = setup.solver.add_com_task(robot.center_of_mass(q_start) + np.array([0.0, 0.10, 0.0]))
    pull.configure("pull the CoM out", "soft", 10.0)
    for _ in range(100):
        setup.solver.solve(True)
        setup.wrapper.update_kinematics()
    q = placo_configuration(robot, setup.wrapper)
    return setup.polygon.margin_of(robot.center_of_mass(q)[:2])


def test_signed_area_orientation(bench):
    square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]  # counter-clockwise, area 1
    assert bench.signed_area(square) == pytest.approx(1.0)
    assert bench.signed_area(square[::-1]) == pytest.approx(-1.0)


def test_polygon_handed_to_placo_is_clockwise_and_hard(bench, start):
    robot, q_start, foot_target = start
    setup = bench.placo_problem(robot, q_start, foot_target)
    handed = np.array(setup.vertices)
    assert bench.signed_area(handed) < 0.0  # clockwise
    # the same vertices as our polygon (the right sole, 100 x 60 mm), only in the other order
    assert abs(bench.signed_area(handed)) == pytest.approx(0.100 * 0.060, rel=1e-9)
    assert sorted(map(tuple, handed.round(12))) == sorted(map(tuple, setup.polygon.vertices.round(12)))
    # what PlaCo holds is what we handed it
    np.testing.assert_allclose(np.array(list(setup.com.polygon)), handed)
    assert setup.com.margin == pytest.approx(bench.MARGIN)
    assert setup.com.priority == "hard"


def test_placo_default_priority_is_soft():
    """Why configure() is needed: a constraint added without it is soft."""
    constraint = placo.CoMPolygonConstraint([np.array([0.0, 0.0]), np.array([0.0, 1.0]),
                                             np.array([1.0, 0.0])], 0.0)
    assert constraint.priority == "soft"


def test_clockwise_hard_polygon_keeps_the_pulled_com_inside(bench, start):
    margin = _solve_pulled(bench, *start)
    assert margin >= -1e-6
    assert margin >= bench.MARGIN - 1e-6  # and the 5 mm margin too


def test_counter_clockwise_polygon_does_not(bench, start):
    # counter-clockwise and soft (PlaCo's default when not configured): the CoM leaves
    assert _solve_pulled(bench, *start, clockwise=False, hard=False) < -0.01
    # counter-clockwise and hard: every half-plane is inverted, no configuration satisfies them all
    with pytest.raises(RuntimeError, match="[Ii]nfeasible"):
        _solve_pulled(bench, *start, clockwise=False, hard=True)
    # clockwise but soft: the pull wins over the polygon, so "hard" matters as well
    assert _solve_pulled(bench, *start, clockwise=True, hard=False) < -0.01
