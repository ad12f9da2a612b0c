"""Closed-form IK of the Golem-III arm (golem3.md, thesis ch. 4.1 and 4.2.1), both arms, vectorised.

Right arm, joints t = (m0, m10..m14), gripper centre in torso_link (h, l1.. from the thesis table):

    l3 = l4 sin(t4+rho) + l5 sin(t4+t5) + l6 cos(t4+t5)
    x  = l1 sin t1 + l2 sin(t1+t2) + l3 cos(gamma)
    y  = -l1 cos t1 - l2 cos(t1+t2) + l3 sin(gamma)
    z  = h - l4 cos(t4+rho) - l5 cos(t4+t5) + l6 sin(t4+t5)
    R  = Rz(gamma) Ry(beta) Rx(alpha),  gamma = t1+t2+t3, beta = -t4-t5, alpha = t6

The left arm is the mirror image (see wbik.models.golem3): T_left(m0, q) = M T_right(-m0, q) M with
M = diag(1, -1, 1), so a left target is mirrored, solved as a right one, and m0 negated back.

Pose IK: alpha is taken with |alpha| <= pi/2 (the other Euler triple has t6 = alpha +- pi, outside the
+-1.5 rad limits), then beta and gamma from R Rx(-alpha) = Rz(gamma) Ry(beta). At gimbal lock
(beta = +-pi/2, gripper axis vertical) t6 is free: q0's t6 and a sweep of t6 values are tried.
z fixes cos(t4+rho) (two signs of the sine), l3 follows, and (x, y) minus the l3 link is a planar 2R
problem for (t1, t2) (elbow-left/right). So at most 2 x 2 = 4 real branches; the
thesis' 2^3 = 8 sign choices come from squaring the t1 equation, and half of them are spurious (its
FK check drops them). Cosines within ``CLAMP_TOLERANCE`` of +-1 are clamped (the thesis' failures
near singular poses) and the FK screening decides.

Position IK: t6 = ``yaw`` (it does not move the gripper centre), t1..t5 for the three coordinates,
two free parameters. For fixed (t1, t2) the rest is closed form: the shoulder point S(t1, t2), then
l3 = +-|p_xy - S| and gamma its direction, then (l3, h - z) is a planar 2R problem of the links l4
and sqrt(l5^2 + l6^2) for (t4, t5). A vectorised grid over the (t1, t2) limit box gives exact
candidates; a bounded Levenberg-Marquardt on the position (closed-form Jacobian) starts from q0 and,
where the grid found nothing, from the grid points nearest to feasibility (robust near the workspace
boundary). Positions outside a certified outer bound of the workspace are rejected at once; other
unreachable ones after at most ``lm_iterations`` steps. The framework returns the candidate nearest
to q0 among the exact, in-limit ones (the LM from q0 gives a nearby solution; grid ones are 0.25 rad
apart), so "nearest" is among these candidates, not a global optimum over the solution surface.
"""

from __future__ import annotations

import math

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.models.golem3 import L1, L2, L4, L5, L6, LEFT_JOINTS, RHO, H
from wbik.robot import Chain
from wbik.solvers.analytic import LIMIT_TOLERANCE, TWO_PI, ClosedForm, wrap_one_into_limits

