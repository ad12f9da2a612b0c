"""Family: a base yaw carrying a planar arm of parallel horizontal axes, every branch. The yaw turns the arm
plane: r = |(x, y)| at q1 = atan2(y, x), -|(x, y)| at q1 + pi. Yaw + planar 2R: r = l2 c2 + l3 c23, z = l1 +
l2 s2 + l3 s23. Yaw + planar 2R + pitch (the Pincher): wrist (a s2 + b s23, h + a c2 + b c23), tool point =
wrist + t (cos psi, sin psi), psi = pi/2 - (q2 + q3 + q4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import wbik.solvers.analytic.recognition as recognition
from wbik.dh import homogeneous
from wbik.errors import InvalidConfigurationError
from wbik.geometry import wrap_to_pi
from wbik.robot import Chain
from wbik.solvers.analytic.closed_form import LIMIT_TOLERANCE, ClosedForm, wrap_into_limits
from wbik.solvers.analytic.recognition import HALF_PI, require, small
from wbik.solvers.analytic.subproblems import COSINE_TOLERANCE, clamped_acos, planar_2r

AXIS_RELATIVE_TOLERANCE = 1e-9  # x the arm's length: a target this near the base axis keeps q0's q1


def shoulder_sides(positions: np.ndarray, start_yaw: np.ndarray | None = None,
                   axis_tolerance: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(yaws (B, 2), signed reaches (B, 2)): facing the point (atan2(y, x), +r), turned away (+ pi, -r);
    within ``axis_tolerance`` of the base axis, ``start_yaw`` (B,)."""
    reach = np.hypot(positions[:, 0], positions[:, 1])
    yaw = np.arctan2(positions[:, 1], positions[:, 0])
    if start_yaw is not None:
        yaw = np.where(reach > axis_tolerance, yaw, start_yaw)
    return np.stack((yaw, yaw + np.pi), axis=1), np.stack((reach, -reach), axis=1)


def yaw_planar_2r(yaw, along, across, first: float, second: float) -> tuple[np.ndarray, np.ndarray]:
    """Both elbows of the planar 2R in the plane of ``yaw`` (broadcast to S): (Q (S, 2, 3), real (S, 2))."""
    yaw, along, across = np.broadcast_arrays(yaw, along, across)
    angle1, angle2, real = planar_2r(along, across, first, second)
    q_all = np.stack((np.broadcast_to(yaw[..., None], angle1.shape), angle1, angle2), axis=-1)
    return q_all, np.broadcast_to(real[..., None], angle1.shape)


# --- yaw + planar 2R ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Yaw2RGeometry:
    """Base height l1 and links l2, l3 (m): DH a = (0, l2, l3), alpha = (pi/2, 0, 0), d = (l1, 0, 0)."""

    l1: float
    l2: float
    l3: float


class Yaw2RPosition(ClosedForm):
    """Position IK of a yaw + planar 2R arm of ``geometry``: 2 shoulder sides x 2 elbows (K = 4)."""

    target_kind = "position"

    def __init__(self, chain: Chain, geometry: Yaw2RGeometry):
        super().__init__(chain)
        self.geometry = g = geometry
        self.axis_tolerance = AXIS_RELATIVE_TOLERANCE * (abs(g.l2) + abs(g.l3))

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        g = self.geometry
        yaws, reaches = shoulder_sides(positions, q0[:, 0], self.axis_tolerance)
        q_all, real = yaw_planar_2r(yaws, reaches, (positions[:, 2] - g.l1)[:, None], g.l2, g.l3)
        count = len(positions)
        return q_all.reshape(count, 4, 3), real.reshape(count, 4)

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """End point; rotation = the DH frame 3 (Rz(q1) Rx(pi/2) Rz(q2 + q3))."""
        g = self.geometry
        q = np.asarray(q, dtype=float)
        c1, s1 = np.cos(q[..., 0]), np.sin(q[..., 0])
        c2, s2 = np.cos(q[..., 1]), np.sin(q[..., 1])
        c23, s23 = np.cos(q[..., 1] + q[..., 2]), np.sin(q[..., 1] + q[..., 2])
        reach = g.l2 * c2 + g.l3 * c23
        position = np.stack((c1 * reach, s1 * reach, g.l1 + g.l2 * s2 + g.l3 * s23), axis=-1)
        zero = np.zeros_like(c1)
        rotation = np.stack((
            np.stack((c1 * c23, -c1 * s23, s1), axis=-1),
            np.stack((s1 * c23, -s1 * s23, -c1), axis=-1),
            np.stack((s23, c23, zero), axis=-1),
        ), axis=-2)
        return position, rotation


