"""Method ``ik_geo``: IK-Geo's subproblem solvers for 6R arms (PyPI ``ik-geo`` 1.0.3; Elias and Wen,
arXiv:2211.05737), the branch chosen as ``eaik`` chooses.

IK-Geo takes the axes H (6, 3) and offsets P (7, 3) at q = 0, joint points moved onto the intersections
and parallel axes sharing a direction (it reads a family's relations from exact zeros), and the family.
:data:`FAMILIES` are tried on the chain and the reversed chain, the first whose relations hold and whose
branches reproduce 6 of 8 seeded FK poses kept (docs/measurements.md, ik_geo).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wbik.dependencies import IK_GEO_LIBRARY, import_optional
from wbik.errors import UnsupportedError
from wbik.robot import Chain, ChainCache
from wbik.solvers.analytic.closed_form import (
    PROBE_POSES,
    PROBE_REQUIRED,
    PROBE_SEED,
    PROBE_TOLERANCE,
    BranchLibrarySolver,
    fk_residual,
)
from wbik.solvers.analytic.structure import STRUCTURE_TOLERANCE, ChainLines, chain_lines
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate
from wbik.targets import Target

WRIST = (3, 4, 5)


@dataclass(frozen=True)
class Family:
    """An IK-Geo decomposition: its factory name, how it solves, and the relations it needs (0-based
    joints): ``parallel`` axes, an ``intersecting`` pair, a spherical wrist (joints 3, 4, 5 concurrent)."""

    name: str
    kind: str
    parallel: tuple[int, ...] = ()
    intersecting: tuple[int, int] | None = None
    spherical_wrist: bool = False


FAMILIES = (
    Family("spherical_two_parallel", "closed form", parallel=(1, 2), spherical_wrist=True),
    Family("spherical_two_intersecting", "closed form", intersecting=(0, 1), spherical_wrist=True),
    Family("three_parallel_two_intersecting", "closed form", parallel=(1, 2, 3), intersecting=(4, 5)),
    Family("spherical", "closed form", spherical_wrist=True),
    Family("three_parallel", "closed form", parallel=(1, 2, 3)),
    Family("two_parallel", "1-D search", parallel=(1, 2)),
    Family("two_intersecting", "1-D search", intersecting=(4, 5)),
    Family("gen_six_dof", "2-D search"),
)
"""IK-Geo's families in the order they are tried (its README's "Performance"; relations as its MATLAB
``IK_setups`` build them)."""


def _import_robot():
    """IK-Geo's Robot class, or MissingDependencyError with the install command."""
    return import_optional(IK_GEO_LIBRARY, "method 'ik_geo'", "ik_geo").Robot


class IKGeoPanic(Exception):
    """IK-Geo's Rust code panicked (pyo3's PanicException, a BaseException)."""


