"""Same verdicts on any machine: degenerate geometry perturbed by rounding-sized noise.

Every property test perturbs a degenerate input (side-by-side soles, collinear corners, a singular
UR5 wrist, a vertical Golem-III gripper, stretched Pincher/Bioloid limbs where two branches merge,
joints exactly at a limit) by relative noise of magnitude 10^k, k drawn in [-16, -10], and checks the
answer against values computed independently (hand geometry, Pinocchio FK), never against earlier
output of the code under test. Tolerances:

- support polygon margins within 1e-9 m of the hand value (noise <= 1e-10 of a 0.14 m polygon moves
  the boundary by <= 1.4e-11 m, the hull tolerance by <= 1.4e-10 m), the vertex count exactly the
  hand count, degenerate sets always raising DegenerateSupportPolygonError; the same for point feet
  (four, three, a sole and a point), and degenerate point feet (two, on one line, coincident far from
  the origin) always collapsing to the hand segment or point, with margin minus the hand distance;
- closed forms: success unchanged (True), the solution's Pinocchio FK within the shared 1e-6 m / 1e-6
  rad, q6 of the start kept to 1e-12 rad at a singular UR5 wrist, merged branches listed once.

The tests marked ``numerics`` also run in subprocesses under two OpenBLAS core types that round
differently (test_numerics_under_two_openblas_core_types); OPENBLAS_CORETYPE=Haswell made the
Bioloid balance scenario fail (CoM margin 0) before the support polygon used qhull with a scaled
tolerance.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import wbik
from wbik.qp.humanoid import sole_corners
from wbik.qp.kinematics import Kinematics
from wbik.qp.support_polygon import (
    DegenerateSupport,
    DegenerateSupportPolygonError,
    SupportPolygon,
    contact_points,
    support_region,
)
from wbik.robot_packages.bioloid.model import ALPHA
from wbik.solvers.analytic.closed_form import wrap_into_limits

ROOT = Path(__file__).resolve().parents[1]
CHILD = "WBIK_NUMERICS_CHILD"
NUMERICS_FILES = ["tests/test_robust_numerics.py", "tests/test_scenarios_wholebody.py",
                  "tests/test_scenarios_legged.py", "tests/test_analytic_ur5.py", "tests/test_ur_kernel.py",
                  "tests/test_compiled.py"]
SETTINGS = settings(deadline=None, max_examples=50, derandomize=True, database=None)
RHO = math.radians(13.43)  # golem3.md
MARGIN_TOLERANCE = 1e-9


@st.composite
def noise(draw, shape):
    """Relative noise of magnitude 10^k, k in [-16, -10], with random signs and shape ``shape``."""
    exponent = draw(st.floats(-16.0, -10.0))
    seed = draw(st.integers(0, 2**32 - 1))
    return 10.0 ** exponent * np.random.default_rng(seed).uniform(-1.0, 1.0, shape)


@pytest.fixture(scope="module")
def bioloid():
    return wbik.load("bioloid")


@pytest.fixture(scope="module")
def solvers():
    ur5, golem, pincher, bioloid = (wbik.load(name) for name in ("ur5", "golem3", "pincher", "bioloid"))
    return {"ur5": wbik.solver("analytic", ur5, chain="ee"),
            "golem": wbik.solver("analytic", golem, chain="right_arm"),
            "pincher": wbik.solver("analytic", pincher, chain="arm"),
            "leg": wbik.solver("analytic", bioloid, chain="right_leg"),
            "arm": wbik.solver("analytic", bioloid, chain="right_arm")}


def fk_error(chain, q, pose) -> tuple[float, float]:
    reached = chain.fk(q)
    return (float(np.linalg.norm(reached.translation - pose.translation)),
            float(np.linalg.norm(pin.log3(pose.rotation.T @ reached.rotation))))


def wrapped(angle):
    return float(np.angle(np.exp(1j * angle)))


# --- support polygon --------------------------------------------------------------------------------
def bioloid_feet(robot) -> np.ndarray:
    """The 8 sole corners (x, y) of both feet at the nominal stance, read from the robot."""
    kinematics = Kinematics(robot.model, robot.nominal)
    return contact_points(kinematics, sole_corners(robot), ["r_sole", "l_sole"])[:, :2]


def rectangle_margin(point, x_range, y_range) -> float:
    """Hand geometry: distance from a point inside an axis-aligned rectangle to its boundary."""
    x, y = point
    return min(x - x_range[0], x_range[1] - x, y - y_range[0], y_range[1] - y)


def test_the_reported_case_side_by_side_soles_with_rounding_noise():
    """The user's report: two 100 x 60 mm soles at y = +-0.0385, front corners' x off by +1e-18 and
    -3e-17 gave a hexagon and margin 0 at the right sole's centre; by hand the hull is the 100 x 137 mm
    rectangle and the margin there 30 mm."""
    sole = np.array([[0.05, 0.03], [-0.05, 0.03], [-0.05, -0.03], [0.05, -0.03]])
    right, left = sole + [0.0, -0.0385], sole + [0.0, 0.0385]
    right[[0, 3], 0] += 1e-18
    left[[0, 3], 0] -= 3e-17
    polygon = SupportPolygon(np.vstack((right, left)))
    assert len(polygon.vertices) == 4
    assert abs(polygon.margin_of([0.0, -0.0385]) - 0.03) < MARGIN_TOLERANCE
    assert abs(polygon.margin_of([0.0, 0.0]) - 0.05) < MARGIN_TOLERANCE


@pytest.mark.numerics
@SETTINGS
@given(relative=noise((8, 2)), absolute=noise((8, 2)))
def test_bioloid_two_feet_polygon_survives_rounding(bioloid, relative, absolute):
    corners = bioloid_feet(bioloid)
    # hand geometry: both soles flat and parallel at the nominal stance -> the hull is the bounding box
    x_range, y_range = (corners[:, 0].min(), corners[:, 0].max()), (corners[:, 1].min(), corners[:, 1].max())
    assert np.allclose(np.sort(np.unique(np.round(corners[:, 0], 12))), x_range)
    size = max(np.ptp(corners, axis=0))
    polygon = SupportPolygon(corners * (1.0 + relative) + size * absolute)
    assert len(polygon.vertices) == 4
    right_centre = corners[:4].mean(axis=0)
    for point in (right_centre, corners[4:].mean(axis=0), corners.mean(axis=0), right_centre + [0.01, 0.02]):
        assert abs(polygon.margin_of(point) - rectangle_margin(point, x_range, y_range)) < MARGIN_TOLERANCE
    outside = np.array([x_range[1] + 0.01, 0.0])
    assert abs(polygon.margin_of(outside) + 0.01) < MARGIN_TOLERANCE
    assert polygon.margin_of(right_centre) >= 0.005


@pytest.mark.numerics
@SETTINGS
@given(relative=noise((12, 2)), order=st.permutations(range(12)))
def test_collinear_edge_points_and_duplicates_are_merged(relative, order):
    """A 0.1 x 0.06 rectangle plus points on its edges and duplicated corners: 4 vertices, exact margins."""
    corners = np.array([[0.05, 0.03], [-0.05, 0.03], [-0.05, -0.03], [0.05, -0.03]])
    on_edges = np.array([[0.0, 0.03], [0.05, 0.0], [-0.05, 0.01], [0.02, -0.03]])
    points = np.vstack((corners, on_edges, corners))[list(order)]
    polygon = SupportPolygon(points * (1.0 + relative) + 0.1 * relative[::-1])
    assert len(polygon.vertices) == 4
    assert np.all(np.linalg.norm(np.roll(polygon.vertices, -1, axis=0) - polygon.vertices, axis=1) > 0.05)
    edges = np.roll(polygon.vertices, -1, axis=0) - polygon.vertices
    assert np.all(edges[:, 0] * np.roll(edges, -1, axis=0)[:, 1]
                  - edges[:, 1] * np.roll(edges, -1, axis=0)[:, 0] > 0.0)  # counter-clockwise
    for point in ([0.0, 0.0], [0.04, 0.0], [0.0, -0.025]):
        assert abs(polygon.margin_of(point) - rectangle_margin(point, (-0.05, 0.05), (-0.03, 0.03))) \
            < MARGIN_TOLERANCE


@pytest.mark.numerics
@SETTINGS
@given(relative=noise((5, 2)), direction=st.floats(0.0, math.pi))
def test_collinear_corners_raise_a_typed_error(relative, direction):
    """Points on one line (a single foot edge, a knife-edge contact) have no interior at any rounding."""
    line = np.outer([0.0, 0.02, 0.05, 0.07, 0.1], [math.cos(direction), math.sin(direction)]) + [0.3, -0.1]
    with pytest.raises(DegenerateSupportPolygonError, match="not on one line"):
        SupportPolygon(line * (1.0 + relative))
    with pytest.raises(ValueError):  # still a ValueError for callers that caught the old one
        SupportPolygon(np.vstack((line[:1], line[:1] * (1.0 + relative[:1]))))


# --- point feet ----------------------------------------------------------------------------------------
FEET = np.array([[0.1946, 0.1689], [-0.1946, 0.1689], [-0.1946, -0.1689], [0.1946, -0.1689]])
"""A quadruped's four feet (x, y), m: Solo12's standing stance, written here by hand."""


def line_margin(point, vertices) -> float:
    """Hand geometry: signed distance from ``point`` to the boundary of the convex polygon ``vertices``
    given counter-clockwise (cross products, positive inside)."""
    margins = []
    for a, b in zip(vertices, np.roll(vertices, -1, axis=0), strict=True):
        edge, offset = b - a, np.asarray(point) - a
        margins.append((edge[0] * offset[1] - edge[1] * offset[0]) / np.hypot(*edge))
    return float(min(margins))


def segment_distance(point, a, b) -> float:
    """Hand geometry: distance from ``point`` to the segment [a, b]."""
    direction = b - a
    t = np.clip(np.dot(np.asarray(point) - a, direction) / np.dot(direction, direction), 0.0, 1.0)
    return float(np.hypot(*(np.asarray(point) - a - t * direction)))


@pytest.mark.numerics
@SETTINGS
@given(relative=noise((4, 2)), angle=st.floats(-math.pi, math.pi), shift=st.floats(-2.0, 2.0))
def test_four_point_feet_keep_their_quadrilateral_and_margins(relative, angle, shift):
    """Four point feet, turned and moved anywhere, with rounding noise: 4 vertices, the hand margins to
    1e-9 m, and the CoM decision at 1 um either side of a 20 mm margin does not flip."""
    turn = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    feet = FEET @ turn.T + [shift, -shift]
    polygon = SupportPolygon(feet * (1.0 + relative))
    assert len(polygon.vertices) == 4
    centre = feet.mean(axis=0)
    for local in ([0.0, 0.0], [0.1, 0.05], [-0.15, 0.12], [0.25, 0.0]):
        point = centre + turn @ local
        assert abs(polygon.margin_of(point) - line_margin(point, feet)) < MARGIN_TOLERANCE
    for offset in (-1e-6, 1e-6):  # CoM 20 mm +- 1 um from the front edge
        point = centre + turn @ [FEET[0, 0] - 0.02 + offset, 0.0]
        assert (polygon.margin_of(point) >= 0.02) == (offset < 0)


@pytest.mark.numerics
@SETTINGS
@given(relative=noise((3, 2)), lifted=st.integers(0, 3))
def test_three_point_feet_make_a_triangle(relative, lifted):
    """One foot lifted: the triangle of the other three, margins by hand (the centre of the four feet
    lies on the triangle's diagonal: margin 0 to 1e-9, so a positive margin needs the CoM moved)."""
    feet = np.delete(FEET, lifted, axis=0)  # still counter-clockwise
    polygon = SupportPolygon(feet * (1.0 + relative))
    assert len(polygon.vertices) == 3
    assert abs(polygon.margin_of([0.0, 0.0])) < MARGIN_TOLERANCE
    inside = feet.mean(axis=0)
    assert abs(polygon.margin_of(inside) - line_margin(inside, feet)) < MARGIN_TOLERANCE


@pytest.mark.numerics
@SETTINGS
@given(relative=noise((2, 2)), pair=st.sampled_from([(0, 2), (1, 3), (0, 1), (1, 2)]),
       point=st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3)))