# --- yaw + planar 2R + wrist pitch ------------------------------------------------------------------
@dataclass(frozen=True)
class PitchArmGeometry:
    """Base height h, links a and b, wrist-to-tool length t (m) of a yaw + planar 2R + pitch arm."""

    h: float
    a: float
    b: float
    t: float


def pitch_arm_branches(g: PitchArmGeometry, yaw, signed_reach, height,
                       pitch) -> tuple[np.ndarray, np.ndarray]:
    """Both elbows for a tool point at (signed_reach, height), q1 = yaw, ``pitch``: (Q (S, 2, 4), real)."""
    yaw, signed_reach, height, pitch = np.broadcast_arrays(yaw, signed_reach, height, pitch)
    wrist_r = signed_reach - g.t * np.cos(pitch)
    wrist_z = height - g.h - g.t * np.sin(pitch)
    # angles from the vertical: the planar subproblem's "x" is z_w and its "y" is r_w
    q_arm, real = yaw_planar_2r(yaw, wrist_z, wrist_r, g.a, g.b)
    q4 = np.pi / 2 - pitch[..., None] - q_arm[..., 1] - q_arm[..., 2]
    return np.concatenate((q_arm, q4[..., None]), axis=-1), real


def pitch_arm_fk(g: PitchArmGeometry, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tool frame of joints (..., 4): positions (..., 3), rotations (..., 3, 3)."""
    q = np.asarray(q, dtype=float)
    c1, s1 = np.cos(q[..., 0]), np.sin(q[..., 0])
    q23 = q[..., 1] + q[..., 2]
    pitch = np.pi / 2 - q23 - q[..., 3]
    reach = g.a * np.sin(q[..., 1]) + g.b * np.sin(q23) + g.t * np.cos(pitch)
    height = g.h + g.a * np.cos(q[..., 1]) + g.b * np.cos(q23) + g.t * np.sin(pitch)
    position = np.stack((reach * c1, reach * s1, height), axis=-1)
    cp, sp = np.cos(pitch), np.sin(pitch)
    # columns: x = y cross z = (-c1 sp, -s1 sp, cp), y = (s1, -c1, 0), z = approach (c1 cp, s1 cp, sp)
    rotation = np.stack((
        np.stack((-c1 * sp, s1, c1 * cp), axis=-1),
        np.stack((-s1 * sp, -c1, s1 * cp), axis=-1),
        np.stack((cp, np.zeros_like(c1), sp), axis=-1),
    ), axis=-2)
    return position, rotation


class PitchArmPose(ClosedForm):
    """Full poses: q1 from the tool y axis, the pitch from the approach axis, 2 elbows."""

    target_kind = "pose"
    geometry_fk = staticmethod(pitch_arm_fk)

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        yaw = np.arctan2(rotations[:, 0, 1], -rotations[:, 1, 1])
        c1, s1 = np.cos(yaw), np.sin(yaw)
        approach = rotations[:, :, 2]
        pitch = np.arctan2(approach[:, 2], approach[:, 0] * c1 + approach[:, 1] * s1)
        signed_reach = positions[:, 0] * c1 + positions[:, 1] * s1
        q_all, real = pitch_arm_branches(self.geometry, yaw, signed_reach, positions[:, 2], pitch)
        off_plane = np.abs(positions[:, 0] * s1 - positions[:, 1] * c1)
        tolerance = self.screen_tolerance
        consistent = (np.abs(rotations[:, 2, 1]) <= tolerance) & (off_plane <= tolerance)
        return q_all, real & consistent[:, None]


PITCH_GRID = 48  # pitches tried across the arc when the nearest has no branch inside the limits
PITCH_BISECTIONS = 30  # from the best grid pitch toward the nearest
PITCH_TIE = 1e-9  # rad: pitches this close are equal (q0's, and the two sides' up to rounding)


class PitchArmPosition(ClosedForm):
    """Positions: the pitch nearest q0's with a branch inside the limits. Per shoulder side the reachable
    pitches form an arc: q0's projected onto it, else the nearest usable grid pitch bisected toward it."""

    target_kind = "position"
    geometry_fk = staticmethod(pitch_arm_fk)

    def __init__(self, chain: Chain, geometry: PitchArmGeometry):
        super().__init__(chain, geometry)
        g = geometry
        if g.a != g.b:
            raise InvalidConfigurationError(
                f"the pitch search needs equal links (a wrist annulus without a hole), got {g.a} and {g.b}")
        self._revolute = ~chain.is_prismatic
        self.axis_tolerance = AXIS_RELATIVE_TOLERANCE * (g.a + g.b + g.t)

    def _sides(self, positions: np.ndarray, q0: np.ndarray):
        """Per target and side: yaw, signed reach, arc centre psi_T, half-width, reachable: with T = (reach,
        z - h), cos(psi - psi_T) >= (|T|^2 + t^2 - (a + b)^2) / (2 t |T|) (empty above 1)."""
        g = self.geometry
        yaws, reaches = shoulder_sides(positions, q0[:, 0], self.axis_tolerance)
        height = (positions[:, 2] - g.h)[:, None]
        distance = np.hypot(reaches, height)
        centre = np.arctan2(height, reaches)
        ratio = ((distance ** 2 + g.t ** 2 - (g.a + g.b) ** 2) / (2.0 * g.t * np.maximum(distance, 1e-300)))
        half_width, _ = clamped_acos(ratio)
        return yaws, reaches, centre, half_width, ratio <= 1.0 + COSINE_TOLERANCE  # < -1: every pitch

    def _candidates(self, yaws, reaches, heights, pitches, q0):
        """Branches at pitches (B, 2, M): Q (B, 2, M, 2, 4), exact (..., 2), inside limits (..., 2)."""
        q_all, exact = pitch_arm_branches(self.geometry, yaws[..., None], reaches[..., None],
                                          heights[:, None, None], pitches)
        wrapped, inside = wrap_into_limits(q_all, q0[:, None, None, None, :], self.chain.lower,
                                           self.chain.upper, self._revolute)
        return wrapped, exact, exact & inside

    def _usable(self, yaws, reaches, heights, pitches):
        """A branch with a 2 pi shift in the limits (B, 2, M, 2): (q - lower) mod 2 pi <= upper - lower."""
        q_all, exact = pitch_arm_branches(self.geometry, yaws[..., None], reaches[..., None],
                                          heights[:, None, None], pitches)
        span = self.chain.upper - self.chain.lower + 2.0 * LIMIT_TOLERANCE  # as wrap_into_limits
        inside = np.all(np.mod(q_all - self.chain.lower + LIMIT_TOLERANCE, 2.0 * np.pi) <= span, axis=-1)
        return exact & inside

    def _search_pitch(self, yaws, reaches, heights, centre, half_width, nearest_offset, pitch0, q0):
        """Per side, the usable grid pitch nearest, bisected toward it: (Q, exact, usable, pitch)."""
        grid = half_width[..., None] * np.linspace(-1.0, 1.0, PITCH_GRID)  # offsets (R, 2, M)
        usable_grid = np.any(self._usable(yaws, reaches, heights, centre[..., None] + grid), axis=-1)
        gap = grid - nearest_offset[..., None]
        best_offset = nearest_offset.copy()
        best_score = np.full(nearest_offset.shape, np.inf)
        for direction in (-1.0, 1.0):
            score = np.where(usable_grid & (direction * gap >= 0.0), np.abs(gap), np.inf)
            pick = np.argmin(score, axis=2)
            found = np.isfinite(np.min(score, axis=2))
            good = np.take_along_axis(grid, pick[..., None], axis=2)[..., 0]
            bad = nearest_offset
            for _ in range(PITCH_BISECTIONS):
                middle = 0.5 * (good + bad)
                pitches = (centre + middle)[..., None]
                usable_middle = self._usable(yaws, reaches, heights, pitches)
                inside = np.any(usable_middle[:, :, 0], axis=-1) & found
                good = np.where(inside, middle, good)
                bad = np.where(inside, bad, middle)
            score = np.where(found, np.abs(wrap_to_pi(centre + good - pitch0)), np.inf)
            better = score < best_score
            best_offset = np.where(better, good, best_offset)
            best_score = np.where(better, score, best_score)
        pitch = centre + best_offset
        q_all, exact, usable = self._candidates(yaws, reaches, heights, pitch[..., None], q0)
        return q_all[:, :, 0], exact[:, :, 0], usable[:, :, 0], pitch

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        count = len(positions)
        yaws, reaches, centre, half_width, reachable = self._sides(positions, q0)
        pitch0 = (np.pi / 2 - q0[:, 1:].sum(axis=1))[:, None]
        offset = np.clip(wrap_to_pi(pitch0 - centre), -half_width, half_width)
        nearest = (centre + offset)[..., None]  # (B, 2, 1)
        q_best, exact, usable = self._candidates(yaws, reaches, positions[:, 2], nearest, q0)
        q_best, exact, usable = q_best[:, :, 0].copy(), exact[:, :, 0].copy(), usable[:, :, 0].copy()
        chosen = nearest[:, :, 0].copy()
        # search the sides whose nearest pitch has no branch in the limits, unless the other side already
        # has one at q0's own pitch (nothing can be nearer)
        side_ok = np.any(usable, axis=-1)
        at_pitch0 = side_ok & (np.abs(wrap_to_pi(chosen - pitch0)) <= PITCH_TIE)
        retry_side = ~side_ok & reachable & ~at_pitch0[:, ::-1]
        retry = np.any(retry_side, axis=1)
        if np.any(retry):
            refined = self._search_pitch(yaws[retry], reaches[retry], positions[retry, 2], centre[retry],
                                         half_width[retry], offset[retry], pitch0[retry], q0[retry])
            keep = retry_side[retry]
            for mine, found in zip((q_best, exact, usable, chosen), refined, strict=True):
                mask = keep.reshape(keep.shape + (1,) * (found.ndim - 2))
                mine[retry] = np.where(mask, found, mine[retry])
        # keep the side(s) whose pitch is nearest to q0's pitch among those with a usable branch
        score = np.where(np.any(usable, axis=-1), np.abs(wrap_to_pi(chosen - pitch0)), np.inf)
        best_side = score <= score.min(axis=1, keepdims=True) + PITCH_TIE
        valid = np.where(np.any(usable, axis=(1, 2))[:, None, None], usable & best_side[..., None], exact)
        valid &= reachable[..., None]
        return q_best.reshape(count, 4, 4), valid.reshape(count, 4)


# --- recognition --------------------------------------------------------------------------------------
CANONICAL_2R = recognition.Canonical((HALF_PI, 0.0, 0.0), (0.0, 0.0, 0.0), np.eye(4), np.eye(4))
NOA = homogeneous([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
CANONICAL_PITCH = recognition.Canonical((-HALF_PI, 0.0, 0.0, 0.0), (0.0, -HALF_PI, 0.0, 0.0), np.eye(4), NOA)


def match(lines, kind: str, options: dict) -> recognition.Match:
    """A base axis meeting a planar 2R (3R, positions) or 3R (4R) at a right angle."""
    require(lines.count in (3, 4), f"it has {lines.count} joints, the family 3 (yaw + planar 2R) or 4 "
                                   "(yaw + planar 3R)")
    recognition.require_revolute(lines, lines.count)
    three = lines.count == 3
    require(not three or kind == "position", "a yaw + planar 2R arm is solved for positions only")
    canonical = CANONICAL_2R if three else CANONICAL_PITCH
    first, sign = recognition.first_frame(lines, np.eye(3))
    result = recognition.walk(lines, first, sign, canonical.alphas[:-1], (1.0,) * (lines.count - 1))
    require(small(result.a[0], lines), f"axes 1 and 2 miss each other by {abs(result.a[0]):.3g} m")
    last = result.frames[-1]
    sideways, reach = recognition.tip_offset(lines, last)
    distance = float(np.linalg.norm(reach))
    on_axis = small(distance, lines)
    if kind == "position":
        require(small(sideways, lines), f"the tip is {abs(sideways):.3g} m off the arm's plane")
        require(not on_axis, f"the tip is on the last axis ({distance:.3g} m from it)")
    theta = 0.0 if on_axis else recognition.angle_about(last[:3, 2], last[:3, 0], reach / distance)
    recognition.close_walk(result, theta, 0.0, 0.0 if on_axis else distance, 0.0)
    aligned = recognition.aligned(canonical, lines, result)
    recognition.no_options(options, "yaw_planar")
    if three:
        geometry = Yaw2RGeometry(l1=result.d[0], l2=result.a[1], l3=result.a[2])
        words = "yaw + planar 2R, " + recognition.in_words(geometry, ("l1", "l2", "l3"))
        return recognition.Match("yaw_planar", lambda chain: Yaw2RPosition(chain, geometry), *aligned, words)
    a, b = result.a[1], result.a[2]
    if kind == "position":
        require(small(a - b, lines), f"its links differ ({a:.6g} and {b:.6g} m); the family's position "
                                     "search needs equal links")
        b = a
    geometry = PitchArmGeometry(h=result.d[0], a=a, b=b, t=result.a[3])
    family = PitchArmPose if kind == "pose" else PitchArmPosition
    words = "yaw + planar 2R + pitch, " + recognition.in_words(geometry, ("h", "a", "b", "t"))
    return recognition.Match("yaw_planar", lambda chain: family(chain, geometry), *aligned, words)


YAW_PLANAR = recognition.Family("yaw_planar", match)
