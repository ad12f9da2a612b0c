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

import math

import numpy as np

from wbik.robot import Chain
from wbik.solvers.analytic import TWO_PI, ClosedForm, wrap_one_into_limits
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


def ee_fk_scalar(q) -> tuple[tuple[float, float, float], tuple[float, ...]]:
    """:func:`ee_fk` of one joint vector in plain floats: (position, rotation row by row (9,))."""
    q1, q2, q3, q4, q5, q6 = q
    q23 = q2 + q3
    q234 = q23 + q4
    c1, s1, c2, s2 = math.cos(q1), math.sin(q1), math.cos(q2), math.sin(q2)
    c4, s4, c5, s5 = math.cos(q4), math.sin(q4), math.cos(q5), math.sin(q5)
    c6, s6, c23, s23 = math.cos(q6), math.sin(q6), math.cos(q23), math.sin(q23)
    c234, s234 = math.cos(q234), math.sin(q234)
    side = s1 * s5 + c234 * c1 * c5
    front = c1 * s5 - c234 * c5 * s1
    rotation = (c234 * c1 * s5 - c5 * s1, c6 * side - s234 * c1 * s6, -s6 * side - s234 * c1 * c6,
                c1 * c5 + c234 * s1 * s5, -c6 * front - s234 * s1 * s6, s6 * front - s234 * c6 * s1,
                -s234 * s5, -c234 * s6 - s234 * c5 * c6, s234 * c5 * s6 - c234 * c6)
    position = (D6 * c234 * c1 * s5 - A3 * c23 * c1 - A2 * c1 * c2 - D6 * c5 * s1 - D5 * s234 * c1 - D4 * s1,
                D6 * (c1 * c5 + c234 * s1 * s5) + D4 * c1 - A3 * c23 * s1 - A2 * c2 * s1 - D5 * s234 * s1,
                D1 + A3 * s23 + A2 * s2 - D5 * (c23 * c4 - s23 * s4) - D6 * s5 * (c23 * s4 + s23 * c4))
    return position, rotation