def test_two_point_feet_are_a_degenerate_segment(relative, pair, point):
    """Two point feet (a trot's diagonal pair, or one side): no polygon at any rounding; the region
    they collapse to is the segment, whose margin is minus the hand distance to it, never inside."""
    feet = FEET[list(pair)] * (1.0 + relative)
    with pytest.raises(DegenerateSupportPolygonError):
        SupportPolygon(feet)
    region = support_region(feet)
    assert isinstance(region, DegenerateSupport) and len(region.vertices) == 2
    expected = -segment_distance(point, *FEET[list(pair)])
    assert abs(region.margin_of(point) - expected) < MARGIN_TOLERANCE
    assert region.margin_of(point) <= 0.0


@pytest.mark.numerics
@SETTINGS
@given(relative=noise((4, 2)), middle=st.floats(0.1, 0.9))
def test_point_feet_on_one_line_are_degenerate(relative, middle):
    """Three or four point feet on one line (the diagonal, with rounding across it): a segment."""
    a, b = FEET[0], FEET[2]
    feet = np.array([a, a + middle * (b - a), b, a + 0.5 * middle * (b - a)]) * (1.0 + relative)
    with pytest.raises(DegenerateSupportPolygonError, match="one line"):
        SupportPolygon(feet)
    region = support_region(feet)
    assert len(region.vertices) == 2
    assert abs(region.margin_of(a) - 0.0) < MARGIN_TOLERANCE  # an end of the segment lies on it


