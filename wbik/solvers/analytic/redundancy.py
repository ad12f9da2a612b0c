"""A 7-joint chain in closed form, as IKFast's free joint: joint k held at v, the other six solved by a
family or EAIK. v is searched over the joint's range (``"search"``, :mod:`.held_search`), or v = q0_k
(``"seed"``), or q0_k and ``grid_size`` values (``"grid"``). Holding the first or last joint moves only the
base or the tool (one form, the target moved); a joint in between needs a form per value.
"""

from __future__ import annotations

import math
import threading
from itertools import compress

import numpy as np

from wbik.errors import InvalidSettingError, UnsupportedError
from wbik.geometry import TWO_PI
from wbik.robot import Chain
from wbik.solvers.analytic.closed_form import ClosedForm, stacked_branches
from wbik.solvers.analytic.held_search import HeldJointSearch
from wbik.solvers.analytic.model_agreement import check_fk_against_model
from wbik.solvers.analytic.recognition import (
    Family,
    Recognised,
    first_recognised,
    recognise_eaik,
    recognise_family,
    recognise_search,
)
from wbik.solvers.analytic.structure import ChainLines, axis_rotation, chain_lines, locked_lines, poe_fk

REDUNDANCY_MODES = ("search", "seed", "grid")
DEFAULT_GRID_SIZE = 16  # held values over the range in "grid" and "search" (~0.4 rad apart on 2 pi)
KEPT_FORMS = 256  # forms kept for a joint held in the middle (the grid's values recur)


class LockedChain:
    """``chain`` with joint ``index`` held at ``value``: what a closed form reads of a chain."""

    def __init__(self, chain, index: int, value: float):
        self.parent, self.index, self.value = chain, index, float(value)
        keep = np.arange(chain.nq) != index
        self.robot = chain.robot
        self.name = f"{chain.name} with {chain.joint_names[index]} at {self.value:.6g}"
        self.base_frame, self.tip_frame = chain.base_frame, chain.tip_frame
        self.joint_names = [name for name, kept in zip(chain.joint_names, keep, strict=True) if kept]
        self.lower, self.upper = chain.lower[keep].copy(), chain.upper[keep].copy()
        self.nominal = chain.nominal[keep].copy()
        self.is_prismatic = np.asarray(chain.is_prismatic)[keep].copy()
        self.lines = locked_lines(chain_lines(chain), index, self.value)

    nq = Chain.nq  # len(joint_names)
    random = Chain.random  # uniform joints inside the limits

    def full(self, q: np.ndarray) -> np.ndarray:
        """The parent's joints (..., n + 1) with the held value inserted."""
        return np.insert(np.asarray(q, dtype=float), self.index, self.value, axis=-1)

    def fk(self, q: np.ndarray):
        """The tip pose (pin.SE3) at joints q (n,), the parent's FK."""
        return self.parent.fk(self.full(q))


def held_range(chain, index: int) -> tuple[float, float]:
    """The held joint's range: its limits, [-pi, pi] where a bound is infinite."""
    low, high = float(chain.lower[index]), float(chain.upper[index])
    return (low, high) if math.isfinite(low) and math.isfinite(high) else (-math.pi, math.pi)


def held_values(chain, index: int, mode: str, grid_size: int) -> np.ndarray:
    """"grid" and "search" modes' values over the range (:func:`held_range`; a turn without its end)."""
    low, high = held_range(chain, index)
    full_turn = not chain.is_prismatic[index] and high - low >= TWO_PI - 1e-12
    return np.zeros(0) if mode == "seed" else np.linspace(low, high, grid_size, endpoint=not full_turn)


