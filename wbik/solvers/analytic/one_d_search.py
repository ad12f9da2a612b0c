"""Search-based geometric closed forms (IK-Geo's 1-D search): a 6R arm without a closed form, one joint
angle x searched, the other five by subproblems at each x, up to four branches, each with a scalar error
e(x) that is zero where the branch reaches the target. A grid of x (intervals where a branch's angles jump,
an error nears zero or |e| has a local minimum split once more), a sign change of e along a branch
(branches matched between neighbouring samples by their angles) brackets a root; vectorised Newton steps
kept inside the bracket refine it; the joints at the roots are the form's branches (the solver screens them
by FK as every form's).

- :class:`TwoParallelForm`: axes 2 and 3 parallel; x = q6, (q1, q4) by SP6, q2 + q3 by SP1, e = |v| - |p23|.
- :class:`TwoIntersectingForm`: axes 1, 2 and axes 5, 6 meet; x = q4 or q3, the other by SP3, (q1, q2) by
  SP2, e = the wrist's alignment, (q5, q6) by SP1.
"""

from __future__ import annotations

import math

import numpy as np

from wbik.geometry import TWO_PI
from wbik.solvers.analytic.closed_form import ClosedForm
from wbik.solvers.analytic.structure import ChainLines, axis_rotation, eaik_vectors, poe_fk, skew
from wbik.solvers.analytic.subproblems import circle_terms, cross, dot, rotate, sp1, sp2, sp3, sp6

SAMPLES = 96  # grid values of the searched joint over a full turn (fewer over a narrower range, at least 8)
SMOOTH = 0.15  # rad: an interval where a branch's angles move more is split in SPLIT, at most LEVELS times
SPLIT, LEVELS = 4, 1
NEAR = 0.01  # x the chain's length: an interval with an end's error below is split too (close pairs of roots)
MATCH = 0.6  # rad: a branch at the next sample is the same branch when its angles moved less than this
ROOT_TOLERANCE = 1e-12  # rad: a Newton step this small ends a root's refinement
REFINE_STEPS = 10  # Newton steps at most per root (a bracket over a jump of e does not converge)
SLOPE_STEP = 1e-7  # rad: the forward difference giving e's slope
FINAL_POLISH = 8  # Newton steps on SP6's roots at the refined roots (slow near a double root)
NEWTON_LAST, LAST_STEP = 1e-5, 1e-4  # |e| (m or 1) and |step| (rad) from which one more step is the last


