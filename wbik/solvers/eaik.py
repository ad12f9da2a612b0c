"""Method ``eaik``: EAIK 1.2.2's closed forms (Ostermeier et al.), every branch of a full pose on a 1R..6R
chain EAIK decomposes (:mod:`wbik.solvers.analytic.eaik_family`); ``solve`` returns the branch nearest q0,
wrapped into the limits, whose FK reaches the target within 1e-7 (:mod:`wbik.kernels.eaik`), ``solve_many``
makes one ``IK_batched`` call. Of the built-in chains it takes the UR5 ``arm`` and ``ee``, the Bioloid legs
and arms, arm3r and the Panda with joint 4, 5, 6 or 7 locked; it refuses the Golem-III arms, the Panda
with joint 1, 2 or 3 locked, the 7R Panda and the Pincher (q1 = 0 in every branch: the probe refuses it).
"""

from __future__ import annotations

from time import perf_counter

import numpy as np

import wbik.kernels.eaik as eaik_kernel
from wbik.dependencies import EAIK_LIBRARY
from wbik.options import COUNT
from wbik.solvers.analytic.closed_form import BranchLibrarySolver
from wbik.solvers.analytic.eaik_family import EAIKForm, eaik_structure
from wbik.solvers.analytic.model_agreement import check_fk_against_model
from wbik.solvers.check import evaluate, evaluate_screened
from wbik.solvers.method import IKMethod
from wbik.solvers.result import Candidate, IKResult
from wbik.targets import Target, as_target, plain_pose_matrix, pose_target


class EAIKSolver(BranchLibrarySolver):
    """EAIK's closed forms behind the common interface; see the module docstring."""

    name = "eaik"
    library = "EAIK"
    pose_only_because = "EAIK 1.2.2 solves full poses only (no position-only mode)"

    def __init__(self, robot, chain=None, batch_threads: int = 1, **options):
        """``batch_threads``: worker threads of EAIK's ``IK_batched`` in :meth:`solve_many`."""
        super().__init__(robot, chain, **options)
        self.batch_threads = COUNT.checked(batch_threads, "batch_threads", "EAIKSolver")
        self.structure = eaik_structure(self.chain)
        self.family = self.structure.family
        self.form = EAIKForm(self.chain, structure=self.structure)
        check_fk_against_model(self.form)  # the choice screens and checks with the form's FK
        self._params = self.form.params
        self._kernel_choose = eaik_kernel.twins()[1]  # compiled, or the twin under WBIK_PURE_PYTHON=1
        self._parts_size = self.chain.nq + 24  # what choose writes: joints, tip pose, errors
        self._tip = np.eye(4)
        self._tip[:3, :3] = self.structure.tip_rotation_t

    def _new_thread_state(self):
        return self.form.robot()

    def eaik_pose(self, target: Target) -> np.ndarray:
        """The pose ``eaik.IK_HP.HPRobot(H, P)`` takes for a target of ours: T @ diag(R0^T, 1)."""
        return EAIKForm.pose(target.position, target.rotation) @ self._tip

    def _branches(self, solution) -> np.ndarray:
        return np.asarray(solution.Q, dtype=float).reshape(-1, self.chain.nq)

    def _library_branches(self, target: Target) -> np.ndarray:
        return self._branches(self._thread_state().calculate_IK(self._target_pose(target)))

    @staticmethod
    def _target_pose(target: Target) -> np.ndarray:
        """The target's 4 x 4 matrix: the one its arrays are views of (``as_target``'s), else a new one."""
        matrix = target.rotation.base
        if matrix is not None and matrix is target.position.base and matrix.shape == (4, 4):
            return matrix
        return EAIKForm.pose(target.position, target.rotation)

    def _choose(self, q_all: np.ndarray, target: Target,
                q0: np.ndarray) -> tuple[Candidate, np.ndarray | None]:
        """(``choose``'s branch, its 4 x 4 tip pose), else (:meth:`_pick`'s reason, None)."""
        if len(q_all):
            out = np.empty(len(q0) + 24)
            if self._kernel_choose(self._params, q_all, q0, self._target_pose(target), out):
                placement = out[len(q0):len(q0) + 16].reshape(4, 4)
                return Candidate(out[:len(q0)], 1, extra={"branches": len(q_all)}), placement
        return self._pick(q_all, target, q0), None

    def solve(self, target, q0=None) -> IKResult:
        """:meth:`Solver.solve` on one path: EAIK on the target's own matrix, one ``choose``, the check."""
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
        if (parts := self._screened(q_all, q_start, pose)) is not None:
            elapsed = perf_counter() - start
            return evaluate_screened(chain, pose if target is None else target, parts,
                                     {"branches": len(q_all)}, self.tolerances, elapsed, self.name)
        target = pose_target(pose) if target is None else target
        candidate = self._pick(q_all, target, q_start)
        elapsed = perf_counter() - start
        return evaluate(chain, target, candidate, self.tolerances, elapsed, self.name)

    def _solve(self, target: Target, q0: np.ndarray, deadline: float) -> Candidate:
        return self._choose(self._library_branches(target), target, q0)[0]

    def _solve_targets(self, targets: list, q0s) -> list[IKResult]:
        """One EAIK ``IK_batched`` call, then ``solve``'s choice and check per pose (the same answers);
        per-pose time = total / B."""
        targets = [as_target(t) for t in targets]
        if not targets:
            return []
        for target in targets:
            self._check_target_kind(target)
        starts = self._batch_starts(q0s, len(targets))
        q_starts = [self.chain.nominal if q0 is None else q0 for q0 in starts]
        start = perf_counter()
        poses = [self._target_pose(target) for target in targets]
        solutions = self._thread_state().calculate_IK_batched(poses, self.batch_threads)
        branches = [solution.Q for solution in solutions]
        chosen = [self._screened(q_all, q0, pose)
                  for q_all, q0, pose in zip(branches, q_starts, poses, strict=True)]
        picked = {index: self._pick(q_all, targets[index], q_starts[index])
                  for index, (q_all, parts) in enumerate(zip(branches, chosen, strict=True)) if parts is None}
        per_pose = (perf_counter() - start) / len(targets)
        results = []
        for index, (target, q_all, parts) in enumerate(zip(targets, branches, chosen, strict=True)):
            if parts is not None:
                extra = {"branches": len(q_all), "batched": True}
                results.append(evaluate_screened(self.chain, target, parts, extra, self.tolerances, per_pose,
                                                 self.name))
            else:
                candidate = picked[index]
                candidate.extra["batched"] = True
                results.append(evaluate(self.chain, target, candidate, self.tolerances, per_pose, self.name))
        return results

    def _screened(self, q_all: np.ndarray, q_start: np.ndarray, pose: np.ndarray) -> np.ndarray | None:
        """The compiled choice's parts (joints, tip pose, errors) of the branch nearest ``q_start`` that
        passes the screen, else None (then :meth:`_pick` says why)."""
        if len(q_all):
            out = np.empty(self._parts_size)
            if self._kernel_choose(self._params, q_all, q_start, pose, out):
                return out
        return None


IK_METHODS = (
    IKMethod("eaik", EAIKSolver,
             "EAIK 1.2.2: closed forms by subproblem decomposition, every branch, nearest to q0",
             needs=EAIK_LIBRARY),
)
