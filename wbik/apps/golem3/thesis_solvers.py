"""The Golem-III thesis's own solvers, written literally: ``thesis_literal`` and ``thesis_sweep``.

Source: the thesis (seed ``000_48c793128bbb812d``, ch. 4-5) and its code reference [19], read for facts only;
reproductions kept beside our closed form (:mod:`wbik.robot_packages.golem3.closed_form`).

``thesis_literal``: the 6-DOF closed form of the right arm (eq. 3.6, 4.2-4.37 as in :func:`thesis_branches`,
with golem3.md's correction t4 -> t4 + rho) for a target (x, y, z) and the thesis's angles (yaw alpha = t6,
pitch beta = -t4 - t5, roll gamma = t1 + t2 + t3), 8 branches in the code's order. As in the thesis: a
negative square-root argument discards the branch (no clamp), angles are wrapped into (-pi, pi], a branch
outside the joint limits is discarded, and a survivor must match the input by closed-form FK within
THESIS_CHECK_TOLERANCE on x, y, z, yaw and pitch (the code's check); the survivor nearest q0 (Euclidean) is
returned, then judged by the shared 1e-6 check. No rounding of inputs or outputs (the code's 6 decimals are
not in the text). A target rotation R is read as Rz(gamma) Ry(beta) Rx(alpha), |alpha| <= pi/2.

``thesis_sweep``: the position-only search (ch. 4.2.1): yaw fixed, roll (outer loop) and pitch (inner)
each 0, +0.01, -0.01, ..., +2.99, -2.99 rad (magnitudes accumulated by repeated addition, as the code),
at most 599 x 599 closed-form evaluations; the first (roll, pitch) with a solution wins. Blocks of sweep
points are evaluated at once, the first point in sweep order taken, so answer and iteration count are
those of the one-at-a-time loop. Left arm: targets mirrored, solved as right-arm ones, m0 negated back."""

from __future__ import annotations

import math
import time

import numpy as np

from wbik.errors import InvalidSettingError, UnsupportedError
from wbik.geometry import wrap_to_pi
from wbik.robot_packages.golem3.closed_form import mirror_positions, mirror_rotations, right_arm_coordinates
from wbik.robot_packages.golem3.model import L1, L2, L4, L5, L6, RHO, H
from wbik.solvers.base import Solver
from wbik.solvers.check import evaluate
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate
from wbik.targets import Target, as_target

THESIS_CHECK_TOLERANCE = 1e-3  # the code's acceptance: |FK - input| on x, y, z (m), yaw and pitch (rad)
SWEEP_STEP = 0.01  # rad between two swept magnitudes (the code's increment)
SWEEP_MAGNITUDES = 300  # per axis: 0, 0.01, ..., 2.99, each but 0 with both signs
SWEEP_POINTS = (2 * SWEEP_MAGNITUDES - 1) ** 2  # closed-form evaluations of the whole sweep: 599 x 599
GOLEM3_CHAINS = ("right_arm", "left_arm")
NO_BRANCH, NEGATIVE_SQRT, OUTSIDE_LIMITS, CHECK_FAILED, ACCEPTED = range(5)  # a branch's fate, in order


