"""Closed-form IK of the UR5 (ur5-riveting.md section 1.2, the ur_kinematics solution), vectorised.

DH (standard): d1 = 0.089159, a2 = -0.425, a3 = -0.39225, d4 = 0.10915, d5 = 0.09465, d6 = 0.0823,
alpha = (pi/2, 0, 0, pi/2, -pi/2, 0). The closed form works on T = base_link -> ee_link, first turned
into the DH frames: T_dh = B T E^T with B = base_link -> link0 = Rz(pi) and E = link6 -> ee_link.
Up to 8 branches = 2 (shoulder q1) x 2 (wrist q5) x 2 (elbow q3):

1. q1 = atan2(-b, a) +- acos(d4 / sqrt(a^2 + b^2)), a = d6 T12 - T13, b = d6 T02 - T03
   (no solution when the wrist-2 centre is within d4 of the base axis);
2. q5 = +-acos((T03 s1 - T13 c1 - d4) / d6), computed as +-atan2(|s5|, c5) with
   |s5| = hypot(T00 s1 - T10 c1, T01 s1 - T11 c1) from the rotation (well conditioned at q5 = 0, pi);
3. q6 = atan2(-sgn(s5) (T01 s1 - T11 c1), sgn(s5) (T00 s1 - T10 c1)); at the wrist singularity
   (|s5| < 1e-8) q6 is free and we keep q6 of the start configuration q0 (ur_kinematics' q6_des);
4. (q2, q3) from the planar two-link problem p13 = a2 (c2, s2) + a3 (c23, s23), and
   q4 = atan2(c23 x04y - s23 x04x, c23 x04x + s23 x04y).

Chain ``ee`` is base_link -> ee_link; chain ``arm`` (base_link -> tcp) composes with the fixed
ee_link -> tcp transform X read from the model: T_ee = T_tcp X^-1 and FK_tcp = FK_ee X.
Angles come out in (-pi, pi]; the framework wraps them into the +-2 pi limits nearest to q0.
"""

from __future__ import annotations

import numpy as np

from wbik.robot import Chain
from wbik.solvers.analytic import ClosedForm
from wbik.solvers.analytic.arm3r import COSINE_TOLERANCE, two_link_planar

D1 = 0.089159
A2 = -0.42500
A3 = -0.39225
D4 = 0.10915
D5 = 0.09465
D6 = 0.0823
WRIST_SINGULARITY = 1e-8
"""|sin q5| below which q6 is free (ur_kinematics' threshold). |sin q5| is read from the rotation, where
rounding moves it by ~1e-16, so the decision has a margin of 1e8 over rounding; keeping q6 of q0 there
costs at most ~1e-8 rad of orientation, far below the screening tolerance (1e-7)."""

BASE_TO_LINK0 = np.diag([-1.0, -1.0, 1.0])
LINK6_TO_EE = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])


def ee_fk(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form FK base_link -> ee_link (ur_kinematics' ``forward``) of joints (..., 6)."""
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
        D6 * c234 * c1 * s5 - A3 * c23 * c1 - A2 * c1 * c2 - D6 * c5 * s1 - D5 * s234 * c1 - D4 * s1,
        D6 * (c1 * c5 + c234 * s1 * s5) + D4 * c1 - A3 * c23 * s1 - A2 * c2 * s1 - D5 * s234 * s1,
        D1 + A3 * s23 + A2 * s2 - D5 * (c23 * c4 - s23 * s4) - D6 * s5 * (c23 * s4 + s23 * c4),
    ), axis=-1)
    return position, rotation


