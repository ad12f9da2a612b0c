"""Every branch of a chain's closed form. A closed form is *complete* when ``analytic`` solves full poses
without holding a joint: where the Jacobian is regular at every solution, its branches are every solution
(revolute modulo 2 pi), so branches all outside the limits prove a pose unreachable inside them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.errors import UnsupportedError
from wbik.geometry import TWO_PI, joint_gap
from wbik.robot import Chain

BRANCH_RESIDUAL = 1e-7  # model FK residual (m and rad) at or below which a branch solves the pose
SAME_SOLUTION = 1e-6  # branches whose joints differ by less (rad or m, revolute modulo 2 pi) are one


@dataclass(frozen=True)
class ClosedFormBranches:
    """A chain's complete closed form: ``solver`` (``analytic`` on the chain) and its ``family``."""

    chain: Chain
    solver: object
    family: str

    def all_branches(self, positions: np.ndarray, rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(q (B, K, n), real (B, K)): the closed form's every branch of each pose, in its list's order."""
        chain = self.chain
        starts = np.broadcast_to(chain.nominal, (len(positions), chain.nq)).copy()
        with np.errstate(invalid="ignore"):
            return self.solver.closed_form("pose").branches(np.asarray(positions, float),
                                                            np.asarray(rotations, float), starts)

    def branches(self, positions: np.ndarray, rotations: np.ndarray) -> list[np.ndarray]:
        """Per pose, its distinct solutions (K, n) as the closed form gives them (not wrapped into the
        limits) whose model FK residual is at most BRANCH_RESIDUAL."""
        chain = self.chain
        q_all, real = self.all_branches(positions, rotations)
        revolute = ~chain.is_prismatic
        found = []
        for index in range(len(positions)):
            target = pin.SE3(np.asarray(rotations[index], float), np.asarray(positions[index], float))
            distinct: list[np.ndarray] = []
            for q in q_all[index][real[index]]:
                if not np.all(np.isfinite(q)) or residual(chain, q, target) > BRANCH_RESIDUAL:
                    continue
                if not any(joint_gap(q, other, revolute) < SAME_SOLUTION for other in distinct):
                    distinct.append(q)
            found.append(np.array(distinct).reshape(len(distinct), chain.nq))
        return found


def complete_closed_form(chain: Chain) -> ClosedFormBranches | str:
    """The chain's complete closed form, or why it has none (text for the report)."""
    from wbik.solvers.analytic.redundancy import LockedJointForm
    from wbik.solvers.method_registry import solver as make_solver

    try:
        solver = make_solver("analytic", chain.robot, chain=chain.name)
        form = solver.closed_form("pose")
    except (UnsupportedError, ImportError) as exc:  # ImportError: a family's optional library (EAIK)
        return f"no closed form of full poses ({exc})"
    family = solver.families.get("pose", "")
    if isinstance(form, LockedJointForm):
        return (f"the closed form ({family}) holds a joint at a value: its branches are the solutions at "
                "that value only, not every solution")
    return ClosedFormBranches(chain, solver, family)


def residual(chain: Chain, q: np.ndarray, target: pin.SE3) -> float:
    """max(|p - p*|, angle(R*^T R)) of FK(q) (the model's) against ``target``."""
    reached = chain.fk(q)
    position = float(np.linalg.norm(reached.translation - target.translation))
    return max(position, float(np.linalg.norm(pin.log3(target.rotation.T @ reached.rotation))))


def joint_excess(q: np.ndarray, chain: Chain) -> np.ndarray:
    """Per joint, the excess of q (..., n) over [l, u], 0 iff it has a representative inside: revolute,
    x = (q - l) mod 2 pi, w = u - l: 0 if w >= 2 pi or x <= w, else min(x - w, 2 pi - x); prismatic, the
    distance to [l, u]."""
    q = np.asarray(q, dtype=float)
    lower, upper = chain.lower, chain.upper
    width = upper - lower
    x = np.mod(q - lower, TWO_PI)
    circular = np.where((width >= TWO_PI) | (x <= width), 0.0, np.minimum(x - width, TWO_PI - x))
    return np.where(chain.is_prismatic, np.maximum(lower - q, 0.0) + np.maximum(q - upper, 0.0), circular)


def branch_excess(branches: np.ndarray, chain: Chain) -> np.ndarray:
    """Per branch (K, n), its largest joint excess (K,)."""
    return np.max(joint_excess(branches, chain), axis=-1) if len(branches) else np.zeros(0)


def in_limit_branches(branches: np.ndarray, chain: Chain) -> np.ndarray:
    """The branches with a representative inside the limits (K', n), each as the closed form gives it."""
    return branches[branch_excess(branches, chain) == 0.0] if len(branches) else branches


def branch_index(q: np.ndarray, branches: np.ndarray, revolute: np.ndarray, tolerance: float) -> int:
    """The index of the nearest branch within ``tolerance`` of q (revolute modulo 2 pi); -1 if none."""
    if len(branches) == 0 or not np.all(np.isfinite(q)):
        return -1
    distance = joint_gap(branches, q, revolute)
    nearest = int(np.argmin(distance))
    return nearest if distance[nearest] <= tolerance else -1
