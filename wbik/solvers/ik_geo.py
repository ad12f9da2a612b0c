"""Method ``ik_geo``: IK-Geo's subproblem solvers for 6R arms (PyPI ``ik-geo`` 1.0.3), behind one interface.

IK-Geo (Elias and Wen, "IK-Geo: Unified Robot Inverse Kinematics Using Subproblem Decomposition",
arXiv:2211.05737; the package is its Rust port with Python bindings) solves a 6R arm given in
product-of-exponentials form: joint axes ``h`` (6, 3) and offsets ``p`` (7, 3) between consecutive
joint points at q = 0, in the base frame,

    R(q) = rot(h_1, q_1) ... rot(h_6, q_6),  p(q) = p_01 + R_1 p_12 + R_1 R_2 p_23 + ... + R(q) p_6T,

and a kinematic family the caller names (its README: "you need to choose the correct decomposition
strategy ... If you choose the wrong one, you will get wrong answers").

Building the robot. H and P come from the chain's reduced Pinocchio model
(:func:`wbik.solvers.task_error.serial_structure`) at q = 0 in the chain's base frame, as for EAIK
(:mod:`wbik.solvers.eaik`). IK-Geo's tool frame has the base's orientation at q = 0, ours has R0 (the
tip's orientation at q = 0), so IK-Geo is asked for ``T_target @ diag(R0^T, 1)``. Its solvers read a
family's relations from P being exactly zero (MATLAB setups of IK-Geo: ``P(:,6) = 0`` for "h5 intersects
h6", ``p_45 = p_56 = 0`` for a spherical wrist) and parallel axes from one shared ``h``, so each joint
point is moved along its own axis (which changes no kinematics) onto the intersections the family
uses, parallel axes get one direction (an anti-parallel one has its angle negated), and the Python
binding's rotation argument is passed transposed (its ``lib.rs``, in the 1.0.1 sdist, fills
``rotation[(i, j)] = rot_matrix[j][i]``, and ``forward_kinematics`` returns the transpose likewise; 1.0.3
does the same, as tests/test_ik_geo.py checks against our FK).

Choosing the family. From the joint lines at q = 0, with :data:`GEOMETRY_TOLERANCE`: two axes are
parallel when the sine of their angle is at most the tolerance, two lines intersect when they are
not parallel and at most tolerance x the chain's length apart, and a spherical wrist is joints 4, 5, 6
meeting in one point. IK-Geo's families (:data:`FAMILIES`, joints counted from 0 there), closed forms
first, then its 1-D and 2-D searches, are tried on the chain and on the reversed chain (the
inverse pose solved with the joints in reverse order and negated: a spherical *shoulder* is then a
spherical wrist, as on the Panda with a wrist joint locked); the first whose structure holds and whose
branches reproduce :data:`PROBE_REQUIRED` of :data:`PROBE_POSES` FK poses of seeded random joints (to
1e-6 m and rad) is kept. A chain with no such family is an UnsupportedError naming the families its
geometry allows and how they missed. With ``ik-geo`` 1.0.3 the closed forms reach their poses, the
searches (two_parallel, two_intersecting, gen_six_dof) fall short of the shared 1e-6 check, so in
practice only the closed-form families pass (the measurements: docs/measurements.md, ik_geo).
A search that finds no bracket panics in Rust (pyo3's PanicException, a BaseException; Rust's panic hook
prints it on stderr): it counts as a miss in the probe, and as "IK-Geo failed" in a solve.

Which chains (checked with this module): the UR3, UR5 and UR10 arms (three_parallel_two_intersecting),
the Kinova Jaco j2s6s200 of example-robot-data (spherical_two_parallel: its wrist axes meet in one point,
axes 2 and 3 are parallel), the Panda with joint 5 (spherical_two_parallel), 6 or 7
(spherical_two_intersecting) locked at its nominal, both on the reversed chain, and with joint 4 locked
(spherical, reversed: IK-Geo's branches reach nearly every pose, but its subproblem 5 misses the branch
inside the limits for some, so ``solve`` misses those poses; docs/measurements.md, ik_geo). Refused: the
7R Panda and every chain of more or fewer than 6 joints (IK-Geo 1.0.3: "7-joint bots are not yet
supported"; lock a joint with a :class:`wbik.ChainSpec` listing six), prismatic joints, and 6R chains
that only a search family fits (the Panda with joint 1, 2 or 3 locked, the Golem-III arms, the Bravo 7:
their answers miss the check).

Choosing a branch. As in ``eaik``: each angle is shifted by multiples of 2 pi into the limits nearest
to q0 (:func:`wbik.solvers.analytic.closed_form.wrap_into_limits`), branches outside the limits are dropped,
and
``solve`` returns the branch nearest to q0 (Euclidean) whose FK reaches the target within 1e-7 (m, rad);
IK-Geo's least-squares flag is not trusted either way, the FK screen decides. ``solve_all`` returns
every distinct branch inside the limits that passes the shared check. Full poses only; no budget (a
closed form does a fixed amount of work). Each thread has its own IK-Geo robot (its ``get_ik`` borrows
the object mutably).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from wbik.errors import MissingDependencyError
from wbik.errors import UnsupportedError
from wbik.robot import Chain
from wbik.robot import ChainCache
from wbik.solvers.analytic.closed_form import checked_branches
from wbik.solvers.analytic.closed_form import fk_residual
from wbik.solvers.analytic.closed_form import pick_reaching
from wbik.solvers.base import Solver
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate
from wbik.solvers.result import IKResult
from wbik.solvers.task_error import joint_lines_at_zero
from wbik.solvers.task_error import serial_structure
from wbik.targets import Target
from wbik.targets import as_target

INSTALL = "pip install ik-geo==1.0.3"
GEOMETRY_TOLERANCE = 1e-9
"""Two axes are parallel when sin(angle) <= this; two lines intersect (or a point lies on a line) when
they are <= this x the chain's length apart. URDFs write angles and lengths to 10-12 digits (the UR and
Kinova axes are parallel to 1e-11), and a relation held to 1e-9 moves the FK by about 1e-9 x the chain's
length, three orders below the shared check; a real offset or tilt misses it by orders of magnitude."""
SCREEN_TOLERANCE = 1e-7
"""FK residual (m and rad) above which a branch is not a solution (``analytic``'s and ``eaik``'s screen)."""
PROBE_POSES, PROBE_REQUIRED, PROBE_SEED, PROBE_TOLERANCE = 8, 6, 0, 1e-6
"""A family is kept when its branches reproduce (to PROBE_TOLERANCE, m and rad) at least PROBE_REQUIRED of
PROBE_POSES FK poses of seeded random joints inside the limits."""
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
"""IK-Geo's families for custom kinematics, in the order they are tried (IK-Geo README, "Performance";
the relations as its MATLAB ``IK_setups`` build them)."""


def _import_robot():
    """IK-Geo's Robot class, or MissingDependencyError with the install command."""
    try:
        from ik_geo import Robot
    except ImportError as exc:
        raise MissingDependencyError(
            f"method 'ik_geo' needs the ik-geo package ({exc}); install it with: {INSTALL}") from None
    return Robot