@pytest.mark.numerics
@SETTINGS
@given(relative=noise((3, 2)), far=st.floats(1.0, 1000.0))
def test_coincident_point_feet_far_from_the_origin_are_one_point(relative, far):
    """Three feet a rounding apart at (far, -far/2) m: one point, not a tiny triangle (the tolerance
    scales with the coordinates, whose rounding is what separates them); margin = -distance to it."""
    where = np.array([far, -0.5 * far])
    feet = np.tile(where, (3, 1)) * (1.0 + relative)
    with pytest.raises(DegenerateSupportPolygonError):
        SupportPolygon(feet)
    region = support_region(feet)
    assert len(region.vertices) == 1
    assert abs(region.margin_of(where + [0.3, 0.4]) + 0.5) < 1e-9 * far


@pytest.mark.numerics
@SETTINGS
@given(relative=noise((5, 2)))
def test_a_flat_sole_and_a_point_foot_share_one_hull(relative):
    """A 0.2 x 0.1 m sole and a point foot 0.3 m ahead of its centre: a pentagon (the sole's four
    corners and the point), margins by hand."""
    sole = np.array([[0.1, 0.05], [-0.1, 0.05], [-0.1, -0.05], [0.1, -0.05]])
    tip = np.array([[0.3, 0.0]])
    polygon = SupportPolygon(np.vstack((sole, tip)) * (1.0 + relative))
    assert len(polygon.vertices) == 5
    pentagon = np.array([[0.3, 0.0], [0.1, 0.05], [-0.1, 0.05], [-0.1, -0.05], [0.1, -0.05]])
    for point in ([0.0, 0.0], [0.15, 0.01], [0.25, 0.0], [0.4, 0.0]):
        assert abs(polygon.margin_of(point) - line_margin(point, pentagon)) < MARGIN_TOLERANCE


