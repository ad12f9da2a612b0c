"""Family: UR-type 6R arms (UR3/UR5/UR10 and the like), every branch: DH a = (0, a2, a3, 0, 0, 0), d = (d1,
0, 0, d4, d5, d6), alpha = (pi/2, 0, 0, pi/2, -pi/2, 0). ur_kinematics' closed form (ur5-riveting.md 1.2) on
T_dh = B T E^T (B = Rz(pi), E = link6 -> ee_link), 8 branches, shoulder q1 x wrist q5 x elbow q3:

1. q1 = atan2(-b, a) +- acos(d4 / |(a, b)|), a = d6 T12 - T13, b = d6 T02 - T03;
2. q5 = +-atan2(|s5|, c5), c5 = (T03 s1 - T13 c1 - d4) / d6, |s5| = |(T00 s1 - T10 c1, T01 s1 - T11 c1)|;
3. q6 = atan2(-sgn(s5) (T01 s1 - T11 c1), sgn(s5) (T00 s1 - T10 c1)), the start's q6 where
   |s5| < WRIST_SINGULARITY;
4. (q2, q3) the planar 2R of p13 = a2 (c2, s2) + a3 (c23, s23); q4 = atan2(c23 x04y - s23 x04x,
   c23 x04x + s23 x04y).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import wbik.solvers.analytic.recognition as recognition
from wbik.dh import homogeneous
from wbik.kernels.twins import KERNELS
from wbik.solvers.analytic.closed_form import ClosedForm
from wbik.solvers.analytic.compiled import compiled_form
from wbik.solvers.analytic.recognition import HALF_PI, require, small
from wbik.solvers.analytic.subproblems import (
    COSINE_TOLERANCE,
    WRIST_SINGULARITY,
    clamped_acos,
    clamped_cosine,
    planar_2r_elbow,
)

_ur_kernel = next(k.extension for k in KERNELS if k.name == "ur_type")  # None where not built: the twin

BASE_TO_LINK0 = np.diag([-1.0, -1.0, 1.0])  # Rz(pi) exactly: base_link -> link0 (the DH base)
LINK6_TO_EE = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])  # link6 (DH flange) -> ee_link
CANONICAL = recognition.Canonical((HALF_PI, 0.0, 0.0, HALF_PI, -HALF_PI, 0.0), (0.0,) * 6,
                                  homogeneous(BASE_TO_LINK0), homogeneous(LINK6_TO_EE))
# the form divides by d6 (wrist centre to flange; the tool takes the rest): the tip's own distance when at
# least FLANGE_MINIMUM x the chain's length, else FLANGE_SHARE x the length
FLANGE_SHARE, FLANGE_MINIMUM = 0.1, 0.01


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


def branches_by_joint(geometry: URGeometry, positions: np.ndarray, rotations: np.ndarray, q6_free: np.ndarray,
                      tolerance: float = COSINE_TOLERANCE) -> tuple[np.ndarray, np.ndarray]:
    """All 8 branches for base_link -> ee_link poses, joint-major and batch-last (the cheaper layout): (Q (6,
    8, B), real (8, B)), q1 (+, -) x q5 (+, -) x q3 (+, -); ``q6_free`` (B,) at the wrist singularity."""
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

    # 2. wrist 2: (2, 2, B). cos q5 from the position, |sin q5| from the rotation (sqrt(1 - cos5^2) would
    # turn one ulp of cos5 into 1.5e-8 at q5 = 0 or pi); (cos, sin) of q5 over their length enter only q4
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


class URArm(ClosedForm):
    """A UR-type arm's base_link -> ee_link (full poses, 8 branches); a binding sets ``geometry``."""

    target_kind = "pose"
    geometry: URGeometry

    geometry_fk = staticmethod(fk)

    def __init__(self, chain, geometry: URGeometry | None = None):
        super().__init__(chain, geometry)
        self.kernel = self.compiled(chain, None, self.screen_tolerance)

    def branches_by_joint(self, positions: np.ndarray, rotations: np.ndarray | None,
                          q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return branches_by_joint(self.geometry, positions, rotations, q0[:, 5])

    def compiled(self, chain, alignment, screen_tolerance: float):
        g = self.geometry
        numbers = (g.d1, g.a2, g.a3, g.d4, g.d5, g.d6, COSINE_TOLERANCE, WRIST_SINGULARITY)
        return compiled_form(_ur_kernel, "ur_type", numbers, chain, alignment, screen_tolerance)


def match(lines, kind: str, options: dict) -> recognition.Match:
    """6R, axes 2-4 parallel, 1 meeting 2, 5 meeting 4 and 6, at right angles; full poses."""
    require(kind == "pose", "the family solves full poses only")
    recognition.require_revolute(lines, 6)
    first, sign = recognition.first_frame(lines, CANONICAL.base[:3, :3])
    result = recognition.walk(lines, first, sign, CANONICAL.alphas[:5], (1.0, -1.0, -1.0, 1.0, 1.0))
    for row, pair in ((0, "1 and 2"), (3, "4 and 5"), (4, "5 and 6")):
        require(small(result.a[row], lines), f"axes {pair} miss each other by {abs(result.a[row]):.3g} m")
    length = lines.length
    along, _ = recognition.tip_offset(lines, result.frames[-1])
    d6 = along if abs(along) >= FLANGE_MINIMUM * length else math.copysign(FLANGE_SHARE * length, along)
    recognition.close_walk(result, 0.0, d6, 0.0, 0.0)
    geometry = URGeometry(d1=result.d[0], a2=result.a[1], a3=result.a[2], d4=result.d[3], d5=result.d[4],
                          d6=d6)
    recognition.no_options(options, "ur_type")
    return recognition.Match("ur_type", lambda chain: URArm(chain, geometry),
                             *recognition.aligned(CANONICAL, lines, result),
                             recognition.in_words(geometry, ("d1", "a2", "a3", "d4", "d5", "d6")))


UR_TYPE = recognition.Family("ur_type", match)
