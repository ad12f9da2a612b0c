"""The subproblems shared by the closed forms (wbik.solvers.analytic.subproblems), by hand and by FK."""

from __future__ import annotations

import numpy as np

from wbik.solvers.analytic.subproblems import COSINE_TOLERANCE, clamped_acos, clamped_cosine, planar_2r


def test_planar_2r_by_hand():
    """a = 2, b = 2 reaching (2, 2): elbow +-90 deg, first angle 0 or 90 deg (a square's corners)."""
    first, second, real = planar_2r(np.array(2.0), np.array(2.0), 2.0, 2.0)
    assert real
    np.testing.assert_allclose(np.degrees(second), [90.0, -90.0], atol=1e-12)
    np.testing.assert_allclose(np.degrees(first), [0.0, 90.0], atol=1e-12)
    _, _, real = planar_2r(np.array(4.1), np.array(0.0), 2.0, 2.0)
    assert not real


def test_planar_2r_reaches_the_point():
    rng = np.random.default_rng(2)
    for first, second in ((0.425, 0.39225), (-0.425, -0.39225), (1.0, 0.3), (0.105, 0.105)):
        angles = rng.uniform(-np.pi, np.pi, (500, 2))
        x = first * np.cos(angles[:, 0]) + second * np.cos(angles.sum(axis=1))
        y = first * np.sin(angles[:, 0]) + second * np.sin(angles.sum(axis=1))
        angle1, angle2, real = planar_2r(x, y, first, second)
        assert real.all()
        reached_x = first * np.cos(angle1) + second * np.cos(angle1 + angle2)
        reached_y = first * np.sin(angle1) + second * np.sin(angle1 + angle2)
        np.testing.assert_allclose(reached_x, np.broadcast_to(x[:, None], (500, 2)), atol=1e-12)
        np.testing.assert_allclose(reached_y, np.broadcast_to(y[:, None], (500, 2)), atol=1e-12)
    assert not planar_2r(np.array([4.1, np.nan]), np.array([0.0, 0.0]), 2.0, 2.0)[2].any()


def test_stretched_elbow_within_the_tolerance_is_clamped():
    """A point whose elbow cosine is 1 + COSINE_TOLERANCE / 2 is real and gives the stretched arm."""
    reach = 4.0 * (1.0 + COSINE_TOLERANCE / 8)
    angle1, angle2, real = planar_2r(np.array(reach), np.array(0.0), 2.0, 2.0)
    assert real
    np.testing.assert_array_equal(angle2, [0.0, 0.0])
    np.testing.assert_array_equal(angle1, [0.0, 0.0])


def test_clamped_cosine_scaled_tolerance():
    value = np.array([1.0 + 5e-10, 1.0 + 5e-9, -1.0 - 5e-9, 0.3, np.nan])
    clipped, real = clamped_cosine(value)
    np.testing.assert_array_equal(real, [True, False, False, True, False])
    np.testing.assert_array_equal(clipped[:4], [1.0, 1.0, -1.0, 0.3])
    # terms ten times the denominator: rounding ten times larger is allowed
    _, real = clamped_cosine(value, scale=np.array([10.0, 10.0, 10.0, 10.0, 10.0]))
    np.testing.assert_array_equal(real, [True, True, True, True, False])
    angle, real = clamped_acos(np.array([1.0 + 5e-10, -0.5]))
    np.testing.assert_allclose(angle, [0.0, 2.0 * np.pi / 3], atol=1e-15)
    assert real.all()
