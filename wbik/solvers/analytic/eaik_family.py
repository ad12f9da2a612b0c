"""EAIK 1.2.2's decomposition as a closed form (``analytic``'s fallback for full poses, ``eaik``'s model):
EAIK built from the joint lines at q = 0 with the tip's rotation as its end effector's, its claimed
decomposition probed (it gets some wrong, e.g. the Pincher's).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

import wbik.kernels.eaik as eaik_kernel
from wbik.dependencies import EAIK_LIBRARY, import_optional
from wbik.errors import UnsupportedError
from wbik.kernels.twins import pure_python
from wbik.peer_output import captured_output
from wbik.robot import Chain, ChainCache
from wbik.solvers.analytic.closed_form import (
    BOUND_SLACK,
    LIMIT_TOLERANCE,
    PROBE_POSES,
    PROBE_REQUIRED,
    PROBE_SEED,
    PROBE_TOLERANCE,
    ClosedForm,
    stacked_branches,
)
from wbik.solvers.analytic.structure import chain_lines, eaik_vectors, poe_fk


def import_eaik():
    """EAIK's HPRobot class, or MissingDependencyError with the install command."""
    return import_optional(EAIK_LIBRARY, "method 'eaik' (and the analytic method's EAIK family)",
                           "eaik.IK_HP").HPRobot


@dataclass(frozen=True)
class EAIKStructure:
    """A chain in EAIK's terms: axes H (n, 3), offsets P (n + 1, 3), tip rotation R0 at q = 0."""

    H: np.ndarray
    P: np.ndarray
    tip_rotation_t: np.ndarray  # R0^T: EAIK's pose = our pose @ diag(R0^T, 1)
    family: str


_STRUCTURES = ChainCache()


def eaik_structure(chain: Chain) -> EAIKStructure:
    """:func:`eaik_verdict`, UnsupportedError naming the chain."""
    try:
        return eaik_verdict(chain)
    except UnsupportedError as refused:
        label = f"{chain.robot.name}.{chain.name}"
        raise UnsupportedError(f"method 'eaik' cannot solve {label}: {refused}") from None


def eaik_verdict(chain, probe: bool = True) -> EAIKStructure:
    """H, P and R0 of a chain-like object with EAIK's verdict (UnsupportedError saying why); ``probe``:
    check EAIK's branches on seeded FK poses (the result then cached per chain)."""
    HPRobot = import_eaik()  # first, so a missing EAIK is reported also for a cached chain
    if probe and (cached := _STRUCTURES.get(chain)) is not None:
        return cached
    lines = chain_lines(chain)
    if lines.prismatic.any():
        names = [n for n, p in zip(chain.joint_names, lines.prismatic, strict=True) if p]
        raise UnsupportedError(f"EAIK takes revolute joints only, {names} prismatic")
    H, P, tip_rotation = eaik_vectors(lines)
    try:
        with captured_output("EAIK") as printed:
            robot = HPRobot(H, P)
            family, known = robot.getKinematicFamily(), robot.hasKnownDecomposition()
    except RuntimeError as exc:
        raise UnsupportedError(f"EAIK says {str(exc).strip()!r} ({chain.nq} joints)") from None
    if not known:
        raise UnsupportedError(f"EAIK knows no decomposition for its kinematic family ({family!r})"
                               f"{printed.reason()}")
    result = EAIKStructure(H, P, tip_rotation.T.copy(), family)
    if not probe:
        return result
    reproduced, miss = _probe(chain, robot, result)
    if reproduced < PROBE_REQUIRED:
        raise UnsupportedError(
            f"EAIK reports a decomposition ({family!r}) but its branches reproduce only {reproduced} of "
            f"{PROBE_POSES} FK poses of random joints (the nearest branch's 4x4 pose off by up to "
            f"{miss:.3g}), a decomposition EAIK 1.2.2 gets wrong on this geometry")
    return _STRUCTURES.store(chain, result)


