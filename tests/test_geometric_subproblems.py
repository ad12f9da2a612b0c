"""IK-Geo's subproblems SP1-SP6 (wbik.solvers.analytic.subproblems) on random instances built from known
angles: the angles found reproduce the instance, one of them the angles it was built from. Rotations by
:func:`~wbik.solvers.analytic.structure.axis_rotation` (Rodrigues' matrix), not the code under test."""

from __future__ import annotations

import numpy as np

from wbik.solvers.analytic.structure import axis_rotation
from wbik.solvers.analytic.subproblems import circle_terms, quartic_roots, rotate, sp1, sp2, sp3, sp4, sp6

COUNT = 100


def _units(rng, *shape):
    v = rng.normal(size=shape + (3,))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _turned(axes, angles, points):
    return np.einsum("mij,mj->mi", np.array([axis_rotation(k, q) for k, q in zip(axes, angles, strict=True)]),
                     points)


def _gap(found, known):
    """Per instance the smallest angle (rad, modulo 2 pi) between a found angle (m, K) and the known (m,)."""
    return np.abs(np.angle(np.exp(1j * (found - known[:, None])))).min(axis=1)


def test_rotate_is_rodrigues():
    rng = np.random.default_rng(0)
    axes, angles, points = _units(rng, COUNT), rng.uniform(-np.pi, np.pi, COUNT), rng.normal(size=(COUNT, 3))
    np.testing.assert_allclose(rotate(axes, angles, points), _turned(axes, angles, points), atol=1e-14)


def test_sp1_sp3_sp4_recover_the_angle():
    rng = np.random.default_rng(1)
    axes, angles, points = _units(rng, COUNT), rng.uniform(-np.pi, np.pi, COUNT), rng.normal(size=(COUNT, 3))
    turned = _turned(axes, angles, points)
    assert _gap(sp1(points, turned, axes)[:, None], angles).max() < 1e-12
    normals = _units(rng, COUNT)
    found, real = sp4(normals, points, axes, np.einsum("mi,mi->m", normals, turned))
    assert real.all() and _gap(found, angles).max() < 1e-9
    centres = rng.normal(size=(COUNT, 3))
    found, real = sp3(points, centres, axes, np.linalg.norm(turned - centres, axis=1))
    assert real.all() and _gap(found, angles).max() < 1e-9
    for q in found.T:  # both angles of SP3 are at the distance asked
        np.testing.assert_allclose(np.linalg.norm(_turned(axes, q, points) - centres, axis=1),
                                   np.linalg.norm(turned - centres, axis=1), atol=1e-9)
    _, real = sp4(normals, points, axes, np.linalg.norm(points, axis=1) + 0.1)  # beyond the circle's reach
    assert not real.any()


def test_sp2_recovers_both_angles():
    rng = np.random.default_rng(2)
    first_axes, second_axes = _units(rng, COUNT), _units(rng, COUNT)
    first, second = rng.uniform(-np.pi, np.pi, (2, COUNT))
    points = rng.normal(size=(COUNT, 3))
    turned = _turned(first_axes, first, points)
    others = _turned(second_axes, -second, turned)  # Rot(k1, q1) p1 = Rot(k2, q2) p2
    found_first, found_second, real = sp2(points, others, first_axes, second_axes)
    assert real.all()
    gap = np.maximum(np.abs(np.angle(np.exp(1j * (found_first - first[:, None])))),
                     np.abs(np.angle(np.exp(1j * (found_second - second[:, None])))))
    assert gap.min(axis=1).max() < 1e-9