# --- closed forms -----------------------------------------------------------------------------------
@pytest.mark.numerics
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), flip=st.booleans(), angle=noise(()), pose_noise=noise((6,)))
def test_ur5_singular_wrist_keeps_q6_of_the_start(solvers, seed, flip, angle, pose_noise):
    """q5 = 0 or pi (+ noise): q6 is free, so the solver keeps the start's q6; the pose is reached.

    q6 also swings the wrist-1 centre on a circle of radius d5 about the aligned axes 4 and 6, so the
    start's q6 is 0.1 rad from the true one and the elbow well bent: the planar arm still reaches it."""
    solver = solvers["ur5"]
    chain = solver.chain
    rng = np.random.default_rng(seed)
    q = rng.uniform(-2.5, 2.5, 6)
    q[2] = rng.choice([-1.0, 1.0]) * rng.uniform(0.8, 2.2)
    q[4] = (math.pi if flip else 0.0) + math.pi * float(angle)
    pose = chain.fk(q)
    pose = pin.SE3(pose.rotation @ pin.exp3(pose_noise[:3]), pose.translation * (1.0 + pose_noise[3:]))
    q0 = q + rng.uniform(-0.02, 0.02, 6)
    q0[5] = q[5] + 0.1
    result = solver.solve(pose, q0=q0)
    assert result.success, result.reason
    assert abs(result.q[5] - q0[5]) < 1e-12
    assert abs(wrapped(result.q[4] - q[4])) < 1e-9
    position_error, rotation_error = fk_error(chain, result.q, pose)
    assert position_error < 1e-6 and rotation_error < 1e-6


