"""EAIK's decomposition as a closed form: the fallback of ``analytic`` for full poses where no family of
wbik matches the chain, and the scalar path of the ``eaik`` method.

EAIK 1.2.2 (:mod:`wbik.solvers.eaik`, which says which chains it accepts and how its verdict is
checked) returns every branch of a pose; here they feed ``analytic``'s own choice (wrapping into the
limits, the screen with this form's FK, the branch nearest q0: :func:`wbik.solvers.analytic.nearest_branch`).
Each thread builds its own EAIK robot, from the chain's H and P and with the tip's rotation at q = 0 as
EAIK's end-effector rotation R6T, so a target pose goes to EAIK as it is. The vectorised FK is the
product of exponentials of the chain's lines (:func:`~wbik.solvers.analytic.structure.poe_fk`, the
model's to rounding); the scalar path's FK is the chain's own (Pinocchio).
"""

from __future__ import annotations

import threading

import numpy as np

from wbik.geometry import TWO_PI
from wbik.solvers.analytic import ClosedForm
from wbik.solvers.analytic.structure import chain_lines
from wbik.solvers.analytic.structure import poe_fk

_INVERSE_TURN = 1.0 / TWO_PI
_TURN_SQUARED = {joints: np.full(joints, TWO_PI * TWO_PI) for joints in range(1, 7)}
"""(2 pi)^2 per joint, for EAIK's chains of 1 to 6 joints."""


def branch_bounds(q_all: np.ndarray, reference: np.ndarray) -> list[float]:
    """Per branch of q_all (K, n), sum_i remainder(q_i - r_i, 2 pi)^2 (to rounding, far below
    ``BOUND_SLACK``): a lower bound of its squared distance to ``reference`` once wrapped into the
    limits (:func:`wbik.solvers.analytic.nearest_branch`), computed in turns in six small NumPy calls:
    (2 pi)^2 sum_i (t_i - rint(t_i))^2 with t = (q - r) / 2 pi. NaN where a joint is not finite."""
    turns = np.subtract(q_all, reference)
    turns *= _INVERSE_TURN
    turns -= np.rint(turns)
    turns *= turns
    return np.dot(turns, _TURN_SQUARED[turns.shape[-1]]).tolist()


def eaik_robot(structure):
    """An EAIK robot of a verdict's H and P whose end-effector rotation is the chain tip's at q = 0 (as
    ``eaik.IK_HP.HPRobot``, which fixes it to the identity): it takes our target poses as they are."""
    from wbik.solvers.eaik import _import_eaik

    _import_eaik()  # MissingDependencyError with the install command
    from eaik.pybindings import EAIK

    return EAIK.Robot(structure.H.T, structure.P.T, structure.tip_rotation_t.T, [], True)


class EAIKForm(ClosedForm):
    """Full poses through EAIK's decomposition of the chain (UnsupportedError, saying why, where EAIK
    refuses it). ``structure``: a verdict already reached, else :func:`wbik.solvers.eaik.eaik_verdict`
    (``probe``: check EAIK's branches on seeded FK poses)."""

    target_kind = "pose"
    has_scalar_path = True

    def __init__(self, chain, probe: bool = True, structure=None):
        from wbik.solvers.eaik import eaik_verdict

        super().__init__(chain)
        self.structure = eaik_verdict(chain, probe) if structure is None else structure
        self.family = self.structure.family
        self.lines = chain_lines(chain)
        self._local = threading.local()

    def robot(self):
        """This thread's EAIK robot (:func:`eaik_robot`)."""
        robot = getattr(self._local, "robot", None)
        if robot is None:
            robot = self._local.robot = eaik_robot(self.structure)
        return robot

    @staticmethod
    def pose(position: np.ndarray, rotation: np.ndarray) -> np.ndarray:
        """The 4 x 4 pose EAIK takes (:func:`eaik_robot`: the target as it is)."""
        pose = np.empty((4, 4))
        pose[:3, :3] = rotation
        pose[:3, 3] = position
        pose[3] = (0.0, 0.0, 0.0, 1.0)
        return pose

    @staticmethod
    def bounded(q_all: np.ndarray, reference) -> list[tuple[float, list[float]]]:
        """Branches (K, n) as ``branches_one`` returns them: (:func:`branch_bounds`, q)."""
        if not len(q_all):
            return []
        return list(zip(branch_bounds(q_all, reference), q_all.tolist(), strict=True))

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        robot, joints = self.robot(), self.chain.nq
        solutions = [np.asarray(robot.calculate_IK(self.pose(p, r)).Q, dtype=float).reshape(-1, joints)
                     for p, r in zip(positions, rotations, strict=True)]
        width = max((len(q) for q in solutions), default=0) or 1
        q_all = np.full((len(positions), width, joints), np.nan)
        real = np.zeros((len(positions), width), dtype=bool)
        for index, q in enumerate(solutions):
            q_all[index, :len(q)] = q
            real[index, :len(q)] = True
        return q_all, real

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return poe_fk(self.lines, q)

    def branches_one(self, position, rotation, reference):
        pose = self.pose(position, np.reshape(rotation, (3, 3)))
        q_all = np.asarray(self.robot().calculate_IK(pose).Q, dtype=float).reshape(-1, self.chain.nq)
        return self.bounded(q_all, reference)

    def fk_one(self, q):
        pose = self.chain.fk(np.asarray(q, dtype=float)).homogeneous.tolist()
        (a, b, c, x), (d, e, f, y), (g, h, i, z), _ = pose
        return (x, y, z), (a, b, c, d, e, f, g, h, i)
