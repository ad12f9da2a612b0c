"""Subproblems shared by the closed forms (the bottom layer, as in IK-Geo and EAIK), on arrays of any
leading batch shape: clamped cosines and the planar two-link arm."""

from __future__ import annotations

import numpy as np

COSINE_TOLERANCE = 1e-9  # how far a cosine may leave [-1, 1] and its angle count as real (clamped)
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