def thesis_branches(x, y, z, yaw, pitch, roll, lower, upper):
    """The thesis's 8 branches for right-arm targets (broadcast arrays of shape S) and (6,) joint limits:
    (Q (S..., 8, 6), fate (S..., 8): the first test a branch fails or ACCEPTED, the three square-root
    arguments (S..., 8, 3), NaN after an earlier failed root). Branch k = 4 j1 + 2 j2 + j3: the sign of
    sin(t4 + rho) (+, -), the quadratic's root (-, +), the sign of sin t1 (+, -)."""
    x, y, z, yaw, pitch, roll = (v[..., None] for v in np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (x, y, z, yaw, pitch, roll))))
    j1 = np.array([1.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0, -1.0])
    j2 = np.array([-1.0, -1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0])
    j3 = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0])
    t6 = wrap_to_pi(yaw) + 0.0 * j1
    c4 = (H - z - L5 * np.cos(-pitch) + L6 * np.sin(-pitch)) / L4 + 0.0 * j1
    arg4 = 1.0 - c4 ** 2
    real = arg4 >= 0.0
    s4 = j1 * np.sqrt(np.where(real, arg4, 0.0))
    t4 = wrap_to_pi(np.arctan2(s4, c4) - RHO)
    t5 = wrap_to_pi(-pitch - t4)
    l3 = L4 * np.sin(t4 + RHO) + L5 * np.sin(t4 + t5) + L6 * np.cos(t4 + t5)
    xp = x - l3 * np.cos(roll)
    yp = -y + l3 * np.sin(roll)
    a = 2.0 * yp * L1
    b = 2.0 * xp * L1
    c = xp ** 2 + yp ** 2 + L1 ** 2 - L2 ** 2
    discriminant = (2.0 * a * c) ** 2 - 4.0 * (a ** 2 + b ** 2) * (c ** 2 - b ** 2)
    discriminant = np.where(real, discriminant, np.nan)
    real_1 = real & (discriminant >= 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        c1 = (2.0 * a * c + j2 * np.sqrt(np.where(real_1, discriminant, 0.0))) / (2.0 * (a ** 2 + b ** 2))
    arg1 = np.where(real_1, 1.0 - c1 ** 2, np.nan)
    real_2 = real_1 & (arg1 >= 0.0)
    s1 = j3 * np.sqrt(np.where(real_2, arg1, 0.0))
    c1 = np.where(real_2, c1, 1.0)
    t1 = np.arctan2(s1, c1)
    t2 = wrap_to_pi(np.arctan2((xp - L1 * s1) / L2, (yp - L1 * c1) / L2) - t1)
    t3 = wrap_to_pi(roll - t1 - t2)
    q = np.stack([t1, t2, t3, t4, t5, t6], axis=-1)
    inside = np.all((q >= lower) & (q <= upper), axis=-1)
    # the thesis's check: closed-form FK (eq. 3.3-3.9) against the input, x y z yaw pitch
    s = t4 + t5
    gamma = wrap_to_pi(t1 + t2 + t3)
    l3_fk = L4 * np.sin(t4 + RHO) + L5 * np.sin(s) + L6 * np.cos(s)
    x_fk = L1 * np.sin(t1) + L2 * np.sin(t1 + t2) + l3_fk * np.cos(gamma)
    y_fk = -L1 * np.cos(t1) - L2 * np.cos(t1 + t2) + l3_fk * np.sin(gamma)
    z_fk = H - L4 * np.cos(t4 + RHO) - L5 * np.cos(s) + L6 * np.sin(s)
    differences = (x_fk - x, y_fk - y, z_fk - z, t6 - yaw, wrap_to_pi(-s) - pitch)
    matches = np.all(np.abs(np.stack(differences, axis=-1)) <= THESIS_CHECK_TOLERANCE, axis=-1)
    fate = np.where(~real_2, NEGATIVE_SQRT,
                    np.where(~inside, OUTSIDE_LIMITS, np.where(matches, ACCEPTED, CHECK_FAILED)))
    arguments = np.stack([arg4, discriminant, arg1], axis=-1)
    return q, fate, arguments


def thesis_angles(rotation: np.ndarray) -> tuple[float, float, float]:
    """(yaw alpha, pitch beta, roll gamma) of R = Rz(gamma) Ry(beta) Rx(alpha), |alpha| <= pi/2."""
    r = np.asarray(rotation, dtype=float)
    alpha = math.atan2(r[2, 1], r[2, 2])
    if abs(alpha) > math.pi / 2:
        alpha -= math.copysign(math.pi, alpha)
    ca, sa = math.cos(alpha), math.sin(alpha)
    # R Rx(-alpha) = Rz(gamma) Ry(beta): entries (3,1), (3,3), (1,2), (2,2)
    beta = math.atan2(-r[2, 0], sa * r[2, 1] + ca * r[2, 2])
    gamma = math.atan2(-(ca * r[0, 1] - sa * r[0, 2]), ca * r[1, 1] - sa * r[1, 2])
    return alpha, beta, gamma


def sweep_order(magnitudes: int = SWEEP_MAGNITUDES, step: float = SWEEP_STEP) -> np.ndarray:
    """The thesis's sweep, (N, 2) rows (roll, pitch) in visiting order: per axis 0, +m1, -m1, +m2, -m2, ...
    with m_k = m_(k-1) + step (accumulated, as the code), roll the outer loop."""
    values, magnitude = [0.0], 0.0
    for _ in range(magnitudes - 1):
        magnitude = magnitude + step
        values += [magnitude, -magnitude]
    axis = np.array(values)
    roll, pitch = np.meshgrid(axis, axis, indexing="ij")
    return np.stack([roll.ravel(), pitch.ravel()], axis=1)


class _ThesisGolem3(Solver):
    """Shared: applies to the Golem-III arm chains only; mirroring of the left arm."""

    def __init__(self, robot, chain=None, **options):
        super().__init__(robot, chain, **options)
        if self.robot.name != "golem3" or self.chain.name not in GOLEM3_CHAINS:
            raise UnsupportedError(
                f"method {self.name!r} is the Golem-III thesis's solver: it applies to golem3's "
                f"{' and '.join(GOLEM3_CHAINS)} only, not {self.robot.name}.{self.chain.name}")
        self.mirrored, self.right_lower, self.right_upper = right_arm_coordinates(self.chain)
        self.flip = np.r_[-1.0 if self.mirrored else 1.0, np.ones(5)]  # m0 negated between the arms

    def _right_target(self, target: Target) -> tuple[np.ndarray, np.ndarray | None]:
        """Position and rotation in right-arm coordinates (M p, M R M, M = diag(1, -1, 1))."""
        if not self.mirrored:
            return target.position, target.rotation
        rotation = None if target.rotation is None else mirror_rotations(target.rotation)
        return mirror_positions(target.position), rotation

    def _pick(self, q: np.ndarray, accepted: np.ndarray, q0: np.ndarray) -> np.ndarray:
        """The accepted branch nearest q0 (right-arm q (K, 6), mask (K,)), in the chain's joints."""
        candidates = q[accepted]
        return candidates[np.argmin(np.linalg.norm(candidates - self.flip * q0, axis=1))] * self.flip


def _fate_counts(fate: np.ndarray) -> dict[str, int]:
    """How many branches met each end short of acceptance."""
    ends = {"negative_sqrt": NEGATIVE_SQRT, "outside_limits": OUTSIDE_LIMITS, "check_failed": CHECK_FAILED}
    return {key: int(np.sum(fate == code)) for key, code in ends.items()}


class ThesisLiteralSolver(_ThesisGolem3):
    """``thesis_literal``: the thesis's 6-DOF closed form as written (see the module docstring)."""

    name = "thesis_literal"
    budgeted = False
    supports_position_only = False

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        position, rotation = self._right_target(target)
        yaw, pitch, roll = thesis_angles(rotation)
        q, fate, arguments = thesis_branches(*position, yaw, pitch, roll, self.right_lower, self.right_upper)
        accepted = fate == ACCEPTED
        negative = arguments[arguments < 0.0]  # the square-root arguments that discarded a branch
        extra = {"branches": int(accepted.sum()), **_fate_counts(fate),
                 "min_negative_sqrt_argument": float(np.min(negative)) if negative.size else None}
        if not accepted.any():
            reason = (f"no solution (thesis closed form): of 8 branches {extra['negative_sqrt']} had a "
                      f"negative square-root argument, {extra['outside_limits']} a joint outside the "
                      f"limits, {extra['check_failed']} failed the thesis's FK check")
            if extra["min_negative_sqrt_argument"] is not None:
                reason += f" (most negative argument {extra['min_negative_sqrt_argument']:.3g})"
            return Candidate(None, 1, reason, extra)
        return Candidate(self._pick(q, accepted, q0), 1, extra=extra)

    def solve_all(self, target):
        """Every branch the thesis accepts that also passes the shared FK check."""
        target = as_target(target)
        self._check_target_kind(target)
        position, rotation = self._right_target(target)
        q, fate, _ = thesis_branches(*position, *thesis_angles(rotation), self.right_lower, self.right_upper)
        results = [evaluate(self.chain, target, Candidate(branch, 1), self.tolerances, 0.0, self.name)
                   for branch in q[fate == ACCEPTED] * self.flip]
        return [result for result in results if result.success]


class ThesisSweepSolver(_ThesisGolem3):
    """``thesis_sweep``: the thesis's position-only search. Options: ``yaw`` (rad, the fixed wrist roll t6);
    ``max_iterations`` (sweep points, default the whole sweep); ``timeout_s`` (checked between blocks)."""

    name = "thesis_sweep"
    supports_pose = False
    iteration_cost_s = 3e-6
    """The budget's unit: one sweep point (8 branches) in a block of ``first_block`` to ``max_block`` points
    (docs/measurements.md, thesis_sweep)."""
    first_block = 599  # the roll = 0 row; later blocks double up to max_block
    max_block = 1198

    def __init__(self, robot, chain=None, *, yaw: float = 0.0, max_iterations: int | None = None, **options):
        super().__init__(robot, chain, **options)
        lower, upper = self.chain.lower[5], self.chain.upper[5]
        if isinstance(yaw, bool) or not isinstance(yaw, (int, float, np.floating, np.integer)) \
                or not math.isfinite(float(yaw)) or not lower <= float(yaw) <= upper:
            raise InvalidSettingError(
                f"yaw (the fixed wrist roll {self.chain.joint_names[5]}) must be a number inside "
                f"[{lower}, {upper}] rad, got {yaw!r}")
        self.yaw = float(yaw)
        if max_iterations is None and self.timeout_s is None:
            self.max_iterations = SWEEP_POINTS
        else:
            self.max_iterations = min(self._iteration_budget(max_iterations), SWEEP_POINTS)
        self.order = sweep_order()

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        (x, y, z), _ = self._right_target(target)
        start, block = 0, self.first_block
        extra = {"negative_sqrt": 0, "outside_limits": 0, "check_failed": 0}
        while start < self.max_iterations:
            stop = min(start + block, self.max_iterations)
            roll, pitch = self.order[start:stop, 0], self.order[start:stop, 1]
            q, fate, _ = thesis_branches(x, y, z, self.yaw, pitch, roll, self.right_lower, self.right_upper)
            found = np.flatnonzero((fate == ACCEPTED).any(axis=1))
            visited = fate[:found[0] + 1] if found.size else fate
            extra = {key: extra[key] + count for key, count in _fate_counts(visited).items()}
            if found.size:
                point = found[0]
                extra.update(roll=float(roll[point]), pitch=float(pitch[point]), yaw=self.yaw)
                q_best = self._pick(q[point], fate[point] == ACCEPTED, q0)
                return Candidate(q_best, start + point + 1, extra=extra)
            start, block = stop, min(2 * block, self.max_block)
            if start < self.max_iterations and time.perf_counter() > deadline:
                return Candidate(None, start, f"timeout after {start} of {SWEEP_POINTS} sweep orientations "
                                              "without a thesis closed-form solution", extra)
        if self.max_iterations < SWEEP_POINTS:
            reason = (f"iteration budget spent: none of the first {self.max_iterations} of {SWEEP_POINTS} "
                      f"sweep orientations has a thesis closed-form solution")
        else:
            reason = (f"no solution in the whole sweep ({SWEEP_POINTS} roll-pitch orientations, "
                      f"yaw {self.yaw:g})")
        return Candidate(None, self.max_iterations, reason, extra)


IK_METHODS = (
    IKMethod("thesis_literal", ThesisLiteralSolver,
             "the Golem-III thesis's 6-DOF closed form as written (no clamp), Golem-III arms only"),
    IKMethod("thesis_sweep", ThesisSweepSolver,
             "the Golem-III thesis's position-only roll/pitch sweep of its closed form (Golem-III)"),
)
