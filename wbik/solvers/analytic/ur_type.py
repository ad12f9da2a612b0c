"""Family: UR-type 6R arms (Universal Robots' UR3/UR5/UR10 and the like), every branch.

Axes 2, 3 and 4 are parallel (IK-Geo's and EAIK's "three parallel" 6R) and consecutive axes are
otherwise perpendicular. Standard DH: a = (0, a2, a3, 0, 0, 0), d = (d1, 0, 0, d4, d5, d6),
alpha = (pi/2, 0, 0, pi/2, -pi/2, 0); a robot binding gives these six numbers (:class:`URGeometry`).
The closed form is ur_kinematics' (ur5-riveting.md section 1.2), on T = base_link -> ee_link of the
ROS-Industrial UR description, first turned into the DH frames: T_dh = B T E^T with
B = base_link -> link0 = Rz(pi) and E = link6 -> ee_link. Up to 8 branches = 2 (shoulder q1) x
2 (wrist q5) x 2 (elbow q3), in that order:

1. q1 = atan2(-b, a) +- acos(d4 / sqrt(a^2 + b^2)), a = d6 T12 - T13, b = d6 T02 - T03
   (no solution when the wrist-2 centre is within d4 of the base axis);
2. q5 = +-acos((T03 s1 - T13 c1 - d4) / d6), computed as +-atan2(|s5|, c5) with
   |s5| = hypot(T00 s1 - T10 c1, T01 s1 - T11 c1) from the rotation (well conditioned at q5 = 0, pi);
3. q6 = atan2(-sgn(s5) (T01 s1 - T11 c1), sgn(s5) (T00 s1 - T10 c1)); at the wrist singularity
   (|s5| < WRIST_SINGULARITY) q6 is free and the start configuration's q6 is kept (ur_kinematics'
   q6_des);
4. (q2, q3) from the planar two-link subproblem p13 = a2 (c2, s2) + a3 (c23, s23), and
   q4 = atan2(c23 x04y - s23 x04x, c23 x04x + s23 x04y).

Angles come out in (-2 pi, 2 pi); the framework wraps them into the limits nearest to q0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wbik.geometry import TWO_PI
from wbik.geometry import add_wrapped_squares
from wbik.solvers.analytic.closed_form import ClosedForm
from wbik.solvers.analytic.subproblems import COSINE_TOLERANCE
from wbik.solvers.analytic.subproblems import WRIST_SINGULARITY
from wbik.solvers.analytic.subproblems import clamped_acos
from wbik.solvers.analytic.subproblems import clamped_cosine
from wbik.solvers.analytic.subproblems import planar_2r_elbow
from wbik.solvers.analytic.subproblems import planar_2r_one
from wbik.solvers.analytic.ur_kernel import URKernel
from wbik.solvers.analytic.ur_kernel import ur_kernel

BASE_TO_LINK0 = np.diag([-1.0, -1.0, 1.0])
"""Rz(pi), exactly: the UR description's base_link -> link0 (the DH base)."""
LINK6_TO_EE = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
"""The UR description's link6 (the DH flange) -> ee_link."""


@dataclass(frozen=True)
class URGeometry:
    """The six non-zero DH numbers of a UR-type arm (m)."""

    d1: float
    a2: float
    a3: float
    d4: float
    d5: float
    d6: float


