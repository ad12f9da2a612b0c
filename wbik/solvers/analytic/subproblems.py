"""Subproblems shared by the closed forms (the bottom layer, as in IK-Geo and EAIK), on arrays of any
leading batch shape: clamped cosines, the planar two-link arm, and IK-Geo's SP1-SP4 and SP6 (its linear
form, through a trigonometric quadratic's roots) on the joint lines' vectors."""

from __future__ import annotations

import numpy as np

from wbik.solvers.analytic.structure import skew

COSINE_TOLERANCE = 1e-9  # how far a cosine may leave [-1, 1] and its angle count as real (clamped)
DOUBLE_ANGLE = 1e-6  # |a1| + |b1| relative below which a trigonometric quadratic starts from its 2q part
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
    p = np.asarray(p, dtype=float)
    along, k_cross_p = _along_and_across(axis, p)
    return along + np.sin(angle) * k_cross_p + np.cos(angle) * (p - along)


def _along_and_across(axis, p) -> tuple[np.ndarray, np.ndarray]:
    """k (k . p) and k x p (one axis (3,) by matrix products, else elementwise)."""
    axis = np.asarray(axis, dtype=float)
    if axis.ndim == 1:
        return (p @ axis)[..., None] * axis, p @ -skew(axis)
    return axis * dot(axis, p)[..., None], cross(axis, p)


def circle_terms(h, k, p) -> tuple[np.ndarray, np.ndarray]:
    """h . Rot(k, q) p = A . (sin q, cos q) + c: (A (..., 2), c (...)), A = (h . k x p, h . p - c)."""
    p = np.asarray(p, dtype=float)
    along, k_cross_p = _along_and_across(k, p)
    constant = dot(h, along)
    return np.stack((dot(h, k_cross_p), dot(h, p) - constant), axis=-1), constant


def sp1(p1, p2, k) -> np.ndarray:
    """SP1, circle and point: q with Rot(k, q) p1 = p2 (least squares where none)."""
    p1 = np.asarray(p1, dtype=float)
    along, k_cross_p = _along_and_across(k, p1)
    return np.arctan2(dot(p2, k_cross_p), dot(p2, p1 - along))


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