def _probe(chain: Chain, robot, structure: EAIKStructure) -> tuple[int, float]:
    """(how many of PROBE_POSES FK poses of seeded random joints EAIK reproduces, worst miss)."""
    tip = np.eye(4)
    tip[:3, :3] = structure.tip_rotation_t
    reproduced, worst = 0, 0.0
    for q in chain.random(np.random.default_rng(PROBE_SEED), PROBE_POSES):
        pose = chain.fk(q).homogeneous
        branches = np.asarray(robot.IK(pose @ tip).Q, dtype=float).reshape(-1, chain.nq)
        misses = [np.abs(chain.fk(b).homogeneous - pose).max() for b in branches if np.all(np.isfinite(b))]
        miss = min(misses, default=np.inf)
        reproduced += miss <= PROBE_TOLERANCE
        worst = max(worst, miss)
    return reproduced, worst


def eaik_robot(structure):
    """An EAIK robot of a verdict's H and P with the tip's rotation at q = 0 (our poses as they are)."""
    import_eaik()  # MissingDependencyError with the install command
    from eaik.pybindings import EAIK

    with captured_output("EAIK"):
        return EAIK.Robot(structure.H.T, structure.P.T, structure.tip_rotation_t.T, [], True)


class EAIKForm(ClosedForm):
    """Full poses through EAIK's decomposition; ``structure``: a verdict already reached."""

    target_kind = "pose"

    def __init__(self, chain, probe: bool = True, structure=None):
        super().__init__(chain)
        self.structure = eaik_verdict(chain, probe) if structure is None else structure
        self.family = self.structure.family
        self.lines = chain_lines(chain)
        self.params = eaik_kernel.parameters(chain.nq, chain.lower.tolist(), chain.upper.tolist(),
                                             chain.nq * BOUND_SLACK, LIMIT_TOLERANCE, self.lines,
                                             self.screen_tolerance)
        self._local = threading.local()
        compiled = eaik_kernel.choose_compiled is not None and not pure_python("eaik")
        self.kernel = EAIKChoice(self) if compiled else None

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

    def branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                 q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self._solutions(positions, rotations, exact=False)

    def exact_branches(self, positions: np.ndarray, rotations: np.ndarray | None,
                       q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """EAIK's least-squares solutions (``is_LS``) marked not real."""
        return self._solutions(positions, rotations, exact=True)

    def _solutions(self, positions: np.ndarray, rotations: np.ndarray,
                   exact: bool) -> tuple[np.ndarray, np.ndarray]:
        robot, joints = self.robot(), self.chain.nq
        poses = np.zeros((len(positions), 4, 4))  # as :meth:`pose`, all at once
        poses[:, :3, :3], poses[:, :3, 3], poses[:, 3, 3] = rotations, positions, 1.0
        parts = []
        for pose in poses:
            solution = robot.calculate_IK(pose)
            q, exact_flags = np.asarray(solution.Q, dtype=float), ~np.asarray(solution.is_LS, dtype=bool)
            parts.append((q.reshape(len(q), joints), exact_flags if exact else True))
        return stacked_branches(parts, joints)

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return poe_fk(self.lines, q)


class EAIKChoice:
    """``solve``'s kernel of an :class:`EAIKForm`: EAIK's branches, the ``eaik`` method's compiled choice."""

    def __init__(self, form: EAIKForm):
        self.form, self.joints, self.params = form, form.chain.nq, form.params

    def nearest_into(self, position: np.ndarray, rotation: np.ndarray, reference: np.ndarray,
                     out: np.ndarray) -> int:
        """As :class:`~.compiled.CompiledForm`'s."""
        pose = EAIKForm.pose(position, rotation)
        q_all = self.form.robot().calculate_IK(pose).Q
        if not len(q_all):
            return 0
        parts = np.empty(self.joints + 24)
        if eaik_kernel.choose_compiled(self.params, q_all, reference, pose, parts):
            out[:] = parts[:self.joints]
            return len(q_all)
        inside = eaik_kernel.order_compiled(self.params, q_all, reference, np.empty(np.shape(q_all)))
        return -2 if inside else -1
