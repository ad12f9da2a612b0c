"""Closed-form position IK of the 3-DOF articulated arm of seed 001 (chain ``arm``: base_link -> tip).

arm3r.md (standard DH a = (0, l2, l3), alpha = (pi/2, 0, 0), d = (l1, 0, 0)):

    x = c1 r,  y = s1 r,  z = l1 + l2 s2 + l3 s23,   with r = l2 c2 + l3 c23 (signed reach).

So q1 = atan2(y, x) with r = +sqrt(x^2 + y^2), or q1 + pi with r = -sqrt(x^2 + y^2) (shoulder
branches), and (q2, q3) solve the planar two-link problem (r, z - l1) (elbow branches): up to
4 solutions. On the base axis (x = y = 0) q1 is free; we keep q1 of the start configuration q0.

:func:`two_link_planar` is the planar two-link solution shared by the other closed forms here.
"""

from __future__ import annotations

import numpy as np

from wbik.robot import Chain
from wbik.solvers.analytic import ClosedForm

COSINE_TOLERANCE = 1e-9
"""How far a cosine may leave [-1, 1] (rounding) before the branch counts as non-existent."""

AXIS_RELATIVE_TOLERANCE = 1e-9
"""Horizontal distance below which a target counts as on the base axis (q1 free), relative to the arm's
length: FK of a pose on the axis leaves ~1e-16 m of rounding there, and keeping q0's q1 for a target
r off the axis misses it by at most 2 r (1e-9 of the arm), far below the screening tolerance."""


def two_link_planar(x: np.ndarray, y: np.ndarray, first: float | np.ndarray, second: float | np.ndarray,
                    tolerance: float = COSINE_TOLERANCE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Both elbow branches of a planar two-link arm reaching (x, y).

    The arm is x = a c1 + b c12, y = a s1 + b s12 (a = ``first``, b = ``second``, lengths may be
    negative as in the UR DH table). Law of cosines: c2 = (x^2 + y^2 - a^2 - b^2) / (2 a b),
    q2 = +-acos(c2), q1 = atan2(y, x) - atan2(b s2, a + b c2).

    Returns (angle1 (..., 2), angle2 (..., 2), valid (...)): the last axis is the elbow branch
    (q2 >= 0 first); ``valid`` is False where |c2| > 1 + tolerance (target out of reach).
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    cosine = (x * x + y * y - first * first - second * second) / (2.0 * first * second)
    valid = np.abs(cosine) <= 1.0 + tolerance
    cosine = np.clip(cosine, -1.0, 1.0)
    sine = np.sqrt(1.0 - cosine * cosine)
    sines = np.stack((sine, -sine), axis=-1)
    cosines = cosine[..., None]
    angle2 = np.arctan2(sines, cosines)
    angle1 = (np.arctan2(y, x)[..., None]
              - np.arctan2(second * sines, first + second * cosines))
    return angle1, angle2, valid


class Arm3RPosition(ClosedForm):
    """Position-only closed form of arm3r: 2 shoulder x 2 elbow branches (K = 4)."""

    target_kind = "position"

    def __init__(self, chain: Chain):
        super().__init__(chain)
        self.l1, self.l2, self.l3 = (float(v) for v in chain.robot.info["lengths"])
        self.axis_tolerance = AXIS_RELATIVE_TOLERANCE * (abs(self.l2) + abs(self.l3))

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x, y, z = positions[:, 0], positions[:, 1], positions[:, 2]
        reach = np.hypot(x, y)
        yaw = np.where(reach > self.axis_tolerance, np.arctan2(y, x), q0[:, 0])
        q_all, valid_all = [], []
        for shoulder_yaw, signed_reach in ((yaw, reach), (yaw + np.pi, -reach)):
            q2, q3, valid = two_link_planar(signed_reach, z - self.l1, self.l2, self.l3)
            q1 = np.broadcast_to(shoulder_yaw[:, None], q2.shape)
            q_all.append(np.stack((q1, q2, q3), axis=-1))
            valid_all.append(np.broadcast_to(valid[:, None], q2.shape))
        return np.concatenate(q_all, axis=1), np.concatenate(valid_all, axis=1)

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """End point from arm3r.md's equations; rotation = the DH frame 3 (Rz(q1) Rx(pi/2) Rz(q2+q3))."""
        q = np.asarray(q, dtype=float)
        c1, s1 = np.cos(q[..., 0]), np.sin(q[..., 0])
        c2, s2 = np.cos(q[..., 1]), np.sin(q[..., 1])
        c23, s23 = np.cos(q[..., 1] + q[..., 2]), np.sin(q[..., 1] + q[..., 2])
        reach = self.l2 * c2 + self.l3 * c23
        position = np.stack((c1 * reach, s1 * reach, self.l1 + self.l2 * s2 + self.l3 * s23), axis=-1)
        zero = np.zeros_like(c1)
        rotation = np.stack((
            np.stack((c1 * c23, -c1 * s23, s1), axis=-1),
            np.stack((s1 * c23, -s1 * s23, -c1), axis=-1),
            np.stack((s23, c23, zero), axis=-1),
        ), axis=-2)
        return position, rotation