def trig_quadratic_roots(coefficients, polish: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Real roots q (..., 4) of f(q) = a0 + a1 cos q + b1 sin q + a2 cos 2q + b2 sin 2q (``coefficients``:
    (a0, a1, b1, a2, b2), arrays (...)) and their mask: with q = s + 2 atan(t) a quartic in t (s among 0,
    pi/2, the one giving the larger leading coefficient f(s + pi)), by Ferrari, then ``polish`` Newton steps
    (cos 2q = 2 c^2 - 1, sin 2q = 2 s c). Where the whole batch has a1, b1 near 0 (a robot's symmetry), the
    start is the roots of a0 + r cos(2q - phi): (phi +- acos(-a0 / r)) / 2 (+ pi), without the quartic."""
    a0, a1, b1, a2, b2 = (np.asarray(value, dtype=float) for value in coefficients)
    if np.all(np.abs(a1) + np.abs(b1) <= DOUBLE_ANGLE * (np.abs(a0) + np.abs(a2) + np.abs(b2))):
        radius, phase = np.hypot(a2, b2), np.arctan2(b2, a2)
        half = 0.5 * np.arccos(np.clip(-a0 / np.where(radius == 0.0, 1.0, radius), -1.0, 1.0))
        q = (0.5 * phase)[..., None] + np.stack((half, -half, half + np.pi, np.pi - half), axis=-1)
        nearly_real = (np.abs(a0) <= radius * (1.0 + COSINE_TOLERANCE))[..., None]
    else:
        quarter = np.abs(a0 - a1 + a2) < np.abs(a0 - b1 - a2)  # s = pi/2: (a1, b1, a2, b2) to (b1, -a1, ...)
        a1s, b1s = np.where(quarter, b1, a1), np.where(quarter, -a1, b1)
        a2s, b2s = np.where(quarter, -a2, a2), np.where(quarter, -b2, b2)
        # (1 + t^2)^2 f with cos q = (1 - t^2) / (1 + t^2), sin q = 2t / (1 + t^2)
        t = quartic_roots((a0 - a1s + a2s, 2 * b1s - 4 * b2s, 2 * a0 - 6 * a2s, 2 * b1s + 4 * b2s,
                           a0 + a1s + a2s))
        nearly_real = 2.0 * np.abs(t.imag) <= ROOT_IMAGINARY * (1.0 + np.abs(t) ** 2)  # |Im q| to first order
        q = 2.0 * np.arctan(t.real) + np.where(quarter, 0.5 * np.pi, 0.0)[..., None]
    a0, a1, b1, a2, b2 = (value[..., None] for value in (a0, a1, b1, a2, b2))
    for step in range(polish + 1):
        c, s = np.cos(q), np.sin(q)
        c2, s2 = 2.0 * c * c - 1.0, 2.0 * s * c
        value = a0 + a1 * c + b1 * s + a2 * c2 + b2 * s2
        if step == polish:
            break
        slope = b1 * c - a1 * s + 2.0 * (b2 * c2 - a2 * s2)
        q = q - value / np.where(slope == 0.0, 1.0, slope)
    scale = np.abs(a0) + np.abs(a1) + np.abs(b1) + np.abs(a2) + np.abs(b2)
    return q, nearly_real & (np.abs(value) <= 1e-7 * scale)


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


def sp6(first, second, rest, polish: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SP6 in its linear form: (q1, q2) (..., 4) with F x1 + S x2 = rest, x_i = (sin q_i, cos q_i), F and S
    (..., 2, 2), rest (..., 2), and the real mask: the better-conditioned block G eliminated (K the other),
    x_j = M x_i + m (M = -G^-1 K, m = G^-1 rest), and |M x_i + m|^2 = 1 a trigonometric quadratic in q_i."""
    first, second, rest = (np.asarray(value, dtype=float) for value in (first, second, rest))
    f00, f01, f10, f11 = first[..., 0, 0], first[..., 0, 1], first[..., 1, 0], first[..., 1, 1]
    s00, s01, s10, s11 = second[..., 0, 0], second[..., 0, 1], second[..., 1, 0], second[..., 1, 1]
    f_det, s_det = f00 * f11 - f01 * f10, s00 * s11 - s01 * s10
    f_size = f00 * f00 + f01 * f01 + f10 * f10 + f11 * f11
    s_size = s00 * s00 + s01 * s01 + s10 * s10 + s11 * s11
    swap = np.abs(f_det) * s_size > np.abs(s_det) * f_size  # F inverted, q2 solved for
    k00, k01, k10, k11 = (np.where(swap, b, a) for a, b in ((f00, s00), (f01, s01), (f10, s10), (f11, s11)))
    g00, g01, g10, g11 = (np.where(swap, a, b) for a, b in ((f00, s00), (f01, s01), (f10, s10), (f11, s11)))
    det = np.where(swap, f_det, s_det)
    scale = 1.0 / np.where(det == 0.0, 1e-300, det)
    r0, r1 = rest[..., 0], rest[..., 1]
    m0, m1 = (g11 * r0 - g01 * r1) * scale, (g00 * r1 - g10 * r0) * scale
    big00, big01 = (g01 * k10 - g11 * k00) * scale, (g01 * k11 - g11 * k01) * scale
    big10, big11 = (g10 * k00 - g00 * k10) * scale, (g10 * k01 - g00 * k11) * scale
    q00, q11 = big00 * big00 + big10 * big10, big01 * big01 + big11 * big11
    q01 = big00 * big01 + big10 * big11
    linear_s, linear_c = 2.0 * (m0 * big00 + m1 * big10), 2.0 * (m0 * big01 + m1 * big11)
    with np.errstate(invalid="ignore", divide="ignore"):  # a degenerate quartic's NaN roots: not real
        solved, real = trig_quadratic_roots((0.5 * (q00 + q11) + m0 * m0 + m1 * m1 - 1.0, linear_c, linear_s,
                                             0.5 * (q11 - q00), q01), polish)
    real &= np.isfinite(solved)
    sine, cosine = np.sin(solved), np.cos(solved)
    other = np.arctan2(big00[..., None] * sine + big01[..., None] * cosine + m0[..., None],
                       big10[..., None] * sine + big11[..., None] * cosine + m1[..., None])
    swap = swap[..., None]
    return np.where(swap, other, solved), np.where(swap, solved, other), real