def fk(geometry: URGeometry, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form FK base_link -> ee_link (ur_kinematics' ``forward``) of joints (..., 6)."""
    d1, a2, a3, d4, d5, d6 = geometry.d1, geometry.a2, geometry.a3, geometry.d4, geometry.d5, geometry.d6
    q = np.asarray(q, dtype=float)
    q23 = q[..., 1] + q[..., 2]
    angles = np.stack((q[..., 0], q[..., 1], q[..., 3], q[..., 4], q[..., 5], q23, q23 + q[..., 3]))
    cosines, sines = np.cos(angles), np.sin(angles)  # one call each: numpy's per-call cost dominates
    c1, c2, c4, c5, c6, c23, c234 = cosines
    s1, s2, s4, s5, s6, s23, s234 = sines
    side = s1 * s5 + c234 * c1 * c5  # recurring products
    front = c1 * s5 - c234 * c5 * s1
    rows = (
        (c234 * c1 * s5 - c5 * s1, c6 * side - s234 * c1 * s6, -s6 * side - s234 * c1 * c6),
        (c1 * c5 + c234 * s1 * s5, -c6 * front - s234 * s1 * s6, s6 * front - s234 * c6 * s1),
        (-s234 * s5, -c234 * s6 - s234 * c5 * c6, s234 * c5 * s6 - c234 * c6),
    )
    rotation = np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)
    position = np.stack((
        d6 * c234 * c1 * s5 - a3 * c23 * c1 - a2 * c1 * c2 - d6 * c5 * s1 - d5 * s234 * c1 - d4 * s1,
        d6 * (c1 * c5 + c234 * s1 * s5) + d4 * c1 - a3 * c23 * s1 - a2 * c2 * s1 - d5 * s234 * s1,
        d1 + a3 * s23 + a2 * s2 - d5 * (c23 * c4 - s23 * s4) - d6 * s5 * (c23 * s4 + s23 * c4),
    ), axis=-1)
    return position, rotation


def fk_one(geometry: URGeometry, q) -> tuple[tuple[float, float, float], tuple[float, ...]]:
    """:func:`fk` of one joint vector in plain floats: (position, rotation row by row (9,))."""
    d1, a2, a3, d4, d5, d6 = geometry.d1, geometry.a2, geometry.a3, geometry.d4, geometry.d5, geometry.d6
    q1, q2, q3, q4, q5, q6 = q
    q23 = q2 + q3
    q234 = q23 + q4
    cos, sin = math.cos, math.sin
    c1, s1, c2, s2 = cos(q1), sin(q1), cos(q2), sin(q2)
    c4, s4, c5, s5 = cos(q4), sin(q4), cos(q5), sin(q5)
    c6, s6, c23, s23 = cos(q6), sin(q6), cos(q23), sin(q23)
    c234, s234 = cos(q234), sin(q234)
    side = s1 * s5 + c234 * c1 * c5
    front = c1 * s5 - c234 * c5 * s1
    rotation = (c234 * c1 * s5 - c5 * s1, c6 * side - s234 * c1 * s6, -s6 * side - s234 * c1 * c6,
                c1 * c5 + c234 * s1 * s5, -c6 * front - s234 * s1 * s6, s6 * front - s234 * c6 * s1,
                -s234 * s5, -c234 * s6 - s234 * c5 * c6, s234 * c5 * s6 - c234 * c6)
    position = (d6 * c234 * c1 * s5 - a3 * c23 * c1 - a2 * c1 * c2 - d6 * c5 * s1 - d5 * s234 * c1 - d4 * s1,
                d6 * (c1 * c5 + c234 * s1 * s5) + d4 * c1 - a3 * c23 * s1 - a2 * c2 * s1 - d5 * s234 * s1,
                d1 + a3 * s23 + a2 * s2 - d5 * (c23 * c4 - s23 * s4) - d6 * s5 * (c23 * s4 + s23 * c4))
    return position, rotation


def branches_by_joint(geometry: URGeometry, positions: np.ndarray, rotations: np.ndarray, q6_free: np.ndarray,
                      tolerance: float = COSINE_TOLERANCE) -> tuple[np.ndarray, np.ndarray]:
    """All 8 branches for base_link -> ee_link poses, joint-major and batch-last: (Q (6, 8, B), real (8, B)).

    Branch order: q1 (+, -) x q5 (+, -) x q3 (+, -). ``q6_free`` (B,) is used at the wrist singularity.
    Every intermediate keeps the batch on its last axis, (choices..., B), so that NumPy broadcasts a
    per-target value over the branches along whole rows (broadcasting over a short last axis costs
    more per element; the measurements: docs/measurements.md, analytic).
    """
    d1, a2, a3, d4, d5, d6 = geometry.d1, geometry.a2, geometry.a3, geometry.d4, geometry.d5, geometry.d6
    count = len(positions)
    r = np.ascontiguousarray(rotations.reshape(count, 9).T)  # r[3 i + j] = R_ij, each (B,)
    p = np.ascontiguousarray(positions.T)
    # into the DH convention: B R E^T with B = diag(-1, -1, 1) and E^T's columns -e1, -e2, e0; B p
    t00, t01, t02, t10, t11, t12 = r[1], r[2], -r[0], r[4], r[5], -r[3]
    t20, t21, t22 = -r[7], -r[8], r[6]
    t03, t13, t23 = -p[0], -p[1], p[2]

    # 1. shoulder: (2, B)
    a = d6 * t12 - t13
    b = d6 * t02 - t03
    offset, real1 = clamped_acos(d4 / np.maximum(np.sqrt(a * a + b * b), 1e-300), tolerance)
    q1 = np.arctan2(-b, a) + np.stack((offset, -offset))
    c1, s1 = np.cos(q1), np.sin(q1)

    # 2. wrist 2: (2, 2, B). cos q5 from the position (ur_kinematics); |sin q5| from the rotation,
    # hypot(T00 s1 - T10 c1, T01 s1 - T11 c1) = |s5| |(c6, s6)|, which rounding moves by ~1e-16, whereas
    # sqrt(1 - cos5^2) turns one ulp of cos5 into 1.5e-8 at q5 = 0 or pi (the singularity decision and
    # q5 itself would then depend on the CPU's rounding). |cos5| <= 1 up to rounding of the terms of
    # its numerator, relative to their size. q5 = +-atan2(|sin q5|, cos q5), so (cos, sin) of q5 are
    # (cos5, +-|sin q5|) over their length (they enter only q4; no trigonometry).
    t03_s1, t13_c1 = t03 * s1, t13 * c1
    cos5, real5 = clamped_cosine((t03_s1 - t13_c1 - d4) / d6, tolerance,
                                 (np.abs(t03_s1) + np.abs(t13_c1) + d4) / d6)
    u, v = t00 * s1 - t10 * c1, t01 * s1 - t11 * c1
    sine5 = np.hypot(u, v)
    angle5 = np.arctan2(sine5, cos5)
    q5 = np.stack((angle5, -angle5), axis=1)
    length5 = np.maximum(np.sqrt(sine5 * sine5 + cos5 * cos5), 1e-300)
    c5 = (cos5 / length5)[:, None]
    s5 = np.stack((sine5, -sine5), axis=1) / length5[:, None]
    c1, s1, u, v = c1[:, None], s1[:, None], u[:, None], v[:, None]

    # 3. wrist 3: (2, 2, B)
    sign = np.where(s5 >= 0.0, 1.0, -1.0)
    q6 = np.arctan2(-sign * v, sign * u)
    q6 = np.where((sine5 < WRIST_SINGULARITY)[:, None], q6_free, q6)
    c6, s6 = np.cos(q6), np.sin(q6)

    # 4. planar shoulder-lift / elbow / wrist 1: (2, 2, 2, B), the elbow on the third axis; q4 from the
    # direction of q2 + q3, which the elbow gives up to a positive length (planar_2r_elbow)
    r0 = t00 * c1 + t10 * s1
    r1 = t01 * c1 + t11 * s1
    r2 = t02 * c1 + t12 * s1
    x04x = -s5 * r2 - c5 * (s6 * r1 - c6 * r0)
    x04y = c5 * (t20 * c6 - t21 * s6) - t22 * s5
    p13x = d5 * (s6 * r0 + c6 * r1) - d6 * r2 + t03 * c1 + t13 * s1
    p13y = t23 - d1 - d6 * t22 + d5 * (t21 * c6 + t20 * s6)
    q_all = np.empty((6, 2, 2, 2, count))
    q_all[1], q_all[2], real3, cos3, sin3 = planar_2r_elbow(p13x, p13y, a2, a3, tolerance, axis=-2)
    p13x, p13y = p13x[:, :, None], p13y[:, :, None]
    along, across = a3 + a2 * cos3, a2 * sin3
    c23 = p13x * along - p13y * across  # (cos, sin) of q2 + q3 times a positive length
    s23 = p13y * along + p13x * across
    x04x, x04y = x04x[:, :, None], x04y[:, :, None]
    np.arctan2(c23 * x04y - s23 * x04x, x04x * c23 + x04y * s23, out=q_all[3])
    q_all[0] = q1[:, None, None]
    q_all[4] = q5[:, :, None]
    q_all[5] = q6[:, :, None]
    real = (real1 & real5[:, None] & real3)[:, :, None]  # (2, 2, 1, B): both elbows alike
    return q_all.reshape(6, 8, count), np.broadcast_to(real, (2, 2, 2, count)).reshape(8, count)


def branches(geometry: URGeometry, positions: np.ndarray, rotations: np.ndarray, q6_free: np.ndarray,
             tolerance: float = COSINE_TOLERANCE) -> tuple[np.ndarray, np.ndarray]:
    """:func:`branches_by_joint` laid out target by target: (Q (B, 8, 6), real (B, 8))."""
    q_all, real = branches_by_joint(geometry, positions, rotations, q6_free, tolerance)
    return np.ascontiguousarray(q_all.transpose(2, 1, 0)), np.ascontiguousarray(real.T)


def branches_one(geometry: URGeometry, position, rotation, reference,
                 tolerance: float = COSINE_TOLERANCE) -> list[tuple[float, list[float]]]:
    """:func:`branches` for one pose in plain floats: the real branches in the same order, each as
    (bound, q) with bound = sum_i remainder(q_i - reference_i, 2 pi)^2 (summed along the tree of
    shoulder, wrist and elbow choices, so each remainder is taken once). q6 at the wrist singularity
    is reference[5]."""
    d1, a2, a3, d4, d5, d6 = geometry.d1, geometry.a2, geometry.a3, geometry.d4, geometry.d5, geometry.d6
    x, y, z = position
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rotation
    # into the DH convention: B R E^T with B = diag(-1, -1, 1) and E^T's columns -e1, -e2, e0
    t00, t01, t02, t10, t11, t12 = r01, r02, -r00, r11, r12, -r10
    t20, t21, t22 = -r21, -r22, r20
    t03, t13, t23 = -x, -y, z
    ref1, ref2, ref3, ref4, ref5, ref6 = reference
    atan2, cos, sin, remainder = math.atan2, math.cos, math.sin, math.remainder
    branches = []
    a, b = d6 * t12 - t13, d6 * t02 - t03
    ratio = d4 / max(math.sqrt(a * a + b * b), 1e-300)
    if not ratio <= 1.0 + tolerance:
        return branches
    offset = math.acos(min(1.0, ratio))
    shoulder = atan2(-b, a)
    for q1 in (shoulder + offset, shoulder - offset):
        e1 = remainder(q1 - ref1, TWO_PI)
        bound1 = e1 * e1
        c1, s1 = cos(q1), sin(q1)
        cos5 = (t03 * s1 - t13 * c1 - d4) / d6
        if not abs(cos5) <= 1.0 + tolerance * max((abs(t03 * s1) + abs(t13 * c1) + d4) / d6, 1.0):
            continue
        u, v = t00 * s1 - t10 * c1, t01 * s1 - t11 * c1
        sine5 = math.sqrt(u * u + v * v)  # not math.hypot (CPython's own algorithm): the kernel's arithmetic
        angle5 = atan2(sine5, min(1.0, max(-1.0, cos5)))
        singular = sine5 < WRIST_SINGULARITY
        r0, r1, r2 = t00 * c1 + t10 * s1, t01 * c1 + t11 * s1, t02 * c1 + t12 * s1
        for q5 in (angle5, -angle5):
            c5, s5 = cos(q5), sin(q5)
            if singular:
                q6 = ref6
            else:
                sign = 1.0 if s5 >= 0.0 else -1.0
                q6 = atan2(-sign * v, sign * u)
            e5, e6 = remainder(q5 - ref5, TWO_PI), remainder(q6 - ref6, TWO_PI)
            bound5 = bound1 + e5 * e5 + e6 * e6
            c6, s6 = cos(q6), sin(q6)
            x04x = -s5 * r2 - c5 * (s6 * r1 - c6 * r0)
            x04y = c5 * (t20 * c6 - t21 * s6) - t22 * s5
            px = d5 * (s6 * r0 + c6 * r1) - d6 * r2 + t03 * c1 + t13 * s1
            py = t23 - d1 - d6 * t22 + d5 * (t21 * c6 + t20 * s6)
            for q2, q3 in planar_2r_one(px, py, a2, a3, tolerance):
                q23 = q2 + q3
                c23, s23 = cos(q23), sin(q23)
                q4 = atan2(c23 * x04y - s23 * x04x, x04x * c23 + x04y * s23)
                branches.append((add_wrapped_squares(bound5, q2, ref2, q3, ref3, q4, ref4),
                                 [q1, q2, q3, q4, q5, q6]))
    return branches


class URArm(ClosedForm):
    """Closed form of a UR-type arm's base_link -> ee_link chain (full poses, 8 branches); a binding
    sets ``geometry``."""

    target_kind = "pose"
    has_scalar_path = True
    geometry: URGeometry

    def __init__(self, chain, geometry: URGeometry | None = None):
        """``geometry``: the arm's DH numbers, where the class does not set them (a recognised chain)."""
        super().__init__(chain)
        if geometry is not None:
            self.geometry = geometry
        self.kernel = self.compiled_kernel()

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return branches(self.geometry, positions, rotations, q0[:, 5])

    def branches_by_joint(self, positions: np.ndarray, rotations: np.ndarray | None,
                          q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return branches_by_joint(self.geometry, positions, rotations, q0[:, 5])

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return fk(self.geometry, q)

    def branches_one(self, position, rotation, reference):
        return branches_one(self.geometry, position, rotation, reference)

    def fk_one(self, q):
        return fk_one(self.geometry, q)

    def compiled_kernel(self, tool: tuple[np.ndarray, np.ndarray] | None = None,
                        screen_tolerance: float | None = None) -> URKernel | None:
        tolerance = self.screen_tolerance if screen_tolerance is None else screen_tolerance
        return ur_kernel(self.geometry, self.chain, tool, tolerance)