class IKGeoPanic(Exception):
    """IK-Geo's Rust code panicked (e.g. its 1-D search finding no sign change); raised as pyo3's
    PanicException, which derives from BaseException, not Exception."""


@dataclass(frozen=True)
class Lines:
    """Joint lines at q = 0 in the base frame: unit ``axes`` (6, 3), a point of each line ``points``
    (6, 3), the ``tip`` pose (4, 4) and the chain's ``length`` (m, the scale of the length tolerance)."""

    axes: np.ndarray
    points: np.ndarray
    tip: np.ndarray
    length: float

    def parallel(self, i: int, j: int) -> bool:
        return float(np.linalg.norm(np.cross(self.axes[i], self.axes[j]))) <= GEOMETRY_TOLERANCE

    def meeting_point(self, i: int, j: int) -> np.ndarray | None:
        """The point where lines i and j meet (midpoint of their closest points), None if they are
        parallel or further apart than the tolerance."""
        if self.parallel(i, j):
            return None
        a, b, offset = self.axes[i], self.axes[j], self.points[j] - self.points[i]
        ab = float(a @ b)
        denominator = 1.0 - ab * ab
        s = (offset @ a - ab * (offset @ b)) / denominator
        t = (ab * (offset @ a) - offset @ b) / denominator
        on_i, on_j = self.points[i] + s * a, self.points[j] + t * b
        if np.linalg.norm(on_i - on_j) > GEOMETRY_TOLERANCE * self.length:
            return None
        return 0.5 * (on_i + on_j)

    def distance_to_line(self, point: np.ndarray, k: int) -> float:
        offset = point - self.points[k]
        return float(np.linalg.norm(offset - (offset @ self.axes[k]) * self.axes[k]))