class OneDSearchForm(ClosedForm):
    """A 6R chain's search form: :meth:`evaluate` gives, at searched values x (M,) and targets (M, ...), the
    branches' errors e (M, K), matching angles (M, K, A) in [-pi, pi] and, with ``full``, their joints
    (M, K, 6)."""

    searched = 0  # the searched joint's index
    family = ""
    samples = SAMPLES

    def __init__(self, chain, lines: ChainLines):
        super().__init__(chain)
        self.lines = lines
        self.near = NEAR * lines.length
        self.axes, self.offsets, self.tip_rotation = eaik_vectors(lines)
        low, high = float(chain.lower[self.searched]), float(chain.upper[self.searched])
        self.full_turn = not (math.isfinite(low) and math.isfinite(high)) or high - low >= TWO_PI - 1e-12
        if self.full_turn:
            self.grid = np.linspace(-math.pi, math.pi, self.samples, endpoint=False)
        else:
            self.grid = np.linspace(low, high, max(8, math.ceil(self.samples * (high - low) / TWO_PI) + 1))

    def evaluate(self, x: np.ndarray, positions: np.ndarray, rotations: np.ndarray,
                 full: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        raise NotImplementedError

    def prepared(self, positions: np.ndarray, rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The targets as :meth:`evaluate` takes them: the tip's position, R06 = R R0^T."""
        return positions, rotations @ self.tip_rotation.T

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        positions, rotations = self.prepared(positions, rotations)
        roots, targets, anchors = self._brackets(positions, rotations)
        counts = np.bincount(targets, minlength=len(positions))
        q_all = np.full((len(positions), max(int(counts.max(initial=0)), 1), 6), np.nan)
        real = np.zeros(q_all.shape[:2], dtype=bool)
        if len(roots):
            e, anchor, q = self.evaluate(roots, positions[targets], rotations[targets], full=True)
            order = np.argsort(targets, kind="stable")
            rank = np.arange(len(roots)) - (np.cumsum(counts) - counts)[targets[order]]  # among its target's
            q_all[targets[order], rank] = q[order, _nearest_branch(anchor, anchors)[order]]
            real[targets[order], rank] = True
        return q_all, real

    def _samples(self, positions: np.ndarray, rotations: np.ndarray):
        """The grid per target, each interval where a branch moves more than :data:`SMOOTH` or the number
        of branches changes split in :data:`SPLIT` up to :data:`LEVELS` times: (x, target, e, anchor), ordered
        by target then x."""
        count = len(positions)
        x, target = np.tile(self.grid, count), np.repeat(np.arange(count), len(self.grid))
        e, anchor = self.evaluate(x, positions[target], rotations[target])[:2]
        for _ in range(LEVELS):
            following, end, _ = self._pairs(x, target)
            moved = _moved(anchor[following], anchor)  # (pairs, K now, K next)
            real_now, real_next = np.isfinite(e), np.isfinite(e)[following]
            near = np.abs(np.where(np.isfinite(e), e, np.inf)).min(axis=1) < self.near
            near |= _dips(e, moved, following)
            jumpy = (np.where(real_now, moved.min(axis=2), 0.0).max(axis=1) > SMOOTH) | \
                (np.where(real_next, moved.min(axis=1), 0.0).max(axis=1) > SMOOTH) | \
                (real_now.sum(axis=1) != real_next.sum(axis=1)) | near | near[following]
            split = np.flatnonzero(jumpy)
            if not len(split):
                break
            fractions = np.arange(1, SPLIT) / SPLIT
            new_x = (x[split, None] + (end[split] - x[split])[:, None] * fractions).reshape(-1)
            if self.full_turn:
                new_x = _wrapped(new_x)
            new_target = np.repeat(target[split], SPLIT - 1)
            new_e, new_anchor = self.evaluate(new_x, positions[new_target], rotations[new_target])[:2]
            x, target = np.concatenate((x, new_x)), np.concatenate((target, new_target))
            e, anchor = np.concatenate((e, new_e)), np.concatenate((anchor, new_anchor))
            order = np.lexsort((x, target))
            x, target, e, anchor = x[order], target[order], e[order], anchor[order]
        return x, target, e, anchor

    def _pairs(self, x: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per sample its neighbour's index (the target's first after its last on a full turn, else itself),
        the neighbour's x (unwrapped) and whether the pair is an interval."""
        following = np.arange(1, len(x) + 1)
        last = np.ones(len(x), dtype=bool)
        np.not_equal(target[1:], target[:-1], out=last[:-1])
        firsts = np.flatnonzero(np.roll(last, 1))
        following[last] = firsts if self.full_turn else np.flatnonzero(last)
        end = x[following] + np.where(last & self.full_turn, TWO_PI, 0.0)
        return following, end, ~last | self.full_turn

    def _brackets(self, positions: np.ndarray, rotations: np.ndarray):
        """The refined roots x (R,), their targets (R,) and the matching angles of their branches (R, A)."""
        x, targets, e, anchor = self._samples(positions, rotations)
        following, end, interval = self._pairs(x, targets)
        moved = _moved(anchor[following], anchor)
        match = np.argmin(moved, axis=-1)
        matched = (np.take_along_axis(moved, match[..., None], -1)[..., 0] < MATCH) & interval[:, None]
        e_match = np.take_along_axis(e[following], match, -1)
        crossing = matched & (np.sign(e) * np.sign(e_match) <= 0.0) & np.isfinite(e) & np.isfinite(e_match)
        pair, branch = np.nonzero(crossing)
        low, high, target = x[pair], end[pair], targets[pair]
        e_low, e_high = e[pair, branch], e_match[pair, branch]
        anchors = anchor[pair, branch]
        # Newton steps (the slope by a forward difference in the same batch), kept inside the bracket (regula
        # falsi where they leave it); a step from |e| <= NEWTON_LAST is the last (its error ~ e^2)
        roots, found = _secant(low, e_low, high, e_high), anchors.copy()
        index, x, targets = np.arange(len(low)), roots.copy(), target
        for _ in range(REFINE_STEPS):
            count = len(index)
            if not count:
                break
            rows = np.concatenate((targets, targets))
            e_x, anchor_x = self.evaluate(np.concatenate((x, x + SLOPE_STEP)), positions[rows],
                                          rotations[rows])[:2]
            chosen = _nearest_branch(anchor_x, np.concatenate((anchors, anchors)))
            values = e_x[np.arange(2 * count), chosen]
            value, slope = values[:count], (values[count:] - values[:count]) / SLOPE_STEP
            picked = anchor_x[np.arange(count), chosen[:count]]
            anchors = np.where(np.isfinite(picked), picked, anchors)
            same = np.sign(value) == np.sign(e_high)
            high, e_high = np.where(same, x, high), np.where(same, value, e_high)
            low, e_low = np.where(same, low, x), np.where(same, e_low, value)
            step = value / np.where(slope == 0.0, np.inf, slope)
            newton = x - step
            inside = (newton >= np.minimum(low, high)) & (newton <= np.maximum(low, high))
            x = np.where(inside, newton, _secant(low, e_low, high, e_high))
            roots[index], found[index] = x, anchors
            last = (np.abs(value) <= NEWTON_LAST) & (np.abs(step) <= LAST_STEP)  # quadratic from here
            keep = np.isfinite(value) & ~(inside & (last | (np.abs(step) <= ROOT_TOLERANCE)))
            index, x, targets, anchors = index[keep], x[keep], targets[keep], anchors[keep]
            low, high, e_low, e_high = low[keep], high[keep], e_low[keep], e_high[keep]
        anchors = found
        return roots, target, anchors

    def exact_branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                       q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.branches(positions, rotations, q0)

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return poe_fk(self.lines, q)


def _secant(x0: np.ndarray, e0: np.ndarray, x1: np.ndarray, e1: np.ndarray) -> np.ndarray:
    """Where the line through (x0, e0) and (x1, e1) crosses zero (x0 where it is flat)."""
    slope = e1 - e0
    return np.where(slope != 0.0, x0 - e0 * (x1 - x0) / np.where(slope == 0.0, 1.0, slope), x0)


def _dips(e: np.ndarray, moved: np.ndarray, following: np.ndarray) -> np.ndarray:
    """Per sample, whether a branch's |e| is at a local minimum along it without a sign change (a close
    pair of roots may hide between the samples), branches matched as in :meth:`OneDSearchForm._brackets`."""
    match = np.argmin(moved, axis=-1)
    matched = np.take_along_axis(moved, match[..., None], -1)[..., 0] < MATCH
    e_next = np.where(matched, np.take_along_axis(e[following], match, -1), np.nan)
    e_previous = np.full(e.shape, np.nan)
    rows, branches = np.nonzero(matched)
    e_previous[following[rows], match[rows, branches]] = e[rows, branches]
    with np.errstate(invalid="ignore"):
        dip = (np.abs(e) < np.abs(e_next)) & (np.abs(e) < np.abs(e_previous)) & \
            (np.sign(e) == np.sign(e_next)) & (np.sign(e) == np.sign(e_previous))
    return dip.any(axis=1)


def _wrapped(angle: np.ndarray) -> np.ndarray:
    return np.remainder(angle + math.pi, TWO_PI) - math.pi


def _moved(following: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """How far (rad, the largest angle) each branch (M, K, A) moved to each of the next (M, K', A):
    (M, K, K'), inf where either is missing; angles in [-pi, pi] (as :meth:`OneDSearchForm.evaluate`
    gives them)."""
    moved = np.abs(following[:, None, :, :] - anchor[:, :, None, :])
    moved = np.minimum(moved, TWO_PI - moved).max(axis=-1)
    return np.where(np.isnan(moved), np.inf, moved)


def _nearest_branch(anchor: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Per row the branch (of K) whose angles (M, K, A) are nearest ``reference`` (M, A)."""
    return np.argmin(_moved(anchor, reference[:, None, :])[:, 0], axis=-1)


class TwoParallelForm(OneDSearchForm):
    """Axes 2 and 3 parallel (IK-Geo's ``IK_2_parallel``, searched at the other end: the wrist's last joint,
    which a near-spherical wrist leaves well conditioned). At x = q6, R05 = R06 R6^T and
    w = p06 - R05 p56 = R1 (p12 + R2 p23 + R23 p34 + R23 R4 p45); h2 . R23 = h2 . gives
    h2 . R1^T w - h2 . R4 p45 = h2 . (p12 + p23 + p34) and h2 . R1^T R05 h5 - h2 . R4 h5 = 0: (q1, q4) by
    SP6; q2 + q3 = SP1(R4 h5 -> R1^T R05 h5 about h2); e = |v| - |p23| with v = R1^T w - p12
    - R23 (p34 + R4 p45) = R2 p23; q2 = SP1(p23 -> v), q5 from R5 = (R1 R23 R4)^T R05."""

    searched = 5
    family = "search: joints 2 and 3 parallel (1-D)"

    def __init__(self, chain, lines: ChainLines):
        super().__init__(chain, lines)
        h, p = self.axes, self.offsets
        k = -h[0]  # h2 . Rot(k, q1) u = u . (columns (sin, cos) + along) for u = w, R05 h5
        self.q1_columns = np.stack((cross(h[1], k), h[1] - dot(h[1], k) * k), axis=-1)
        self.q1_along = dot(h[1], k) * k
        self.q1_axis, self.q1_across = k, -skew(k)  # u @ q1_across = k x u
        terms = [circle_terms(h[1], h[3], v) for v in (p[4], h[4])]
        self.q4_block = -np.stack([a for a, _ in terms])
        self.rest = np.array((dot(h[1], p[1] + p[2] + p[3]) + terms[0][1], terms[1][1]))
        self.wrist_vectors = np.stack((p[5], h[4]), axis=-1)  # R05 @ this: R05 p56, R05 h5
        elbow = np.stack((h[4], p[4]))  # Rot(h4, q4) (h5, p45) = along + sin q4 across + cos q4 (v - along)
        along = np.outer(elbow @ h[3], h[3])
        self.elbow = (along, elbow @ -skew(h[3]), elbow - along)
        normal = cross(h[4], np.eye(3)[np.argmin(np.abs(h[4]))])
        self.normal5 = normal / np.linalg.norm(normal)  # a direction across axis 5, for q5 by SP1

    def prepared(self, positions: np.ndarray, rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """p06 (from joint 1's point to joint 6's) and R06."""
        rotations = rotations @ self.tip_rotation.T
        return positions - rotations @ self.offsets[-1] - self.offsets[0], rotations

    def evaluate(self, x: np.ndarray, positions: np.ndarray, rotations: np.ndarray,
                 full: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        h, p = self.axes, self.offsets
        wrist = rotations @ axis_rotation(h[5], -x)  # R05 = R06 R6^T (M, 3, 3)
        moved = wrist @ self.wrist_vectors
        vectors = np.stack((positions - moved[..., 0], moved[..., 1]), axis=-2)  # w, R05 h5 (M, 2, 3)
        q1, q4, real = sp6(vectors @ self.q1_columns, self.q4_block, self.rest - vectors @ self.q1_along,
                           FINAL_POLISH if full else 2)
        # R1^T (w, R05 h5) (M, K, 2, 3), Rot(h4, q4) (h5, p45) (M, K, 2, 3)
        along = (vectors @ self.q1_axis)[..., None] * self.q1_axis
        across, rest = vectors @ self.q1_across, vectors - along
        base = along[:, None] + np.sin(q1)[..., None, None] * across[:, None] + \
            np.cos(q1)[..., None, None] * rest[:, None]
        fixed, turning, staying = self.elbow
        elbow = fixed + np.sin(q4)[..., None, None] * turning + np.cos(q4)[..., None, None] * staying
        q23 = sp1(elbow[..., 0, :], base[..., 1, :], h[1])
        v = base[..., 0, :] - p[1] - rotate(h[1], q23, p[3] + elbow[..., 1, :])
        e = np.where(real, np.sqrt(dot(v, v)) - np.linalg.norm(p[2]), np.nan)
        anchor = np.where(real[..., None], _wrapped(np.stack((q1, q4), axis=-1)), np.nan)
        if not full:
            return e, anchor, None
        q2 = sp1(p[2], v, h[1])
        arm = axis_rotation(h[0], q1) @ axis_rotation(h[1], q23) @ axis_rotation(h[3], q4)  # R1 R23 R4
        turned = np.einsum("mkji,mjl,l->mki", arm, wrist, self.normal5)  # R5 n5
        q5 = sp1(self.normal5, turned, h[4])
        joints = np.stack((q1, q2, q23 - q2, q4, q5, np.broadcast_to(x[:, None], q2.shape)), axis=-1)
        return e, anchor, joints


class TwoIntersectingForm(OneDSearchForm):
    """Axes 1, 2 meet at S and axes 5, 6 at W (IK-Geo's SP3-SP2-SP1 search): W's place at the target, W*,
    is |W* - S| from S whatever q1, q2; at x = q4 (or q3), |e3(q3) e4(q4) W - S| = |W* - S| gives q3 (or q4)
    by SP3, Rot(h2, q2) (e3 e4 W - S) = Rot(-h1, q1) (W* - S) gives (q1, q2) by SP2, and the wrist's
    alignment e = h5 . R04^T R06 h6 - h5 . h6 vanishes where (q5, q6) exist: both by SP1. The joint searched
    is the one whose turn moves W less (a short lever solved by SP3 would swing)."""

    family = "search: axes 1, 2 and axes 5, 6 meet (1-D)"
    samples = 32  # its error, the wrist's alignment, is smooth: a coarser grid serves

    def __init__(self, chain, lines: ChainLines):
        self.shoulder, wrist = lines.meeting_point(0, 1), lines.meeting_point(4, 5)
        self.searched = 3 if lines.distance_to_line(wrist, 3) < lines.distance_to_line(wrist, 2) else 2
        super().__init__(chain, lines)
        self.wrist, self.wrist_from_tip = wrist, wrist - lines.tip[:3, 3]  # W* = p + R06 (W - p_tip(0))
        self.alignment = dot(self.axes[4], self.axes[5])

    def evaluate(self, x: np.ndarray, positions: np.ndarray, rotations: np.ndarray,
                 full: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        h, origins, shoulder, count = self.axes, self.lines.origins, self.shoulder, len(x)
        wrist_target = positions + rotations @ self.wrist_from_tip  # W* (M, 3)
        reach = np.sqrt(dot(wrist_target - shoulder, wrist_target - shoulder))
        if self.searched == 3:  # W turned by q4 = x, then q3 by SP3 about line 3
            turned = rotate(h[3], x, self.wrist - origins[3]) + origins[3] - origins[2]  # e4 W - c3
            q3, real3 = sp3(turned, shoulder - origins[2], h[2], reach)  # (M, 2)
            q4 = np.broadcast_to(x[:, None], q3.shape)
            placed = rotate(h[2], q3, turned[:, None]) + origins[2] - shoulder  # e3 e4 W - S (M, 2, 3)
        else:  # S turned back by q3 = x, then q4 by SP3 about line 4
            moved = rotate(h[2], -x, shoulder - origins[2]) + origins[2] - origins[3]  # e3^-1 S - c4
            q4, real3 = sp3(self.wrist - origins[3], moved, h[3], reach)
            q3 = np.broadcast_to(x[:, None], q4.shape)
            elbow = rotate(h[3], q4, self.wrist - origins[3]) + origins[3] - origins[2]
            placed = rotate(h[2], x[:, None], elbow) + origins[2] - shoulder
        q2, q1, real = sp2(placed, (wrist_target - shoulder)[:, None], h[1], -h[0])  # (M, 2, 2)
        q1, q2 = q1.reshape(count, 4), q2.reshape(count, 4)
        real = np.repeat(real & real3[:, None], 2, axis=-1)  # SP2's two pairs are real where its SP4 is
        q3, q4 = np.repeat(q3, 2, axis=-1), np.repeat(q4, 2, axis=-1)
        turned_h5 = rotate(h[0], q1, rotate(h[1], q2, rotate(h[2], q3, rotate(h[3], q4, h[4]))))  # R04 h5
        e = np.where(real, dot(turned_h5, (rotations @ h[5])[:, None]) - self.alignment, np.nan)
        solved = q3 if self.searched == 3 else q4
        anchor = np.where(real[..., None], _wrapped(np.stack((q1, q2, solved), axis=-1)), np.nan)
        if not full:
            return e, anchor, None
        arm = axis_rotation(h[0], q1) @ axis_rotation(h[1], q2) @ axis_rotation(h[2], q3) @ \
            axis_rotation(h[3], q4)  # R04 (M, 4, 3, 3)
        rest = np.swapaxes(arm, -1, -2) @ rotations[:, None]  # R04^T R06 = R5 R6
        q5 = sp1(h[5], rest @ h[5], h[4])
        q6 = sp1(h[4], np.swapaxes(rest, -1, -2) @ h[4], -h[5])
        return e, anchor, np.stack((q1, q2, q3, q4, q5, q6), axis=-1)