GOLEM_DEGENERATE = [
    [0.1, 0.4, 0.3, 0.5, math.pi / 2 - 0.5, 0.4],     # beta = -pi/2: gripper vertical, t6 and gamma coupled
    [0.3, 0.5, -0.4, -RHO, 0.8, 0.2],                 # t4 + rho = 0: cos(t4 + rho) = 1 (wrist singularity)
    [0.7, 0.0, -2.0, -RHO, 1.2, 1.0],                 # and the planar elbow stretched, t2 = 0
]


@pytest.mark.numerics
@SETTINGS
@given(case=st.sampled_from(GOLEM_DEGENERATE), joint_noise=noise((6,)))
def test_golem3_vertical_gripper_and_wrist_singularity(solvers, case, joint_noise):
    solver = solvers["golem"]
    chain = solver.chain
    q = np.array(case) + math.pi * joint_noise
    assert chain.in_limits(q)
    pose = chain.fk(q)
    for start in (chain.nominal, q + 0.05):
        result = solver.solve(pose, q0=np.clip(start, chain.lower, chain.upper))
        assert result.success, (q, result.reason)
        position_error, rotation_error = fk_error(chain, result.q, pose)
        assert position_error < 1e-6 and rotation_error < 1e-6


@pytest.mark.numerics
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), joint_noise=noise((4,)))
def test_pincher_stretched_elbow_is_one_branch(solvers, seed, joint_noise):
    """q3 = 0: both elbow branches of the pose closed form coincide (by hand: one solution)."""
    solver = solvers["pincher"]
    chain = solver.chain
    q = np.random.default_rng(seed).uniform(-1.0, 1.0, 4)
    q[2] = 0.0
    q = q + math.pi * joint_noise
    pose = chain.fk(q)
    every = solver.solve_all(pose)
    assert len(every) == 1
    assert np.max(np.abs(every[0].q - q)) < 1e-6
    assert solver.solve(pose.translation, q0=q).success


