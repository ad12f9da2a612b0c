"""A geometric joint path: knots q_k at path parameters s_k in [0, 1], before any timing, with the
task reference of a Cartesian path (the tip pose wanted at each s)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from wbik.geometry import rotation_angle
from wbik.robot import Chain
from wbik.targets import Target


class TaskReference(Protocol):
    """The tip pose wanted at path parameter s in [0, 1] (chain base frame)."""

    def target(self, s: float) -> Target: ...


@dataclass
class JointPath:
    """Knots of a joint path on one chain; ``solved[k]`` False where IK missed knot k (``reasons[k]``),
    ``jumps`` the knots whose step exceeded the jump threshold."""

    chain: Chain
    s: np.ndarray  # (K,) increasing, s[0] = 0, s[-1] = 1
    q: np.ndarray  # (K, n)
    reference: TaskReference | None = None
    solved: np.ndarray | None = None  # (K,) bool
    reasons: dict[int, str] = field(default_factory=dict)
    jumps: list[int] = field(default_factory=list)
    waypoint_knots: list[int] = field(default_factory=list)
    info: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.s = np.asarray(self.s, dtype=float)
        self.q = np.asarray(self.q, dtype=float)
        if self.solved is None:
            self.solved = np.ones(len(self.s), dtype=bool)

    @property
    def success(self) -> bool:
        """Every knot solved and no branch jump."""
        return bool(np.all(self.solved)) and not self.jumps

    def max_step(self) -> float:
        """The largest joint change between consecutive knots (rad or m)."""
        return float(np.max(np.abs(np.diff(self.q, axis=0)))) if len(self.q) > 1 else 0.0

    def knot_errors(self) -> tuple[np.ndarray, np.ndarray]:
        """(position error norm, rotation error angle) of FK at each knot against the reference."""
        if self.reference is None:
            nan = np.full(len(self.s), np.nan)
            return nan, nan.copy()
        return tracking_errors(self.chain, self.reference, self.s, self.q)

    def summary(self) -> dict:
        position_errors, rotation_errors = self.knot_errors()
        return {
            "knots": int(len(self.s)),
            "success": self.success,
            "unsolved_knots": [int(k) for k in np.flatnonzero(~self.solved)],
            "jumps": list(self.jumps),
            "max_joint_step": self.max_step(),
            "max_knot_position_error": nanmax(position_errors),
            "max_knot_rotation_error": nanmax(rotation_errors),
            "reasons": {str(k): v for k, v in self.reasons.items()},
        }


def tracking_errors(chain: Chain, reference: TaskReference, s: np.ndarray, q: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Position error norms and rotation error angles of FK(q_i) against reference(s_i)."""
    position_errors, rotation_errors = np.empty(len(s)), np.empty(len(s))
    for index, (parameter, joints) in enumerate(zip(s, q, strict=True)):
        wanted = reference.target(float(parameter))
        reached = chain.fk(joints)
        position_errors[index] = np.linalg.norm(reached.translation - wanted.position)
        rotation_errors[index] = 0.0 if wanted.rotation is None else rotation_angle(reached.rotation,
                                                                                    wanted.rotation)
    return position_errors, rotation_errors


def nanmax(values: np.ndarray) -> float | None:
    """The largest value that is not NaN; None when all are."""
    return None if np.all(np.isnan(values)) else float(np.nanmax(values))
