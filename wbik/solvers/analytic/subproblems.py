"""Subproblems shared by the closed forms (the bottom layer, as in IK-Geo and EAIK), on arrays of any
leading batch shape: clamped cosines and the planar two-link arm."""

from __future__ import annotations

import numpy as np

COSINE_TOLERANCE = 1e-9  # how far a cosine may leave [-1, 1] and its angle count as real (clamped)
ROOT_IMAGINARY = 1e-6  # |Im q| below which a root of a trigonometric polynomial counts as real (polished)
WRIST_SINGULARITY = 1e-8  # |sin q5| below which a spherical wrist's last joint is free (q0's is kept)


def clamped_cosine(value, tolerance: float = COSINE_TOLERANCE, scale=None) -> tuple[np.ndarray, np.ndarray]:
    """(value clipped into [-1, 1], real where |value| <= 1 + tolerance * max(scale, 1)); ``scale``: the size
    of the terms relative to the denominator, e.g. (|a| + |b| + c) / d for (a - b - c) / d (None: 1)."""
    value = np.asarray(value, dtype=float)
    bound = 1.0 + tolerance if scale is None else 1.0 + tolerance * np.maximum(scale, 1.0)
    return np.clip(value, -1.0, 1.0), np.abs(value) <= bound


def clamped_acos(value, tolerance: float = COSINE_TOLERANCE, scale=None) -> tuple[np.ndarray, np.ndarray]:
    """(arccos of the clamped cosine in [0, pi], real mask) (see :func:`clamped_cosine`)."""
    cosine, real = clamped_cosine(value, tolerance, scale)
    return np.arccos(cosine), real