@dataclass(frozen=True)
class IKGeoStructure:
    """A chain in IK-Geo's terms: IK-Geo's joints g = signs * q[order] (``order`` reversed for a reversed
    chain, whose ``signs`` include the negation), ``H`` (6, 3) and ``P`` (7, 3), ``tip_rotation_t`` R0^T."""

    family: Family
    reversed: bool
    H: np.ndarray
    P: np.ndarray
    signs: np.ndarray
    order: np.ndarray
    tip_rotation_t: np.ndarray

    def robot(self):
        """A new IK-Geo robot of this structure."""
        return getattr(_import_robot(), self.family.name)(self.H, self.P)

    def ik_geo_pose(self, rotation: np.ndarray, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(R, p) for get_ik of our pose: R_target R0^T, inverted for a reversed chain, R transposed."""
        rotation = rotation @ self.tip_rotation_t
        if self.reversed:
            rotation, position = rotation.T, -(rotation.T @ position)
        return rotation.T, position

    def joints(self, branches: np.ndarray) -> np.ndarray:
        """Our joint values (K, 6) of IK-Geo's branches (K, 6)."""
        q = np.empty_like(branches)
        q[:, self.order] = branches * self.signs
        return q


def _structure_for(lines: ChainLines, family: Family, reverse: bool) -> IKGeoStructure | None:
    """IK-Geo's H and P of ``family`` for the chain (or the reversed chain), None if a relation fails."""
    index = (lambda k: 5 - k) if reverse else (lambda k: k)
    points = lines.origins.copy()
    if family.spherical_wrist:
        a, b, c = (index(k) for k in WRIST)
        centre = lines.meeting_point(a, b)
        if centre is None or lines.parallel(b, c) or \
                lines.distance_to_line(centre, c) > STRUCTURE_TOLERANCE * lines.length:
            return None
        points[[a, b, c]] = centre
    if family.intersecting is not None:
        a, b = (index(k) for k in family.intersecting)
        if (meeting := lines.meeting_point(a, b)) is None:
            return None
        points[[a, b]] = meeting
    axes = lines.axes.copy()
    signs = np.ones(6)
    if family.parallel:
        first = index(family.parallel[0])
        for k in family.parallel[1:]:
            other = index(k)
            if not lines.parallel(first, other):
                return None
            signs[other] = 1.0 if axes[first] @ axes[other] > 0 else -1.0  # rot(a, q) = rot(-a, -q)
            axes[other] = axes[first]
    offsets = np.vstack((points[0], np.diff(points, axis=0), lines.tip[:3, 3] - points[-1]))
    order = np.arange(6)
    if reverse:  # T^-1 = the chain read backwards: H' = H reversed, P' = -P reversed, q' = -q reversed
        axes, offsets, signs, order = axes[::-1], -offsets[::-1], -signs[::-1], order[::-1]
    return IKGeoStructure(family, reverse, np.ascontiguousarray(axes), np.ascontiguousarray(offsets),
                          signs, order, lines.tip[:3, :3].T.copy())


_STRUCTURES = ChainCache()


def ik_geo_structure(chain: Chain) -> IKGeoStructure:
    """IK-Geo's family, H and P for ``chain``, once per chain; UnsupportedError saying why where none."""
    _import_robot()  # first, so a missing package is reported also for a cached chain
    if (cached := _STRUCTURES.get(chain)) is not None:
        return cached
    label = f"method 'ik_geo' cannot solve {chain.robot.name}.{chain.name}"
    if chain.nq != 6:
        raise UnsupportedError(
            f"{label}: IK-Geo 1.0.3 solves 6R arms, this chain has {chain.nq} joints {chain.joint_names}"
            + ("; its 7-joint arms need one joint locked (a wbik.ChainSpec listing six joints)"
               if chain.nq == 7 else ""))
    lines = chain_lines(chain)
    if lines.prismatic.any():
        names = [n for n, p in zip(chain.joint_names, lines.prismatic, strict=True) if p]
        raise UnsupportedError(f"{label}: IK-Geo takes revolute joints only, {names} prismatic")
    tried = []
    for family in FAMILIES:
        for reverse in (False, True) if family.name != "gen_six_dof" else (False,):
            if (structure := _structure_for(lines, family, reverse)) is None:
                continue
            reproduced, miss = _probe(chain, structure)
            if reproduced >= PROBE_REQUIRED:
                return _STRUCTURES.store(chain, structure)
            tried.append(f"{family.name}{' (reversed chain)' if reverse else ''}, a {family.kind}, "
                         f"{reproduced} of {PROBE_POSES} (off by up to {miss:.2g})")
    raise UnsupportedError(
        f"{label}: no IK-Geo family reproduces at least {PROBE_REQUIRED} of {PROBE_POSES} FK poses of random "
        f"joints to {PROBE_TOLERANCE:g}; the families its geometry allows reproduce: " + "; ".join(tried)
        + " (the closed-form families need a spherical wrist or three parallel axes)")


def _probe(chain: Chain, structure: IKGeoStructure) -> tuple[int, float]:
    """(how many of PROBE_POSES FK poses of seeded random joints IK-Geo reproduces, worst miss)."""
    robot = structure.robot()
    reproduced, worst = 0, 0.0
    for tried, q in enumerate(chain.random(np.random.default_rng(PROBE_SEED), PROBE_POSES), 1):
        pose = chain.fk(q)
        target = Target(pose.translation.copy(), pose.rotation.copy())
        try:
            miss = min((fk_residual(chain, branch, target) for branch in _branches(robot, structure, target)),
                       default=np.inf)
        except IKGeoPanic:
            miss = np.inf
        worst = max(worst, miss)
        reproduced += miss <= PROBE_TOLERANCE
        if tried - reproduced > PROBE_POSES - PROBE_REQUIRED:  # too many missed already
            break
    return reproduced, worst


def _branches(robot, structure: IKGeoStructure, target: Target) -> np.ndarray:
    """IK-Geo's branches (K, 6) of a target in our joints (raw); IKGeoPanic when IK-Geo panics."""
    rotation, position = structure.ik_geo_pose(target.rotation, target.position)
    try:
        solutions = robot.get_ik(rotation, position)
    except BaseException as exc:  # noqa: B036 - pyo3_runtime.PanicException is a BaseException
        if type(exc).__name__ != "PanicException":
            raise
        raise IKGeoPanic(str(exc).strip() or "panic") from None
    if not solutions:
        return np.empty((0, 6))
    return structure.joints(np.array([q for q, _ in solutions], dtype=float))


class IKGeoSolver(BranchLibrarySolver):
    """IK-Geo's closed forms behind the common interface; see the module docstring."""

    name = "ik_geo"
    library = "IK-Geo"
    pose_only_because = "IK-Geo solves full poses only (no position-only mode)"

    def __init__(self, robot, chain=None, **options):
        super().__init__(robot, chain, **options)
        self.structure = ik_geo_structure(self.chain)
        self.family = self.structure.family.name + (" (reversed chain)" if self.structure.reversed else "")

    def _new_thread_state(self):
        """This thread's IK-Geo robot (its get_ik takes the object mutably)."""
        return self.structure.robot()

    def _library_branches(self, target: Target) -> np.ndarray:
        """IK-Geo's branches, none where it panics."""
        try:
            return _branches(self._thread_state(), self.structure, target)
        except IKGeoPanic:
            return np.empty((0, self.chain.nq))

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        try:
            q_all = _branches(self._thread_state(), self.structure, target)
        except IKGeoPanic as exc:
            return Candidate(None, 1, f"IK-Geo failed on this target ({exc})")
        return self._pick(q_all, target, q0)


IK_METHODS = (
    IKMethod("ik_geo", IKGeoSolver,
             "IK-Geo 1.0.3: 6R closed forms by subproblem decomposition, every branch, nearest to q0",
             needs=IK_GEO_LIBRARY),
)
