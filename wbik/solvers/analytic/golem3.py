"""Golem-III binding (golem3.md, thesis ch. 4.1 and 4.2.1): both arms, the stacked-planar family
(:mod:`wbik.solvers.analytic.stacked_planar`) with the thesis's geometry.

The left arm is the mirror image of the right one (see wbik.models.golem3): T_left(m0, q) =
M T_right(-m0, q) M with M = diag(1, -1, 1), so a left target is mirrored, solved as a right one,
and m0 negated back.

Position IK (t6 = ``yaw`` fixed, two free parameters): a vectorised grid over the (t1, t2) limit box
gives exact candidates through the family's closed form of t3..t5; a bounded Levenberg-Marquardt on
the position (closed-form Jacobian; the project's one LM policy, :mod:`wbik.solvers.levenberg_marquardt`)
starts from q0 and, where the grid found nothing, from the grid
points nearest to feasibility (robust near the workspace boundary). Positions outside a certified
outer bound of the workspace are rejected at once; other unreachable ones after at most
``lm_iterations`` steps. The framework returns the candidate nearest to q0 among the exact, in-limit
ones (the LM from q0 gives a nearby solution; grid ones are 0.25 rad apart), so "nearest" is among
these candidates, not a global optimum over the solution surface.
"""

from __future__ import annotations

import math

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.models.golem3 import L1, L2, L4, L5, L6, LEFT_JOINTS, RHO, H
from wbik.robot import Chain
from wbik.solvers.analytic import LIMIT_TOLERANCE, ClosedForm
from wbik.solvers.analytic import stacked_planar as family
from wbik.solvers.levenberg_marquardt import JointBounds, LevenbergMarquardt

GOLEM3 = family.StackedPlanarGeometry(l1=L1, l2=L2, l4=L4, l5=L5, l6=L6, h=H, rho=RHO)
"""The thesis's geometry (golem3.md)."""
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
        position, rotation = family.fk(GOLEM3, self._mirror_q(q))
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
        q_all, real = family.pose_branches(GOLEM3, positions, rotations, alpha)
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
        branches = family.pose_branches_one(GOLEM3, (x, y, z), (r11, r12, r13, r21, r22, r23, r31, r32, r33),
                                            rolls, reference)
        if self.mirrored:
            for _, q in branches:
                q[0] = -q[0]
        return branches

    def fk_one(self, q):
        if not self.mirrored:
            return family.fk_one(GOLEM3, q)
        (x, y, z), (r11, r12, r13, r21, r22, r23, r31, r32, r33) = family.fk_one(GOLEM3, [-q[0], *q[1:]])
        return (x, -y, z), (r11, -r12, r13, -r21, r22, -r23, r31, -r32, r33)


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
    lm_stall = 8
    """Trials without |e| falling below 0.99 of its best after which a start is given up: rejected trials
    count, and near the workspace boundary progress is slow (with 2, 2 of 10,000 reachable positions
    were given up; the accept-every-step LM this replaced needed no margin)."""
    damping_factor = 0.1
    chunk = 256

    def __init__(self, chain: Chain, yaw: float = 0.0):
        super().__init__(chain)
        self.yaw = yaw
        self._policy = LevenbergMarquardt(cost_weight=self.damping_factor, floor=1e-9, progress=0.99 ** 2,
                                          stall=self.lm_stall)
        self._bounds = JointBounds(self.right_lower[:5], self.right_upper[:5])

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
        parts = [self._solve_right(positions[i:i + self.chunk], q0[i:i + self.chunk])
                 for i in range(0, len(positions), self.chunk)]
        q_all = np.concatenate([p[0] for p in parts])
        valid = np.concatenate([p[1] for p in parts])
        return self._mirror_q(q_all), valid

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
        reach = L4 + GOLEM3.forearm
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
        q_grid, real = family.position_candidates(GOLEM3, positions, grid1, grid2, self.yaw)
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
        """Levenberg-Marquardt on the position error e = p(q) - p* over t1..t5, from starts (B, S, 6)
        where ``use`` (B, S); returns (joints, converged to 1e-9 m).

        The project's one LM policy (:mod:`wbik.solvers.levenberg_marquardt`): damping
        lambda = damping_factor |e|^2 + mu (quadratic near a regular solution, damped near singular
        ones), a trial accepted when it lowers |e|, joints pushed against a limit frozen for the step.
        A start stops when it converges (|e| <= lm_tolerance), stalls (|e| not below 0.99 of its best
        in ``lm_stall`` trials) or after ``lm_iterations`` trials.
        """
        count, seeds, _ = starts.shape
        q = starts.reshape(-1, 6).copy()
        target = np.repeat(positions, seeds, axis=0)
        policy, bounds = self._policy, self._bounds
        active = np.flatnonzero(use.reshape(-1))
        reached, jacobian = family.position_jacobian(GOLEM3, q[active])
        error = reached - target[active]
        cost = np.einsum("bi,bi->b", error, error)
        damping = np.full(len(active), policy.first_damping)
        best, since = cost.copy(), np.zeros(len(active), dtype=int)
        stalled = np.zeros(len(active), dtype=bool)
        final_cost = np.full(len(q), np.inf)
        final_cost[active] = cost
        for _ in range(self.lm_iterations):
            running = (cost > self.lm_tolerance ** 2) & ~stalled
            if not running.all():
                active, error, jacobian, cost, damping, best, since = (
                    array[running] for array in (active, error, jacobian, cost, damping, best, since))
            if not len(active):
                break
            joints = q[active, :5]
            trial = policy.trial_batch(jacobian, error, cost, damping, joints, bounds)
            trial_reached, trial_jacobian = family.position_jacobian(GOLEM3, trial)
            trial_error = trial_reached - target[active]
            trial_cost = np.einsum("bi,bi->b", trial_error, trial_error)
            accepted = trial_cost < cost
            q[active, :5] = np.where(accepted[:, None], trial, joints)
            error = np.where(accepted[:, None], trial_error, error)
            jacobian = np.where(accepted[:, None, None], trial_jacobian, jacobian)
            cost = np.minimum(trial_cost, cost)
            damping, best, since, stalled = policy.update_batch(accepted, damping, cost, best, since)
            final_cost[active] = cost
        converged = final_cost <= 1e-18  # |e| <= 1e-9 m
        return q.reshape(count, seeds, 6), converged.reshape(count, seeds)