def planar_2r(x, y, first, second, tolerance: float = COSINE_TOLERANCE,
              axis: int = -1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Both elbows of a planar two-link arm x = a c1 + b c12, y = a s1 + b s12 (a = ``first``, b =
    ``second``, maybe negative) reaching (x, y): c2 = (x^2 + y^2 - a^2 - b^2) / (2 a b), q2 = atan2(+-sqrt(1
    - c2^2), c2), q1 = atan2(y, x) - atan2(b s2, a + b c2). Returns (angle1, angle2, real): ``axis`` of the
    angles is the elbow (q2 >= 0 first), ``real`` (x's shape) False out of reach."""
    return planar_2r_elbow(x, y, first, second, tolerance, axis)[:3]


def planar_2r_elbow(x, y, first, second, tolerance: float = COSINE_TOLERANCE,
                    axis: int = -1) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`planar_2r` and the elbow's cosine (expanded on ``axis``) and sines: e^{i(q1 + q2)} is (x + i y)
    ((b + a c2) + i a s2) over a positive length, without trigonometry."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    cosine, real = clamped_cosine((x * x + y * y - first * first - second * second) / (2.0 * first * second),
                                  tolerance)
    sine = np.sqrt(1.0 - cosine * cosine)
    sines = np.stack((sine, -sine), axis=axis)
    cosines = np.expand_dims(cosine, axis)
    angle2 = np.arctan2(sines, cosines)
    angle1 = np.expand_dims(np.arctan2(y, x), axis) - np.arctan2(second * sines, first + second * cosines)
    return angle1, angle2, real, cosines, sines


# --- IK-Geo's subproblems on batches: vectors (..., 3), unit axes (3,) or (..., 3), angles (...) ---------
def cross(a, b) -> np.ndarray:
    """a x b over the last axis (broadcast; faster than np.cross on small batches)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return np.stack((a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]), axis=-1)


def dot(a, b) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def rotate(axis, angle, p) -> np.ndarray:
    """Rot(k, q) p = k (k.p) + sin q (k x p) - cos q (k x (k x p)) (Rodrigues, k = ``axis``)."""
    angle = np.asarray(angle, dtype=float)[..., None]
    k_cross_p = cross(axis, p)
    along = np.asarray(axis) * dot(axis, p)[..., None]
    return along + np.sin(angle) * k_cross_p + np.cos(angle) * (np.asarray(p) - along)


def circle_terms(h, k, p) -> tuple[np.ndarray, np.ndarray]:
    """h . Rot(k, q) p = A . (sin q, cos q) + c: (A (..., 2), c (...))."""
    k_cross_p = cross(k, p)
    return np.stack((dot(h, k_cross_p), -dot(h, cross(k, k_cross_p))), axis=-1), dot(h, k) * dot(k, p)


def sp1(p1, p2, k) -> np.ndarray:
    """SP1, circle and point: q with Rot(k, q) p1 = p2 (least squares where none)."""
    terms, _ = circle_terms(p2, k, p1)
    return np.arctan2(terms[..., 0], terms[..., 1])


def sp4(h, p, k, d) -> tuple[np.ndarray, np.ndarray]:
    """SP4, circle and plane: both q (..., 2) with h . Rot(k, q) p = d, and the real mask (...): with
    h . Rot(k, q) p = A . x + c, x = (sin q, cos q) = (A (d - c) +- J A sqrt(|A|^2 - (d - c)^2)) / |A|^2."""
    terms, constant = circle_terms(h, k, p)
    rest = np.asarray(d, dtype=float) - constant
    squared = dot(terms, terms)
    spread = np.sqrt(np.maximum(squared - rest * rest, 0.0))[..., None, None]
    normal = np.stack((terms[..., 1], -terms[..., 0]), axis=-1)[..., None, :]
    x = (terms * rest[..., None])[..., None, :] + np.array([1.0, -1.0])[:, None] * spread * normal
    return np.arctan2(x[..., 0], x[..., 1]), rest * rest <= squared * (1.0 + COSINE_TOLERANCE)


def sp3(p1, p2, k, d) -> tuple[np.ndarray, np.ndarray]:
    """SP3, circle and sphere: both q (..., 2) with |Rot(k, q) p1 - p2| = d, real mask (SP4 on p2)."""
    return sp4(p2, p1, k, 0.5 * (dot(p1, p1) + dot(p2, p2) - np.asarray(d) ** 2))


def sp2(p1, p2, k1, k2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SP2, two circles: (q1, q2) (..., 2) with Rot(k1, q1) p1 = Rot(k2, q2) p2 (|p1| = |p2|), real mask:
    k2 . Rot(k1, q1) p1 = k2 . p2 by SP4, then q2 by SP1."""
    first, real = sp4(k2, p1, k1, dot(k2, p2))
    turned = rotate(np.asarray(k1)[..., None, :], first, np.asarray(p1)[..., None, :])
    return first, sp1(np.asarray(p2)[..., None, :], turned, np.asarray(k2)[..., None, :]), real


def trig_quadratic_roots(coefficients: np.ndarray, polish: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Real roots q (..., 4) of f(q) = a0 + a1 cos q + b1 sin q + a2 cos 2q + b2 sin 2q (``coefficients``
    (..., 5) in that order) and their mask: with q = s + 2 atan(t) a quartic in t (s among 0, pi/2, the one
    giving the larger leading coefficient f(s + pi)), by Ferrari, then ``polish`` Newton steps on f."""
    a0, a1, b1, a2, b2 = np.moveaxis(np.asarray(coefficients, dtype=float), -1, 0)
    shift = np.where(np.abs(a0 - a1 + a2) >= np.abs(a0 - b1 - a2), 0.0, 0.5 * np.pi)
    c, s, c2, s2 = np.cos(shift), np.sin(shift), np.cos(2 * shift), np.sin(2 * shift)
    a1s, b1s, a2s, b2s = a1 * c + b1 * s, b1 * c - a1 * s, a2 * c2 + b2 * s2, b2 * c2 - a2 * s2
    # (1 + t^2)^2 f with cos q = (1 - t^2) / (1 + t^2), sin q = 2t / (1 + t^2)
    quartic = np.stack((a0 - a1s + a2s, 2 * b1s - 4 * b2s, 2 * a0 - 6 * a2s, 2 * b1s + 4 * b2s,
                        a0 + a1s + a2s))
    t = quartic_roots(quartic)
    q = shift[..., None] + 2.0 * np.arctan(t.real)
    nearly_real = 2.0 * np.abs(t.imag) <= ROOT_IMAGINARY * (1.0 + np.abs(t) ** 2)  # |Im q| to first order
    coefficients = np.stack((a0, a1, b1, a2, b2), axis=-1)[..., None, :]
    for _ in range(polish):
        value, slope = _trig_quadratic(coefficients, q)
        q = q - value / np.where(slope == 0.0, 1.0, slope)
    value, _ = _trig_quadratic(coefficients, q)
    scale = np.abs(coefficients).sum(axis=-1)
    return q, nearly_real & (np.abs(value) <= 1e-7 * scale)


def _trig_quadratic(coefficients: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a0, a1, b1, a2, b2 = np.moveaxis(coefficients, -1, 0)
    c, s, c2, s2 = np.cos(q), np.sin(q), np.cos(2 * q), np.sin(2 * q)
    return a0 + a1 * c + b1 * s + a2 * c2 + b2 * s2, b1 * c - a1 * s + 2 * (b2 * c2 - a2 * s2)


def quartic_roots(coefficients: np.ndarray) -> np.ndarray:
    """The 4 complex roots (..., 4) of A t^4 + B t^3 + C t^2 + D t + E (``coefficients`` (5, ...)) by Ferrari:
    t = -B/4A + y, y^4 + alpha y^2 + beta y + gamma = 0 split into two quadratics by the resolvent cubic."""
    big_a, b, c, d, e = (np.asarray(x, dtype=complex) for x in coefficients)
    big_a = np.where(np.abs(big_a) < 1e-14 * (np.abs(b) + np.abs(c) + np.abs(d) + np.abs(e) + 1e-300),
                     1e-14 * (np.abs(b) + np.abs(c) + np.abs(d) + np.abs(e) + 1e-300), big_a)
    b, c, d, e = b / big_a, c / big_a, d / big_a, e / big_a
    alpha = c - 0.375 * b * b
    beta = 0.125 * b ** 3 - 0.5 * b * c + d
    gamma = -3.0 / 256.0 * b ** 4 + c * b * b / 16.0 - 0.25 * b * d + e
    p = -alpha * alpha / 12.0 - gamma
    q = -alpha ** 3 / 108.0 + alpha * gamma / 3.0 - beta * beta / 8.0
    r = -0.5 * q + np.sqrt(0.25 * q * q + p ** 3 / 27.0)
    u = r ** (1.0 / 3.0)
    safe_u = np.where(u == 0, 1.0, u)
    y = np.where(u == 0, -5.0 / 6.0 * alpha - q ** (1.0 / 3.0), -5.0 / 6.0 * alpha + u - p / (3.0 * safe_u))
    w = np.sqrt(alpha + 2.0 * y)  # near 0 (beta near 0): the biquadratic's roots, polished by the caller
    scale = 1.0 + np.abs(alpha)
    tiny = (np.abs(alpha + 2.0 * y) < 1e-8 * scale) | (np.abs(beta) < 1e-12 * scale)
    safe_w = np.where(tiny, 1.0, w)
    plus = np.sqrt(-(3 * alpha + 2 * y + 2 * beta / safe_w))
    minus = np.sqrt(-(3 * alpha + 2 * y - 2 * beta / safe_w))
    general = np.stack((w + plus, w - plus, -w + minus, -w - minus), axis=-1) * 0.5
    root = np.sqrt(alpha * alpha - 4 * gamma)  # beta = 0: y^2 = (-alpha +- root) / 2
    outer, inner = np.sqrt(0.5 * (-alpha + root)), np.sqrt(0.5 * (-alpha - root))
    biquadratic = np.stack((outer, -outer, inner, -inner), axis=-1)
    return np.where(tiny[..., None], biquadratic, general) - 0.25 * b[..., None]


def sp6(first, second, rest) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SP6 in its linear form: (q1, q2) (..., 4) with F x1 + S x2 = rest, x_i = (sin q_i, cos q_i), F and S
    (..., 2, 2), rest (..., 2), and the real mask: the better-conditioned block eliminated, x_j = M x_i + m,
    and |M x_i + m|^2 = 1 a trigonometric quadratic in q_i (:func:`trig_quadratic_roots`)."""
    first, second = np.asarray(first, dtype=float), np.asarray(second, dtype=float)
    swap = np.abs(_det(first)) * _square(second) > np.abs(_det(second)) * _square(first)
    kept = np.where(swap[..., None, None], second, first)  # the angle solved for
    gone = np.where(swap[..., None, None], first, second)  # the block inverted
    det = _det(gone)
    det = np.where(det == 0.0, 1e-300, det)
    inverse = np.stack((np.stack((gone[..., 1, 1], -gone[..., 0, 1]), -1),
                        np.stack((-gone[..., 1, 0], gone[..., 0, 0]), -1)), -2) / det[..., None, None]
    m = np.einsum("...ij,...j->...i", inverse, rest)
    big_m = -inverse @ kept
    quadratic = np.swapaxes(big_m, -1, -2) @ big_m  # x^T Q x with x = (s, c)
    linear = 2.0 * np.einsum("...i,...ij->...j", m, big_m)
    constant = 0.5 * (quadratic[..., 0, 0] + quadratic[..., 1, 1]) + dot(m, m) - 1.0
    coefficients = np.stack((constant, linear[..., 1], linear[..., 0], 0.5 * (quadratic[..., 1, 1]
                             - quadratic[..., 0, 0]), quadratic[..., 0, 1]), axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):  # a degenerate quartic's NaN roots: not real
        solved, real = trig_quadratic_roots(coefficients)
    real &= np.isfinite(solved)
    unit = np.stack((np.sin(solved), np.cos(solved)), -1)
    x = np.einsum("...ij,...kj->...ki", big_m, unit) + m[..., None, :]
    other = np.arctan2(x[..., 0], x[..., 1])
    swap = swap[..., None]
    return np.where(swap, other, solved), np.where(swap, solved, other), real


def _det(matrix: np.ndarray) -> np.ndarray:
    return matrix[..., 0, 0] * matrix[..., 1, 1] - matrix[..., 0, 1] * matrix[..., 1, 0]


def _square(matrix: np.ndarray) -> np.ndarray:
    return np.einsum("...ij,...ij->...", matrix, matrix)
