"""Golem-III binding (golem3.md, thesis ch. 4.1 and 4.2.1): both arms, the stacked-planar family
(:mod:`wbik.solvers.analytic.stacked_planar`) with the thesis's geometry.

The left arm is the mirror image of the right one (see wbik.robot_packages.golem3.model): T_left(m0, q) =
M T_right(-m0, q) M with M = diag(1, -1, 1), so a left target is mirrored, solved as a right one,
and m0 negated back.

Position IK (t6 = ``yaw`` fixed, two free parameters): the family's search over (t1, t2)
(:class:`~wbik.solvers.analytic.stacked_planar.PositionSearch`: an exact grid and a bounded
Levenberg-Marquardt refinement), in right-arm coordinates.
"""

from __future__ import annotations

import math

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.robot import Chain
from wbik.robot_packages.golem3.model import LEFT_JOINTS
from wbik.robot_packages.golem3.model import Golem3Facts
from wbik.solvers.analytic import stacked_planar as family
from wbik.solvers.analytic.closed_form import ClosedForm

LOCK_SWEEP = 7
"""Wrist rolls t6 tried (evenly over its range, besides q0's) for a pose at gimbal lock."""
_MIRROR_P = np.array([1.0, -1.0, 1.0])
_MIRROR_R = np.outer(_MIRROR_P, _MIRROR_P)  # M R M, entry-wise


def right_arm_coordinates(chain: Chain) -> tuple[bool, np.ndarray, np.ndarray]:
    """(mirrored, lower, upper): whether ``chain`` is the left arm, solved as the mirror image of the
    right one, and its limits in right-arm coordinates (m0 -> -m0 on the left)."""
    mirrored = any(name in chain.joint_names for name in LEFT_JOINTS)
    lower, upper = chain.lower.copy(), chain.upper.copy()
    if mirrored:
        lower[0], upper[0] = -chain.upper[0], -chain.lower[0]
    return mirrored, lower, upper


def mirror_positions(positions: np.ndarray) -> np.ndarray:
    """M p with M = diag(1, -1, 1) (positions (..., 3))."""
    return positions * _MIRROR_P


def mirror_rotations(rotations: np.ndarray) -> np.ndarray:
    """M R M with M = diag(1, -1, 1) (rotations (..., 3, 3))."""
    return rotations * _MIRROR_R


class _Golem3Form(ClosedForm):
    """Shared by both arms: mirrors left-arm targets and joints onto the right arm's closed form."""

    def __init__(self, chain: Chain):
        super().__init__(chain)
        if chain.nq != 6 or chain.base_frame != "torso_link":
            raise InvalidConfigurationError(
                f"the Golem-III closed form needs a chain from torso_link over (m0, 5 arm joints); "
                f"{chain.name!r} is {chain.base_frame} -> {chain.tip_frame} with {chain.joint_names}")
        self.mirrored, self.right_lower, self.right_upper = right_arm_coordinates(chain)
        self.geometry = chain.robot.require_facts(Golem3Facts, "the Golem-III closed form").arm

    def _mirror_q(self, q: np.ndarray) -> np.ndarray:
        if not self.mirrored:
            return q
        q = np.array(q, dtype=float, copy=True)
        q[..., 0] = -q[..., 0]
        return q

    def _mirror_positions(self, positions: np.ndarray) -> np.ndarray:
        return mirror_positions(positions) if self.mirrored else positions

    def _mirror_rotations(self, rotations: np.ndarray) -> np.ndarray:
        return mirror_rotations(rotations) if self.mirrored else rotations

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        position, rotation = family.fk(self.geometry, self._mirror_q(q))
        return self._mirror_positions(position), self._mirror_rotations(rotation)


class Golem3PoseIK(_Golem3Form):
    """6-DOF pose IK: up to 4 real branches per pose (K = 4); at gimbal lock (gripper x axis vertical)
    t6 is free and q0's t6 and LOCK_SWEEP rolls over its range are tried (K = 4 (1 + LOCK_SWEEP) when
    some pose of the batch is locked)."""

    target_kind = "pose"
    has_scalar_path = True

    def __init__(self, chain: Chain):
        super().__init__(chain)
        self.roll_sweep = np.linspace(self.right_lower[5], self.right_upper[5], LOCK_SWEEP)
        self._sweep_list = self.roll_sweep.tolist()
        self._roll_limits = (float(self.right_lower[5]), float(self.right_upper[5]))

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        positions, rotations = self._mirror_positions(positions), self._mirror_rotations(rotations)
        alpha = family.wrist_roll(rotations)[:, None]
        real_roll = np.ones(alpha.shape, dtype=bool)
        locked = family.gimbal_locked(rotations)
        if locked.any():
            roll = np.clip(q0[:, 5], *self._roll_limits)
            count, sweep = len(alpha), len(self.roll_sweep)
            alpha = np.concatenate([np.where(locked[:, None], roll[:, None], alpha),
                                    np.broadcast_to(self.roll_sweep, (count, sweep))], axis=1)
            real_roll = np.concatenate([real_roll, np.broadcast_to(locked[:, None], (count, sweep))], axis=1)
        q_all, real = family.pose_branches(self.geometry, positions, rotations, alpha)
        real = real & real_roll[..., None]
        count = len(positions)
        return self._mirror_q(q_all.reshape(count, -1, 6)), real.reshape(count, -1)

    def branches_one(self, position, rotation, reference):
        x, y, z = position
        r11, r12, r13, r21, r22, r23, r31, r32, r33 = rotation
        reference = list(reference)
        if self.mirrored:
            y, r12, r21, r23, r32 = -y, -r12, -r21, -r23, -r32
            reference[0] = -reference[0]
        alpha = math.atan2(r32, r33)
        if abs(alpha) > math.pi / 2:
            alpha -= math.copysign(math.pi, alpha)
        rolls = [alpha]
        if math.hypot(r32, r33) < family.GIMBAL_LOCK:
            low, high = self._roll_limits
            rolls = [min(high, max(low, reference[5])), *self._sweep_list]
        branches = family.pose_branches_one(self.geometry, (x, y, z),
                                            (r11, r12, r13, r21, r22, r23, r31, r32, r33), rolls, reference)
        if self.mirrored:
            for _, q in branches:
                q[0] = -q[0]
        return branches

    def fk_one(self, q):
        if not self.mirrored:
            return family.fk_one(self.geometry, q)
        (x, y, z), (r11, r12, r13, r21, r22, r23, r31, r32, r33) = family.fk_one(self.geometry,
                                                                                 [-q[0], *q[1:]])
        return (x, -y, z), (r11, -r12, r13, -r21, r22, -r23, r31, -r32, r33)


class Golem3PositionIK(_Golem3Form):
    """Position-only IK with the wrist roll t6 fixed at ``yaw`` (rad, default 0): the family's
    (t1, t2) search (:class:`~wbik.solvers.analytic.stacked_planar.PositionSearch`) in right-arm
    coordinates, over batches of at most ``chunk`` positions."""

    target_kind = "position"
    chunk = 256

    def __init__(self, chain: Chain, yaw: float = 0.0):
        super().__init__(chain)
        self.yaw = yaw
        self.search = family.PositionSearch(self.geometry, self.right_lower, self.right_upper)

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
        parts = [self.search.candidates(positions[i:i + self.chunk], q0[i:i + self.chunk], self.yaw)
                 for i in range(0, len(positions), self.chunk)]
        q_all = np.concatenate([p[0] for p in parts])
        valid = np.concatenate([p[1] for p in parts])
        return self._mirror_q(q_all), valid
