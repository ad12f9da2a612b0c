"""A 6- or 7-joint arm whose neighbouring axes pass close by without meeting: solved through a nearby arm
(:data:`NEARBY_ARMS`), some axes moved along their common normal onto the one before (by at most
:data:`NEARBY_SHARE` of the chain's length), which a family or EAIK solves in closed form (a 7-joint one
with a held joint). Its branches (of a held joint: at its start value and a grid over its range,
``redundancy="grid"``, then a denser grid where none reaches the target inside the limits, ``"search"``,
the default, or the start's value alone, ``"seed"``) are refined by Newton on the chain itself (min-norm
steps on all joints, e = log6(T*^-1 T)), the nearest first."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.errors import UnsupportedError
from wbik.geometry import TWO_PI
from wbik.robot import Chain
from wbik.solvers.analytic.closed_form import LIMIT_TOLERANCE, ClosedForm, stacked_branches, wrap_into_limits
from wbik.solvers.analytic.held_search import DENSER, limit_excess
from wbik.solvers.analytic.recognition import (
    Recognised,
    first_recognised,
    recognise_eaik,
    recognise_family,
    recognise_search,
)
from wbik.solvers.analytic.redundancy import DEFAULT_GRID_SIZE, held_values, lock_redundant_joint
from wbik.solvers.analytic.structure import ChainLines, chain_lines, poe_fk
from wbik.solvers.vectorised_chain import VectorisedChain

# per joint count the nearby arms tried, in order: their name and the axes moved onto the previous one
NEARBY_ARMS = {7: (("axes 1, 2, 3 meeting and axes 5, 6 meeting", (1, 2, 5)),
                   ("axes 2, 3 meeting and axes 5, 6, 7 meeting", (2, 5, 6)),
                   ("every two neighbouring axes meeting", (1, 2, 3, 4, 5, 6))),
               6: (("axes 3, 4 meeting and axes 4, 5, 6 meeting", (3, 4, 5)),
                   ("axes 1, 2, 3 meeting", (1, 2)),
                   ("every two neighbouring axes meeting", (1, 2, 3, 4, 5)))}
NEARBY_SHARE = 0.1  # an axis moves by at most this x the chain's length
NEAREST_FIRST = 6  # nearby branches refined first (the nearest the start, inside the limits or nearly)
NEWTON_STEPS = 12  # Newton steps at most per refinement
STEP_LIMIT = 0.3  # rad: the largest joint change of one step (the step scaled down)
CONVERGED = 1e-12  # |e| (m and rad) at which a branch is refined
FREE_STEPS, PROGRESS = 3, 0.5  # a row stalls after FREE_STEPS steps where |e| falls less than 2 x a step
NEAR_LIMITS = 0.3  # rad: how far outside the limits a nearby branch may be and still be refined first


def nearby_lines(lines: ChainLines, moved: tuple[int, ...]) -> tuple[ChainLines, float]:
    """The lines with each axis k of ``moved`` (0-based, from the base) moved along its common normal with
    axis k - 1 onto it (a parallel pair left), and the largest move (m)."""
    origins = lines.origins.copy()
    largest = 0.0
    for k in moved:
        normal = np.cross(lines.axes[k - 1], lines.axes[k])
        size = float(np.linalg.norm(normal))
        if size <= 1e-9:
            continue
        normal /= size
        gap = float((origins[k - 1] - origins[k]) @ normal)
        origins[k] += gap * normal
        largest = max(largest, abs(gap))
    return ChainLines(lines.axes.copy(), origins, lines.tip.copy(), lines.prismatic.copy()), largest


class NearbyChain:
    """What a closed form reads of a chain, with the nearby arm's lines (its FK their product)."""

    def __init__(self, chain, lines: ChainLines):
        self.parent, self.robot, self.lines = chain, chain.robot, lines
        self.name = f"{chain.name} (nearby arm)"
        self.base_frame, self.tip_frame = chain.base_frame, chain.tip_frame
        self.joint_names, self.is_prismatic = list(chain.joint_names), np.asarray(chain.is_prismatic)
        self.lower, self.upper, self.nominal = chain.lower, chain.upper, chain.nominal

    nq = Chain.nq
    random = Chain.random

    def fk(self, q: np.ndarray) -> pin.SE3:
        position, rotation = poe_fk(self.lines, np.asarray(q, dtype=float))
        return pin.SE3(rotation, position)