def ee_branches_scalar(position, rotation, q6_free: float, tolerance: float = COSINE_TOLERANCE):
    """:func:`ee_branches` for one pose in plain floats: the 8 (joints, exists) in the same order."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = rotation
    # into the DH convention: B R E^T with B = diag(-1, -1, 1) and E^T's columns -e1, -e2, e0
    t00, t01, t02, t10, t11, t12 = r01, r02, -r00, r11, r12, -r10
    t20, t21, t22 = -r21, -r22, r20
    t03, t13, t23 = -position[0], -position[1], position[2]
    a, b = D6 * t12 - t13, D6 * t02 - t03
    ratio = D4 / max(math.sqrt(a * a + b * b), 1e-300)
    exists1 = ratio <= 1.0 + tolerance
    offset = math.acos(min(1.0, max(-1.0, ratio)))
    shoulder = math.atan2(-b, a)
    branches = []
    for q1 in (shoulder + offset, shoulder - offset):
        c1, s1 = math.cos(q1), math.sin(q1)
        cos5 = (t03 * s1 - t13 * c1 - D4) / D6
        scale = (abs(t03 * s1) + abs(t13 * c1) + D4) / D6
        exists5 = abs(cos5) <= 1.0 + tolerance * max(scale, 1.0)
        u, v = t00 * s1 - t10 * c1, t01 * s1 - t11 * c1
        sine5 = math.hypot(u, v)
        angle5 = math.atan2(sine5, min(1.0, max(-1.0, cos5)))
        singular = sine5 < WRIST_SINGULARITY
        r0, r1, r2 = t00 * c1 + t10 * s1, t01 * c1 + t11 * s1, t02 * c1 + t12 * s1
        for q5 in (angle5, -angle5):
            c5, s5 = math.cos(q5), math.sin(q5)
            sign = 1.0 if s5 >= 0.0 else -1.0
            q6 = q6_free if singular else math.atan2(-sign * v, sign * u)
            c6, s6 = math.cos(q6), math.sin(q6)
            x04x = -s5 * r2 - c5 * (s6 * r1 - c6 * r0)
            x04y = c5 * (t20 * c6 - t21 * s6) - t22 * s5
            px = D5 * (s6 * r0 + c6 * r1) - D6 * r2 + t03 * c1 + t13 * s1
            py = t23 - D1 - D6 * t22 + D5 * (t21 * c6 + t20 * s6)
            cosine = (px * px + py * py - A2 * A2 - A3 * A3) / (2.0 * A2 * A3)
            exists3 = abs(cosine) <= 1.0 + tolerance
            cosine = min(1.0, max(-1.0, cosine))
            sine = math.sqrt(1.0 - cosine * cosine)
            reach = math.atan2(py, px)
            for elbow_sine in (sine, -sine):
                q3 = math.atan2(elbow_sine, cosine)
                q2 = reach - math.atan2(A3 * elbow_sine, A2 + A3 * cosine)
                c23, s23 = math.cos(q2 + q3), math.sin(q2 + q3)
                q4 = math.atan2(c23 * x04y - s23 * x04x, x04x * c23 + x04y * s23)
                branches.append(([q1, q2, q3, q4, q5, q6], exists1 and exists5 and exists3))
    return branches


class UR5EndEffector(ClosedForm):
    """Chain ``ee`` (base_link -> ee_link), full poses, 8 branches."""

    target_kind = "pose"

    def __init__(self, chain: Chain):
        super().__init__(chain)
        self._lower, self._upper = chain.lower.tolist(), chain.upper.tolist()

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return ee_branches(positions, rotations, q0[:, 5])

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return ee_fk(q)

    # -- scalar fast path (the framework's screening, in plain floats) ---------------------------
    def _to_ee(self, position, rotation):
        """The target of the ee_link frame (identity here; the tool chain composes its transform)."""
        return position, rotation

    def _fk_scalar(self, q):
        return ee_fk_scalar(q)

    def solve_one(self, position: np.ndarray, rotation: np.ndarray, q0: np.ndarray):
        """Same answer as the vectorised path (every branch wrapped into the limits nearest q0,
        closed-form FK residual <= screen_tolerance, the one nearest q0) at a fraction of its cost,
        by branch and bound: a branch's distance to q0 is at least the sum of its joints' distances
        to q0 modulo 2 pi (``math.remainder``), so branches are taken in that order and wrapped and
        screened only until no remaining branch can be nearer than the best found.
        Returns (q or None, number of real branches)."""
        target_p = position.tolist()
        target_r = rotation.tolist()
        ee_p, ee_r = self._to_ee(target_p, target_r)
        reference = q0.tolist()
        remainder = math.remainder
        bounded = []
        for joints, exists in ee_branches_scalar(ee_p, ee_r, reference[5]):
            if exists:
                bound = sum(remainder(a - b, TWO_PI) ** 2 for a, b in zip(joints, reference, strict=True))
                bounded.append((bound, joints))
        bounded.sort(key=lambda item: item[0])  # stable: ties keep the branch order
        flat_r = [value for row in target_r for value in row]
        best, best_distance = None, math.inf
        for bound, joints in bounded:
            if bound >= best_distance:
                break
            q = wrap_one_into_limits(joints, reference, self._lower, self._upper)
            if q is None or not all(math.isfinite(value) for value in q):
                continue
            distance = sum((a - b) ** 2 for a, b in zip(q, reference, strict=True))
            if distance >= best_distance:
                continue
            reached_p, reached_r = self._fk_scalar(q)
            trace = sum(a * b for a, b in zip(flat_r, reached_r, strict=True))
            angle = math.acos(min(1.0, max(-1.0, 0.5 * (trace - 1.0))))
            if max(math.dist(reached_p, target_p), angle) <= self.screen_tolerance:
                best, best_distance = q, distance
        return (None if best is None else np.array(best)), len(bounded)


class UR5Tool(UR5EndEffector):
    """Chain ``arm`` (base_link -> tcp): the ``ee`` closed form composed with the fixed ee_link -> tcp."""

    def __init__(self, chain: Chain):
        super().__init__(chain)
        ee_chain = chain.robot.chain("ee")
        tool = ee_chain.fk(ee_chain.nominal).inverse() * chain.fk(chain.nominal)
        self.tool_rotation = tool.rotation.copy()
        self.tool_translation = tool.translation.copy()
        self._tool_r, self._tool_p = self.tool_rotation.tolist(), self.tool_translation.tolist()

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ee_rotations = rotations @ self.tool_rotation.T
        ee_positions = positions - ee_rotations @ self.tool_translation
        return ee_branches(ee_positions, ee_rotations, q0[:, 5])

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        position, rotation = ee_fk(q)
        return position + rotation @ self.tool_translation, rotation @ self.tool_rotation

    def _to_ee(self, position, rotation):
        """T_ee = T_tcp X^-1: R_ee = R R_X^T, p_ee = p - R_ee p_X (plain floats)."""
        tool_r, tool_p = self._tool_r, self._tool_p
        ee_r = [[sum(row[k] * tool_r[j][k] for k in range(3)) for j in range(3)] for row in rotation]
        ee_p = [position[i] - sum(ee_r[i][k] * tool_p[k] for k in range(3)) for i in range(3)]
        return ee_p, ee_r

    def _fk_scalar(self, q):
        """FK_tcp = FK_ee X: p + R p_X, R R_X (plain floats, R row by row)."""
        (px, py, pz), r = ee_fk_scalar(q)
        tool_r, tool_p = self._tool_r, self._tool_p
        rows = (r[0:3], r[3:6], r[6:9])
        position = tuple(p + sum(row[k] * tool_p[k] for k in range(3))
                         for p, row in zip((px, py, pz), rows, strict=True))
        rotation = tuple(sum(row[k] * tool_r[k][j] for k in range(3)) for row in rows for j in range(3))
        return position, rotation