class LockedJointForm(ClosedForm):
    """A chain solved with joint ``index`` held; UnsupportedError where the rest has no closed form."""

    def __init__(self, chain, index: int, kind: str, families: tuple[Family, ...],
                 options: dict | None = None, mode: str = "search", grid_size: int = DEFAULT_GRID_SIZE,
                 ways: tuple[bool, bool, bool] = (True, True, False)):
        super().__init__(chain)
        # what the held joint moves where one form serves every value: the base, the tool, or None
        self.moves = "base" if index == 0 else "tool" if index == chain.nq - 1 and kind == "pose" else None
        if mode == "search" and self.moves is None:
            mode = "grid"  # a joint in the middle needs a form per value: its grid, not a search
        self.index, self.mode, self.kind = index, mode, kind
        self.options = dict(options or {})
        self.target_kind = kind
        self.lines: ChainLines = chain_lines(chain)
        self.revolute = not chain.is_prismatic[index]
        self.range = held_range(chain, index)
        self.grid = held_values(chain, index, mode, grid_size)
        self.families = families
        value = 0.0 if self.moves else float(np.clip(chain.nominal[index], chain.lower[index],
                                                     chain.upper[index]))
        self.sub = self._recognise(LockedChain(chain, index, value), ways)
        self.family, self.parameters = self.sub.family, self.sub.parameters
        self.screen_tolerance = self.sub.form.screen_tolerance
        self._forms: dict[float, ClosedForm | None] = {value: self.sub.form}
        self._lock = threading.Lock()
        served = tuple(self.family.startswith(prefix) for prefix in ("eaik:", "search:"))
        self._per_value = (not any(served), *served)  # tried at another value of a middle joint: what served
        one_value = self.moves is not None and not len(self.grid)
        self.search = HeldJointSearch(self) if mode == "search" else None
        held = HeldChoice(self) if one_value and self.sub.form.kernel is not None else None
        self.kernel = self.search or held

    def _recognise(self, locked: LockedChain, ways: tuple[bool, bool, bool],
                   probe: bool = True) -> Recognised:
        """A family of ``families``, EAIK, a search form (where ``ways`` says) solving the 6-joint chain."""
        recognisers = (lambda: recognise_family(locked, self.kind, self.options, self.families),
                       lambda: recognise_eaik(locked, self.kind, probe=probe),
                       lambda: recognise_search(locked, self.kind))
        found = first_recognised(*compress(recognisers, ways))
        if isinstance(found, list):
            raise UnsupportedError("; ".join(found))
        return found

    def _form_at(self, value: float) -> ClosedForm | None:
        """The 6-joint form with a middle joint held at ``value``, None where it has none."""
        with self._lock:
            if value in self._forms:
                return self._forms[value]
        try:
            locked = LockedChain(self.chain, self.index, value)
            form = self._recognise(locked, self._per_value, probe=False).form
        except UnsupportedError:
            form = None
        with self._lock:
            if len(self._forms) >= KEPT_FORMS:
                self._forms.pop(next(iter(self._forms)))
            self._forms[value] = form
        return form

    def values(self, starts: np.ndarray) -> np.ndarray:
        """Held values per start (B, V): q0_k inside the limits, then the grid."""
        k = self.index
        seeds = np.clip(starts[:, k], self.chain.lower[k], self.chain.upper[k])[:, None]
        return np.concatenate((seeds, np.broadcast_to(self.grid, (len(starts), len(self.grid)))), axis=1)

    def _motions(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """exp([xi_k] v) for values (m,): rotations (m, 3, 3), translations (m, 3)."""
        axis, point = self.lines.axes[self.index], self.lines.origins[self.index]
        if not self.revolute:
            return np.broadcast_to(np.eye(3), (len(values), 3, 3)), values[:, None] * axis
        rotations = axis_rotation(axis, values)
        return rotations, point - rotations @ point

    def moved_targets(self, positions: np.ndarray, rotations: np.ndarray | None,
                      values: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Targets of the form built at v = 0 per (target, value) pair (m, ...): exp(-[xi_1] v) T (base), or
        T Y_v^-1 with Y_v = M^-1 exp([xi_n] v) M (tool)."""
        turn, shift = self._motions(values)
        if self.moves == "base":
            positions = np.einsum("mji,mj->mi", turn, positions - shift)
            return positions, None if rotations is None else np.matmul(np.swapaxes(turn, 1, 2), rotations)
        tip_r, tip_p = self.lines.tip[:3, :3], self.lines.tip[:3, 3]
        # Y_v = (R0^T turn R0, R0^T (turn p0 + shift - p0)); T Y^-1 = (R Y_R^T, p - R Y_R^T Y_p)
        moved_r = np.swapaxes(tip_r.T @ turn @ tip_r, 1, 2)  # Y_R^T
        moved_p = (np.einsum("mij,j->mi", turn, tip_p) + shift - tip_p) @ tip_r  # Y_p
        new_rotations = rotations @ moved_r
        return positions - np.einsum("mij,mj->mi", new_rotations, moved_p), new_rotations

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.search is None:
            return self.branches_at(positions, rotations, q0, self.values(q0))
        return stacked_branches([self.search.run(positions[i], None if rotations is None else rotations[i],
                                                 q0[i])[:2] for i in range(len(positions))], self.chain.nq)

    def branches_at(self, positions: np.ndarray, rotations: np.ndarray | None, q0: np.ndarray,
                    values: np.ndarray, exact: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Every branch with the joint held at each of ``values`` (B, V): (Q (B, V K, n), real (B, V K));
        ``exact``: the 6-joint form's :meth:`~.ClosedForm.exact_branches`."""
        count, per_target = values.shape
        sub_starts = np.repeat(np.delete(q0, self.index, axis=1), per_target, axis=0)
        flat = values.reshape(-1)
        if self.moves is not None:
            repeated = None if rotations is None else np.repeat(rotations, per_target, axis=0)
            moved_p, moved_r = self.moved_targets(np.repeat(positions, per_target, axis=0), repeated, flat)
            solve = self.sub.form.exact_branches if exact else self.sub.form.branches
            sub_q, sub_real = solve(moved_p, moved_r, sub_starts)
        else:
            parts = []
            for row, value in enumerate(flat.tolist()):
                form = self._form_at(value)
                target = row // per_target
                if form is None:
                    parts.append((np.full((1, self.chain.nq - 1), np.nan), np.zeros(1, dtype=bool)))
                    continue
                q, real = form.branches(positions[target:target + 1],
                                        None if rotations is None else rotations[target:target + 1],
                                        sub_starts[row:row + 1])
                parts.append((q[0], real[0]))
            sub_q, sub_real = stacked_branches(parts, self.chain.nq - 1)
        held = np.broadcast_to(flat[:, None, None], sub_q.shape[:2] + (1,))
        q_all = np.concatenate((sub_q[..., :self.index], held, sub_q[..., self.index:]), axis=-1)
        width = q_all.shape[1]
        return q_all.reshape(count, per_target * width, -1), sub_real.reshape(count, per_target * width)

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return poe_fk(self.lines, q)

class HeldChoice:
    """``solve``'s kernel of a :class:`LockedJointForm` holding an end joint (the target moved)."""

    def __init__(self, form: LockedJointForm):
        self.form, self.index = form, form.index
        self.low, self.high = float(form.chain.lower[form.index]), float(form.chain.upper[form.index])

    def nearest_into(self, position: np.ndarray, rotation: np.ndarray, reference: np.ndarray,
                     out: np.ndarray) -> int:
        k = self.index
        value = min(max(float(reference[k]), self.low), self.high)
        moved_p, moved_r = self.form.moved_targets(position[None], rotation[None], np.array([value]))
        sub = np.empty(len(reference) - 1)
        status = self.form.sub.form.kernel.nearest_into(moved_p[0], moved_r[0], np.delete(reference, k), sub)
        if status > 0:
            out[:k], out[k], out[k + 1:] = sub[:k], value, sub[k:]
        return status


def check_redundancy_options(chain, joint, mode: str, grid_size) -> int | None:
    """The held joint's index (None: the default); InvalidSettingError saying what is accepted."""
    from wbik.options import COUNT

    if mode not in REDUNDANCY_MODES:
        raise InvalidSettingError(f"redundancy must be one of {list(REDUNDANCY_MODES)}, got {mode!r}")
    COUNT.checked(grid_size, "grid_size", "wbik.solver('analytic')")
    if joint is None:
        return None
    if isinstance(joint, str):
        if joint not in chain.joint_names:
            raise InvalidSettingError(f"redundant_joint {joint!r} is not a joint of {chain.name!r}: "
                                      f"{chain.joint_names}")
        return chain.joint_names.index(joint)
    if isinstance(joint, int | np.integer) and not isinstance(joint, bool) and -chain.nq <= joint < chain.nq:
        return int(joint) % chain.nq
    raise InvalidSettingError(f"redundant_joint must name a joint of {chain.name!r} ({chain.joint_names}) "
                              f"or index one (0..{chain.nq - 1}), got {joint!r}")


HELD_WAYS = ((True, True, False), (False, False, True))
"""What may solve the chain left with a joint held, tried in turn: a family or EAIK, then a search form."""


def lock_redundant_joint(chain, kind: str, options: dict | None, redundancy: dict,
                         families: tuple[Family, ...], attempts: tuple[int, ...] = (0, 1)) -> Recognised:
    """The closed form holding ``redundancy["joint"]``, by default the first of the last, the first, the
    others from the tip that leaves one, solved by the ``attempts`` of :data:`HELD_WAYS`; UnsupportedError
    saying why none."""
    mode = redundancy.get("mode", "search")
    grid_size = redundancy.get("grid_size", DEFAULT_GRID_SIZE)
    index = redundancy.get("joint")
    count = chain.nq
    if index is None:
        if count != 7:
            raise UnsupportedError(f"holding one joint: for 7-joint chains (this one has {count})")
        candidates = [count - 1, 0, *range(count - 2, 0, -1)]
    else:
        candidates = [index]
    first_reasons = ["", ""]
    for attempt in attempts:
        ways = HELD_WAYS[attempt]
        for candidate in candidates if not attempt else [k for k in candidates if k in (0, count - 1)]:
            try:
                form = LockedJointForm(chain, candidate, kind, families, options, mode, grid_size, ways)
            except UnsupportedError as refused:
                first_reasons[attempt] = first_reasons[attempt] or \
                    f"holding {chain.joint_names[candidate]}: {refused}" + \
                    (", the held joint searched too: 3-D in all" if attempt else "")
                continue
            check_fk_against_model(form)
            family = f"{form.family} with {chain.joint_names[candidate]} held ({form.mode})"
            return Recognised(form, family, form.parameters)
    first_reason = "; ".join(filter(None, first_reasons))
    if index is not None:
        raise UnsupportedError(first_reason)
    raise UnsupportedError(f"holding any one joint leaves no chain with a closed form ({first_reason})")
