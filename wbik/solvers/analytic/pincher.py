"""Closed-form IK of the PhantomX Pincher (chain ``arm``: base_link -> noa), pincher.md's inverse.

Geometry (SI: metres, radians; h = 0.137 base height, L = 0.105 both links, l4 = 0.095 wrist to
tool). q1 turns the arm plane about the base z axis. In that plane, with r the signed horizontal
distance along (cos q1, sin q1, 0) and z the height,

    wrist      (r_w, z_w) = L (sin q2 + sin(q2 + q3), cos q2 + cos(q2 + q3)) + (0, h)
    tool point (r, z)     = (r_w, z_w) + l4 (cos psi, sin psi),   psi = pi/2 - (q2 + q3 + q4)

psi is the tool pitch above the horizontal measured in the arm plane (the seed's theta). The noa
frame's z axis is the approach a = cos psi (c1, s1, 0) + sin psi (0, 0, 1), its y axis is
(s1, -c1, 0). Given q1 and psi, the wrist follows and (q2, q3) is a planar two-link problem with
both elbow branches (the wrist may lie behind the base: r_w < 0 is handled exactly, since r_w is
a signed projection); q4 = pi/2 - psi - q2 - q3.

Three target kinds:

- pose (SE3): q1 = atan2(R[0,1], -R[1,1]) from the noa y axis, psi from the approach axis; 2 branches.
  A pose the arm cannot take (y axis not horizontal, or position off the arm plane of that yaw) has
  no branch: success=False, "unreachable".
- position + pitch (the seed's [px, py, pz, theta], :func:`position_pitch_branches`): q1 = atan2(py, px)
  with pitch theta, or q1 + pi with pitch pi - theta (same approach direction, tool rolled by pi);
  2 x 2 branches. :func:`pose_from_position_pitch` turns the seed's 4-vector into the SE3 the arm
  reaches with q1 = atan2(py, px).
- position only (3-vector), one free parameter, the pitch. Rule: take the pitch psi closest to the
  pitch at q0 (psi0 = pi/2 - (q2 + q3 + q4) of q0) for which a branch exists inside the joint limits;
  for each shoulder side (q1 = atan2(py, px) and q1 + pi) the reachable pitches form an exact arc,
  so the first candidate is psi0 projected onto the arc; only on a side where none of its branches
  is inside the limits, a grid of PITCH_GRID pitches across the arc is tried (all targets at once), and the
  grid pitches with such a branch nearest on either side are moved toward psi0 by bisection up to
  the edge of the in-limits set. The
  branches at the chosen pitch (both elbows, both sides when equally close) go to the solver,
  which keeps the one nearest to q0.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.geometry import wrap_to_pi
from wbik.models.pincher import BASE_HEIGHT, LINK, WRIST_TO_TOOL
from wbik.robot import Chain
from wbik.solvers.analytic import LIMIT_TOLERANCE, ClosedForm, wrap_into_limits
from wbik.solvers.analytic.arm3r import AXIS_RELATIVE_TOLERANCE, COSINE_TOLERANCE, two_link_planar

PITCH_GRID = 48
"""Pitches tried across the reachable arc when the nearest pitch has no branch inside the limits."""
PITCH_BISECTIONS = 30
"""Bisection steps from the best grid pitch toward the nearest pitch (arc width / 2^30 resolution)."""
AXIS_TOLERANCE = AXIS_RELATIVE_TOLERANCE * (2.0 * LINK + WRIST_TO_TOOL)
"""Horizontal distance (m) below which a target is on the base axis (q1 of q0 kept), 1e-9 of the arm."""
PITCH_TIE = 1e-9
"""Pitches (rad) this close count as equal: q0's own pitch, and both shoulder sides equally near to it
(the sides' arcs come from atan2(h, r) and atan2(h, -r), equal to pi - each other only up to rounding)."""


def arm_plane_branches(yaw: np.ndarray, signed_reach: np.ndarray, height: np.ndarray,
                       pitch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both elbow branches for a tool point at (signed_reach, height) of the plane of q1 = yaw.

    All inputs broadcast to a common shape S; returns (Q (S, 2, 4), valid (S, 2)).
    """
    yaw, signed_reach, height, pitch = np.broadcast_arrays(yaw, signed_reach, height, pitch)
    wrist_r = signed_reach - WRIST_TO_TOOL * np.cos(pitch)
    wrist_z = height - BASE_HEIGHT - WRIST_TO_TOOL * np.sin(pitch)
    # angles from the vertical: the plane's "x" is z_w and its "y" is r_w
    q2, q3, valid = two_link_planar(wrist_z, wrist_r, LINK, LINK)
    q4 = np.pi / 2 - pitch[..., None] - q2 - q3
    q1 = np.broadcast_to(yaw[..., None], q2.shape)
    return np.stack((q1, q2, q3, q4), axis=-1), np.broadcast_to(valid[..., None], q2.shape)


def position_pitch_branches(positions: np.ndarray, pitches: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The seed's inverse for [px, py, pz] (B, 3) in metres and pitch theta (B,) in radians.

    Returns (Q (B, 4, 4), valid (B, 4)): branches q1 = atan2(py, px) (elbow q3 >= 0, then q3 <= 0),
    then q1 + pi with pitch pi - theta (both elbows). Angles are not wrapped into the limits.
    """
    positions = np.atleast_2d(np.asarray(positions, dtype=float))
    pitches = np.atleast_1d(np.asarray(pitches, dtype=float))
    reach = np.hypot(positions[:, 0], positions[:, 1])
    yaw = np.arctan2(positions[:, 1], positions[:, 0])
    front = arm_plane_branches(yaw, reach, positions[:, 2], pitches)
    back = arm_plane_branches(yaw + np.pi, -reach, positions[:, 2], np.pi - pitches)
    return np.concatenate((front[0], back[0]), axis=1), np.concatenate((front[1], back[1]), axis=1)


def pose_from_position_pitch(position, pitch: float) -> pin.SE3:
    """The noa pose for the seed's target [px, py, pz] (m) and tool pitch theta (rad), q1 = atan2(py, px)."""
    position = np.asarray(position, dtype=float)
    yaw = float(np.arctan2(position[1], position[0]))
    approach = np.array([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
    side = np.array([np.sin(yaw), -np.cos(yaw), 0.0])
    return pin.SE3(np.column_stack((np.cross(side, approach), side, approach)), position)


def tool_fk(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form FK of the noa frame for joints (..., 4): positions (..., 3), rotations (..., 3, 3)."""
    q = np.asarray(q, dtype=float)
    c1, s1 = np.cos(q[..., 0]), np.sin(q[..., 0])
    q23 = q[..., 1] + q[..., 2]
    pitch = np.pi / 2 - q23 - q[..., 3]
    reach = LINK * (np.sin(q[..., 1]) + np.sin(q23)) + WRIST_TO_TOOL * np.cos(pitch)
    height = BASE_HEIGHT + LINK * (np.cos(q[..., 1]) + np.cos(q23)) + WRIST_TO_TOOL * np.sin(pitch)
    position = np.stack((reach * c1, reach * s1, height), axis=-1)
    cp, sp = np.cos(pitch), np.sin(pitch)
    # columns: x = y cross z = (-c1 sp, -s1 sp, cp), y = (s1, -c1, 0), z = approach (c1 cp, s1 cp, sp)
    rotation = np.stack((
        np.stack((-c1 * sp, s1, c1 * cp), axis=-1),
        np.stack((-s1 * sp, -c1, s1 * cp), axis=-1),
        np.stack((cp, np.zeros_like(c1), sp), axis=-1),
    ), axis=-2)
    return position, rotation


class _PincherForm(ClosedForm):
    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return tool_fk(q)


class PincherPose(_PincherForm):
    """Full-pose targets: q1 and the pitch from the rotation, 2 elbow branches (K = 2)."""

    target_kind = "pose"

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        yaw = np.arctan2(rotations[:, 0, 1], -rotations[:, 1, 1])
        c1, s1 = np.cos(yaw), np.sin(yaw)
        approach = rotations[:, :, 2]
        pitch = np.arctan2(approach[:, 2], approach[:, 0] * c1 + approach[:, 1] * s1)
        signed_reach = positions[:, 0] * c1 + positions[:, 1] * s1
        q_all, valid = arm_plane_branches(yaw, signed_reach, positions[:, 2], pitch)
        # the arm can only take poses whose y axis is horizontal and whose position is in the arm plane
        off_plane = np.abs(positions[:, 0] * s1 - positions[:, 1] * c1)
        tolerance = self.screen_tolerance
        consistent = (np.abs(rotations[:, 2, 1]) <= tolerance) & (off_plane <= tolerance)
        return q_all, valid & consistent[:, None]


class PincherPosition(_PincherForm):
    """Position-only targets: the pitch nearest to q0's pitch with a branch inside the limits (K = 4)."""

    target_kind = "position"

    def __init__(self, chain: Chain):
        super().__init__(chain)
        self._revolute = ~chain.is_prismatic

    def _sides(self, positions: np.ndarray, q0: np.ndarray):
        """Per target and side (front, back): yaw, signed reach, arc centre psi_T, half-width, reachable.

        With T = (signed reach, z - h), the wrist T - l4 u(psi) is within 2 L iff
        cos(psi - psi_T) >= (|T|^2 + l4^2 - 4 L^2) / (2 l4 |T|) =: ratio; the arc is empty if ratio > 1.
        """
        reach = np.hypot(positions[:, 0], positions[:, 1])
        yaw = np.where(reach > AXIS_TOLERANCE, np.arctan2(positions[:, 1], positions[:, 0]), q0[:, 0])
        yaws = np.stack((yaw, yaw + np.pi), axis=1)
        reaches = np.stack((reach, -reach), axis=1)
        height = (positions[:, 2] - BASE_HEIGHT)[:, None]
        distance = np.hypot(reaches, height)
        centre = np.arctan2(height, reaches)
        ratio = ((distance ** 2 + WRIST_TO_TOOL ** 2 - 4.0 * LINK ** 2)
                 / (2.0 * WRIST_TO_TOOL * np.maximum(distance, 1e-300)))
        half_width = np.arccos(np.clip(ratio, -1.0, 1.0))
        return yaws, reaches, centre, half_width, ratio <= 1.0 + COSINE_TOLERANCE

    def _candidates(self, yaws, reaches, heights, pitches, q0):
        """Branches at pitches (B, 2, M): Q (B, 2, M, 2, 4), exact (..., 2), inside limits (..., 2)."""
        q_all, exact = arm_plane_branches(yaws[..., None], reaches[..., None], heights[:, None, None],
                                          pitches)
        wrapped, inside = wrap_into_limits(q_all, q0[:, None, None, None, :], self.chain.lower,
                                           self.chain.upper, self._revolute)
        return wrapped, exact, exact & inside

    def _usable(self, yaws, reaches, heights, pitches):
        """Branch exists and some 2 pi shift of it is inside the limits: (B, 2, M, 2), without wrapping.

        (q - lower) mod 2 pi <= upper - lower  <=>  q + 2 pi k is in [lower, upper] for some integer k.
        """
        q_all, exact = arm_plane_branches(yaws[..., None], reaches[..., None], heights[:, None, None],
                                          pitches)
        span = self.chain.upper - self.chain.lower + 2.0 * LIMIT_TOLERANCE  # as wrap_into_limits
        inside = np.all(np.mod(q_all - self.chain.lower + LIMIT_TOLERANCE, 2.0 * np.pi) <= span, axis=-1)
        return exact & inside

    def _search_pitch(self, yaws, reaches, heights, centre, half_width, nearest_offset, pitch0, q0):
        """Where the nearest pitch has no branch inside the limits. Per side and per direction along the
        arc, the grid pitch with such a branch closest to the nearest pitch, moved toward it by bisection
        to the edge of the in-limits set; the better direction wins.

        Pitches are centre + offset, |offset| <= half_width; returns (Q, exact, usable, pitch) per side.
        """
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