def chain_lines(chain: Chain) -> Lines:
    """The chain's joint lines at q = 0 (from its reduced model), UnsupportedError for prismatic joints."""
    structure = serial_structure(chain)
    if structure.prismatic.any():
        names = [n for n, p in zip(chain.joint_names, structure.prismatic, strict=True) if p]
        raise UnsupportedError(f"IK-Geo takes revolute joints only, {names} prismatic")
    axes, points, tip = joint_lines_at_zero(structure)
    route = np.vstack((np.zeros(3), points, tip[:3, 3]))
    length = max(float(np.linalg.norm(np.diff(route, axis=0), axis=1).sum()), 1e-3)
    return Lines(axes, points, tip, length)


@dataclass(frozen=True)
class IKGeoStructure:
    """A chain in IK-Geo's terms. IK-Geo's joints g relate to ours by g = signs * q[order]
    (``order`` reversed for a reversed chain, whose ``signs`` include the negation); ``H`` (6, 3) and
    ``P`` (7, 3) are what IK-Geo is built from; ``tip_rotation_t`` is R0^T."""

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
        """(R, p) to give IK-Geo's get_ik for our tip pose (rotation, position): R = R_target R0^T, p,
        inverted for a reversed chain; R transposed for the binding (it reads rows as columns)."""
        rotation = rotation @ self.tip_rotation_t
        if self.reversed:
            rotation, position = rotation.T, -(rotation.T @ position)
        return rotation.T, position

    def joints(self, branches: np.ndarray) -> np.ndarray:
        """Our joint values (K, 6) of IK-Geo's branches (K, 6)."""
        q = np.empty_like(branches)
        q[:, self.order] = branches * self.signs
        return q


def _structure_for(lines: Lines, family: Family, reverse: bool) -> IKGeoStructure | None:
    """IK-Geo's H and P of ``family`` for the chain (or the reversed chain), None if the geometry lacks
    a relation the family needs. The relations are read on the chain's own lines, joint k of the
    reversed chain being joint 5 - k."""
    index = (lambda k: 5 - k) if reverse else (lambda k: k)
    points = lines.points.copy()
    if family.spherical_wrist:
        a, b, c = (index(k) for k in WRIST)
        centre = lines.meeting_point(a, b)
        if centre is None or lines.parallel(b, c) or \
                lines.distance_to_line(centre, c) > GEOMETRY_TOLERANCE * lines.length:
            return None
        points[[a, b, c]] = centre
    if family.intersecting is not None:
        a, b = (index(k) for k in family.intersecting)
        meeting = lines.meeting_point(a, b)
        if meeting is None:
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
    """IK-Geo's family, H and P for ``chain``, decided once per chain (see the module docstring);
    UnsupportedError naming the chain and the reason when IK-Geo has no family that solves it."""
    _import_robot()  # first, so a missing package is reported also for a cached chain
    if (cached := _STRUCTURES.get(chain)) is not None:
        return cached
    label = f"method 'ik_geo' cannot solve {chain.robot.name}.{chain.name}"
    if chain.nq != 6:
        raise UnsupportedError(
            f"{label}: IK-Geo 1.0.3 solves 6R arms, this chain has {chain.nq} joints {chain.joint_names}"
            + ("; its 7-joint arms need one joint locked (a wbik.ChainSpec listing six joints)"
               if chain.nq == 7 else ""))
    try:
        lines = chain_lines(chain)
    except UnsupportedError as refused:
        raise UnsupportedError(f"{label}: {refused}") from None
    tried = []
    for family in FAMILIES:
        for reverse in (False, True) if family.name != "gen_six_dof" else (False,):
            structure = _structure_for(lines, family, reverse)
            if structure is None:
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
    """(how many of PROBE_POSES FK poses of seeded random joints IK-Geo reproduces, worst miss); stops
    once the family can no longer reach PROBE_REQUIRED."""
    robot = structure.robot()
    reproduced, worst, missed = 0, 0.0, 0
    for q in chain.random(np.random.default_rng(PROBE_SEED), PROBE_POSES):
        pose = chain.fk(q)
        target = Target(pose.translation.copy(), pose.rotation.copy())
        try:
            miss = min((fk_residual(chain, branch, target) for branch in _branches(robot, structure, target)),
                       default=np.inf)
        except IKGeoPanic:
            miss = np.inf
        worst = max(worst, miss)
        if miss <= PROBE_TOLERANCE:
            reproduced += 1
        else:
            missed += 1
            if missed > PROBE_POSES - PROBE_REQUIRED:
                break
    return reproduced, worst