class NearbyArmForm(ClosedForm):
    """The chain solved through its nearby arm's closed form (``near``, of a held joint or of all joints),
    then where no branch is refined inside the limits through ``fallback`` (a form of the chain itself),
    Newton-refined on the chain."""

    def __init__(self, chain, near: Recognised, lines: ChainLines, mode: str, grid_size: int,
                 fallback: ClosedForm | None = None):
        super().__init__(chain)
        self.near, self.lines = near.form, lines
        self.index = getattr(self.near, "index", None)
        # the branches' sources in turn: the held values besides the start's, none ("seed"), the grid
        # ("grid"), then a denser one ("search"); else the nearby form; then the fallback form
        sizes = (grid_size, DENSER * grid_size) if mode == "search" else (grid_size,)
        self.sources = [self.near] if self.index is None else [
            held_values(chain, self.index, "grid" if mode == "search" else mode, size) for size in sizes]
        self.sources += [] if fallback is None else [fallback]
        self.vectorised = VectorisedChain(chain)
        self.revolute = ~np.asarray(chain.is_prismatic, dtype=bool)
        self.kernel = NearbyChoice(self)

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return poe_fk(self.lines, q)

    def nearby_branches(self, positions: np.ndarray, rotations: np.ndarray, q0: np.ndarray,
                        source: np.ndarray | ClosedForm) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A source's branches (B, K, n): a form's, or the nearby arm's with the held joint at values (V,)
        after the start's own (clipped); and their masks (B, K): finite, and exact (EAIK's least-squares
        ones not)."""
        if isinstance(source, ClosedForm):
            q, exact = source.exact_branches(positions, rotations, q0)
        else:
            starts = np.clip(q0[:, self.index], self.chain.lower[self.index], self.chain.upper[self.index])
            held = np.concatenate((starts[:, None], np.broadcast_to(source, (len(q0), len(source)))), axis=1)
            q, exact = self.near.branches_at(positions, rotations, q0, held, exact=True)
        finite = np.all(np.isfinite(q), axis=-1)
        return q, finite, exact & finite

    def refine(self, q: np.ndarray, positions: np.ndarray, rotations: np.ndarray, first: bool = False
               ) -> tuple[np.ndarray, np.ndarray]:
        """Newton on the chain from joints q (M, n) towards targets (M, ...): (q, converged (M,)). A step is
        -J^+ e, J^+ = J^T (J J^T)^-1, plus (more than 6 joints) the pull into the limits (joints at their
        2 pi shift nearest the limits' middle) projected onto J's null space (the self-motion, which leaves
        the pose), each scaled to at most STEP_LIMIT; until every row converged inside the limits or stalls
        (after :data:`FREE_STEPS`, |e|, or once converged the limit excess, not below :data:`PROGRESS` x the
        last), or with ``first`` one row converged inside, at most NEWTON_STEPS."""
        damping = 1e-14 * np.eye(6)
        lower, upper, revolute = self.chain.lower, self.chain.upper, self.revolute
        middle = 0.5 * (lower + upper)
        last_size = last_excess = np.full(len(q), np.inf)
        square = q.shape[1] == 6
        for count in range(NEWTON_STEPS + 1):
            error, transposed = self.vectorised.evaluate(q, positions, rotations)
            near_middle = q + revolute * TWO_PI * np.round((middle - q) / TWO_PI)
            pull = near_middle - np.clip(near_middle, lower, upper)
            size, excess = np.abs(error).max(axis=1), np.abs(pull).sum(axis=1)
            done = size <= CONVERGED
            finished = done & (excess <= LIMIT_TOLERANCE)
            stalled = np.where(done, excess > PROGRESS * last_excess, size > PROGRESS * last_size)
            stalled &= count >= FREE_STEPS
            if count == NEWTON_STEPS or np.all(finished | stalled) or (first and finished.any()):
                return q, done
            last_size, last_excess = size, excess
            normal = np.swapaxes(transposed, 1, 2) @ transposed + damping
            if square:  # no self-motion: the Newton step alone
                q = q - _limited((transposed @ np.linalg.solve(normal, error[..., None]))[..., 0])
                continue
            task = np.einsum("mki,mk->mi", transposed, pull)  # J pull
            solved = np.linalg.solve(normal, np.stack((error, task), axis=-1))  # (M, 6, 2)
            moves = transposed @ solved  # J^+ e and J^+ J pull (M, n, 2)
            newton, inward = moves[..., 0], pull - moves[..., 1]
            q = q - _limited(newton) - _limited(inward)
        return q, done

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per target the refined branches :meth:`NearbyChoice.run` finds first (all real)."""
        parts = [self.kernel.run(positions[b], rotations[b], q0[b])[0] for b in range(len(q0))]
        return stacked_branches([(q, np.ones(len(q), dtype=bool)) for q in parts], self.chain.nq)


def _limited(step: np.ndarray) -> np.ndarray:
    """Steps (M, n) scaled down to at most STEP_LIMIT in any joint."""
    largest = np.abs(step).max(axis=1, keepdims=True)
    return step * np.minimum(1.0, STEP_LIMIT / np.maximum(largest, 1e-300))


class NearbyChoice:
    """The staged choice of a :class:`NearbyArmForm` (``solve``'s kernel): each source's branches in turn
    (the grid, the dense grid, the fallback), the nearest :data:`NEAREST_FIRST` (inside the limits or
    nearly, exact first) refined first, then the others, until one converges inside the limits."""

    def __init__(self, form: NearbyArmForm):
        self.form = form
        chain = form.chain
        self.lower, self.upper = chain.lower, chain.upper

    def run(self, position: np.ndarray, rotation: np.ndarray, reference: np.ndarray,
            nearest: bool = False) -> tuple[np.ndarray, int]:
        """(the refined branches inside the limits (K, n), wrapped nearest ``reference``, of the first batch
        with any; ``nearest``: only the nearest of the rows refined first), outcome: the number of nearby
        branches, else 0 (none), -1 (none refined inside the limits) or -2 (none refined)."""
        form, outcome = self.form, 0
        for source in form.sources:
            near_q, finite, exact = form.nearby_branches(position[None], rotation[None], reference[None],
                                                         source)
            near_q, exact = near_q[0][finite[0]], exact[0][finite[0]]
            if not len(near_q):
                continue
            outcome = outcome or -2
            shifted = near_q + form.revolute * TWO_PI * np.round((reference - near_q) / TWO_PI)
            excess = limit_excess(near_q, self.lower, self.upper, form.revolute)
            order = np.lexsort((np.linalg.norm(shifted - reference, axis=1), ~exact, excess > NEAR_LIMITS))
            for part in (order[:NEAREST_FIRST], order[NEAREST_FIRST:]):
                if not len(part):
                    continue
                count = len(part)
                q, converged = form.refine(shifted[part], np.broadcast_to(position, (count, 3)),
                                           np.broadcast_to(rotation, (count, 3, 3)), first=nearest)
                q, inside = wrap_into_limits(q, reference, self.lower, self.upper, form.revolute)
                if converged.any():
                    outcome = -1
                passing = np.flatnonzero(converged & inside)
                if len(passing) and nearest:
                    passing = passing[[np.argmin(np.linalg.norm(q[passing] - reference, axis=1))]]
                if len(passing):
                    return q[passing], len(near_q)
        return np.zeros((0, len(reference))), outcome

    def nearest_into(self, position: np.ndarray, rotation: np.ndarray, reference: np.ndarray,
                     out: np.ndarray) -> int:
        """``solve``'s kernel: the branch :meth:`run` chooses into ``out``, its outcome."""
        q, outcome = self.run(position, rotation, reference, nearest=True)
        if len(q):
            out[:] = q[0]
        return outcome


def _nearby_form(near_chain: NearbyChain, kind: str, options: dict | None, redundancy: dict,
                 families) -> Recognised | list[str]:
    """The nearby arm's closed form: a family's or EAIK's (6 joints), a held joint's (7), else the reasons."""
    if near_chain.nq == 6:
        return first_recognised(lambda: recognise_family(near_chain, kind, options, families),
                                lambda: recognise_eaik(near_chain, kind))
    try:
        return lock_redundant_joint(near_chain, kind, options, {**redundancy, "mode": "grid"}, families)
    except UnsupportedError as refused:
        return [str(refused)]


def nearby_arm(chain, kind: str, options: dict | None, redundancy: dict, families) -> Recognised:
    """The 6- or 7-joint chain's :class:`NearbyArmForm` through the first of :data:`NEARBY_ARMS` with a
    closed form (a family's or EAIK's; of a 7-joint arm with a held joint; a 6R's with its 1-D search form
    after it), or UnsupportedError saying why none."""
    if kind != "pose" or chain.nq not in NEARBY_ARMS:
        raise UnsupportedError("the nearby arm refined by Newton: for full poses of 6- or 7-joint chains")
    lines = chain_lines(chain)
    if lines.prismatic.any():
        raise UnsupportedError("the nearby arm refined by Newton: for revolute joints only")
    fallback = first_recognised(lambda: recognise_search(chain, kind)) if chain.nq == 6 else None
    if isinstance(fallback, list):  # alone it misses poses (of Tiago Pro's first six joints 19 %)
        raise UnsupportedError("the nearby arm refined by Newton: for a 6R only before a 1-D search form")
    reasons = []
    for name, moved in NEARBY_ARMS[chain.nq]:
        near_lines, largest = nearby_lines(lines, moved)
        if largest > NEARBY_SHARE * lines.length:
            reasons.append(f"{name}: axes moved by {1e3 * largest:.3g} mm, more than {NEARBY_SHARE:g} x the "
                           f"chain's length ({1e3 * lines.length:.4g} mm)")
            continue
        near = _nearby_form(NearbyChain(chain, near_lines), kind, options, redundancy, families)
        if isinstance(near, list):
            reasons.append(f"{name} (axes moved by up to {1e3 * largest:.3g} mm): {'; '.join(near)}")
            continue
        if getattr(near.form, "moves", "") is None:  # a middle joint held: a closed form per value, too slow
            reasons.append(f"{name}: only with a middle joint held ({near.family})")
            continue
        mode = redundancy.get("mode", "search")
        form = NearbyArmForm(chain, near, lines, mode, redundancy.get("grid_size", DEFAULT_GRID_SIZE),
                             fallback and fallback.form)
        family = (f"nearby arm with {name} (axes moved by up to {1e3 * largest:.3g} mm): "
                  f"{near.family.replace('(grid)', f'({mode})')}, Newton-refined on the chain"
                  f"{fallback and ', else ' + fallback.family or ''}")
        return Recognised(form, family, near.parameters)
    raise UnsupportedError("no nearby arm has a closed form (" + "; ".join(reasons) + ")")
