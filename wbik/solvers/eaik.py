"""Method ``eaik``: EAIK's closed forms (analytic IK by subproblem decomposition) behind the one interface.

EAIK 1.2.2 (``pip install EAIK==1.2.2``; Ostermeier et al., "Automatic Geometric Decomposition for
Analytical Inverse Kinematics") looks at a 1R..6R chain's joint axes, recognises a kinematic family
it can decompose into Paden-Kahan subproblems, and returns every closed-form branch of a pose.

Building the EAIK robot. Its description comes from the chain's own reduced Pinocchio model (the
chain's joint lines, :func:`wbik.solvers.analytic.structure.chain_lines`), not from the URDF, so any
chain works, also one whose other joints are locked: at q = 0 the joint axes ``H`` (n, 3) and the
offsets ``P`` (n + 1, 3) between consecutive joint origins (base -> joint 1, ..., joint n -> tip) are
written in the chain's base frame. ``eaik.IK_HP.HPRobot(H, P)``'s end-effector frame has the base's
orientation at q = 0 (its R6T is the identity), ours has R0, the tip's orientation at q = 0: the verdict
and the probe use HPRobot and ask it for ``T_target @ diag(R0^T, 1)`` (:meth:`EAIKSolver.eaik_pose`);
the solver's own robot is built with R6T = R0 (:func:`wbik.solvers.analytic.eaik_family.eaik_robot`)
and takes the target as it is. Either way EAIK's FK equals our chain FK to 3e-16 on every chain below.
The structure and EAIK's verdict are computed once per chain (cached); each thread builds its own
robot (:meth:`Solver._thread_state`).

Choosing a branch. The rule of ``analytic`` (:func:`wbik.solvers.analytic.closed_form.nearest_branch`,
the chain as the closed form :class:`wbik.solvers.analytic.eaik_family.EAIKForm`): each revolute angle
is shifted by multiples of 2 pi into the limits, nearest to q0 (which matters for the UR5's +-2 pi
joints), branches outside the limits are dropped, and ``solve`` returns the branch with the smallest
Euclidean joint distance to q0 whose FK reaches the target within 1e-7 (m, rad). The per-call path is
one call of ``choose`` (:mod:`wbik.kernels.eaik`, C where built, a Python twin with the same bits
under ``WBIK_PURE_PYTHON=1``): it bounds every branch's squared distance from below, wraps them in the
order of their bounds only while one could still be nearer than the nearest wrapped one, and screens
the wrapped branches in the order of their distances, usually only the first, with the form's FK (the
product of exponentials of the chain's joint lines, held to the model's FK when the solver is built).
The chosen branch's pose and its errors go to the shared check
(:func:`~wbik.solvers.base.evaluate_screened`: the batched check's rule, as ``analytic``'s
``solve_many``). ``tests/test_eaik.py`` holds the choice to the rule spelled out,
``tests/test_eaik_kernel.py`` the twins to each other. EAIK's ``is_LS`` flag is not trusted either
way (it marks exact branches of 4R chains as least-squares); the FK screen decides. Where no branch
passes, the reason says whether none is inside the limits or EAIK returned only least-squares
branches. ``solve_all`` returns every distinct branch inside the limits that passes the shared check;
``solve_many`` makes one batched EAIK call (``batch_threads`` worker threads, 1 by default) and picks
branches exactly as ``solve`` does.

Cost: ``benchmarks/eaik_interface.py`` times a ``solve`` against EAIK's own call on the same poses
(docs/benchmarks.md gives the figures and the machine).

Targets. EAIK solves full poses only (its 1R..5R solvers solve the over-determined pose and flag
the inexact branches as least-squares); a position-only target raises UnsupportedError on every
chain. There is no wall-clock budget: a closed form does not iterate.

Which chains EAIK accepts (measured with this module, EAIK 1.2.2):

==========================  =====  ===========================================================
chain                       DOF    EAIK's verdict (``getKinematicFamily()``)
==========================  =====  ===========================================================
ur5.arm, ur5.ee             6R     accepted: 6R-THREE_INNER_PARALLEL
bioloid.right_leg/left_leg  6R     accepted: 6R-THREE_INNER_PARALLEL
bioloid.right_arm/left_arm  3R     accepted (poses only): 3R; our studies give them positions
arm3r.arm                   3R     accepted (poses only): 3R; our studies give it positions
panda, joint 4, 5, 6 or 7   6R     accepted: 6R-SPHERICAL_SECOND_TWO_INTERSECTING (4 locked),
locked at the nominal              -SPHERICAL_SECOND_TWO_PARALLEL (5), -SPHERICAL_FIRST_TWO_INTERSECTING
                                   (6 or 7)
golem3.right_arm/left_arm   6R     refused: "6R-Unknown Kinematic Class". At q = 0 axes 1-3 (chest
                                   yaw, shoulder) are parallel and 4-5 parallel, but 5 and 6 are
                                   skew (0.034 m apart): not a family EAIK decomposes (our thesis
                                   closed form uses the arm's planar structure instead)
panda, joint 1, 2 or 3      6R     refused: "6R-Unknown Kinematic Class"
locked
panda.arm                   7R     refused: "Currently, only 1-6R robots are solvable with EAIK.
                                   Consider locking redundant joints."
golem3.right_arm_lift       P+6R   refused: the torso lift is prismatic; EAIK takes revolute joints
pincher.arm                 4R     refused by our probe (below): EAIK says 4R-THIRD_FOURTH_INTERSECTING
                                   but returns q1 = 0 in every branch: 0 of 200 FK poses reproduced
==========================  =====  ===========================================================

So of the built-in robots' chains (every one is in the table; re-checked with this module) EAIK
refuses the Golem-III arms (a kinematic class it has no decomposition for), the Golem-III arm with the
torso lift (a prismatic joint), the 7R Panda (redundant; lock a joint) and the Pincher (its 4R solver
is wrong on exact axes, see the probe); the 3R arms it accepts solve full poses only, while the
studies give those chains positions.

The probe. EAIK's verdict alone is not trusted: a chain it claims must reproduce at least 6 of 8 FK
poses of seeded random joints (``PROBE_*``), else UnsupportedError. The Pincher is why. Its axes
(z, then y, y, y, with joints 1 and 2 intersecting) are exact in Pinocchio's model, and EAIK's
4R solver then meets a degenerate subproblem for q1 (rotating the zero offset between joints 1
and 2) and returns q1 = 0. Built through ``IK_URDF`` from the same URDF, whose axes carry 2e-16
of rounding, the same family solves correctly. We do not add noise to dodge EAIK's degenerate path.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from time import perf_counter

import numpy as np

import wbik.kernels.eaik as eaik_kernel
from wbik.options import COUNT
from wbik.solvers.analytic.closed_form import BOUND_SLACK
from wbik.solvers.analytic.closed_form import LIMIT_TOLERANCE
from wbik.solvers.analytic.closed_form import checked_branches
from wbik.solvers.analytic.closed_form import pick_reaching
from wbik.solvers.analytic.eaik_family import SCREEN_TOLERANCE
from wbik.solvers.analytic.eaik_family import EAIKForm
from wbik.solvers.analytic.eaik_family import eaik_structure
from wbik.solvers.analytic.model_agreement import check_fk_against_model
from wbik.solvers.base import Solver
from wbik.solvers.check import evaluate
from wbik.solvers.check import evaluate_screened
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate
from wbik.solvers.result import IKResult
from wbik.targets import Target
from wbik.targets import as_target
from wbik.targets import plain_pose_matrix
from wbik.targets import pose_target


class EAIKSolver(Solver):
    """EAIK's closed forms behind the common interface; see the module docstring."""

    name = "eaik"
    budgeted = False
    supports_position_only = False
    pose_only_because = "EAIK 1.2.2 solves full poses only (no position-only mode)"

    def __init__(self, robot, chain=None, batch_threads: int = 1, **options):
        """``batch_threads``: worker threads of EAIK's ``IK_batched`` in :meth:`solve_many`."""
        super().__init__(robot, chain, **options)
        self.batch_threads = COUNT.checked(batch_threads, "batch_threads", "EAIKSolver")
        self.structure = eaik_structure(self.chain)
        self.family = self.structure.family
        self.form = EAIKForm(self.chain, structure=self.structure)
        """The chain as a closed form of EAIK's branches: the scalar path the choice runs on."""
        self.revolute = ~self.chain.is_prismatic
        lower, upper = self.chain.lower.tolist(), self.chain.upper.tolist()
        check_fk_against_model(self.form)  # the choice screens and checks with the form's FK
        self._params = eaik_kernel.parameters(self.chain.nq, lower, upper, self.chain.nq * BOUND_SLACK,
                                              LIMIT_TOLERANCE, self.form.lines, SCREEN_TOLERANCE)
        self._kernel_choose = eaik_kernel.twins()[1]
        """The choice (:mod:`~wbik.kernels.eaik`): compiled where built, the Python
        twin with ``WBIK_PURE_PYTHON=1`` when the solver is built."""
        self._parts_size = self.chain.nq + 24  # what choose writes: joints, tip pose, errors
        self._tip = np.eye(4)
        self._tip[:3, :3] = self.structure.tip_rotation_t

    def _new_thread_state(self):
        """This thread's EAIK robot (:func:`~wbik.solvers.analytic.eaik_family.eaik_robot`: it takes our
        target poses as they are)."""
        return self.form.robot()

    # -- EAIK in our frames ---------------------------------------------------------------------
    def eaik_pose(self, target: Target) -> np.ndarray:
        """The 4x4 pose to give ``eaik.IK_HP.HPRobot(H, P)`` (end-effector rotation the identity) for a
        target of ours: our tip pose @ diag(R0^T, 1). (This solver's own robot takes the target as it is.)"""
        pose = np.eye(4)
        pose[:3, :3] = target.rotation
        pose[:3, 3] = target.position
        return pose @ self._tip

    def raw_branches(self, target) -> np.ndarray:
        """EAIK's branches (K, n) for a target, as EAIK returns them (no wrapping, no screening)."""
        target = as_target(target)
        self._check_target_kind(target)
        return self._eaik_branches(target)

    def _branches(self, solution) -> np.ndarray:
        q_all = np.asarray(solution.Q, dtype=float)
        return q_all.reshape(-1, self.chain.nq)

    def _choose(self, q_all: np.ndarray, target: Target, q0: np.ndarray) -> Candidate:
        """The branch nearest q0 (wrapped into the limits) whose FK passes the screen; where none does,
        :meth:`_pick` says why (:meth:`_choose_placed` without the placement)."""
        return self._choose_placed(q_all, target, q0)[0]

    def _choose_placed(self, q_all: np.ndarray, target: Target,
                       q0: np.ndarray) -> tuple[Candidate, np.ndarray | None]:
        """(the choice, the chosen branch's tip placement (Pinocchio's 4 x 4) or None): :meth:`_placed`,
        else :meth:`_pick`'s failure."""
        placed = self._placed(q_all, target, q0)
        if placed is None:
            return self._pick(q_all, target, q0), None
        return Candidate(placed[0], 1, extra={"branches": len(q_all)}), placed[1]

    def _placed(self, q_all: np.ndarray, target: Target,
                q0: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(the branch nearest q0, wrapped into the limits, whose FK passes the screen, its 4 x 4 tip pose)
        or None.

        The rule of :func:`~wbik.solvers.analytic.closed_form.nearest_branch` (the nearest branch that
        passes, the first in the bounds' order on a tie) with few FKs, in one call of ``choose``
        (:mod:`~wbik.kernels.eaik`, compiled where built): the branches wrapped into the
        limits in the order of their distances (branch and bound), screened in turn with the form's FK
        (the product of exponentials of the chain's lines, held to the model's FK when the solver is
        built) until one passes; its pose is the one the shared check then uses (``reached`` of
        :func:`evaluate`).
        """
        if not len(q_all):
            return None
        out = np.empty(len(q0) + 24)
        if self._kernel_choose(self._params, q_all, q0, self._target_pose(target), out):
            return out[:len(q0)], out[len(q0):len(q0) + 16].reshape(4, 4)
        return None

    @staticmethod
    def _target_pose(target: Target) -> np.ndarray:
        """The target's 4 x 4 homogeneous matrix: the one its arrays are views of (as
        :func:`~wbik.targets.as_target` makes them), else a new one."""
        matrix = target.rotation.base
        if matrix is not None and matrix is target.position.base and matrix.shape == (4, 4):
            return matrix
        return EAIKForm.pose(target.position, target.rotation)

    def _pick(self, q_all: np.ndarray, target: Target, q0: np.ndarray) -> Candidate:
        """The branch nearest q0 (wrapped into the limits) that reaches the target, or why none does."""
        return pick_reaching(self.chain, q_all, target, q0, self.revolute, SCREEN_TOLERANCE, "EAIK")

    # -- the interface ----------------------------------------------------------------------------
    def solve(self, target, q0=None) -> IKResult:
        """:meth:`Solver.solve` on one path: the same input checks and timing; EAIK's call on the target's
        own 4 x 4 matrix, the choice in one ``choose`` call, and the shared check on the pose and errors it
        wrote (:func:`~wbik.solvers.base.evaluate_screened`; :func:`evaluate` where no branch passes).
        A pose on :func:`~wbik.targets.as_target`'s fast path (:func:`~wbik.targets.plain_pose_matrix`)
        becomes a Target only where the check needs one."""
        pose = plain_pose_matrix(target)
        if pose is None:
            target = as_target(target)
            if target.rotation is None:
                self._check_target_kind(target)  # raises: EAIK solves full poses only
            pose = self._target_pose(target)
        else:
            target = None  # the matrix stands for it (pose_target below where a Target is needed)
        chain = self.chain
        q_start = chain.nominal if q0 is None else chain.check_q(q0)  # read only: no copy needed
        start = perf_counter()
        robot = getattr(self._local, "state", None) or self._thread_state()  # this thread's EAIK robot
        q_all = robot.calculate_IK(pose).Q
        if len(q_all):
            out = np.empty(self._parts_size)
            if self._kernel_choose(self._params, q_all, q_start, pose, out):
                elapsed = perf_counter() - start
                return evaluate_screened(chain, pose if target is None else target, out,
                                         {"branches": len(q_all)}, self.tolerances, elapsed, self.name)
        target = pose_target(pose) if target is None else target
        candidate = self._pick(q_all, target, q_start)
        elapsed = perf_counter() - start
        return evaluate(chain, target, candidate, self.tolerances, elapsed, self.name)

    def _eaik_branches(self, target: Target) -> np.ndarray:
        """EAIK's branches (K, n) of a target from this thread's robot."""
        return self._branches(self._thread_state().calculate_IK(self._target_pose(target)))

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        return self._choose(self._eaik_branches(target), target, q0)

    def solve_many(self, targets: Iterable, q0s=None) -> list[IKResult]:
        """One EAIK ``IK_batched`` call for the batch; branches picked as in ``solve``;
        per-pose time = total / B."""
        targets = [as_target(t) for t in targets]
        if not targets:
            return []
        for target in targets:
            self._check_target_kind(target)
        starts = self._batch_starts(q0s, len(targets))
        q0_array = [self.chain.nominal.copy() if s is None else s for s in starts]
        start = time.perf_counter()
        poses = [self.form.pose(target.position, target.rotation) for target in targets]
        solutions = self._thread_state().calculate_IK_batched(poses, self.batch_threads)
        chosen = [self._choose_placed(self._branches(solution), target, q0)
                  for solution, target, q0 in zip(solutions, targets, q0_array, strict=True)]
        per_pose = (time.perf_counter() - start) / len(targets)
        for candidate, _ in chosen:
            candidate.extra["batched"] = True
        return [evaluate(self.chain, target, candidate, self.tolerances, per_pose, self.name, reached)
                for target, (candidate, reached) in zip(targets, chosen, strict=True)]

    def solve_all(self, target) -> list[IKResult]:
        """Every distinct EAIK branch inside the limits that passes the shared FK check."""
        target = as_target(target)
        self._check_target_kind(target)
        start = time.perf_counter()
        q_all = self._eaik_branches(target)
        elapsed = time.perf_counter() - start
        if len(q_all) == 0:
            return []
        return checked_branches(self, target, q_all, self.revolute, elapsed)


IK_METHODS = (
    IKMethod("eaik", EAIKSolver,
             "EAIK 1.2.2: closed forms by subproblem decomposition, every branch, nearest to q0"),
)
"""The methods this module declares to :mod:`wbik.solvers.method_registry`."""
