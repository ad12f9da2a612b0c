"""Family: a horizontal planar 3R carrying a vertical planar 2R and a roll (the Golem-III arm), every branch.

Links l1, l2 in the horizontal plane at height h, l4 (at angle rho) and the forearm offset (l5, l6) in the
vertical one; the gripper centre and rotation (golem3.md, thesis ch. 4.1)::

    l3 = l4 sin(t4+rho) + l5 sin(t4+t5) + l6 cos(t4+t5)
    x  = l1 sin t1 + l2 sin(t1+t2) + l3 cos(gamma)
    y  = -l1 cos t1 - l2 cos(t1+t2) + l3 sin(gamma)
    z  = h - l4 cos(t4+rho) - l5 cos(t4+t5) + l6 sin(t4+t5)
    R  = Rz(gamma) Ry(beta) Rx(alpha),  gamma = t1+t2+t3, beta = -t4-t5, alpha = t6

Pose IK: alpha = t6 from R Rx(-alpha) = Rz(gamma) Ry(beta), then beta, gamma; z fixes cos(t4 + rho), l3
follows, and (x, y) minus the l3 link is the planar 2R of (t1, t2): 4 branches per roll. Position IK: t6 =
``yaw``, :class:`PositionSearch` over (t1, t2), the rest in closed form (:func:`position_candidates`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import wbik.solvers.analytic.recognition as recognition
from wbik.dh import rot_z
from wbik.errors import InvalidOptionError
from wbik.geometry import wrap_to_pi
from wbik.kernels.twins import KERNELS
from wbik.solvers.analytic.aligned import FamilyChain
from wbik.solvers.analytic.closed_form import LIMIT_TOLERANCE, ClosedForm
from wbik.solvers.analytic.compiled import compiled_form
from wbik.solvers.analytic.recognition import HALF_PI, require, small
from wbik.solvers.analytic.subproblems import COSINE_TOLERANCE, clamped_cosine, planar_2r
from wbik.solvers.levenberg_marquardt import JointBounds, LevenbergMarquardt, batch_cost, keep_better

_stacked_kernel = next(k.extension for k in KERNELS if k.name == "stacked_planar")  # None: not built

GIMBAL_LOCK = 1e-9  # |cos(beta)| = hypot(R32, R33) below which t6 is free


@dataclass(frozen=True)
class StackedPlanarGeometry:
    """Lengths (m) and the angle rho (rad) of the arm (the module docstring's)."""

    l1: float
    l2: float
    l4: float
    l5: float
    l6: float
    h: float
    rho: float

    @property
    def forearm(self) -> float:
        """|(l5, l6)|: the elbow to the gripper centre in the arm's vertical plane."""
        return math.hypot(self.l5, self.l6)

    @property
    def forearm_angle(self) -> float:
        """Its angle from link l5's direction: l5 sin s + l6 cos s = forearm sin(s + forearm_angle)."""
        return math.atan2(self.l6, self.l5)


def fk(g: StackedPlanarGeometry, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form FK of joints (..., 6): positions (..., 3), rotations Rz(gamma) Ry(beta) Rx(t6)."""
    q = np.asarray(q, dtype=float)
    t1, t2, t3, t4, t5, t6 = (q[..., i] for i in range(6))
    s = t4 + t5
    t12 = t1 + t2
    gamma = t12 + t3
    ss, cs, sg, cg, sa, ca = np.sin(s), np.cos(s), np.sin(gamma), np.cos(gamma), np.sin(t6), np.cos(t6)
    l3 = g.l4 * np.sin(t4 + g.rho) + g.l5 * ss + g.l6 * cs
    sb = -ss  # beta = -s
    position = np.stack((g.l1 * np.sin(t1) + g.l2 * np.sin(t12) + l3 * cg,
                         -g.l1 * np.cos(t1) - g.l2 * np.cos(t12) + l3 * sg,
                         g.h - g.l4 * np.cos(t4 + g.rho) - g.l5 * cs + g.l6 * ss), axis=-1)
    rows = ((cg * cs, cg * sb * sa - sg * ca, cg * sb * ca + sg * sa),
            (sg * cs, sg * sb * sa + cg * ca, sg * sb * ca - cg * sa),
            (-sb, cs * sa, cs * ca))
    return position, np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def position_jacobian(g: StackedPlanarGeometry, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(position (N, 3), d position / d (t1..t5) (N, 3, 5)) for q (N, >=5), in few ufunc calls."""
    t1, t2, t3, t4, t5 = q[:, 0], q[:, 1], q[:, 2], q[:, 3], q[:, 4]
    angles = np.stack([t1, t1 + t2, t1 + t2 + t3, t4 + t5, t4 + g.rho], axis=1)
    sines, cosines = np.sin(angles), np.cos(angles)
    s1, s12, sg, ss, s4 = sines.T
    c1, c12, cg, cs, c4 = cosines.T
    l3 = g.l4 * s4 + g.l5 * ss + g.l6 * cs
    position = np.empty((len(q), 3))
    position[:, 0] = g.l1 * s1 + g.l2 * s12 + l3 * cg
    position[:, 1] = -g.l1 * c1 - g.l2 * c12 + l3 * sg
    position[:, 2] = g.h - g.l4 * c4 - g.l5 * cs + g.l6 * ss
    d_l3_t5 = g.l5 * cs - g.l6 * ss
    d_l3_t4 = g.l4 * c4 + d_l3_t5
    jacobian = np.zeros((len(q), 3, 5))
    jacobian[:, 0, 2] = -l3 * sg
    jacobian[:, 1, 2] = l3 * cg
    jacobian[:, 0, 1] = g.l2 * c12 + jacobian[:, 0, 2]
    jacobian[:, 1, 1] = g.l2 * s12 + jacobian[:, 1, 2]
    jacobian[:, 0, 0] = g.l1 * c1 + jacobian[:, 0, 1]
    jacobian[:, 1, 0] = g.l1 * s1 + jacobian[:, 1, 1]
    jacobian[:, 0, 3] = d_l3_t4 * cg
    jacobian[:, 1, 3] = d_l3_t4 * sg
    jacobian[:, 0, 4] = d_l3_t5 * cg
    jacobian[:, 1, 4] = d_l3_t5 * sg
    jacobian[:, 2, 3] = l3
    jacobian[:, 2, 4] = g.l5 * ss + g.l6 * cs
    return position, jacobian


def wrist_roll(rotations: np.ndarray) -> np.ndarray:
    """alpha = t6 of R = Rz Ry Rx(alpha) with |alpha| <= pi/2, (B,)."""
    alpha = np.arctan2(rotations[:, 2, 1], rotations[:, 2, 2])
    return np.where(np.abs(alpha) > np.pi / 2, alpha - np.copysign(np.pi, alpha), alpha)


def gimbal_locked(rotations: np.ndarray) -> np.ndarray:
    """(B,) targets whose gripper axis is vertical (cos(beta) < GIMBAL_LOCK): t6 is free there."""
    return np.hypot(rotations[:, 2, 1], rotations[:, 2, 2]) < GIMBAL_LOCK


def pose_branches(g: StackedPlanarGeometry, positions: np.ndarray, rotations: np.ndarray,
                  alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 4 branches for rolls alpha (B, A): Q (B, A, 4, 6), real (B, A, 4); branch 2 i + j: i the sign
    of sin(t4 + rho), j the elbow t2."""
    x, y, z = (positions[:, i, None] for i in range(3))
    r = rotations[:, :, :, None]  # (B, 3, 3, 1) against alpha (B, A)
    ca, sa = np.cos(alpha), np.sin(alpha)
    # R Rx(-alpha) = Rz(gamma) Ry(beta): entries (3,1), (3,3), (1,2), (2,2)
    beta = np.arctan2(-r[:, 2, 0], sa * r[:, 2, 1] + ca * r[:, 2, 2])
    gamma = np.arctan2(-(ca * r[:, 0, 1] - sa * r[:, 0, 2]), ca * r[:, 1, 1] - sa * r[:, 1, 2])
    sb, cb = np.sin(beta), np.cos(beta)
    cos4, real4 = clamped_cosine((g.h - z - g.l5 * cb - g.l6 * sb) / g.l4)
    sin4 = np.sqrt(1.0 - cos4 * cos4)[..., None] * np.array([1.0, -1.0])  # (B, A, 2)
    t4 = np.arctan2(sin4, cos4[..., None]) - g.rho
    l3 = g.l4 * sin4 + (g.l6 * cb - g.l5 * sb)[..., None]
    cg, sg = np.cos(gamma)[..., None], np.sin(gamma)[..., None]
    # (l3 sin g - y, x - l3 cos g) = l1 (cos t1, sin t1) + l2 (cos t12, sin t12): planar 2R
    t1, t2, real2 = planar_2r(l3 * sg - y[..., None], x[..., None] - l3 * cg, g.l1, g.l2)
    shape = t1.shape  # (B, A, 2, 2)
    t3 = gamma[..., None, None] - (t1 + t2)
    t4 = np.broadcast_to(t4[..., None], shape)
    t5 = -beta[..., None, None] - t4
    t6 = np.broadcast_to(alpha[..., None, None], shape)
    q_all = np.stack([t1, t2, t3, t4, t5, t6], axis=-1).reshape(shape[:2] + (4, 6))
    real = np.broadcast_to(real4[..., None, None] & real2[..., None], shape).reshape(shape[:2] + (4,))
    return q_all, real


def position_candidates(g: StackedPlanarGeometry, positions: np.ndarray, t1: np.ndarray, t2: np.ndarray,
                        yaw: float) -> tuple[np.ndarray, np.ndarray]:
    """t3, t4, t5 for given (t1, t2) (broadcast over (B, G)): Q (B, G, 4, 6) (t3..t5 in (-pi, pi]), real
    (B, G, 4); branch 2 i + j: i the sign of l3 = +-|p_xy - S(t1, t2)|, j the elbow of l4 and |(l5, l6)|."""
    x, y, z = (positions[:, i, None, None] for i in range(3))
    t1, t2 = t1[..., None], t2[..., None]
    dx = x - g.l1 * np.sin(t1) - g.l2 * np.sin(t1 + t2)
    dy = y + g.l1 * np.cos(t1) + g.l2 * np.cos(t1 + t2)
    sign3 = np.array([1.0, -1.0])
    l3 = sign3 * np.hypot(dx, dy)  # (B, G, 2)
    gamma = np.arctan2(sign3 * dy, sign3 * dx)
    # (h - z, l3) = l4 (cos a, sin a) + forearm (cos(a + b), sin(a + b)), a = t4 + rho,
    # a + b = t4 + t5 + forearm_angle
    a, b, real = planar_2r(np.broadcast_to(g.h - z, l3.shape), l3, g.l4, g.forearm)
    shape = a.shape  # (B, G, 2, 2)
    t3 = np.broadcast_to(wrap_to_pi(gamma - t1 - t2)[..., None], shape)
    t4 = wrap_to_pi(a - g.rho)
    t5 = wrap_to_pi(b - g.forearm_angle + g.rho)
    q_all = np.stack([np.broadcast_to(t1[..., None], shape), np.broadcast_to(t2[..., None], shape), t3, t4,
                      t5, np.full(shape, yaw)], axis=-1)
    real = np.broadcast_to(real[..., None], shape)
    return q_all.reshape(shape[:2] + (4, 6)), real.reshape(shape[:2] + (4,))


class PositionSearch:
    """Position IK with t6 fixed: a grid over (t1, t2) of exact candidates (the ``keep`` nearest q0) and LM
    from q0 and, where the grid found nothing, the ``lm_starts`` grid points nearest feasibility."""

    grid_t1 = 9
    grid_t2 = 13
    keep = 4
    lm_starts = 3
    lm_iterations = 300
    """LM trials per start at most. Near the workspace's boundary the error can fall slowly yet steadily:
    with 40, 6 reachable positions of 100,000 random ones stopped short (which ones depended on the
    machine's last bits); they needed 50-150 trials, and none of 80,000 failed with 200
    (``tests/test_analytic_golem3.py``). A start that stops improving still ends at ``lm_stall``."""
    lm_tolerance = 1e-11
    lm_stall = 8  # trials without |e| below 0.99 of its best (slow near the workspace boundary)
    damping_factor = 0.1

    def __init__(self, geometry: StackedPlanarGeometry, lower: np.ndarray, upper: np.ndarray):
        """``lower``, ``upper``: the limits (6,) of t1..t6."""
        self.geometry = geometry
        self.lower, self.upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
        self._policy = LevenbergMarquardt(cost_weight=self.damping_factor, floor=1e-9, progress=0.99 ** 2,
                                          stall=self.lm_stall)
        self._bounds = JointBounds(self.lower[:5], self.upper[:5])

    def _limit_excess(self, q: np.ndarray) -> np.ndarray:
        """Sum over t3..t5 of how far (rad) each is outside its limits."""
        lower, upper = self.lower[2:5], self.upper[2:5]
        return np.sum(np.maximum(lower - q[..., 2:5], 0.0) + np.maximum(q[..., 2:5] - upper, 0.0),
                      axis=-1)

    def outside_outer_bound(self, positions: np.ndarray) -> np.ndarray:
        """Certainly unreachable (B,): farther than l4 + |(l5, l6)| from where the t3-t4 axes can cross."""
        g = self.geometry
        vertical = np.abs(g.h - positions[:, 2])
        reach = g.l4 + g.forearm
        horizontal = np.sqrt(np.maximum(reach * reach - vertical * vertical, 0.0)) + g.l1 + g.l2
        return (vertical > reach * (1.0 + 1e-9)) | (
            np.hypot(positions[:, 0], positions[:, 1]) > horizontal * (1.0 + 1e-9))

    def candidates(self, positions: np.ndarray, q0: np.ndarray, yaw: float) -> tuple[np.ndarray, np.ndarray]:
        """Candidates (B, keep + 1 + lm_starts, 6) with t6 = ``yaw`` and their validity."""
        count = len(positions)
        lower, upper = self.lower, self.upper
        grid1, grid2 = np.meshgrid(np.linspace(lower[0], upper[0], self.grid_t1),
                                   np.linspace(lower[1], upper[1], self.grid_t2), indexing="ij")
        grid1 = np.broadcast_to(grid1.reshape(1, -1), (count, grid1.size))
        grid2 = np.broadcast_to(grid2.reshape(1, -1), (count, grid2.size))
        q_grid, real = position_candidates(self.geometry, positions, grid1, grid2, yaw)
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
        starts[..., 5] = yaw
        hopeless = self.outside_outer_bound(positions)
        use = np.ones(starts.shape[:2], dtype=bool)
        use[:, 1:] = ~feasible.any(axis=1)[:, None]
        use &= ~hopeless[:, None]
        q_lm, converged = self._refine(positions, starts, use)
        return (np.concatenate([q_keep, q_lm], axis=1),
                np.concatenate([valid_keep & ~hopeless[:, None], converged], axis=1))

    def _refine(self, positions: np.ndarray, starts: np.ndarray,
                use: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """LM on e = p(q) - p* over t1..t5 from starts (B, S, 6) where ``use``: (joints, converged)."""
        count, seeds, _ = starts.shape
        q = starts.reshape(-1, 6).copy()
        target = np.repeat(positions, seeds, axis=0)
        policy, bounds = self._policy, self._bounds
        active = np.flatnonzero(use.reshape(-1))
        reached, jacobian = position_jacobian(self.geometry, q[active])
        error = reached - target[active]
        cost, damping, best, since = policy.start_batch(error)
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
            trial_reached, trial_jacobian = position_jacobian(self.geometry, trial)
            trial_error = trial_reached - target[active]
            accepted, cost, (q[active, :5], error, jacobian) = keep_better(
                batch_cost(trial_error), cost, (trial, joints), (trial_error, error),
                (trial_jacobian, jacobian))
            damping, best, since, stalled = policy.update_batch(accepted, damping, cost, best, since)
            final_cost[active] = cost
        converged = final_cost <= 1e-18  # |e| <= 1e-9 m
        return q.reshape(count, seeds, 6), converged.reshape(count, seeds)


# --- the family's forms on any chain of its structure ------------------------------------------------
GIMBAL_LOCK_SWEEP = 7  # rolls t6 over its range (besides q0's) at gimbal lock


def _finite_limits(chain) -> tuple[np.ndarray, np.ndarray]:
    """The chain's limits, an infinite bound replaced by -pi or pi."""
    lower = np.where(np.isfinite(chain.lower), chain.lower, -math.pi)
    upper = np.where(np.isfinite(chain.upper), chain.upper, math.pi)
    return lower, upper


class StackedPlanarPose(ClosedForm):
    """Full poses: ``triples`` rolls (alpha, alpha + pi), 4 branches each; a sweep of t6 at gimbal lock."""

    target_kind = "pose"
    geometry_fk = staticmethod(fk)

    def __init__(self, chain, geometry: StackedPlanarGeometry, triples: int = 2):
        super().__init__(chain, geometry)
        self.triples = triples
        lower, upper = _finite_limits(chain)
        self.roll_limits = (float(lower[5]), float(upper[5]))
        self.roll_sweep = np.linspace(lower[5], upper[5], GIMBAL_LOCK_SWEEP)
        self.kernel = self.compiled(chain, None, self.screen_tolerance)

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        alpha = wrist_roll(rotations)
        locked = gimbal_locked(rotations)
        rolls = alpha[:, None] if self.triples == 1 else np.stack((alpha, alpha + np.pi), axis=1)
        real_roll = np.ones(rolls.shape, dtype=bool)
        if locked.any():
            count, sweep = len(alpha), len(self.roll_sweep)
            start = np.clip(q0[:, 5], *self.roll_limits)
            rolls = np.concatenate([np.where(locked[:, None], start[:, None], rolls),
                                    np.broadcast_to(self.roll_sweep, (count, sweep))], axis=1)
            real_roll[:, 1:] = ~locked[:, None]
            real_roll = np.concatenate([real_roll, np.broadcast_to(locked[:, None], (count, sweep))], axis=1)
        q_all, real = pose_branches(self.geometry, positions, rotations, rolls)
        count = len(positions)
        return q_all.reshape(count, -1, 6), (real & real_roll[..., None]).reshape(count, -1)

    def compiled(self, chain, alignment, screen_tolerance: float):
        g = self.geometry
        numbers = (g.l1, g.l2, g.l4, g.l5, g.l6, g.h, g.rho, COSINE_TOLERANCE, GIMBAL_LOCK, self.triples,
                   *self.roll_limits, *self.roll_sweep)
        return compiled_form(_stacked_kernel, "stacked_planar", numbers, chain, alignment, screen_tolerance)


class StackedPlanarPosition(ClosedForm):
    """Positions with the roll t6 held at ``yaw`` (rad): :class:`PositionSearch`, ``chunk`` at a time."""

    target_kind = "position"
    chunk = 256
    geometry_fk = staticmethod(fk)

    def __init__(self, chain, geometry: StackedPlanarGeometry, yaw: float):
        super().__init__(chain, geometry)
        self.yaw = float(yaw)
        self.search = PositionSearch(geometry, *_finite_limits(chain))

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        parts = [self.search.candidates(positions[i:i + self.chunk], q0[i:i + self.chunk], self.yaw)
                 for i in range(0, len(positions), self.chunk)]
        return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def held_roll(chain, yaw: float | None, error=InvalidOptionError) -> float:
    """The roll joint's value for position targets: ``yaw`` (default the nominal), inside the limits."""
    yaw = float(np.clip(chain.nominal[5], chain.lower[5], chain.upper[5]) if yaw is None else yaw)
    if not math.isfinite(yaw) or not chain.lower[5] <= yaw <= chain.upper[5]:
        raise error(f"yaw (the roll joint {chain.joint_names[5]}) must be inside [{chain.lower[5]}, "
                    f"{chain.upper[5]}] rad, got {yaw}")
    return yaw


# --- recognition --------------------------------------------------------------------------------------
CANONICAL = recognition.Canonical((0.0, 0.0, HALF_PI, 0.0, -HALF_PI, HALF_PI), (-HALF_PI, 0.0, HALF_PI,
                                  -HALF_PI, 0.0, -HALF_PI), np.eye(4), rot_z(HALF_PI))


def match(lines, kind: str, options: dict) -> recognition.Match:
    """6R, axes 1-3 parallel, 4 meeting 3 at a right angle, 5 parallel to 4, 6 at a right angle to 5."""
    recognition.require_revolute(lines, 6)
    first, sign = recognition.first_frame(lines, np.eye(3))
    result = recognition.walk(lines, first, sign, CANONICAL.alphas[:5], (1.0,) * 5)
    require(small(result.a[2], lines), f"axes 3 and 4 miss each other by {abs(result.a[2]):.3g} m")
    require(small(result.d[4], lines), f"the forearm is {abs(result.d[4]):.3g} m off the arm's plane")
    along, off_axis = recognition.tip_offset(lines, result.frames[-1])
    if kind == "position":
        distance = float(np.linalg.norm(off_axis))
        require(small(distance, lines), f"the tip is {distance:.3g} m off the roll axis (6), so positions "
                                        "depend on the roll")
    recognition.close_walk(result, 0.0, along, 0.0, HALF_PI)
    geometry = StackedPlanarGeometry(l1=result.a[0], l2=result.a[1], l4=result.a[3], l5=result.a[4], l6=along,
                                     h=result.d[2], rho=0.0)
    aligned = recognition.aligned(CANONICAL, lines, result)
    parameters = recognition.in_words(geometry, ("l1", "l2", "l4", "l5", "l6", "h"))
    if kind == "pose":
        recognition.no_options(options, "stacked_planar pose")
        return recognition.Match("stacked_planar", lambda chain: StackedPlanarPose(chain, geometry), *aligned,
                                 parameters)
    if unknown := set(options) - {"yaw"}:
        raise InvalidOptionError(f"the recognised stacked_planar position form takes the option 'yaw' (the "
                                 f"roll joint's value, rad), not {sorted(unknown)}",
                                 option=sorted(unknown)[0], accepted=["yaw"])

    def build(family_chain: FamilyChain) -> ClosedForm:
        yaw = held_roll(family_chain.chain, options.get("yaw"))
        family_yaw = family_chain.signs[5] * yaw + family_chain.offsets[5]
        return StackedPlanarPosition(family_chain, geometry, family_yaw)

    return recognition.Match("stacked_planar", build, *aligned, parameters + ", roll held")


STACKED_PLANAR = recognition.Family("stacked_planar", match)