CLAMP_TOLERANCE = 1e-9
"""Cosines up to this much beyond +-1 (rounding near singular poses) are clamped, not rejected."""
LIMIT_SNAP = LIMIT_TOLERANCE
"""Angles this close (rad, modulo 2 pi) outside a limit are set onto it: FK targets of joints at a
limit come back a few 1e-12 rad outside (the framework's wrap tolerance, the same 1e-9 rad)."""
GIMBAL_LOCK = 1e-9
"""|cos(beta)| below which alpha (t6) is taken from q0: the Euler angles are coupled there. It is read
as hypot(R32, R33), entries of the target rotation that rounding moves by ~1e-16 (never through an
arccos), so the decision has a margin of ~1e7 over rounding; the t6 so chosen costs at most
GIMBAL_LOCK * |its change| of orientation, far below the screening tolerance."""
LOCK_SWEEP = 7
"""Wrist rolls t6 tried (evenly over its range, besides q0's) for a pose at gimbal lock."""
WRIST = float(np.hypot(L5, L6))
"""Length of the elbow-to-gripper-centre vector (l5, l6) in the arm's vertical plane."""
WRIST_ANGLE = float(np.arctan2(L6, L5))
"""Its angle from link l5's direction: l5 sin s + l6 cos s = WRIST sin(s + WRIST_ANGLE)."""


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Angles into [-pi, pi)."""
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


def _snap_to_limits(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Angles within LIMIT_SNAP outside [lower, upper] (modulo 2 pi) set onto the limit."""
    below = _wrap(q - lower)
    above = _wrap(q - upper)
    q = np.where((below < 0.0) & (below > -LIMIT_SNAP), lower, q)
    return np.where((above > 0.0) & (above < LIMIT_SNAP), upper, q)


def _snap_scalar(value: float, low: float, high: float) -> float:
    """_snap_to_limits for one angle (same arithmetic)."""
    below = (value - low + math.pi) % (2.0 * math.pi) - math.pi
    if -LIMIT_SNAP < below < 0.0:
        return low
    above = (value - high + math.pi) % (2.0 * math.pi) - math.pi
    if 0.0 < above < LIMIT_SNAP:
        return high
    return value