def test_sp6_recovers_both_angles():
    """h1.Rot(k1, a)p1 + h2.Rot(k2, b)p2 = d1, h3.Rot(k3, a)p3 + h4.Rot(k4, b)p4 = d2 from known (a, b)."""
    rng = np.random.default_rng(3)
    h, k, p = _units(rng, 4, COUNT), _units(rng, 4, COUNT), rng.normal(size=(4, COUNT, 3))
    a, b = rng.uniform(-np.pi, np.pi, (2, COUNT))
    angles = (a, b, a, b)
    values = [np.einsum("mi,mi->m", h[i], _turned(k[i], angles[i], p[i])) for i in range(4)]
    terms = [circle_terms(h[i], k[i], p[i]) for i in range(4)]
    first = np.stack((terms[0][0], terms[2][0]), axis=-2)
    second = np.stack((terms[1][0], terms[3][0]), axis=-2)
    rest = np.stack((values[0] + values[1] - terms[0][1] - terms[1][1],
                     values[2] + values[3] - terms[2][1] - terms[3][1]), axis=-1)
    found_a, found_b, real = sp6(first, second, rest)
    gap = np.where(real, np.maximum(np.abs(np.angle(np.exp(1j * (found_a - a[:, None])))),
                                    np.abs(np.angle(np.exp(1j * (found_b - b[:, None]))))), np.inf)
    assert np.quantile(gap.min(axis=1), 0.99) < 1e-9
    for column in range(4):  # every real pair found solves both equations
        fa, fb, ok = found_a[:, column], found_b[:, column], real[:, column]
        for x, y in ((0, 1), (2, 3)):
            reached = (np.einsum("mi,mi->m", h[x], _turned(k[x], fa, p[x]))
                       + np.einsum("mi,mi->m", h[y], _turned(k[y], fb, p[y])))
            np.testing.assert_allclose(reached[ok], (values[x] + values[y])[ok], atol=1e-7)


def test_quartic_roots_match_numpy():
    rng = np.random.default_rng(4)
    cases = [rng.normal(size=5) for _ in range(50)] + [np.array([2.55, 0.0, 1.56, 0.0, -0.99]),
                                                        np.array([1.0, -10.0, 35.0, -50.0, 24.0])]
    for coefficients in cases:
        found, expected = quartic_roots(coefficients[:, None])[0], np.roots(coefficients)
        assert np.abs(found[:, None] - expected[None, :]).min(axis=0).max() < 1e-7  # each root found
        assert np.abs(found[:, None] - expected[None, :]).min(axis=1).max() < 1e-7  # and nothing else


def test_trig_quadratic_roots_by_the_quartic_and_by_the_double_angle():
    """Roots of a0 + a1 cos q + b1 sin q + a2 cos 2q + b2 sin 2q built from two known roots: f = (cos q - cos
    r1)(cos q - cos r2) turned; and f of 2q alone (a1 = b1 = 0), whose four roots are known in closed form."""
    from wbik.solvers.analytic.subproblems import trig_quadratic_roots

    rng = np.random.default_rng(5)
    r1, r2 = rng.uniform(0.1, 3.0, (2, COUNT))
    # (cos q - c1)(cos q - c2) = cos^2 q - (c1 + c2) cos q + c1 c2, cos^2 q = (1 + cos 2q) / 2
    c1, c2 = np.cos(r1), np.cos(r2)
    found, real = trig_quadratic_roots((0.5 + c1 * c2, -(c1 + c2), np.zeros(COUNT), np.full(COUNT, 0.5),
                                        np.zeros(COUNT)))
    for root in (r1, -r1, r2, -r2):
        assert np.all(np.where(real, np.abs(np.angle(np.exp(1j * (found - root[:, None])))), np.inf)
                      .min(axis=1) < 1e-6)
    phase, angle = rng.uniform(-np.pi, np.pi, (2, COUNT))
    a0 = -np.cos(2 * angle - phase)  # f(q) = a0 + cos(2q - phase) vanishes at q = angle
    found, real = trig_quadratic_roots((a0, np.zeros(COUNT), np.zeros(COUNT), np.cos(phase), np.sin(phase)))
    assert real.all() and _gap(found, angle).max() < 1e-9
    values = a0[:, None] + np.cos(2 * found - phase[:, None])
    assert np.abs(values).max() < 1e-9