@pytest.mark.numerics
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), joint_noise=noise((6,)))
def test_bioloid_straight_knee_is_one_branch(solvers, seed, joint_noise):
    """Knee at 2 alpha (leg straight, cos gamma = -1): both knee branches coincide, and the other hip
    Euler branch needs |hip roll| > pi/2, outside the +-0.87 rad limits: by hand one solution."""
    solver = solvers["leg"]
    chain = solver.chain
    q = np.random.default_rng(seed).uniform(-0.15, 0.15, 6)
    q[3] = 2.0 * ALPHA
    q = q + math.pi * joint_noise
    pose = chain.fk(q)
    every = solver.solve_all(pose)
    assert len(every) == 1
    assert np.max(np.abs(every[0].q - q)) < 1e-6
    assert solver.solve(pose.translation, q0=q).success


@pytest.mark.numerics
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), joint_noise=noise((3,)))
def test_bioloid_stretched_arm_is_reached(solvers, seed, joint_noise):
    """Elbow at 0 (|c5| = 1): the thesis's elbow and the other one merge; the target stays reachable."""
    solver = solvers["arm"]
    chain = solver.chain
    q = np.random.default_rng(seed).uniform(-0.5, 0.5, 3)
    q[2] = 0.0
    q = q + math.pi * joint_noise
    result = solver.solve(chain.fk(q).translation, q0=q)
    assert result.success, result.reason
    assert np.linalg.norm(chain.fk(result.q).translation - chain.fk(q).translation) < 1e-6


@pytest.mark.numerics
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1), joint_noise=noise((6,)))
def test_golem3_joints_at_a_limit(solvers, seed, joint_noise):
    """Half the joints on a stop, pushed in or out by relative noise: still solved, inside the limits."""
    solver = solvers["golem"]
    chain = solver.chain
    rng = np.random.default_rng(seed)
    q = chain.random(rng, 1)[0]
    at_limit = rng.random(6) < 0.5
    q = np.where(at_limit, np.where(rng.random(6) < 0.5, chain.lower, chain.upper), q)
    q = q * (1.0 + joint_noise)
    pose = chain.fk(q)
    result = solver.solve(pose)
    assert result.success, result.reason
    assert chain.in_limits(result.q, tolerance=0.0)
    position_error, rotation_error = fk_error(chain, result.q, pose)
    assert position_error < 1e-6 and rotation_error < 1e-6


@pytest.mark.numerics
@SETTINGS
@given(side=st.booleans(), relative=noise(()))
def test_wrap_into_limits_at_a_limit(side, relative):
    """An angle on a limit +- relative noise is inside, set exactly onto the limit when it was outside."""
    lower, upper = np.array([-2.61799388]), np.array([2.61799388])
    limit = upper if side else lower
    q = limit * (1.0 + relative)
    result, inside = wrap_into_limits(q, np.zeros(1), lower, upper, np.array([True]))
    assert inside
    assert abs(result[0] - q[0]) < 1e-9 and lower[0] <= result[0] <= upper[0]


# --- the same tests under two OpenBLAS core types -----------------------------------------------------
@pytest.mark.skipif(os.environ.get(CHILD) == "1", reason="already inside a core-type run")
def test_numerics_under_two_openblas_core_types():
    """Rerun the ``numerics`` tests with OPENBLAS_CORETYPE=Nehalem and =Haswell (set only in the child):
    the two round differently (Haswell failed the Bioloid balance scenario before the qhull polygon)."""
    children = {}
    for core in ("Nehalem", "Haswell"):
        env = dict(os.environ, OPENBLAS_CORETYPE=core, **{CHILD: "1"})
        children[core] = subprocess.Popen(
            [sys.executable, "-m", "pytest", "-q", "-n", "0", "-m", "numerics", "-p", "no:cacheprovider",
             *NUMERICS_FILES],  # -n 0: the two children already run side by side
            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    for core, child in children.items():
        output, _ = child.communicate(timeout=600)
        assert child.returncode == 0, f"numerics tests fail under OPENBLAS_CORETYPE={core}:\n{output[-3000:]}"