def _clamped_cosine(value: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(value clipped to [-1, 1], real mask allowing CLAMP_TOLERANCE of rounding)."""
    return np.clip(value, -1.0, 1.0), np.abs(value) <= 1.0 + CLAMP_TOLERANCE


def rpy_matrix(gamma: np.ndarray, beta: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Rz(gamma) Ry(beta) Rx(alpha), shape (..., 3, 3)."""
    cg, sg, cb, sb, ca, sa = (np.cos(gamma), np.sin(gamma), np.cos(beta), np.sin(beta),
                              np.cos(alpha), np.sin(alpha))
    matrix = np.empty(np.shape(cg) + (3, 3))
    sb_sa, sb_ca = sb * sa, sb * ca
    matrix[..., 0, 0] = cg * cb
    matrix[..., 0, 1] = cg * sb_sa - sg * ca
    matrix[..., 0, 2] = cg * sb_ca + sg * sa
    matrix[..., 1, 0] = sg * cb
    matrix[..., 1, 1] = sg * sb_sa + cg * ca
    matrix[..., 1, 2] = sg * sb_ca - cg * sa
    matrix[..., 2, 0] = -sb
    matrix[..., 2, 1] = cb * sa
    matrix[..., 2, 2] = cb * ca
    return matrix


def right_arm_fk(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form FK of the right arm: q (..., 6) -> positions (..., 3), rotations (..., 3, 3)."""
    q = np.asarray(q, dtype=float)
    t1, t2, t3, t4, t5, t6 = (q[..., i] for i in range(6))
    s = t4 + t5
    t12 = t1 + t2
    gamma = t12 + t3
    l3 = L4 * np.sin(t4 + RHO) + L5 * np.sin(s) + L6 * np.cos(s)
    position = np.empty(q.shape[:-1] + (3,))
    position[..., 0] = L1 * np.sin(t1) + L2 * np.sin(t12) + l3 * np.cos(gamma)
    position[..., 1] = -L1 * np.cos(t1) - L2 * np.cos(t12) + l3 * np.sin(gamma)
    position[..., 2] = H - L4 * np.cos(t4 + RHO) - L5 * np.cos(s) + L6 * np.sin(s)
    return position, rpy_matrix(gamma, -s, t6)


def right_arm_position_jacobian(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(position (N, 3), d position / d (t1..t5) (N, 3, 5)) of the right arm for q (N, >=5).

    t6 does not move the gripper centre. Written for few ufunc calls (it runs inside the LM loop).
    """
    t1, t2, t3, t4, t5 = q[:, 0], q[:, 1], q[:, 2], q[:, 3], q[:, 4]
    angles = np.stack([t1, t1 + t2, t1 + t2 + t3, t4 + t5, t4 + RHO], axis=1)
    sines, cosines = np.sin(angles), np.cos(angles)
    s1, s12, sg, ss, s4 = sines.T
    c1, c12, cg, cs, c4 = cosines.T
    l3 = L4 * s4 + L5 * ss + L6 * cs
    position = np.empty((len(q), 3))
    position[:, 0] = L1 * s1 + L2 * s12 + l3 * cg
    position[:, 1] = -L1 * c1 - L2 * c12 + l3 * sg
    position[:, 2] = H - L4 * c4 - L5 * cs + L6 * ss
    d_l3_t5 = L5 * cs - L6 * ss
    d_l3_t4 = L4 * c4 + d_l3_t5
    jacobian = np.zeros((len(q), 3, 5))
    jacobian[:, 0, 2] = -l3 * sg
    jacobian[:, 1, 2] = l3 * cg
    jacobian[:, 0, 1] = L2 * c12 + jacobian[:, 0, 2]
    jacobian[:, 1, 1] = L2 * s12 + jacobian[:, 1, 2]
    jacobian[:, 0, 0] = L1 * c1 + jacobian[:, 0, 1]
    jacobian[:, 1, 0] = L1 * s1 + jacobian[:, 1, 1]
    jacobian[:, 0, 3] = d_l3_t4 * cg
    jacobian[:, 1, 3] = d_l3_t4 * sg
    jacobian[:, 0, 4] = d_l3_t5 * cg
    jacobian[:, 1, 4] = d_l3_t5 * sg
    jacobian[:, 2, 3] = l3
    jacobian[:, 2, 4] = L5 * ss + L6 * cs
    return position, jacobian


def _planar_2r(u: np.ndarray, v: np.ndarray, first: float, second: float, sign: np.ndarray):
    """Angles (a, b) with first (cos a, sin a) + second (cos b, sin b) = (u, v); elbow sign ``sign``.

    Returns (a, b, real mask); cos(b - a) is clamped within CLAMP_TOLERANCE.
    """
    cosine = (u * u + v * v - first * first - second * second) / (2.0 * first * second)
    cosine, real = _clamped_cosine(cosine)
    relative = sign * np.arccos(cosine)
    a = np.arctan2(v, u) - np.arctan2(second * np.sin(relative), first + second * np.cos(relative))
    return a, a + relative, real


def right_arm_pose_branches(positions: np.ndarray, rotations: np.ndarray,
                            roll_at_lock: np.ndarray | None = None,
                            roll_sweep: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """All real branches of the right arm for poses: Q (B, K, 6), real (B, K), K = 4 (or more, see
    below).

    Branch k = 2 i + j: i picks the sign of sin(t4 + rho) (+, -), j the sign of the planar elbow
    t2 (+, -); alpha = t6 is taken in [-pi/2, pi/2] (see the module docstring). At gimbal lock
    (cos(beta) < GIMBAL_LOCK, e.g. the gripper pointing straight down) only gamma -+ alpha is fixed
    and t6 is free: there ``roll_at_lock`` (B,) (e.g. q0's t6) and every value of ``roll_sweep``
    are tried, giving K = 4 (1 + len(roll_sweep)) when some pose of the batch is locked; the
    orientation error of a chosen t6 is below GIMBAL_LOCK * |its change|.
    """
    alpha = np.arctan2(rotations[:, 2, 1], rotations[:, 2, 2])
    alpha = np.where(np.abs(alpha) > np.pi / 2, alpha - np.copysign(np.pi, alpha), alpha)[:, None]
    real_roll = np.ones_like(alpha, dtype=bool)
    if roll_at_lock is not None:
        locked = np.hypot(rotations[:, 2, 1], rotations[:, 2, 2]) < GIMBAL_LOCK
        if locked.any():
            sweep = np.zeros(0) if roll_sweep is None else np.asarray(roll_sweep, dtype=float)
            alpha = np.concatenate([np.where(locked[:, None], roll_at_lock[:, None], alpha),
                                    np.broadcast_to(sweep, (len(alpha), len(sweep)))], axis=1)
            real_roll = np.concatenate([np.ones((len(alpha), 1), dtype=bool),
                                        np.broadcast_to(locked[:, None], (len(alpha), len(sweep)))], axis=1)
    q_all, real = _pose_branches_at_roll(positions, rotations, alpha)
    real &= real_roll[..., None]
    count = len(positions)
    return q_all.reshape(count, -1, 6), real.reshape(count, -1)


def _pose_branches_at_roll(positions: np.ndarray, rotations: np.ndarray,
                           alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 4 branches for rolls alpha (B, A): Q (B, A, 4, 6), real (B, A, 4)."""
    x, y, z = (positions[:, i, None] for i in range(3))
    r = rotations[:, :, :, None]  # (B, 3, 3, 1) against alpha (B, A)
    ca, sa = np.cos(alpha), np.sin(alpha)
    # R Rx(-alpha) = Rz(gamma) Ry(beta): entries (3,1), (3,3), (1,2), (2,2)
    beta = np.arctan2(-r[:, 2, 0], sa * r[:, 2, 1] + ca * r[:, 2, 2])
    gamma = np.arctan2(-(ca * r[:, 0, 1] - sa * r[:, 0, 2]), ca * r[:, 1, 1] - sa * r[:, 1, 2])
    sb, cb = np.sin(beta), np.cos(beta)
    cos4, real4 = _clamped_cosine((H - z - L5 * cb - L6 * sb) / L4)
    sign4 = np.array([1.0, 1.0, -1.0, -1.0])
    sign2 = np.array([1.0, -1.0, 1.0, -1.0])
    sin4 = sign4 * np.sqrt(1.0 - cos4 * cos4)[..., None]  # (B, A, 4)
    t4 = np.arctan2(sin4, cos4[..., None]) - RHO
    t5 = -beta[..., None] - t4
    l3 = L4 * sin4 + (L6 * cb - L5 * sb)[..., None]
    cg, sg = np.cos(gamma)[..., None], np.sin(gamma)[..., None]
    # (x - l3 cos g, l3 sin g - y) = l1 (sin t1, cos t1) + l2 (sin t12, cos t12): a 2R problem
    t1, t12, real2 = _planar_2r(l3 * sg - y[..., None], x[..., None] - l3 * cg, L1, L2, sign2)
    t2 = t12 - t1
    t3 = gamma[..., None] - t12
    t6 = np.broadcast_to(alpha[..., None], t1.shape)
    return np.stack([t1, t2, t3, t4, t5, t6], axis=-1), real4[..., None] & real2


def _position_candidates(positions: np.ndarray, t1: np.ndarray, t2: np.ndarray, yaw: float):
    """Closed form of t3, t4, t5 for given (t1, t2) (broadcast over (B, G)), 4 branches each.

    Branch k = 2 i + j: i the sign of l3 (+: gripper beyond the t3 axis), j the elbow sign.
    Returns Q (B, G, 4, 6) (t3..t5 in [-pi, pi)) and the real mask (B, G, 4).
    """
    x, y, z = (positions[:, i, None, None] for i in range(3))
    t1, t2 = t1[..., None], t2[..., None]
    dx = x - L1 * np.sin(t1) - L2 * np.sin(t1 + t2)
    dy = y + L1 * np.cos(t1) + L2 * np.cos(t1 + t2)
    sign3 = np.array([1.0, 1.0, -1.0, -1.0])
    sign5 = np.array([1.0, -1.0, 1.0, -1.0])
    l3 = sign3 * np.hypot(dx, dy)
    gamma = np.arctan2(sign3 * dy, sign3 * dx)
    # (h - z, l3) = l4 (cos a, sin a) + WRIST (cos b, sin b), a = t4 + rho, b = t4 + t5 + WRIST_ANGLE
    a, b, real = _planar_2r(np.broadcast_to(H - z, l3.shape), l3, L4, WRIST, sign5)
    t3 = _wrap(gamma - t1 - t2)
    t4 = _wrap(a - RHO)
    t5 = _wrap(b - a - WRIST_ANGLE + RHO)
    shape = t3.shape
    q_all = np.stack([np.broadcast_to(t1, shape), np.broadcast_to(t2, shape), t3, t4, t5,
                      np.full(shape, yaw)], axis=-1)
    return q_all, real


class _Golem3Form(ClosedForm):
    """Shared by both arms: mirrors left-arm targets and joints onto the right arm's closed form."""

    def __init__(self, chain: Chain):
        super().__init__(chain)
        self.mirrored = any(name in chain.joint_names for name in LEFT_JOINTS)
        if chain.nq != 6 or chain.base_frame != "torso_link":
            raise InvalidConfigurationError(
                f"the Golem-III closed form needs a chain from torso_link over (m0, 5 arm joints); "
                f"{chain.name!r} is {chain.base_frame} -> {chain.tip_frame} with {chain.joint_names}")
        lower, upper = chain.lower.copy(), chain.upper.copy()
        if self.mirrored:  # limits in right-arm coordinates: m0 -> -m0
            lower[0], upper[0] = -chain.upper[0], -chain.lower[0]
        self.right_lower, self.right_upper = lower, upper
        self._lower_list, self._upper_list = lower.tolist(), upper.tolist()

    def _mirror_q(self, q: np.ndarray) -> np.ndarray:
        if not self.mirrored:
            return q
        q = np.array(q, dtype=float, copy=True)
        q[..., 0] = -q[..., 0]
        return q

    def _mirror_positions(self, positions: np.ndarray) -> np.ndarray:
        return positions * np.array([1.0, -1.0, 1.0]) if self.mirrored else positions

    def _mirror_rotations(self, rotations: np.ndarray) -> np.ndarray:
        """M R M with M = diag(1, -1, 1)."""
        if not self.mirrored:
            return rotations
        sign = np.array([[1.0, -1.0, 1.0], [-1.0, 1.0, -1.0], [1.0, -1.0, 1.0]])
        return rotations * sign

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        position, rotation = right_arm_fk(self._mirror_q(q))
        return self._mirror_positions(position), self._mirror_rotations(rotation)


class Golem3PoseIK(_Golem3Form):
    """6-DOF pose IK: up to 4 real branches per pose (K = 4), see the module docstring.

    At gimbal lock (gripper x axis vertical) t6 is free: q0's t6 and ``roll_sweep`` are tried.
    """

    target_kind = "pose"

    @property
    def roll_sweep(self) -> np.ndarray:
        return np.linspace(self.right_lower[5], self.right_upper[5], LOCK_SWEEP)

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        roll = np.clip(q0[:, 5], self.right_lower[5], self.right_upper[5])
        q_all, real = right_arm_pose_branches(self._mirror_positions(positions),
                                              self._mirror_rotations(rotations), roll, self.roll_sweep)
        q_all = _snap_to_limits(q_all, self.right_lower, self.right_upper)
        return self._mirror_q(q_all), real


    def solve_one(self, position: np.ndarray, rotation: np.ndarray,
                  q0: np.ndarray) -> tuple[np.ndarray | None, int]:
        """Scalar fast path in plain floats, same screening as the vectorised path of the framework:
        branches wrapped into the limits nearest to q0, closed-form FK residual <= screen_tolerance,
        the one nearest to q0. Returns (q or None, number of usable branches)."""
        x, y, z = (float(v) for v in position)
        (r11, r12, r13), (r21, r22, r23), (r31, r32, r33) = rotation.tolist()
        reference = [float(v) for v in q0]
        if self.mirrored:
            y, r12, r21, r23, r32 = -y, -r12, -r21, -r23, -r32
            reference[0] = -reference[0]
        alpha = math.atan2(r32, r33)
        if abs(alpha) > math.pi / 2:
            alpha -= math.copysign(math.pi, alpha)
        rolls = [alpha]
        if math.hypot(r32, r33) < GIMBAL_LOCK:
            rolls = [min(self._upper_list[5], max(self._lower_list[5], reference[5])),
                     *self.roll_sweep.tolist()]
        target = (x, y, z, r11, r12, r13, r21, r22, r23, r31, r32, r33)
        best, best_distance, usable = None, math.inf, 0
        for alpha in rolls:
            q, distance, count = self._one_roll(alpha, target, reference)
            usable += count
            if q is not None and distance < best_distance:
                best, best_distance = q, distance
        if best is None:
            return None, 0
        if self.mirrored:
            best[0] = -best[0]
        return np.array(best), usable

    def _one_roll(self, alpha: float, target: tuple, reference: list[float]):
        """(best q or None, its squared distance to reference, real branch count) for one wrist roll."""
        x, y, z, r11, r12, r13, r21, r22, r23, r31, r32, r33 = target
        ca, sa = math.cos(alpha), math.sin(alpha)
        beta = math.atan2(-r31, sa * r32 + ca * r33)
        gamma = math.atan2(-(ca * r12 - sa * r13), ca * r22 - sa * r23)
        sb, cb, sg, cg = math.sin(beta), math.cos(beta), math.sin(gamma), math.cos(gamma)
        cos4 = (H - z - L5 * cb - L6 * sb) / L4
        if abs(cos4) > 1.0 + CLAMP_TOLERANCE:
            return None, math.inf, 0
        cos4 = min(1.0, max(-1.0, cos4))
        root4 = math.sqrt(1.0 - cos4 * cos4)
        raw = []
        for sin4 in (root4, -root4):
            t4 = math.atan2(sin4, cos4) - RHO
            l3 = L4 * sin4 + L6 * cb - L5 * sb
            u, v = l3 * sg - y, x - l3 * cg
            cos2 = (u * u + v * v - L1 * L1 - L2 * L2) / (2.0 * L1 * L2)
            if abs(cos2) > 1.0 + CLAMP_TOLERANCE:
                continue
            elbow = math.acos(min(1.0, max(-1.0, cos2)))
            for t2 in (elbow, -elbow):
                t1 = math.atan2(v, u) - math.atan2(L2 * math.sin(t2), L1 + L2 * math.cos(t2))
                raw.append((t1, t2, gamma - t1 - t2, t4, -beta - t4, alpha))
        # branch and bound: a branch's distance to the reference is at least the sum of its angles'
        # distances modulo 2 pi (less the snap onto a limit, <= LIMIT_SNAP per joint), so branches are
        # taken in that order and snapped, wrapped and screened only while one could still be nearer
        remainder, slack = math.remainder, 6.0 * (2.0 * math.pi * LIMIT_SNAP + LIMIT_SNAP ** 2)
        bounded = sorted(((sum(remainder(a - b, TWO_PI) ** 2 for a, b in zip(q, reference, strict=True))
                           - slack, q) for q in raw), key=lambda item: item[0])
        lower, upper = self._lower_list, self._upper_list
        best, best_distance = None, math.inf
        for bound, raw_q in bounded:
            if bound >= best_distance:
                break
            q = [_snap_scalar(v, low, high) for v, low, high in zip(raw_q, lower, upper, strict=True)]
            q = wrap_one_into_limits(q, reference, lower, upper)
            if q is None or _scalar_residual(q, target) > self.screen_tolerance:
                continue
            distance = math.fsum((a - b) ** 2 for a, b in zip(q, reference, strict=True))
            if distance < best_distance:
                best, best_distance = q, distance
        return best, best_distance, len(raw)


def _scalar_residual(q, target) -> float:
    """max(position error, rotation angle) of the right arm's closed-form FK at q against target."""
    t1, t2, t3, t4, t5, t6 = q
    x, y, z, r11, r12, r13, r21, r22, r23, r31, r32, r33 = target
    s, gamma = t4 + t5, t1 + t2 + t3
    ss, cs, sg, cg = math.sin(s), math.cos(s), math.sin(gamma), math.cos(gamma)
    l3 = L4 * math.sin(t4 + RHO) + L5 * ss + L6 * cs
    dx = L1 * math.sin(t1) + L2 * math.sin(t1 + t2) + l3 * cg - x
    dy = -L1 * math.cos(t1) - L2 * math.cos(t1 + t2) + l3 * sg - y
    dz = H - L4 * math.cos(t4 + RHO) - L5 * cs + L6 * ss - z
    sb, cb, sa, ca = -ss, cs, math.sin(t6), math.cos(t6)
    trace = (r11 * cg * cb + r21 * sg * cb - r31 * sb
             + r12 * (cg * sb * sa - sg * ca) + r22 * (sg * sb * sa + cg * ca) + r32 * cb * sa
             + r13 * (cg * sb * ca + sg * sa) + r23 * (sg * sb * ca - cg * sa) + r33 * cb * ca)
    angle = math.acos(min(1.0, max(-1.0, 0.5 * (trace - 1.0))))
    return max(math.sqrt(dx * dx + dy * dy + dz * dz), angle)


class Golem3PositionIK(_Golem3Form):
    """Position-only IK with the wrist roll t6 fixed at ``yaw`` (rad, default 0).

    Returns K = ``keep`` nearest exact grid candidates + one bounded-LM result per start (q0 and the
    ``lm_starts`` grid points nearest to feasibility), all masked by exactness and limits.
    """

    target_kind = "position"
    grid_t1 = 9
    grid_t2 = 13
    keep = 4
    lm_starts = 3
    lm_iterations = 40
    lm_tolerance = 1e-11
    damping_factor = 0.1
    chunk = 256

    def __init__(self, chain: Chain, yaw: float = 0.0):
        super().__init__(chain)
        self.yaw = yaw
        self._last: tuple | None = None

    @property
    def yaw(self) -> float:
        return self._yaw

    @yaw.setter
    def yaw(self, value: float) -> None:
        value = float(value)
        lower, upper = self.chain.lower[5], self.chain.upper[5]
        if not math.isfinite(value) or not lower <= value <= upper:
            raise InvalidConfigurationError(
                f"yaw (wrist roll {self.chain.joint_names[5]}) must be inside [{lower}, {upper}] rad, "
                f"got {value}")
        self._yaw = value

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        positions = self._mirror_positions(np.asarray(positions, dtype=float))
        q0 = self._mirror_q(np.asarray(q0, dtype=float))
        key = (positions.tobytes(), q0.tobytes(), self.yaw)
        last = self._last  # read once: another thread may replace it (the tuple itself is immutable)
        if last is not None and last[0] == key:  # the framework asks again for a reason
            return last[1]
        parts = [self._solve_right(positions[i:i + self.chunk], q0[i:i + self.chunk])
                 for i in range(0, len(positions), self.chunk)]
        q_all = np.concatenate([p[0] for p in parts])
        valid = np.concatenate([p[1] for p in parts])
        result = self._mirror_q(q_all), valid
        self._last = (key, result)
        return result

    # -- right arm -------------------------------------------------------------------------------
    def _limit_excess(self, q: np.ndarray) -> np.ndarray:
        """Sum over t3..t5 of how far (rad) each is outside its limits."""
        lower, upper = self.right_lower[2:5], self.right_upper[2:5]
        return np.sum(np.maximum(lower - q[..., 2:5], 0.0) + np.maximum(q[..., 2:5] - upper, 0.0),
                      axis=-1)

    @staticmethod
    def outside_outer_bound(positions: np.ndarray) -> np.ndarray:
        """Certainly unreachable (B,): the gripper centre is within l4 + |(l5, l6)| of the t3-t4 axes'
        crossing (height h, within l1 + l2 of the chest axis), whatever the limits."""
        vertical = np.abs(H - positions[:, 2])
        reach = L4 + WRIST
        horizontal = np.sqrt(np.maximum(reach * reach - vertical * vertical, 0.0)) + L1 + L2
        return (vertical > reach * (1.0 + 1e-9)) | (
            np.hypot(positions[:, 0], positions[:, 1]) > horizontal * (1.0 + 1e-9))

    def _solve_right(self, positions: np.ndarray, q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Candidates (B, keep + 1 + lm_starts, 6) and their validity for right-arm positions."""
        count = len(positions)
        lower, upper = self.right_lower, self.right_upper
        grid1, grid2 = np.meshgrid(np.linspace(lower[0], upper[0], self.grid_t1),
                                   np.linspace(lower[1], upper[1], self.grid_t2), indexing="ij")
        grid1 = np.broadcast_to(grid1.reshape(1, -1), (count, grid1.size))
        grid2 = np.broadcast_to(grid2.reshape(1, -1), (count, grid2.size))
        q_grid, real = _position_candidates(positions, grid1, grid2, self.yaw)
        q_grid = q_grid.reshape(count, -1, 6)
        real = real.reshape(count, -1)
        excess = self._limit_excess(q_grid)
        feasible = real & (excess <= LIMIT_TOLERANCE)  # the framework clips that much onto the limit
        distance = np.where(feasible, np.linalg.norm(q_grid - q0[:, None, :], axis=-1), np.inf)
        nearest = np.argsort(distance, axis=1)[:, :self.keep]
        q_keep = np.take_along_axis(q_grid, nearest[..., None], axis=1)
        valid_keep = np.take_along_axis(feasible, nearest, axis=1)
        # refinement starts: q0 always; where the grid found nothing, also the grid points closest to
        # feasible (least limit excess, real branches first), clipped into the limits
        badness = excess + np.where(real, 0.0, 10.0)
        closest = np.argsort(badness, axis=1)[:, :self.lm_starts]
        starts = np.concatenate([q0[:, None, :], np.take_along_axis(q_grid, closest[..., None], axis=1)],
                                axis=1)
        starts = np.clip(starts, lower, upper)
        starts[..., 5] = self.yaw
        hopeless = self.outside_outer_bound(positions)
        use = np.ones(starts.shape[:2], dtype=bool)
        use[:, 1:] = ~feasible.any(axis=1)[:, None]
        use &= ~hopeless[:, None]
        q_lm, converged = self._refine(positions, starts, use)
        return (np.concatenate([q_keep, q_lm], axis=1),
                np.concatenate([valid_keep & ~hopeless[:, None], converged], axis=1))

    def _refine(self, positions: np.ndarray, starts: np.ndarray,
                use: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bounded Levenberg-Marquardt on the position, minimum-norm steps, from starts (B, S, 6)
        where ``use`` (B, S); returns (joints, converged).

        Step: dq = J^T (J J^T + lambda I)^-1 r, lambda = damping_factor |r|^2 + 1e-9 (quadratic near a regular
        solution, damped near singular ones); joints pushed against a limit are frozen for the step.
        A start stops when it converges, stalls (less than 1 % progress twice in a row) or after
        ``lm_iterations``.
        """
        count, seeds, _ = starts.shape
        q = starts.reshape(-1, 6).copy()
        target = np.repeat(positions, seeds, axis=0)
        lower, upper = self.right_lower[:5], self.right_upper[:5]
        active = np.flatnonzero(use.reshape(-1))
        error = np.full(len(q), np.inf)
        stalls = np.zeros(len(q), dtype=int)
        for _ in range(self.lm_iterations + 1):
            reached, jacobian = right_arm_position_jacobian(q[active])
            residual = target[active] - reached
            norm = np.linalg.norm(residual, axis=-1)
            stalls[active] = np.where(norm > 0.99 * error[active], stalls[active] + 1, 0)
            error[active] = norm
            running = (norm > self.lm_tolerance) & (stalls[active] < 2)
            if _ == self.lm_iterations:
                break
            active, residual, jacobian, norm = (active[running], residual[running], jacobian[running],
                                                norm[running])
            if not len(active):
                break
            joints = q[active, :5]
            damping = (self.damping_factor * norm * norm + 1e-9)[:, None, None] * np.eye(3)
            for _pass in range(2):
                gram = jacobian @ np.swapaxes(jacobian, 1, 2) + damping
                step = np.einsum("bji,bj->bi", jacobian, np.linalg.solve(gram, residual[..., None])[..., 0])
                blocked = ((joints <= lower) & (step < 0.0)) | ((joints >= upper) & (step > 0.0))
                if not blocked.any():
                    break
                jacobian = np.where(blocked[:, None, :], 0.0, jacobian)
            q[active, :5] = np.clip(joints + step, lower, upper)
        converged = error <= 1e-9
        return q.reshape(count, seeds, 6), converged.reshape(count, seeds)
