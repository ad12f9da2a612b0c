"""Subproblems shared by the closed forms, the bottom layer as in IK-Geo (Elias and Wen) and EAIK:
subproblems -> kinematic families (:mod:`.ur_type`, :mod:`.yaw_planar`, :mod:`.stacked_planar`) -> one
binding per robot. Every function takes arrays of any leading batch shape.

- :func:`clamped_cosine` / :func:`clamped_acos`: a cosine from lengths is a real angle only inside
  [-1, 1]; rounding puts a boundary target slightly outside, so the verdict allows ``COSINE_TOLERANCE``
  (scaled by the size of the terms) and the value is clipped;
- :func:`planar_2r`: a planar two-link arm reaching a point, both elbow branches.
"""

from __future__ import annotations

import numpy as np

COSINE_TOLERANCE = 1e-9
"""How far a cosine may leave [-1, 1] (rounding) before its angle counts as not real. A target on the
workspace boundary (a stretched elbow, an offset at full reach) comes back up to a few 1e-16 outside
after rounding, or 1e-10 beyond the boundary for a target itself rounded; clamping it moves the limb
by at most COSINE_TOLERANCE * its length (<= 1e-9 m per metre), far below the screening tolerance."""
WRIST_SINGULARITY = 1e-8
"""|sin| of a spherical wrist's middle joint (the UR-type's q5) below which the last joint is free
(ur_kinematics' threshold; read from the rotation, rounding moves it by ~1e-16); keeping q0's q6 there
costs at most ~1e-8 rad of orientation."""


def clamped_cosine(value, tolerance: float = COSINE_TOLERANCE, scale=None) -> tuple[np.ndarray, np.ndarray]:
    """(value clipped into [-1, 1], real mask): real where |value| <= 1 + tolerance * max(scale, 1).

    ``scale`` (broadcasts with ``value``; None = 1): the size of the terms the cosine was computed from
    relative to its denominator, e.g. (|a| + |b| + c) / d for (a - b - c) / d, since rounding of a
    difference of large terms is relative to the terms, not to the difference.
    """
    value = np.asarray(value, dtype=float)
    bound = 1.0 + tolerance if scale is None else 1.0 + tolerance * np.maximum(scale, 1.0)
    return np.clip(value, -1.0, 1.0), np.abs(value) <= bound


def clamped_acos(value, tolerance: float = COSINE_TOLERANCE, scale=None) -> tuple[np.ndarray, np.ndarray]:
    """(arccos of the clamped cosine in [0, pi], real mask) (see :func:`clamped_cosine`)."""
    cosine, real = clamped_cosine(value, tolerance, scale)
    return np.arccos(cosine), real


def planar_2r(x, y, first, second, tolerance: float = COSINE_TOLERANCE,
              axis: int = -1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Both elbow branches of a planar two-link arm reaching (x, y).

    The arm is x = a c1 + b c12, y = a s1 + b s12 (a = ``first``, b = ``second``; lengths may be
    negative as in the UR DH table). Law of cosines: c2 = (x^2 + y^2 - a^2 - b^2) / (2 a b),
    q2 = atan2(+-sqrt(1 - c2^2), c2), q1 = atan2(y, x) - atan2(b s2, a + b c2).

    Returns (angle1, angle2, real): ``axis`` of the angles (of x's shape plus one) is the elbow branch
    (q2 >= 0 first; the last axis by default, -2 for batch-last layouts); ``real`` (x's shape) is
    False where |c2| > 1 + tolerance (the point is out of reach).
    """
    return planar_2r_elbow(x, y, first, second, tolerance, axis)[:3]


def planar_2r_elbow(x, y, first, second, tolerance: float = COSINE_TOLERANCE,
                    axis: int = -1) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`planar_2r` and the elbow's (cos q2, sin q2) it came from: (angle1, angle2, real, cosine
    (x's shape, expanded on ``axis``), sines (the angles' shape)), for a caller that needs the second
    link's direction q1 + q2 without trigonometry: e^{i(q1 + q2)} is (x + i y)((b + a c2) + i a s2) over
    a positive length."""
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