def _branches(robot, structure: IKGeoStructure, target: Target) -> np.ndarray:
    """IK-Geo's branches (K, 6) for a target, in our joints (not wrapped, not screened); IKGeoPanic
    when IK-Geo panics."""
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


class IKGeoSolver(Solver):
    """IK-Geo's closed forms behind the common interface; see the module docstring."""

    name = "ik_geo"
    budgeted = False
    supports_position_only = False
    pose_only_because = "IK-Geo solves full poses only (no position-only mode)"

    def __init__(self, robot, chain=None, **options):
        super().__init__(robot, chain, **options)
        self.structure = ik_geo_structure(self.chain)
        self.family = self.structure.family.name + (" (reversed chain)" if self.structure.reversed else "")
        self.revolute = np.ones(self.chain.nq, dtype=bool)

    def _new_thread_state(self):
        """This thread's IK-Geo robot (its get_ik takes the object mutably)."""
        return self.structure.robot()

    def raw_branches(self, target) -> np.ndarray:
        """IK-Geo's branches (K, 6) in our joints, as IK-Geo returns them (no wrapping, no screening;
        none where IK-Geo panics)."""
        target = as_target(target)
        self._check_target_kind(target)
        try:
            return _branches(self._thread_state(), self.structure, target)
        except IKGeoPanic:
            return np.empty((0, self.chain.nq))

    def _pick(self, q_all: np.ndarray, target: Target, q0: np.ndarray) -> Candidate:
        """The branch nearest q0 (wrapped into the limits) that reaches the target, or why none does."""
        return pick_reaching(self.chain, q_all, target, q0, self.revolute, SCREEN_TOLERANCE, "IK-Geo")

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        try:
            q_all = _branches(self._thread_state(), self.structure, target)
        except IKGeoPanic as exc:
            return Candidate(None, 1, f"IK-Geo failed on this target ({exc})")
        return self._pick(q_all, target, q0)

    def solve_all(self, target) -> list[IKResult]:
        """Every distinct IK-Geo branch inside the limits that passes the shared FK check."""
        target = as_target(target)
        self._check_target_kind(target)
        start = time.perf_counter()
        try:
            q_all = _branches(self._thread_state(), self.structure, target)
        except IKGeoPanic:
            return []
        elapsed = time.perf_counter() - start
        if len(q_all) == 0:
            return []
        return checked_branches(self, target, q_all, self.revolute, elapsed)


IK_METHODS = (
    IKMethod("ik_geo", IKGeoSolver,
             "IK-Geo 1.0.3: 6R closed forms by subproblem decomposition, every branch, nearest to q0"),
)
"""The methods this module declares to :mod:`wbik.solvers.method_registry`."""