def ee_branches(positions: np.ndarray, rotations: np.ndarray, q6_free: np.ndarray,
                tolerance: float = COSINE_TOLERANCE) -> tuple[np.ndarray, np.ndarray]:
    """All 8 branches for base_link -> ee_link poses: (Q (B, 8, 6), valid (B, 8)).

    Branch order: q1 (+, -) x q5 (+, -) x q3 (+, -). ``q6_free`` (B,) is used at the wrist singularity.
    """
    # into the DH convention: rotation B R E^T, position B p
    rot = np.einsum("ij,bjk,lk->bil", BASE_TO_LINK0, rotations, LINK6_TO_EE)
    pos = positions @ BASE_TO_LINK0.T
    t00, t01, t02 = rot[:, 0, 0], rot[:, 0, 1], rot[:, 0, 2]
    t10, t11, t12 = rot[:, 1, 0], rot[:, 1, 1], rot[:, 1, 2]
    t20, t21, t22 = rot[:, 2, 0], rot[:, 2, 1], rot[:, 2, 2]
    t03, t13, t23 = pos[:, 0], pos[:, 1], pos[:, 2]

    # 1. shoulder: (B, 2)
    a = D6 * t12 - t13
    b = D6 * t02 - t03
    radius = np.sqrt(a * a + b * b)
    ratio = D4 / np.maximum(radius, 1e-300)
    valid1 = ratio <= 1.0 + tolerance
    offset = np.arccos(np.clip(ratio, -1.0, 1.0))
    q1 = np.arctan2(-b, a)[:, None] + np.stack((offset, -offset), axis=1)
    c1, s1 = np.cos(q1), np.sin(q1)

    # 2. wrist 2: (B, 2, 2). cos q5 from the position (ur_kinematics); |sin q5| from the rotation,
    # hypot(T00 s1 - T10 c1, T01 s1 - T11 c1) = |s5| |(c6, s6)|, which rounding moves by ~1e-16, whereas
    # sqrt(1 - cos5^2) turns one ulp of cos5 into 1.5e-8 at q5 = 0 or pi (the singularity decision and
    # q5 itself would then depend on the CPU's rounding).
    numerator = t03[:, None] * s1 - t13[:, None] * c1 - D4
    cos5 = numerator / D6
    # |cos5| <= 1 up to rounding of the terms of the numerator, relative to their size
    scale = (np.abs(t03[:, None] * s1) + np.abs(t13[:, None] * c1) + D4) / D6
    valid5 = np.abs(cos5) <= 1.0 + tolerance * np.maximum(scale, 1.0)
    sine5 = np.hypot(t00[:, None] * s1 - t10[:, None] * c1, t01[:, None] * s1 - t11[:, None] * c1)
    angle5 = np.arctan2(sine5, np.clip(cos5, -1.0, 1.0))
    q5 = np.stack((angle5, -angle5), axis=-1)
    singular = (sine5 < WRIST_SINGULARITY)[..., None]
    c1, s1 = c1[..., None], s1[..., None]
    c5, s5 = np.cos(q5), np.sin(q5)

    # 3. wrist 3: (B, 2, 2)
    def per_target(values):
        return values[:, None, None]

    sign = np.where(s5 >= 0.0, 1.0, -1.0)
    q6 = np.arctan2(-sign * (per_target(t01) * s1 - per_target(t11) * c1),
                    sign * (per_target(t00) * s1 - per_target(t10) * c1))
    q6 = np.where(singular, per_target(q6_free), q6)
    c6, s6 = np.cos(q6), np.sin(q6)

    # 4. planar shoulder-lift / elbow / wrist 1: (B, 2, 2, 2)
    r0 = per_target(t00) * c1 + per_target(t10) * s1
    r1 = per_target(t01) * c1 + per_target(t11) * s1
    r2 = per_target(t02) * c1 + per_target(t12) * s1
    x04x = -s5 * r2 - c5 * (s6 * r1 - c6 * r0)
    x04y = c5 * (per_target(t20) * c6 - per_target(t21) * s6) - per_target(t22) * s5
    p13x = D5 * (s6 * r0 + c6 * r1) - D6 * r2 + per_target(t03) * c1 + per_target(t13) * s1
    p13y = per_target(t23) - D1 - D6 * per_target(t22) + D5 * (per_target(t21) * c6 + per_target(t20) * s6)
    q2, q3, valid3 = two_link_planar(p13x, p13y, A2, A3, tolerance)
    q23 = q2 + q3
    c23, s23 = np.cos(q23), np.sin(q23)
    x04x, x04y = x04x[..., None], x04y[..., None]
    q4 = np.arctan2(c23 * x04y - s23 * x04x, x04x * c23 + x04y * s23)

    shape = q2.shape
    q_all = np.stack((
        np.broadcast_to(q1[:, :, None, None], shape), q2, q3, q4,
        np.broadcast_to(q5[..., None], shape), np.broadcast_to(q6[..., None], shape),
    ), axis=-1)
    valid = valid1[:, None, None, None] & valid5[:, :, None, None] & valid3[..., None]
    valid = np.broadcast_to(valid, shape)
    count = len(positions)
    return q_all.reshape(count, 8, 6), valid.reshape(count, 8)


class UR5EndEffector(ClosedForm):
    """Chain ``ee`` (base_link -> ee_link), full poses, 8 branches."""

    target_kind = "pose"

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return ee_branches(positions, rotations, q0[:, 5])

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return ee_fk(q)


class UR5Tool(UR5EndEffector):
    """Chain ``arm`` (base_link -> tcp): the ``ee`` closed form composed with the fixed ee_link -> tcp."""

    def __init__(self, chain: Chain):
        super().__init__(chain)
        ee_chain = chain.robot.chain("ee")
        tool = ee_chain.fk(ee_chain.nominal).inverse() * chain.fk(chain.nominal)
        self.tool_rotation = tool.rotation.copy()
        self.tool_translation = tool.translation.copy()

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ee_rotations = rotations @ self.tool_rotation.T
        ee_positions = positions - ee_rotations @ self.tool_translation
        return ee_branches(ee_positions, ee_rotations, q0[:, 5])

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        position, rotation = ee_fk(q)
        return position + rotation @ self.tool_translation, rotation @ self.tool_rotation
